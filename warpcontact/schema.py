"""The JSON Schema (draft 2020-12) of a case file, for editors that complete and check TOML:
``warpcontact schema`` prints it; docs/case-files.md says how to point an editor at it.

Built from :mod:`warpcontact.records.case`, not written beside it: the tables and their keys are
``case.TABLES``, ``case.REQUIRED_TABLES`` and the ``*_KEYS`` tuples that ``case_from_dict``
checks against; the choices, limits and defaults are case's constants and its dataclasses'
defaults (``SphereSpec``, ``FlatSpec``, ``Grid``, ``LoadSpec``, ``SolverSpec``, ``FrictionSpec``);
each key's description is its line in the ``Attributes:`` section of the class's docstring. What
this module adds is the kind of each value (a length > 0, an integer of at least 8, ...) in
:data:`VALUES`, keyed by the dotted key; a key that ``case`` accepts and :data:`VALUES` lacks
stops :func:`case_schema` (tests/test_schema.py also checks every bound against
``case_from_dict``).

The schema checks each value on its own (type, range, choice) and which keys a table may and must
hold; what involves several keys (plausibility, the contact against the domain, an FFT backend
against the device) is checked by the program alone.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re

from .records import bodies as B
from .records import case as C
from .physics.geometry import MIN_CELLS, Grid

DIALECT = "https://json-schema.org/draft/2020-12/schema"

_NUMBER = {"type": "number"}
_POSITIVE = {"type": "number", "exclusiveMinimum": 0}
#: a yield strength or hardness: > 0, or inf (TOML's inf, or the string "inf") for no limit
_STRENGTH = {"anyOf": [_POSITIVE, {"type": "string", "pattern": r"^\s*\+?[iI][nN][fF]\s*$"}]}


def _integer(minimum: int, maximum: int | None = None) -> dict:
    return {"type": "integer", "minimum": minimum, **({} if maximum is None else {"maximum": maximum})}


def _enum(choices) -> dict:
    return {"type": "string", "enum": list(choices)}


#: The kind of each key's value, by dotted key (the keys themselves come from warpcontact.records.case).
VALUES = {
    "sphere.radius": _POSITIVE,
    "sphere.E": _POSITIVE,
    "sphere.nu": {"type": "number", "exclusiveMinimum": -1, "maximum": 0.5},
    "sphere.yield_strength": _STRENGTH,
    "sphere.hardness": _STRENGTH,
    "sphere.profile": _enum(C.PROFILES),
    "sphere.rigid": {"type": "boolean"},
    "sphere.edge_radius": {"type": "number", "minimum": 0},
    "sphere.half_angle": {"type": "number", "exclusiveMinimum": 0, "exclusiveMaximum": 90},
    "sphere.tip_radius": {"type": "number", "minimum": 0},
    **{f"{body}.{k}": v for body in ("sphere", "flat") for k, v in (
        ("height_map", {"type": "string"}), ("pixel_size", _POSITIVE),
        ("height_unit", _enum(B.HEIGHT_UNITS)))},
    "flat.E": _POSITIVE,
    "flat.nu": {"type": "number", "exclusiveMinimum": -1, "maximum": 0.5},
    "flat.yield_strength": _STRENGTH,
    "flat.hardness": _STRENGTH,
    "flat.rigid": {"type": "boolean"},
    "grid.n": {"anyOf": [_integer(MIN_CELLS), {"const": "map"}]},
    "grid.size": {"anyOf": [_POSITIVE, {"const": "map"}]},
    "load.delta_z": _NUMBER,
    "load.delta_x": _NUMBER,
    "load.delta_y": _NUMBER,
    "load.steps": _integer(1, C.MAX_STEPS),
    "load.normal_steps": _integer(1, C.MAX_STEPS),
    "load.tangential_steps": _integer(1, C.MAX_STEPS),
    "load.delta_x_amplitude": _POSITIVE,
    "load.delta_y_amplitude": _POSITIVE,
    "load.cycles": _integer(1, C.MAX_CYCLES),
    "load.path": {"type": "array", "minItems": 1, "maxItems": 2 * C.MAX_STEPS,
                  "items": {"type": "array", "minItems": 3, "maxItems": 3, "items": _NUMBER}},
    "solver.device": {"type": "string", "pattern": f"^({C._DEVICE_RE.pattern})$"},
    "solver.dtype": _enum(C.DTYPES),
    "solver.tol": {"type": "number", "exclusiveMinimum": 0, "maximum": C.MAX_TOL},
    "solver.max_iter": _integer(1),
    "solver.max_turns": _integer(1),
    "solver.fft": _enum(C.FFT_BACKENDS),
    "solver.nested": {"enum": [True, False, "auto"]},
    "solver.nested_float32": {"enum": [True, False, "auto"]},
    "solver.window": {"enum": [True, False, "auto"]},
    "solver.preconditioner_float32": {"enum": [True, False, "auto"]},
    "solver.preconditioner_grid": _enum(C.PRECONDITIONER_GRIDS),
    "solver.response_float32": {"enum": [True, False, "auto"]},
    "friction.law": _enum(C.FRICTION_KEYS),
    "friction.mu": {"type": "number", "minimum": 0},
    "friction.k_tau": {"type": "number", "exclusiveMinimum": 0, "exclusiveMaximum": 1},
    "friction.k_vm": _POSITIVE,
    "friction.hardness_cap": {"type": "boolean"},
    "adhesion.law": _enum(C.ADHESION_KEYS),
    # the laws' strengths and lengths: > 0, in the units of AdhesionSpec._UNITS (added below)
    "adhesion.smoothing": {"type": "number", "minimum": 0, "exclusiveMaximum": 2},  # below 1 with ramps = "both" (checked by the case)
    "adhesion.ramps": _enum(C.DUGDALE_RAMPS),
    "adhesion.contact_shear": _enum(C.SMC_CONTACT_SHEAR),
}
VALUES.update({f"adhesion.{k}": _POSITIVE for k in C.AdhesionSpec._UNITS if f"adhesion.{k}" not in VALUES})

#: Defaults that the dataclasses leave as None and the checks fill in.
_FILLED_DEFAULTS = {"friction.k_vm": C.DEFAULT_K_VM}


def _union(keys_by_law: dict) -> tuple:
    return tuple(dict.fromkeys(k for keys in keys_by_law.values() for k in keys))


def _tables() -> dict:
    """Each table's keys (case's tuples) and the class whose fields and docstring describe them."""
    return {
        "sphere": (C.SPHERE_KEYS, C.SphereSpec),
        "flat": (C.FLAT_KEYS, C.FlatSpec),
        "grid": (C.GRID_KEYS, Grid),
        "load": (C.LOAD_KEYS, C.LoadSpec),
        "solver": (C.SOLVER_KEYS, C.SolverSpec),
        "friction": (_union(C.FRICTION_KEYS), C.FrictionSpec),
        "adhesion": (_union(C.ADHESION_KEYS), C.AdhesionSpec),
    }


#: the field that holds a key's value where the names differ (the file's load.path is LoadSpec.states)
_FIELD = {"load.path": "states"}


def _attributes(cls) -> dict:
    """``name: text`` of the ``Attributes:`` section of a Google-style docstring, lines joined."""
    doc = cls.__doc__ or ""
    section = re.split(r"^\s*Attributes:\s*$", doc, maxsplit=1, flags=re.M)
    if len(section) < 2:
        return {}
    found, name = {}, None
    lines = [s for s in section[1].splitlines() if s.strip()]
    indent = len(lines[0]) - len(lines[0].lstrip()) if lines else 0
    for line in lines:
        depth = len(line) - len(line.lstrip())
        if depth < indent:
            break  # the section has ended
        m = re.match(r"(\w+):\s*(.*)$", line.strip())
        if depth == indent and m:
            name = m.group(1)
            found[name] = m.group(2)
        elif name is not None:
            found[name] += " " + line.strip()
    return found


def _default(cls, name: str):
    """The dataclass default of field ``name``: MISSING when it has none (the key is required)."""
    for f in dataclasses.fields(cls):
        if f.name == name:
            if f.default is not dataclasses.MISSING:
                return f.default
            if f.default_factory is not dataclasses.MISSING:
                return f.default_factory()
    return dataclasses.MISSING


def _json_value(v):
    return "inf" if isinstance(v, float) and math.isinf(v) else v  # as Case.to_dict writes it


def _property(table: str, key: str, cls) -> tuple[dict, object]:
    """The schema of ``table.key`` and its default (MISSING: required; None: no default)."""
    dotted = f"{table}.{key}"
    if dotted not in VALUES:
        raise KeyError(f"{dotted}: case_from_dict accepts this key but warpcontact.schema.VALUES does not describe "
                       "its value")
    prop = dict(VALUES[dotted])
    name = _FIELD.get(dotted, key)
    text = _attributes(cls).get(name)
    default = _FILLED_DEFAULTS.get(dotted, _default(cls, name))
    if default is not None and default is not dataclasses.MISSING:  # solver.tol: the dtype's, in its text
        prop["default"] = _json_value(default)
    if text:
        prop["description"] = text
    return prop, default


def _by_law(table: str, keys_by_law: dict, defaults: dict, optional: dict) -> list:
    """One alternative per law: its name, the keys it uses, those it needs. (Alternatives under
    ``oneOf`` rather than ``allOf`` of ``if``/``then``: taplo, the TOML language server behind
    VS Code's Even Better TOML, offers no key completion in a table whose schema has ``allOf``.)"""
    rules = []
    for law, keys in keys_by_law.items():
        needed = [k for k in keys if k != "law" and k not in optional.get(law, ())
                  and (defaults[k] is None or defaults[k] is dataclasses.MISSING)]
        rules.append({"properties": {"law": {"const": law}}, "required": ["law", *needed],
                      "propertyNames": {"enum": list(keys)}})
    return rules


def _elastic_or_rigid() -> list:
    """A body's two alternatives: elastic (E and nu required, rigid false or left out) or rigid
    (rigid = true, none of case.MATERIAL_KEYS)."""
    return [{"properties": {"rigid": {"const": False}}, "required": ["E", "nu"]},
            {"properties": {"rigid": {"const": True}, **{k: False for k in C.MATERIAL_KEYS}}, "required": ["rigid"]}]


def _profiles() -> list:
    """The sphere's alternatives, one per profile: its keys required (but the optional ones), the
    other profiles' keys refused; "sphere", the default, also where profile is left out."""
    owned = set(k for keys in B.PROFILE_KEYS.values() for k in keys)
    rules = []
    for profile, keys in B.PROFILE_KEYS.items():
        needed = [k for k in keys if k not in B.PROFILE_OPTIONAL]
        rules.append({"properties": {"profile": {"const": profile}, **{k: False for k in sorted(owned - set(keys))}},
                      "required": needed if profile == "sphere" else ["profile", *needed]})
    return rules


def _flat_map() -> list:
    """The flat with a height map (its file and pixel size) or without (none of its keys)."""
    return [{"required": ["height_map", "pixel_size"]}, {"properties": {k: False for k in B.MAP_KEYS}}]


def case_schema() -> dict:
    """The JSON Schema of a case file (a dict; :func:`schema_json` for the text)."""
    tables = {}
    for table, (keys, cls) in _tables().items():
        props, defaults = {}, {}
        for key in keys:
            props[key], defaults[key] = _property(table, key, cls)
        doc = (cls.__doc__ or "").strip().splitlines()[0].replace("``", "")
        if f"[{table}]" not in doc:  # a class shared beyond the case file (Material, Grid)
            doc = f"The [{table}] table: {doc[:1].lower()}{doc[1:]}"
        t = {"type": "object", "description": doc, "properties": props, "additionalProperties": False}
        if table == "load":  # the default path (delta_z, ...) or an explicit path, never both
            others = [k for k in keys if k != "path"]
            t["oneOf"] = [{"required": ["delta_z"], "properties": {"path": False}},
                          {"required": ["path"], "properties": {k: False for k in others}}]
        elif table == "friction":
            t["required"] = ["law"]
            t["oneOf"] = _by_law(table, C.FRICTION_KEYS, defaults, {})
        elif table == "adhesion":
            t["required"] = ["law"]
            t["oneOf"] = _by_law(table, C.ADHESION_KEYS, defaults, C.ADHESION_OPTIONAL)
        else:
            if table in ("sphere", "flat"):  # E and nu required unless the body is rigid
                t["oneOf"] = _elastic_or_rigid()
                t["anyOf"] = _profiles() if table == "sphere" else _flat_map()
            required = [k for k in keys if defaults[k] is dataclasses.MISSING]
            if required:
                t["required"] = required
        tables[table] = t
    missing = [t for t in C.TABLES if t not in tables]
    if missing:
        raise KeyError(f"warpcontact.schema does not describe the table(s) {', '.join(missing)} of case.TABLES")
    return {
        "$schema": DIALECT,
        "title": "warpcontact case file",
        "description": "A warpcontact case (TOML, SI units: m, Pa). Checks each value's type and range and the keys "
                       "of each table; the plausibility of the values and the contact against the domain are checked "
                       "by warpcontact itself (docs/case-files.md).",
        "type": "object",
        "properties": {t: tables[t] for t in C.TABLES},
        "required": list(C.REQUIRED_TABLES),
        "additionalProperties": False,
    }


def schema_json() -> str:
    """The schema as JSON text, indented, ending in a newline."""
    return json.dumps(case_schema(), indent=2) + "\n"

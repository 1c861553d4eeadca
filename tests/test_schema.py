"""The JSON Schema of a case file (``warpcontact schema``, warpcontact/schema.py) against the checks
it is built from: the same keys as case_from_dict accepts (read from case_from_dict's own
refusals), the same required keys, defaults and bounds (each bound probed on both sides), and
every example case file valid.

Validation here is by a small validator of the keywords the schema uses (it refuses any other
keyword, so the schema stays inside that subset); where the jsonschema package is installed (it
is not a dependency) the schema is also checked against the draft 2020-12 metaschema and the
examples validated by it.
"""

import copy
import json
import math
import re
import subprocess
import sys
import tempfile
import tomllib
import warnings
from pathlib import Path

import pytest

from warpcontact.records.case import MATERIAL_KEYS, case_from_dict
from warpcontact.errors import InputError
from warpcontact.schema import DIALECT, case_schema, schema_json

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
SCHEMA = case_schema()


# ---------------------------------------------------------------------------------------------
# A validator of the subset of draft 2020-12 that the schema uses.

_TYPES = {
    "object": lambda v: isinstance(v, dict),
    "array": lambda v: isinstance(v, list),
    "string": lambda v: isinstance(v, str),
    "boolean": lambda v: isinstance(v, bool),
    # TOML keeps integers and floats apart, and so do the case checks: 8.0 is not an integer here
    # (JSON Schema would accept it; the program refuses it, see docs/case-files.md)
    "integer": lambda v: isinstance(v, int) and not isinstance(v, bool),
    "number": lambda v: isinstance(v, (int, float)) and not isinstance(v, bool),
}
_ANNOTATIONS = {"$schema", "title", "description", "default"}


def errors(schema, value, where="") -> list:
    """The places where ``value`` breaks ``schema`` (empty: valid)."""
    if schema is True:
        return []
    if schema is False:
        return [f"{where or '/'}: not allowed"]
    out = []
    for word, arg in schema.items():
        if word in _ANNOTATIONS:
            continue
        if word == "type":
            if not _TYPES[arg](value):
                return [f"{where or '/'}: not of type {arg}"]
        elif word == "enum":
            if value not in arg:
                out.append(f"{where}: not one of {arg}")
        elif word == "const":
            if value != arg:
                out.append(f"{where}: not {arg!r}")
        elif word == "pattern":
            if isinstance(value, str) and not re.search(arg, value):
                out.append(f"{where}: does not match {arg}")
        elif word in ("minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum"):
            if _TYPES["number"](value):
                ok = {"minimum": value >= arg, "maximum": value <= arg,
                      "exclusiveMinimum": value > arg, "exclusiveMaximum": value < arg}[word]
                if not ok:
                    out.append(f"{where}: breaks {word} {arg}")
        elif word in ("minItems", "maxItems"):
            if isinstance(value, list) and not (len(value) >= arg if word == "minItems" else len(value) <= arg):
                out.append(f"{where}: breaks {word} {arg}")
        elif word == "items":
            if isinstance(value, list):
                for i, v in enumerate(value):
                    out += errors(arg, v, f"{where}/{i}")
        elif word == "properties":
            if isinstance(value, dict):
                for k, sub in arg.items():
                    if k in value:
                        out += errors(sub, value[k], f"{where}/{k}")
        elif word == "additionalProperties":
            if isinstance(value, dict):
                for k in value:
                    if k not in schema.get("properties", {}):
                        out += errors(arg, value[k], f"{where}/{k}")
        elif word == "required":
            if isinstance(value, dict):
                out += [f"{where}/{k}: required" for k in arg if k not in value]
        elif word == "propertyNames":
            if isinstance(value, dict):
                for k in value:
                    out += errors(arg, k, f"{where}/{k} (name)")
        elif word == "anyOf":
            if all(errors(sub, value, where) for sub in arg):
                out.append(f"{where}: matches none of anyOf")
        elif word == "oneOf":
            if sum(not errors(sub, value, where) for sub in arg) != 1:
                out.append(f"{where}: does not match exactly one of oneOf")
        elif word == "allOf":
            for sub in arg:
                out += errors(sub, value, where)
        elif word == "if":
            if not errors(arg, value, where):
                out += errors(schema.get("then", True), value, where)
        elif word == "then":
            pass  # with "if"
        else:
            raise AssertionError(f"the schema uses {word!r}, which this validator does not know")
    return out


def test_the_validator_refuses_what_it_should():
    """The validator itself: each keyword can fail."""
    s = {"type": "object", "properties": {"a": {"type": "integer", "minimum": 2}}, "required": ["a"],
         "additionalProperties": False}
    assert errors(s, {"a": 2}) == []
    assert errors(s, {"a": 1}) and errors(s, {"a": 2.0}) and errors(s, {}) and errors(s, {"a": 2, "b": 0})
    assert errors({"oneOf": [{"required": ["x"]}, {"required": ["y"]}]}, {"x": 1, "y": 1})
    assert errors({"if": {"properties": {"k": {"const": 1}}}, "then": {"required": ["z"]}}, {"k": 1})
    assert not errors({"if": {"properties": {"k": {"const": 1}}}, "then": {"required": ["z"]}}, {"k": 2})


# ---------------------------------------------------------------------------------------------
# Cases to probe with: full tables (Case.to_dict writes every default out).


def _example(name) -> dict:
    return tomllib.loads((EXAMPLES / name).read_text())


#: valid values of each adhesion law (the laws the schema lists must all be here)
ADHESION = {
    "smc": {"sigma_max": 1.8394e7, "tau_max": 1.8394e7, "delta_n": 1e-9, "delta_t": 1e-9, "contact_shear": "added"},
    "dugdale": {"sigma_0": 5e7, "h_0": 1e-9, "smoothing": 0.05, "ramps": "centred"},
    "exponential": {"w": 0.05, "rho": 1e-9},
    "lj93": {"w": 0.05, "z0": 3e-10},
}


def _map_file() -> str:
    """A 16 x 16 height map (.npy) for the variants that read one: a bowl of 1.6 nm depth."""
    import numpy as np

    folder = Path(tempfile.mkdtemp(prefix="wc-schema-"))
    x = np.arange(16) - 7.5
    np.save(folder / "bowl.npy", 0.1 * (x[:, None] ** 2 + x[None, :] ** 2) / 7.5)
    return str(folder / "bowl.npy")


MAP_FILE = _map_file()


def variants() -> list:
    """Valid cases that between them hold every key of the schema."""
    base = case_from_dict(_example("hertz.toml")).to_dict()
    out = [base]
    path = copy.deepcopy(base)
    path["load"] = {"path": [[0.0, 0.0, 5e-11], [2e-11, 0.0, 1e-10]]}
    out.append(path)
    legs = copy.deepcopy(base)  # the tangential leg in steps of its own
    legs["load"].update(delta_x=2e-11, steps=4, tangential_steps=2)
    out.append(legs)
    cyclic = copy.deepcopy(base)  # a cyclic path (fretting): both amplitudes, the cycles, each leg's steps
    cyclic["load"] = {"delta_z": base["load"]["delta_z"], "delta_x_amplitude": 2e-11, "delta_y_amplitude": 1e-11,
                      "cycles": 2, "steps": 3, "normal_steps": 4, "tangential_steps": 2}
    out.append(cyclic)
    out.append({**copy.deepcopy(base), "friction": {"law": "coulomb", "mu": 0.3}})
    out.append({**copy.deepcopy(base), "friction": {"law": "tabor", "k_tau": 0.8, "k_vm": 0.6, "hardness_cap": True}})
    for body in ("sphere", "flat"):  # a rigid body: rigid = true, none of the material's keys
        rigid = copy.deepcopy(base)
        rigid[body] = {k: v for k, v in base[body].items() if k not in MATERIAL_KEYS} | {"rigid": True}
        out.append(rigid)
    size = base["grid"]["size"]
    punch = copy.deepcopy(base)  # the other profiles and height maps (docs/surfaces.md)
    punch["sphere"] = {k: v for k, v in base["sphere"].items() if k != "radius"} | {
        "profile": "flat_punch", "radius": 0.3 * size, "edge_radius": 0.05 * size}
    out.append(punch)
    cone = copy.deepcopy(base)
    cone["sphere"] = {k: v for k, v in base["sphere"].items() if k != "radius"} | {
        "profile": "cone", "half_angle": 80.0, "tip_radius": 1e-7}
    out.append(cone)
    mapped = copy.deepcopy(base)
    mapped["sphere"] = {k: v for k, v in base["sphere"].items() if k != "radius"} | {
        "profile": "height_map", "height_map": MAP_FILE, "pixel_size": size / 16, "height_unit": "nm"}
    mapped["grid"] = {"n": "map", "size": "map"}
    out.append(mapped)
    rough = copy.deepcopy(base)
    rough["flat"] |= {"height_map": MAP_FILE, "pixel_size": size / 16, "height_unit": "pm"}
    out.append(rough)
    adhesive = case_from_dict(_example("pull_off_dmt.toml")).to_dict()
    for law in SCHEMA["properties"]["adhesion"]["properties"]["law"]["enum"]:
        assert law in ADHESION, f"no test values for the adhesion law {law!r}: add them to ADHESION"
        out.append({**copy.deepcopy(adhesive), "adhesion": {"law": law, **ADHESION[law]}})
    for d in out:
        case_from_dict(d)  # valid
        assert errors(SCHEMA, d) == [], d
    return out


VARIANTS = variants()


def _refusal(d):
    """The InputError of case_from_dict(d), or None when the case is valid."""
    try:
        with warnings.catch_warnings():  # probes near a bound draw plausibility warnings
            warnings.simplefilter("ignore")
            case_from_dict(d)
    except InputError as e:
        return e
    return None


def _properties():
    """(table, key, property schema) of every key of the schema."""
    for table, t in SCHEMA["properties"].items():
        for key, prop in t["properties"].items():
            yield table, key, prop


def _holding(table, key) -> list:
    return [d for d in VARIANTS if key in d.get(table, {})]


# ---------------------------------------------------------------------------------------------
# The schema.


def test_the_schema_is_a_draft_2020_12_object_schema():
    assert SCHEMA["$schema"] == DIALECT == "https://json-schema.org/draft/2020-12/schema"
    assert SCHEMA["type"] == "object" and SCHEMA["additionalProperties"] is False
    for table, t in SCHEMA["properties"].items():
        assert t["type"] == "object" and t["additionalProperties"] is False and t["properties"], table
        for key, prop in t["properties"].items():
            assert prop.get("description"), f"{table}.{key} has no description"
    assert json.loads(schema_json()) == SCHEMA


def test_the_schema_passes_the_metaschema_and_validates_the_examples():
    import jsonschema  # the test extra installs it

    jsonschema.Draft202012Validator.check_schema(SCHEMA)
    validator = jsonschema.Draft202012Validator(SCHEMA)
    for d in [*VARIANTS, *(c for _, c in _example_cases())]:
        assert not list(validator.iter_errors(d))
    assert list(validator.iter_errors({**VARIANTS[0], "grid": {"n": 4, "size": 1e-7}}))


def test_the_tables_and_keys_are_those_case_from_dict_accepts():
    """What case_from_dict accepts is read from its own refusal of an unknown key ("expected one
    of ..."), table by table and law by law: the schema holds the same names."""
    e = _refusal({**VARIANTS[0], "zzz": {}})
    assert e.key == "zzz"
    assert _expected(e) == list(SCHEMA["properties"])
    assert set(SCHEMA["required"]) == {t for t in SCHEMA["properties"] if _refusal(
        {k: v for k, v in VARIANTS[0].items() if k != t}) is not None}
    for table in SCHEMA["properties"]:
        d = copy.deepcopy(next(d for d in VARIANTS if table in d))
        d[table]["zzz"] = 1
        e = _refusal(d)
        assert e.key == f"{table}.zzz", e
        assert sorted(_expected(e)) == sorted(SCHEMA["properties"][table]["properties"]), table
    for table in ("friction", "adhesion"):  # the keys of each law
        rules = {r["properties"]["law"]["const"]: r for r in SCHEMA["properties"][table]["oneOf"]}
        assert set(rules) == set(SCHEMA["properties"][table]["properties"]["law"]["enum"])
        for law, then in rules.items():
            d = copy.deepcopy(next(d for d in VARIANTS if d.get(table, {}).get("law") == law))
            other = next(k for k in SCHEMA["properties"][table]["properties"] if k not in then["propertyNames"]["enum"])
            d[table][other] = 1.0
            e = _refusal(d)
            assert e.key == f"{table}.{other}" and "is not used by law" in str(e), e
            assert sorted(_expected(e)) == sorted(then["propertyNames"]["enum"]), (table, law)


def _expected(e: InputError) -> list:
    m = re.search(r"expected one of (.*)$", e.problem)
    assert m, e
    return [k.strip() for k in m.group(1).split(",")]


def test_required_keys_agree_with_case_from_dict():
    """Each key left out of each case that holds it: the schema refuses exactly where
    case_from_dict does (naming a key of that table as required)."""
    checked = 0
    for d in VARIANTS:
        for table, t in d.items():
            for key in t:
                less = copy.deepcopy(d)
                del less[table][key]
                e = _refusal(less)
                # the key, or its alternative (load.path left out: "load.delta_z is required (or give load.path)")
                by_case = e is not None and e.key.startswith(f"{table}.") and "required" in e.problem
                by_schema = bool(errors(SCHEMA, less))
                # (an optional key left out may still be missed by a check of several keys:
                # friction.hardness_cap = true needs the softer body's hardness)
                assert by_schema == by_case, (table, key, d[table], e)
                checked += 1
    assert checked > 50


def test_defaults_are_what_case_from_dict_fills_in():
    checked = 0
    for table, key, prop in _properties():
        if "default" not in prop:
            continue
        d = copy.deepcopy(_holding(table, key)[0])
        del d[table][key]
        assert case_from_dict(d).to_dict()[table][key] == prop["default"], (table, key)
        checked += 1
    assert checked >= 12


def _probes(prop):
    """(value, valid by the schema) on both sides of each bound of a numeric property."""
    number = next((s for s in [prop, *prop.get("anyOf", [])] if s.get("type") in ("number", "integer")), None)
    if number is None:
        return []
    integer = number["type"] == "integer"
    out = []
    for word, b in number.items():
        if word == "minimum":
            out += [(b, True), (b - 1 if integer else math.nextafter(b, -math.inf), False)]
        elif word == "maximum":
            out += [(b, True), (b + 1 if integer else math.nextafter(b, math.inf), False)]
        elif word == "exclusiveMinimum":
            out += [(b, False), (-1e300 if b == 0 else math.nextafter(b, -math.inf), False)]
            if b != 0:  # just above zero, a modulus or a length is refused by plausibility instead
                out.append((math.nextafter(b, math.inf), True))
        elif word == "exclusiveMaximum":
            out += [(b, False), (math.nextafter(b, -math.inf), True)]
    # far out on each side: a bound the program has and the schema lacks shows here (valid: None,
    # the schema's verdict is compared below)
    out += [(-10**12 if integer else -1e300, None), (10**12 if integer else 1e300, None)]
    return out


def test_bounds_agree_with_case_from_dict():
    """Every bound, probed on both sides, and every number far out on both sides: a value the
    schema refuses is refused by case_from_dict, naming the key; a value it accepts is not refused
    by a range check of the key (a check of plausibility may refuse 1e300 m)."""
    checked = 0
    for table, key, prop in _properties():
        for value, valid in _probes(prop):
            d = copy.deepcopy(_holding(table, key)[0])
            d[table][key] = value
            if valid is None:
                valid = not errors(SCHEMA, d)
            assert (not errors(SCHEMA, d)) == valid, (table, key, value)
            e = _refusal(d)
            if valid:  # refused, if at all, for plausibility ("= 1e300 m: ..."), not by a range ("must ...")
                assert e is None or e.key != f"{table}.{key}" or "must" not in e.problem, (table, key, value, e)
            else:
                assert e is not None and e.key == f"{table}.{key}", (table, key, value, e)
            checked += 1
    assert checked >= 25


@pytest.mark.parametrize("wrong", ["1e9", True, [1.0], {"a": 1}, 8.0])
def test_types_agree_with_case_from_dict(wrong):
    """A value of the wrong type in each key: what the schema refuses, case_from_dict refuses
    naming the key; what it accepts (8.0 for a length, "inf" for a strength), case_from_dict does
    not refuse for its type (it may for plausibility: 8.0 m is no asperity's radius)."""
    checked = 0
    for table, key, prop in _properties():
        d = copy.deepcopy(_holding(table, key)[0])
        d[table][key] = wrong
        e = _refusal(d)
        if errors(SCHEMA, d):
            # rigid = true is of the right type: what is refused is the elastic body's E beside it
            expected = f"{table}.E" if key == "rigid" and wrong is True else f"{table}.{key}"
            assert e is not None and e.key == expected, (table, key, wrong, e)
            checked += 1
        else:
            assert e is None or e.key != f"{table}.{key}" or "must be" not in e.problem, (table, key, wrong, e)
    assert checked >= 10


def test_choices_and_patterns_agree_with_case_from_dict():
    for table, key, prop in _properties():
        if "enum" in prop:
            d = copy.deepcopy(_holding(table, key)[0])
            d[table][key] = "no-such-choice"
            e = _refusal(d)
            assert errors(SCHEMA, d) and e is not None and e.key == f"{table}.{key}"
    for device, ok in (("cpu", True), ("cuda", True), ("cuda:12", True), ("gpu", False), ("cuda:", False),
                       ("cuda:x", False), ("CPU", False)):
        d = copy.deepcopy(VARIANTS[0])
        d["solver"]["device"] = device
        assert (not errors(SCHEMA, d)) == ok == (_refusal(d) is None), device
    for strength, ok in (("inf", True), (" +INF ", True), ("infinite", False), ("1e9", False)):
        d = copy.deepcopy(VARIANTS[0])
        d["flat"]["hardness"] = strength
        assert (not errors(SCHEMA, d)) == ok == (_refusal(d) is None), strength


def test_load_takes_a_path_or_delta_z_never_both():
    d = copy.deepcopy(VARIANTS[1])
    d["load"]["steps"] = 2
    assert errors(SCHEMA, d) and _refusal(d).key == "load.steps"
    d = copy.deepcopy(VARIANTS[1])
    d["load"]["path"] = [[0.0, 0.0]]
    assert errors(SCHEMA, d) and _refusal(d).key == "load.path"


def _example_cases():
    """(name, case dict) of every case in examples/: the case files and a sweep or fit file's [base]."""
    for path in sorted(EXAMPLES.glob("*.toml")):
        d = tomllib.loads(path.read_text())
        if "sweep" in d or "fit" in d:
            if isinstance(d.get("base"), dict):
                yield f"{path.name} [base]", d["base"]
        else:
            yield path.name, d


def test_the_example_case_files_validate():
    cases = list(_example_cases())
    assert len(cases) >= 10
    for name, d in cases:
        assert errors(SCHEMA, d) == [], name
        case_from_dict(d)  # and the program agrees


def test_schema_command_prints_and_writes(tmp_path):
    r = subprocess.run([sys.executable, "-m", "warpcontact.cli", "schema"], capture_output=True, text=True,
                       timeout=60)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout) == SCHEMA
    out = tmp_path / "editor" / "case.schema.json"
    r = subprocess.run([sys.executable, "-m", "warpcontact.cli", "schema", "--out", str(out)], capture_output=True,
                       text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    assert json.loads(out.read_text()) == SCHEMA and r.stdout == ""
    assert [p.name for p in out.parent.iterdir()] == ["case.schema.json"]  # no temporary file left


def test_a_key_the_schema_does_not_describe_stops_it(monkeypatch):
    """A key added to case.py's lists without its value's kind in schema.VALUES is not left out
    of the schema silently."""
    from warpcontact.records import case

    monkeypatch.setattr(case, "SPHERE_KEYS", (*case.SPHERE_KEYS, "colour"))
    with pytest.raises(KeyError, match="sphere.colour"):
        case_schema()

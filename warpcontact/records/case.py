"""A case: the whole description of one run, read from a TOML file in SI units.

The file format (tables, keys, units, defaults, ranges) is documented in ``docs/case-files.md``.
Every mistake in a case raises :class:`~warpcontact.errors.InputError` whose ``key`` is the
dotted case-file key (``"sphere.E"``, ``"load.path"``), or the file path for a file that cannot
be read or parsed; the message is one line, ``"<key>: <problem>"``.

What is checked here: types, ranges, unknown and missing keys, the plausibility of the values
(:mod:`warpcontact.records.plausibility`: a modulus below its body's yield strength, an adhesive stress
above E*, a work of adhesion no solids have, a contact far wider than the domain; each refused
with the unit the user probably meant), and the consistency of the case (the Hertz contact fits
in the domain, the domain lies inside the sphere, the FFT backend can run on the device kind). What is not: whether a CUDA device or CuPy exists on this machine (the
runner checks that when it picks the device).

Example::

    case = load_case("paper.toml")
    case.pair.E_star, case.grid.dx, case.load.path()
    case = case.with_overrides(device="cuda:0", dtype="float32")
"""

from __future__ import annotations

import copy
import difflib
import math
import numbers
import re
from dataclasses import dataclass, field, replace
from os import PathLike
from typing import Any, Mapping, Sequence

import numpy as np

try:
    import tomllib
except ModuleNotFoundError:  # Python < 3.11
    import tomli as tomllib

from ..errors import InputError
from ..fft.names import BACKENDS as FFT_BACKENDS  # FFT backends by name (warpcontact.fft)
from ..fft.names import DEVICE_KIND as FFT_DEVICE_KIND  # those that run on one kind of device only
from ..physics.geometry import MIN_CELLS, Grid, Sphere
from .guards import profile_note
from ..physics.materials import Material, MaterialPair
from .plausibility import PREFIXES, check_case

#: Tables of a case file, in the order they are documented and written.
TABLES = ("sphere", "flat", "grid", "load", "solver", "friction", "adhesion")
#: Tables a case file must have.
REQUIRED_TABLES = ("sphere", "flat", "grid", "load")

SPHERE_KEYS = ("radius", "E", "nu", "yield_strength", "hardness", "profile", "rigid")
FLAT_KEYS = ("E", "nu", "yield_strength", "hardness", "rigid")
#: The keys of a body's material: an elastic body needs E and nu, a rigid one (rigid = true) takes none.
MATERIAL_KEYS = ("E", "nu", "yield_strength", "hardness")
GRID_KEYS = ("n", "size")
LOAD_KEYS = ("delta_z", "delta_x", "delta_y", "steps", "normal_steps", "tangential_steps", "delta_x_amplitude",
             "delta_y_amplitude", "cycles", "path")
SOLVER_KEYS = ("device", "dtype", "tol", "max_iter", "max_turns", "fft", "nested", "window")
FRICTION_KEYS = {"coulomb": ("law", "mu"), "tabor": ("law", "k_tau", "k_vm", "hardness_cap")}
ADHESION_KEYS = {"smc": ("law", "sigma_max", "tau_max", "delta_n", "delta_t", "contact_shear"),
                 "dugdale": ("law", "sigma_0", "h_0", "smoothing", "ramps"),
                 "exponential": ("law", "w", "rho"),
                 "lj93": ("law", "w", "z0")}
#: Keys a law may leave out (its default then holds): the SMC law's shear inside the contact,
#: Dugdale's ramp width over h_0 and where the ramps go.
ADHESION_OPTIONAL = {"smc": ("contact_shear",), "dugdale": ("smoothing", "ramps")}
#: The SMC law's shear inside the contact (warpcontact.physics.adhesion.CONTACT_SHEAR): bounded
#: with the contact shear, or added to it.
SMC_CONTACT_SHEAR = ("bounded", "added")
#: Where the Dugdale law's ramps go (warpcontact.physics.adhesion.RAMPS): both ends, or one centred on h_0.
DUGDALE_RAMPS = ("centred", "both")
#: Every key an [adhesion] table may hold.
ADHESION_ALL_KEYS = tuple(dict.fromkeys(k for keys in ADHESION_KEYS.values() for k in keys))

PROFILES = ("sphere", "paraboloid")
DTYPES = ("float64", "float32")
#: Default relative tolerance of the conjugate-gradient solves, per dtype.
DEFAULT_TOL = {"float64": 1e-10, "float32": 1e-5}
#: Largest accepted tolerance.
MAX_TOL = 1e-2
DEFAULT_MAX_ITER = 2000
#: coupling / adhesive fixed-point turns per load step (ContactSolver.max_outer)
DEFAULT_MAX_TURNS = 1000
#: von Mises ratio T_S / S_Y (MODEL.md section 5).
DEFAULT_K_VM = 1.0 / math.sqrt(3.0)
#: Most load steps per leg of the default path (a guard against typos such as 1e9 steps).
MAX_STEPS = 100_000
#: Most whole cycles of a cyclic path (load.cycles); the path's states are bounded too (2 MAX_STEPS).
MAX_CYCLES = 10_000
#: The suggested smallest domain, in Hertz contact radii.
SUGGESTED_SIZE_IN_A = 2.5

_DEVICE_RE = re.compile(r"cpu|cuda(:\d+)?")

State = tuple[float, float, float]


# ---------------------------------------------------------------------------------------------
# Value checks. Each takes the dotted key it reports and returns the normalised value.


def _is_bool(v) -> bool:
    return isinstance(v, (bool, np.bool_))


def _type_name(v) -> str:
    """The TOML name of a value's type, for messages."""
    if _is_bool(v):
        return "boolean"
    if isinstance(v, str):
        return "string"
    if isinstance(v, numbers.Integral):
        return "integer"
    if isinstance(v, numbers.Real):
        return "float"
    if isinstance(v, Mapping):
        return "table"
    if isinstance(v, (list, tuple)):
        return "array"
    if v is None:
        return "nothing"
    return type(v).__name__


def _show(v) -> str:
    """A short one-line rendering of a value, for messages."""
    if _is_bool(v):
        return "true" if v else "false"
    if isinstance(v, numbers.Real) and not isinstance(v, numbers.Integral):
        return repr(float(v))
    text = repr(v)
    text = " ".join(text.split())
    return text if len(text) <= 60 else text[:57] + "..."


def _got(v) -> str:
    return f"got {_type_name(v)} {_show(v)}" if v is not None else "got nothing"


#: units a value may be written with by mistake ("10 um"): the factor to SI and the SI unit named
#: in the hint (case files take bare numbers in SI units)
_UNITS = {prefix + written: (factor, si)
          for written, si in {"m": "m", "Pa": "Pa", "J/m^2": "J/m^2", "J/m2": "J/m^2", "N/m": "J/m^2"}.items()
          for factor, prefix in {1.0: "", **PREFIXES}.items()}
_UNITS |= {"\u00b5m": (1e-6, "m"), "\u03bcm": (1e-6, "m"), "A": (1e-10, "m"), "\u00c5": (1e-10, "m")}
_WITH_UNIT = re.compile(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*([^\s\d].*?)?\s*")


def _string_hint(v: str, unit: str = "") -> str:
    """What to write instead of a number given as a string: the number itself, in SI units where
    the string carries one of ``_UNITS`` ("10 um" -> 1e-05 m) of the key's ``unit`` (any, where
    not given); "" when the string is no number."""
    m = _WITH_UNIT.fullmatch(v)
    if not m:
        return ""
    value, written = float(m.group(1)), m.group(2)
    if written is None:
        return f"; write it without quotes: {value!r}"
    if written in _UNITS and _UNITS[written][1] == (unit or _UNITS[written][1]):
        factor, si = _UNITS[written]
        return f"; case files take SI numbers: write {value * factor:.6g} ({v.strip()} in {si})"
    return f"; case files take bare numbers in SI units ({unit})" if unit else ""


def _number(key: str, v, *, allow_inf: bool = False, unit: str = "") -> float:
    """A real number (int accepted, bool refused), finite unless ``allow_inf`` (+inf only);
    ``unit``: the key's SI unit, for the hint where the number came as a string with a unit."""
    if _is_bool(v) or not isinstance(v, numbers.Real):
        hint = _string_hint(v, unit) if isinstance(v, str) else ""
        raise InputError(key, f"must be a number, {_got(v)}{hint}")
    try:
        x = float(v)
    except OverflowError:
        raise InputError(key, f"must be a finite number, got an integer too large for a float ({_show(v)})") from None
    if math.isnan(x):
        raise InputError(key, "must be a number, got nan")
    if math.isinf(x) and not (allow_inf and x > 0):
        raise InputError(key, f"must be finite, got {x!r}")
    return x


def _positive(key: str, v, unit: str, *, allow_inf: bool = False) -> float:
    x = _number(key, v, allow_inf=allow_inf, unit=unit)
    if not x > 0.0:
        raise InputError(key, f"must be > 0{' ' + unit if unit else ''}, got {x!r}")
    return x


def _strength(key: str, v) -> float:
    """A yield strength or hardness [Pa]: positive, or +inf (TOML ``inf`` or the string "inf") for no limit."""
    if isinstance(v, str) and v.strip().lower() in ("inf", "+inf"):
        return math.inf
    if isinstance(v, str):
        raise InputError(key, f'must be a number in Pa or "inf" (no limit), {_got(v)}{_string_hint(v, "Pa")}')
    return _positive(key, v, "Pa", allow_inf=True)


def _integer(key: str, v, minimum: int, maximum: int | None = None) -> int:
    if _is_bool(v) or not isinstance(v, numbers.Integral):
        raise InputError(key, f"must be an integer, {_got(v)}")
    n = int(v)
    if n < minimum:
        raise InputError(key, f"must be at least {minimum}, got {n}")
    if maximum is not None and n > maximum:
        raise InputError(key, f"must be at most {maximum}, got {n}")
    return n


def _choice(key: str, v, choices: Sequence[str]) -> str:
    if not isinstance(v, str):
        raise InputError(key, f"must be a string, one of {_list(choices)}; {_got(v)}")
    if v not in choices:
        raise InputError(key, f"must be one of {_list(choices)}; got {v!r}")
    return v


def _list(names: Sequence[str]) -> str:
    return ", ".join(repr(n) for n in names)


def _table(key: str, v) -> Mapping:
    if not isinstance(v, Mapping):
        raise InputError(key, f"must be a table, {_got(v)}")
    return v


#: The [load] keys of the default path (an explicit ``path`` replaces them all).
DEFAULT_PATH_KEYS = ("delta_z", "delta_x", "delta_y", "steps", "normal_steps", "tangential_steps",
                     "delta_x_amplitude", "delta_y_amplitude", "cycles")
#: The [load] keys of a cyclic path (fretting): the amplitudes and the number of whole cycles.
CYCLIC_KEYS = ("delta_x_amplitude", "delta_y_amplitude", "cycles")


def substitute(base: dict, params: Mapping) -> dict:
    """A copy of the case dict ``base`` with ``params`` (dotted case key -> value, in the case file's
    SI units: "friction.k_tau", "load.delta_z" [m]) put in: a sweep's combination, a fit's row at a
    point. An explicit ``load.path`` replaces the default path's keys, and the reverse."""
    d = copy.deepcopy(base)
    swept = {tuple(k.split(".", 1)) for k in params}
    load = d.get("load", {})
    if ("load", "path") in swept:
        for k in DEFAULT_PATH_KEYS:
            if ("load", k) not in swept:
                load.pop(k, None)
    elif any(t == "load" and k in DEFAULT_PATH_KEYS for t, k in swept):
        load.pop("path", None)
    for key, v in params.items():
        table, name = key.split(".", 1)
        d.setdefault(table, {})[name] = copy.deepcopy(v)
    return d


def _check_keys(table: str, d: Mapping, allowed: Sequence[str], why: str = "unknown key") -> None:
    """Refuse any key of ``d`` outside ``allowed``, naming it (and, for a typo, the nearest allowed key)."""
    for k in d:
        if k in allowed:
            continue
        name = k if isinstance(k, str) else repr(k)
        typo = why.startswith("unknown") and isinstance(k, str)
        same = [a for a in allowed if a.lower() == name.lower()] if typo else []  # e for E
        near = same or (difflib.get_close_matches(name, allowed, n=1) if typo else [])
        hint = f"did you mean {near[0]!r}? " if near else ""
        raise InputError(f"{table}.{name}" if table else name, f"{why}; {hint}expected one of {', '.join(allowed)}")


def _require(table: str, d: Mapping, keys: Sequence[str], extra: str = "") -> None:
    for k in keys:
        if k not in d:
            raise InputError(f"{table}.{k}", "is required" + extra)


def _inf_out(x: float):
    """JSON-safe form of a strength: the string "inf" for no limit."""
    return "inf" if math.isinf(x) else x


def _set(obj, name: str, value) -> None:
    object.__setattr__(obj, name, value)  # normalising a field of a frozen dataclass


# ---------------------------------------------------------------------------------------------
# The parts of a case.


def _boolean(key: str, v) -> bool:
    if not _is_bool(v):
        raise InputError(key, f"must be true or false, {_got(v)}")
    return bool(v)


def _unused_by_rigid(table: str, key: str) -> InputError:
    return InputError(f"{table}.{key}", f"is not used by a rigid body ({table}.rigid = true: no modulus, no Poisson "
                                        f"ratio, it never yields); leave it out, or set {table}.rigid = false for an "
                                        f"elastic {table}")


def _material(table: str, E, nu, yield_strength, hardness, rigid: bool = False) -> Material:
    """A validated :class:`Material` named after its table, so its own checks report ``table.key``:
    elastic from E and nu, or with ``rigid`` a rigid body (``Material.rigid``), which takes no E
    or nu (None) and no finite yield strength or hardness."""
    if rigid:
        for key, v in (("E", E), ("nu", nu), ("yield_strength", yield_strength), ("hardness", hardness)):
            if v is None or (key in ("yield_strength", "hardness") and _strength(f"{table}.{key}", v) == math.inf):
                continue
            raise _unused_by_rigid(table, key)
        return Material.rigid(table)
    for key, v in (("E", E), ("nu", nu)):
        if v is None:
            raise InputError(f"{table}.{key}", "is required")
    if E == math.inf:
        raise InputError(f"{table}.E", f"must be finite, got inf; for a rigid {table}, set {table}.rigid = true "
                                       "and leave E and nu out")
    E = _positive(f"{table}.E", E, "Pa")
    nu = _number(f"{table}.nu", nu)
    if not -1.0 < nu <= 0.5:
        raise InputError(f"{table}.nu", f"must lie in (-1, 0.5], got {nu!r}")
    return Material(
        E=E,
        nu=nu,
        yield_strength=_strength(f"{table}.yield_strength", yield_strength),
        hardness=_strength(f"{table}.hardness", hardness),
        name=table,
    )


def _material_dict(m: Material) -> dict:
    if m.is_rigid:
        return {"rigid": True}
    return {"E": m.E, "nu": m.nu, "yield_strength": _inf_out(m.yield_strength), "hardness": _inf_out(m.hardness),
            "rigid": False}


def _check_body(spec, table: str) -> None:
    """Validate and normalise the material fields (E, nu, yield_strength, hardness, rigid) of a
    body's table (``SphereSpec``, ``FlatSpec``) in place."""
    _set(spec, "rigid", _boolean(f"{table}.rigid", spec.rigid))
    m = _material(table, spec.E, spec.nu, spec.yield_strength, spec.hardness, spec.rigid)
    if not m.is_rigid:
        for name in MATERIAL_KEYS:
            _set(spec, name, getattr(m, name))


def _body_material(spec, table: str) -> Material:
    """The Material of a validated body table, named after it."""
    if spec.rigid:
        return Material.rigid(table)
    return Material(spec.E, spec.nu, spec.yield_strength, spec.hardness, name=table)


@dataclass(frozen=True)
class SphereSpec:
    """The ``[sphere]`` table: the asperity's geometry and material (body 1).

    Attributes:
        radius: R [m].
        E: Young's modulus [Pa]; required unless rigid.
        nu: Poisson ratio [-], in (-1, 0.5]; required unless rigid.
        yield_strength: S_Y [Pa]; inf for no limit.
        hardness: H [Pa]; inf for no limit.
        profile: "sphere" (exact cap) or "paraboloid" (r^2 / 2R).
        rigid: true for a rigid sphere (the limit E -> inf: a glass lens on rubber), which takes no
            E, nu, yield_strength or hardness; the flat must then be elastic.
    """

    radius: float
    E: float | None = None
    nu: float | None = None
    yield_strength: float = math.inf
    hardness: float = math.inf
    profile: str = "sphere"
    rigid: bool = False

    def __post_init__(self):
        _set(self, "radius", _positive("sphere.radius", self.radius, "m"))
        _set(self, "profile", _choice("sphere.profile", self.profile, PROFILES))
        _check_body(self, "sphere")

    @property
    def material(self) -> Material:
        """The sphere's material (named "sphere")."""
        return _body_material(self, "sphere")

    @property
    def geometry(self) -> Sphere:
        return Sphere(self.radius, self.profile)

    def to_dict(self) -> dict:
        return {"radius": self.radius, **_material_dict(self.material), "profile": self.profile}


@dataclass(frozen=True)
class FlatSpec:
    """The ``[flat]`` table: the flat's material (body 2).

    Attributes:
        E: Young's modulus [Pa]; required unless rigid.
        nu: Poisson ratio [-], in (-1, 0.5]; required unless rigid.
        yield_strength: S_Y [Pa]; inf for no limit.
        hardness: H [Pa]; inf for no limit.
        rigid: true for a rigid flat (the limit E -> inf: an elastic sphere on a rigid flat), which
            takes no E, nu, yield_strength or hardness; the sphere must then be elastic.
    """

    E: float | None = None
    nu: float | None = None
    yield_strength: float = math.inf
    hardness: float = math.inf
    rigid: bool = False

    def __post_init__(self):
        _check_body(self, "flat")

    @property
    def material(self) -> Material:
        """The flat's material (named "flat")."""
        return _body_material(self, "flat")


#: The ``[grid]`` table is a :class:`~warpcontact.physics.geometry.Grid` (n cells per side, size in m).
GridSpec = Grid


@dataclass(frozen=True)
class LoadSpec:
    """The ``[load]`` table: the path of rigid-body approaches (MODEL.md section 3).

    Either the default path (``delta_z`` required; ``delta_x``, ``delta_y``, ``steps``), the
    cyclic path of fretting (``delta_z`` and ``delta_x_amplitude`` or ``delta_y_amplitude``,
    ``cycles``) or an explicit path (``states``, the file's ``path`` key), never two of them.

    Attributes:
        delta_z: final normal approach [m] of the default or cyclic path; None with an explicit path.
        delta_x: final tangential approach along x [m] of the default path.
        delta_y: final tangential approach along y [m] of the default path.
        steps: equal steps per leg of the default path (normal leg, then tangential leg).
        normal_steps: equal steps of the normal leg where they differ from ``steps`` (None: ``steps``).
        tangential_steps: equal steps of the tangential leg where they differ from ``steps`` (None:
            ``steps``); on a cyclic path, the steps of each quarter cycle.
        delta_x_amplitude: displacement amplitude along x [m], > 0, of a cyclic path (fretting): after
            the normal leg, delta_x goes 0 -> +amplitude (the first quarter), then ``cycles`` times
            +amplitude -> -amplitude -> +amplitude; None: no cyclic path.
        delta_y_amplitude: displacement amplitude along y [m], > 0, of a cyclic path, in phase with
            ``delta_x_amplitude``; None: none along y.
        cycles: whole cycles of a cyclic path after its first quarter, 1 to 10000 (default 1).
        states: the explicit path, (delta_x, delta_y, delta_z) triples [m] in order; None for the
            default path.
    """

    delta_z: float | None = None
    delta_x: float = 0.0
    delta_y: float = 0.0
    steps: int = 1
    tangential_steps: int | None = None
    states: tuple[State, ...] | None = None
    normal_steps: int | None = None
    delta_x_amplitude: float | None = None
    delta_y_amplitude: float | None = None
    cycles: int = 1

    def __post_init__(self):
        if self.states is not None:
            if self.delta_z is not None:
                raise InputError("load.delta_z", "must not be given together with load.path (the path lists every state)")
            for name, default in (("delta_x", 0.0), ("delta_y", 0.0), ("steps", 1), ("normal_steps", None),
                                  ("tangential_steps", None), ("delta_x_amplitude", None),
                                  ("delta_y_amplitude", None), ("cycles", 1)):
                if getattr(self, name) != default:
                    raise InputError(f"load.{name}", "must not be given together with load.path (the path lists every state)")
            _set(self, "states", _path_states(self.states))
            return
        if self.delta_z is None:
            raise InputError("load.delta_z", "is required (or give load.path)")
        _set(self, "delta_z", _number("load.delta_z", self.delta_z, unit="m"))
        _set(self, "delta_x", _number("load.delta_x", self.delta_x, unit="m"))
        _set(self, "delta_y", _number("load.delta_y", self.delta_y, unit="m"))
        _set(self, "steps", _integer("load.steps", self.steps, 1, MAX_STEPS))
        for name in ("normal_steps", "tangential_steps"):
            if getattr(self, name) is not None:
                _set(self, name, _integer(f"load.{name}", getattr(self, name), 1, MAX_STEPS))
        for name in ("delta_x_amplitude", "delta_y_amplitude"):
            if getattr(self, name) is not None:
                _set(self, name, _positive(f"load.{name}", getattr(self, name), "m"))
        _set(self, "cycles", _integer("load.cycles", self.cycles, 1, MAX_CYCLES))
        if not self.cyclic:
            if self.cycles != 1:
                raise _cycles_without_amplitude()
            return
        for name in ("delta_x", "delta_y"):
            if getattr(self, name) != 0.0:
                amplitude = f"load.{name}_amplitude"
                raise InputError(f"load.{name}", f"must be left out of a cyclic path (its tangential approach runs "
                                                 f"between -{amplitude} and +{amplitude}); give one or the other")
        quarters = 1 + 4 * self.cycles
        total = self.normal_leg_steps + quarters * self.tangential_leg_steps
        if total > 2 * MAX_STEPS:
            raise InputError("load.cycles", f"{self.cycles} cycle(s) of 4 x {self.tangential_leg_steps} steps after "
                                            f"the first quarter and {self.normal_leg_steps} normal steps give {total} "
                                            f"states; a path holds at most {2 * MAX_STEPS}: take fewer cycles or fewer "
                                            "load.tangential_steps")

    @property
    def explicit(self) -> bool:
        """True when the path was given state by state (the ``path`` key)."""
        return self.states is not None

    @property
    def cyclic(self) -> bool:
        """True for a cyclic (fretting) path: an amplitude was given."""
        return self.delta_x_amplitude is not None or self.delta_y_amplitude is not None

    @property
    def normal_leg_steps(self) -> int | None:
        """The normal leg's equal steps: ``normal_steps``, else ``steps`` (an explicit path: None)."""
        if self.states is not None:
            return None
        return self.steps if self.normal_steps is None else self.normal_steps

    @property
    def tangential_leg_steps(self) -> int | None:
        """The tangential leg's equal steps (a cyclic path: per quarter cycle): ``tangential_steps``,
        else ``steps`` (an explicit path: None)."""
        if self.states is not None:
            return None
        return self.steps if self.tangential_steps is None else self.tangential_steps

    def cycle_bounds(self) -> list[tuple[int, int]]:
        """The whole cycles of a cyclic path as (first, last) indices into :meth:`path`: each cycle
        runs from the state at +amplitude (the last of the first quarter, or of the cycle before)
        through -amplitude back to +amplitude, 4 ``tangential_leg_steps`` steps. Empty for a path
        that is not cyclic."""
        if not self.cyclic:
            return []
        n, q = self.normal_leg_steps, self.tangential_leg_steps
        first = n + q - 1
        return [(first + 4 * q * c, first + 4 * q * (c + 1)) for c in range(self.cycles)]

    def path(self) -> list[State]:
        """The (delta_x, delta_y, delta_z) states [m] of the path, in the order they are solved.

        Default path: delta_z in ``normal_steps`` (default ``steps``) equal steps with delta_x =
        delta_y = 0, then delta_x and delta_y together in ``tangential_steps`` (default ``steps``)
        equal steps at the final delta_z (that leg is left out when delta_x = delta_y = 0). A cyclic
        path has the same normal leg, then the tangential approach s (delta_x_amplitude,
        delta_y_amplitude) with s going 0 -> 1 in ``tangential_steps`` steps (the first quarter)
        and ``cycles`` times 1 -> -1 -> 1 in 4 ``tangential_steps`` steps. The unloaded state
        (0, 0, 0) is not part of the path.
        """
        if self.states is not None:
            return list(self.states)
        n = self.normal_leg_steps
        states = [(0.0, 0.0, self.delta_z * k / n) for k in range(1, n + 1)]
        states[-1] = (0.0, 0.0, self.delta_z)
        q = self.tangential_leg_steps
        if self.cyclic:
            ax, ay = self.delta_x_amplitude or 0.0, self.delta_y_amplitude or 0.0
            # s at each step: 1 - k / q on the way down, k / q - 1 back up (exact at 0 and +-1)
            s = [k / q for k in range(1, q + 1)]
            for _ in range(self.cycles):
                s += [1.0 - k / q for k in range(1, 2 * q + 1)] + [k / q - 1.0 for k in range(1, 2 * q + 1)]
            return states + [(ax * f + 0.0, ay * f + 0.0, self.delta_z) for f in s]  # + 0.0: no -0.0
        if self.delta_x != 0.0 or self.delta_y != 0.0:
            states += [(self.delta_x * k / q, self.delta_y * k / q, self.delta_z) for k in range(1, q + 1)]
            states[-1] = (self.delta_x, self.delta_y, self.delta_z)
        return states

    @property
    def delta_z_max(self) -> float:
        """The largest normal approach on the path [m]."""
        return max(s[2] for s in self.path())

    def to_dict(self) -> dict:
        if self.states is not None:
            return {"path": [list(s) for s in self.states]}
        out = {"delta_z": self.delta_z}
        if self.cyclic:
            out.update({k: getattr(self, k) for k in CYCLIC_KEYS if getattr(self, k) is not None})
        else:
            out.update(delta_x=self.delta_x, delta_y=self.delta_y)
        out["steps"] = self.steps
        for name in ("normal_steps", "tangential_steps"):
            if getattr(self, name) is not None:
                out[name] = getattr(self, name)
        return out


def _cycles_without_amplitude() -> InputError:
    return InputError("load.cycles", "belongs to a cyclic path: give load.delta_x_amplitude or load.delta_y_amplitude "
                                     "(m) with it")


def _path_states(v) -> tuple[State, ...]:
    key = "load.path"
    shape = "an array of [delta_x, delta_y, delta_z] arrays in m"
    if isinstance(v, (str, bytes, Mapping)) or not isinstance(v, (Sequence, np.ndarray)):
        raise InputError(key, f"must be {shape}, {_got(v)}")
    if len(v) == 0:
        raise InputError(key, f"must hold at least one state ({shape}), got an empty array")
    if len(v) > 2 * MAX_STEPS:
        raise InputError(key, f"must hold at most {2 * MAX_STEPS} states, got {len(v)}")
    states = []
    for i, s in enumerate(v):
        if isinstance(s, (str, bytes, Mapping)) or not isinstance(s, (Sequence, np.ndarray)) or len(s) != 3:
            raise InputError(key, f"entry {i} must be [delta_x, delta_y, delta_z] (3 numbers in m), {_got(s)}")
        state = []
        for j, (name, x) in enumerate(zip(("delta_x", "delta_y", "delta_z"), s)):
            if _is_bool(x) or not isinstance(x, numbers.Real):
                raise InputError(key, f"entry {i} ({name}) must be a number in m, {_got(x)}")
            try:
                x = float(x)
            except OverflowError:
                x = math.inf
            if not math.isfinite(x):
                raise InputError(key, f"entry {i} ({name}) must be finite, got {x!r}")
            state.append(x)
        states.append(tuple(state))
    return tuple(states)


@dataclass(frozen=True)
class SolverSpec:
    """The ``[solver]`` table: where and how precisely the problem is solved.

    Attributes:
        device: "cpu", "cuda" or "cuda:N" (existence is checked by the runner).
        dtype: "float64" or "float32".
        tol: relative tolerance of the conjugate-gradient solves, in (0, 1e-2]; None (or leaving
            it out of the file) gives the dtype's default (1e-10 for float64, 1e-5 for float32).
        max_iter: iteration limit of each conjugate-gradient solve.
        max_turns: limit on the turns of a load step (normal and tangential solves in turns, the
            adhesive fixed point); a step that reaches it is reported as not converged.
        fft: "auto", "scipy" (CPU only), "cupy" (CUDA only) or "warp".
        nested: start each step with friction (no adhesion) from its solution on the grid of half
            the cells per side (``ContactSolver.nested``): fewer iterations on large grids. true,
            false or "auto" (the default: from 512 cells per side on the CPU, 2048 on CUDA).
        window: solve each step's shear on the smallest window of the grid that holds the contact
            (``TangentialSolver.window``): the same answer, smaller transforms where the contact
            is a fraction of the domain. true, false or "auto" (the default: from 128 cells per
            side on the CPU, 1024 on CUDA).
        tol_default: True when ``tol`` came from the dtype's default; such a tol follows a dtype
            override (see :meth:`with_overrides`). Not compared, not written by ``to_dict``.
    """

    device: str = "cpu"
    dtype: str = "float64"
    tol: float | None = None
    max_iter: int = DEFAULT_MAX_ITER
    max_turns: int = DEFAULT_MAX_TURNS
    fft: str = "auto"
    nested: bool | str = "auto"
    window: bool | str = "auto"
    tol_default: bool = field(default=False, compare=False, repr=False)

    def __post_init__(self):
        if not isinstance(self.device, str):
            raise InputError("solver.device", f"must be a string ('cpu', 'cuda' or 'cuda:N'), {_got(self.device)}")
        if not _DEVICE_RE.fullmatch(self.device):
            raise InputError("solver.device", f"must be 'cpu', 'cuda' or 'cuda:N' (N = 0, 1, ...), got {self.device!r}")
        _choice("solver.dtype", self.dtype, DTYPES)
        if self.tol is None:
            _set(self, "tol", DEFAULT_TOL[self.dtype])
            _set(self, "tol_default", True)
        tol = _number("solver.tol", self.tol)
        if not 0.0 < tol <= MAX_TOL:
            raise InputError("solver.tol", f"must lie in (0, {MAX_TOL:g}], got {tol!r}")
        _set(self, "tol", tol)
        _set(self, "max_iter", _integer("solver.max_iter", self.max_iter, 1))
        _set(self, "max_turns", _integer("solver.max_turns", self.max_turns, 1))
        _choice("solver.fft", self.fft, FFT_BACKENDS)
        for key in ("nested", "window"):
            value = getattr(self, key)
            if not (_is_bool(value) or value == "auto"):
                raise InputError(f"solver.{key}", f"must be true, false or \"auto\", {_got(value)}")
        kind = FFT_DEVICE_KIND.get(self.fft)
        if kind is not None and not self.device.startswith(kind):
            raise InputError(
                "solver.fft",
                f"{self.fft!r} runs on {kind} devices only, but solver.device is {self.device!r}; use 'auto' or 'warp'",
            )

    def with_overrides(self, device: str | None = None, dtype: str | None = None, fft: str | None = None) -> SolverSpec:
        """A copy with the given settings replaced; a defaulted tol follows a new dtype."""
        changes: dict[str, Any] = {}
        if device is not None:
            changes["device"] = device
        if fft is not None:
            changes["fft"] = fft
        if dtype is not None:
            changes["dtype"] = dtype
            if self.tol_default and dtype != self.dtype:
                changes["tol"] = None
                changes["tol_default"] = False
        return replace(self, **changes)

    def to_dict(self) -> dict:
        """All settings, the tol in effect included (so a record pins the run down)."""
        return {"device": self.device, "dtype": self.dtype, "tol": self.tol, "max_iter": self.max_iter,
                "max_turns": self.max_turns, "fft": self.fft, "nested": self.nested, "window": self.window}


@dataclass(frozen=True)
class FrictionSpec:
    """The ``[friction]`` table: the shear limit q_max(p) (MODEL.md section 5).

    Attributes:
        law: "coulomb" (q_max = mu p) or "tabor" (bond failure capped by von Mises).
        mu: Coulomb coefficient [-], >= 0 (coulomb only).
        k_tau: Tabor's ratio, strictly in (0, 1) (tabor only).
        k_vm: von Mises ratio T_S / S_Y, > 0 (tabor only; default 1/sqrt(3)).
        hardness_cap: cap the pressure at the softer body's hardness (tabor only).
    """

    law: str
    mu: float | None = None
    k_tau: float | None = None
    k_vm: float | None = None
    hardness_cap: bool = False

    def __post_init__(self):
        law = _choice("friction.law", self.law, tuple(FRICTION_KEYS))
        if law == "coulomb":
            for name in ("k_tau", "k_vm"):
                if getattr(self, name) is not None:
                    raise InputError(f"friction.{name}", "is not used by law 'coulomb'; expected one of law, mu")
            if self.hardness_cap is not False:
                raise InputError("friction.hardness_cap", "is not used by law 'coulomb'; expected one of law, mu")
            if self.mu is None:
                raise InputError("friction.mu", "is required for law 'coulomb'")
            mu = _number("friction.mu", self.mu)
            if mu < 0.0:
                raise InputError("friction.mu", f"must be >= 0, got {mu!r}")
            _set(self, "mu", mu)
            return
        if self.mu is not None:
            raise InputError("friction.mu", "is not used by law 'tabor'; expected one of law, k_tau, k_vm, hardness_cap")
        if self.k_tau is None:
            raise InputError("friction.k_tau", "is required for law 'tabor'")
        k_tau = _number("friction.k_tau", self.k_tau)
        if not 0.0 < k_tau < 1.0:
            raise InputError("friction.k_tau", f"must lie strictly between 0 and 1, got {k_tau!r}")
        _set(self, "k_tau", k_tau)
        _set(self, "k_vm", DEFAULT_K_VM if self.k_vm is None else _positive("friction.k_vm", self.k_vm, ""))
        if not _is_bool(self.hardness_cap):
            raise InputError("friction.hardness_cap", f"must be true or false, {_got(self.hardness_cap)}")
        _set(self, "hardness_cap", bool(self.hardness_cap))

    @property
    def mu_b(self) -> float:
        """The friction coefficient of the bond-failure branch: mu (coulomb) or k_vm / sqrt(k_tau^-2 - 1) (tabor)."""
        if self.law == "coulomb":
            return self.mu
        return self.k_vm / math.sqrt(self.k_tau**-2 - 1.0)

    def to_dict(self) -> dict:
        if self.law == "coulomb":
            return {"law": "coulomb", "mu": self.mu}
        return {"law": "tabor", "k_tau": self.k_tau, "k_vm": self.k_vm, "hardness_cap": self.hardness_cap}


@dataclass(frozen=True)
class AdhesionSpec:
    """The ``[adhesion]`` table: the traction-separation law (MODEL.md section 6).

    Attributes:
        law: "smc" (McGarry et al. 2014), "dugdale", "exponential" or "lj93" (the laws of
            ``warpcontact.physics.adhesion``; exponential and lj93 are normal-only, for the JKR side).
        sigma_max: peak normal traction [Pa] (smc).
        tau_max: peak shear traction [Pa] (smc).
        delta_n: normal characteristic length [m] (smc).
        delta_t: tangential characteristic length [m] (smc).
        contact_shear: "bounded" or "added" (smc, optional, default "bounded"): the shear inside
            the contact, ``warpcontact.physics.adhesion.SMC``.
        sigma_0: constant attraction [Pa] (dugdale).
        h_0: range of the attraction [m] (dugdale).
        smoothing: ramp width over h_0 [-] (dugdale, optional, default 0.05; in [0, 2) centred, [0, 1) both).
        ramps: "centred" or "both" (dugdale, optional, default "centred"; ``warpcontact.physics.adhesion.Dugdale``).
        w: work of adhesion [J/m^2] (exponential, lj93).
        rho: decay length of t = (w / rho) exp(-h / rho) [m] (exponential).
        z0: equilibrium distance of the Lennard-Jones 9-3 potential [m] (lj93).
    """

    law: str
    sigma_max: float | None = None
    tau_max: float | None = None
    delta_n: float | None = None
    delta_t: float | None = None
    contact_shear: str | None = None
    sigma_0: float | None = None
    h_0: float | None = None
    smoothing: float | None = None
    ramps: str | None = None
    w: float | None = None
    rho: float | None = None
    z0: float | None = None

    _UNITS = {"sigma_max": "Pa", "tau_max": "Pa", "delta_n": "m", "delta_t": "m", "sigma_0": "Pa", "h_0": "m",
              "w": "J/m^2", "rho": "m", "z0": "m"}

    def __post_init__(self):
        law = _choice("adhesion.law", self.law, tuple(ADHESION_KEYS))
        used = ADHESION_KEYS[law][1:]
        optional = ADHESION_OPTIONAL.get(law, ())
        for name in ADHESION_ALL_KEYS[1:]:
            v = getattr(self, name)
            if name not in used:
                if v is not None:
                    raise InputError(
                        f"adhesion.{name}", f"is not used by law {law!r}; expected one of {', '.join(ADHESION_KEYS[law])}"
                    )
                continue
            if v is None:
                if name in optional:
                    continue
                raise InputError(f"adhesion.{name}", f"is required for law {law!r}")
            if name == "smoothing":
                ramps = self.ramps if self.ramps in DUGDALE_RAMPS else DUGDALE_RAMPS[0]
                limit = 2.0 if ramps == "centred" else 1.0  # adhesion.max_smoothing: case loads no Warp
                if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0.0 <= v < limit:
                    raise InputError("adhesion.smoothing", f"must be a number in [0, {limit:g}) (the ramp width over "
                                                           f"h_0, with ramps = {ramps!r}), got {v!r}")
                _set(self, name, float(v))
                continue
            if name == "ramps":
                _choice("adhesion.ramps", v, DUGDALE_RAMPS)
                continue
            if name == "contact_shear":
                _choice("adhesion.contact_shear", v, SMC_CONTACT_SHEAR)
                continue
            _set(self, name, _positive(f"adhesion.{name}", v, self._UNITS[name]))

    @property
    def work_of_adhesion(self) -> float:
        """w [J/m^2]: e sigma_max delta_n (smc, pure opening), sigma_0 h_0 (dugdale), w (others)."""
        if self.law == "smc":
            return math.e * self.sigma_max * self.delta_n
        if self.law == "dugdale":
            return self.sigma_0 * self.h_0
        return self.w

    @property
    def length(self) -> float:
        """The law's length [m]: delta_n (smc), h_0 (dugdale), rho (exponential), z0 (lj93)."""
        return {"smc": self.delta_n, "dugdale": self.h_0, "exponential": self.rho, "lj93": self.z0}[self.law]

    @property
    def peak_tension(self) -> float:
        """The law's largest normal tension [Pa]: sigma_max, sigma_0, w / rho, 16 w / (9 sqrt(3) z0)."""
        if self.law == "smc":
            return self.sigma_max
        if self.law == "dugdale":
            return self.sigma_0
        if self.law == "exponential":
            return self.w / self.rho
        return 16.0 * self.w / (9.0 * math.sqrt(3.0) * self.z0)

    def to_dict(self) -> dict:
        return {"law": self.law, **{k: getattr(self, k) for k in ADHESION_KEYS[self.law][1:]
                                    if getattr(self, k) is not None}}


# ---------------------------------------------------------------------------------------------
# The case.


@dataclass(frozen=True)
class Case:
    """The whole description of one run (see ``docs/case-files.md``).

    Attributes:
        pair: sphere (body 1) and flat (body 2) materials; named "sphere" and "flat".
        sphere: the asperity's geometry (radius [m], profile).
        grid: the surface grid (n cells per side, size [m]).
        load: the load path.
        solver: device, dtype, tolerances, FFT backend.
        friction: the shear limit; None for a frictionless contact.
        adhesion: the traction-separation law; None for no adhesion.
    """

    pair: MaterialPair
    sphere: Sphere
    grid: Grid
    load: LoadSpec
    solver: SolverSpec = field(default_factory=SolverSpec)
    friction: FrictionSpec | None = None
    adhesion: AdhesionSpec | None = None

    def __post_init__(self):
        for name, cls in (("pair", MaterialPair), ("sphere", Sphere), ("grid", Grid), ("load", LoadSpec), ("solver", SolverSpec)):
            if not isinstance(getattr(self, name), cls):
                raise TypeError(f"Case.{name} must be a {cls.__name__}, got {type(getattr(self, name)).__name__}")
        if self.friction is not None and not isinstance(self.friction, FrictionSpec):
            raise TypeError(f"Case.friction must be a FrictionSpec or None, got {type(self.friction).__name__}")
        if self.adhesion is not None and not isinstance(self.adhesion, AdhesionSpec):
            raise TypeError(f"Case.adhesion must be an AdhesionSpec or None, got {type(self.adhesion).__name__}")
        self._check_domain()
        if self.friction is not None and self.friction.hardness_cap:
            softer = self.pair.softer
            if not math.isfinite(softer.hardness):
                raise InputError(
                    "friction.hardness_cap",
                    f"needs the hardness of the softer body ({softer.name or 'material'}, lower yield strength); "
                    f"set {softer.name or 'sphere'}.hardness",
                )

    def _check_domain(self) -> None:
        """The Hertz contact at the deepest state must fit in the domain, and the domain in the sphere."""
        R, size = self.sphere.radius, self.grid.size
        dz = self.load.delta_z_max
        if dz > 0.0:
            a = math.sqrt(R * dz)
            if not 2.0 * a < size:
                raise InputError(
                    "grid.size",
                    f"must exceed 2 a = {2.0 * a:.4g} m, the Hertz contact diameter at the largest delta_z = {dz:.4g} m "
                    f"(a = sqrt(R delta_z) = {a:.4g} m), got {size:.4g} m; use at least "
                    f"{SUGGESTED_SIZE_IN_A * a:.4g} m ({SUGGESTED_SIZE_IN_A:g} a), more with adhesion"
                    f"{profile_note(SUGGESTED_SIZE_IN_A * a, self.sphere)}",
                )
        if self.sphere.profile == "sphere":
            corner = math.sqrt(2.0) * 0.5 * (self.grid.n - 1) * self.grid.dx
            if corner >= R:
                raise InputError(
                    "grid.size",
                    f"the domain's corner cells lie {corner:.4g} m from the centre, beyond the sphere radius "
                    f"{R:.4g} m; use grid.size below {math.sqrt(2.0) * R:.4g} m or sphere.profile = 'paraboloid'",
                )

    @property
    def sphere_spec(self) -> SphereSpec:
        """The ``[sphere]`` table: geometry and material of the sphere."""
        m = self.pair.sphere
        if m.is_rigid:
            return SphereSpec(self.sphere.radius, profile=self.sphere.profile, rigid=True)
        return SphereSpec(self.sphere.radius, m.E, m.nu, m.yield_strength, m.hardness, self.sphere.profile)

    def with_overrides(self, keys: Mapping | None = None, *, device: str | None = None, dtype: str | None = None,
                       fft: str | None = None) -> Case:
        """A new case with values replaced: ``keys``, dotted case keys -> values in the case file's
        SI units, as sweeps take them (``{"grid.n": 256, "friction.k_tau": 0.8}``; the case is
        checked again as a whole, and an explicit ``load.path`` replaces the default path's keys,
        and the reverse); ``device``, ``dtype``, ``fft``: the solver's (e.g. from the command line),
        None keeps a setting. A defaulted tol follows a new dtype."""
        case = self
        if keys:
            d = self.to_dict()
            if self.solver.tol_default and "solver.tol" not in keys:
                d["solver"].pop("tol", None)  # the new dtype's default, not the old one's
            case = case_from_dict(substitute(d, keys))
        return replace(case, solver=case.solver.with_overrides(device=device, dtype=dtype, fft=fft))

    def to_dict(self) -> dict:
        """The case as plain data (JSON-serialisable, no NaN; inf written as "inf").

        ``case_from_dict(case.to_dict()) == case``. Defaults are written out, the tol in effect
        included, so the dict records the run on its own.
        """
        d = {
            "sphere": self.sphere_spec.to_dict(),
            "flat": _material_dict(self.pair.flat),
            "grid": {"n": int(self.grid.n), "size": float(self.grid.size)},
            "load": self.load.to_dict(),
            "solver": self.solver.to_dict(),
        }
        if self.friction is not None:
            d["friction"] = self.friction.to_dict()
        if self.adhesion is not None:
            d["adhesion"] = self.adhesion.to_dict()
        return d


# ---------------------------------------------------------------------------------------------
# Reading.


def case_from_dict(d: Mapping) -> Case:
    """Build and validate a [`Case`][warpcontact.Case] from parsed TOML (or ``Case.to_dict()`` output).

    Raises:
        InputError: with the dotted key of the first problem found.
    """
    _table("case", d)
    for k, v in d.items():
        if k not in TABLES:
            _check_keys("", {k: v}, TABLES, why="unknown table" if isinstance(v, Mapping) else "unknown top-level key")
    for t in REQUIRED_TABLES:
        if t not in d:
            raise InputError(t, f"is required (a [{t}] table)")
    tables = {t: _table(t, d[t]) for t in TABLES if t in d}

    s = tables["sphere"]
    _check_keys("sphere", s, SPHERE_KEYS)
    _require("sphere", s, ("radius",) if _rigid("sphere", s) else ("radius", "E", "nu"))
    sphere = SphereSpec(
        radius=s["radius"],
        E=s.get("E"),
        nu=s.get("nu"),
        yield_strength=s.get("yield_strength", math.inf),
        hardness=s.get("hardness", math.inf),
        profile=s.get("profile", "sphere"),
        rigid=s.get("rigid", False),
    )

    f = tables["flat"]
    _check_keys("flat", f, FLAT_KEYS)
    _require("flat", f, () if _rigid("flat", f) else ("E", "nu"))
    flat = FlatSpec(**f).material
    pair = MaterialPair(sphere.material, flat)  # refuses two rigid bodies

    g = tables["grid"]
    _check_keys("grid", g, GRID_KEYS)
    _require("grid", g, GRID_KEYS)
    n = _integer("grid.n", g["n"], MIN_CELLS)
    size = _positive("grid.size", g["size"], "m")
    grid = Grid(n, size)

    load = _load_from(tables["load"])

    sv = tables.get("solver", {})
    _check_keys("solver", sv, SOLVER_KEYS)
    solver = SolverSpec(**{k: sv[k] for k in SOLVER_KEYS if k in sv})

    friction = None
    if "friction" in tables:
        fr = tables["friction"]
        _check_keys("friction", fr, ("law", "mu", "k_tau", "k_vm", "hardness_cap"))
        _require("friction", fr, ("law",), f"; one of {_list(tuple(FRICTION_KEYS))}")
        law = _choice("friction.law", fr["law"], tuple(FRICTION_KEYS))
        _check_keys("friction", fr, FRICTION_KEYS[law], why=f"is not used by law {law!r}")
        friction = FrictionSpec(**fr)

    adhesion = None
    if "adhesion" in tables:
        ad = tables["adhesion"]
        _check_keys("adhesion", ad, ADHESION_ALL_KEYS)
        _require("adhesion", ad, ("law",), f"; one of {_list(tuple(ADHESION_KEYS))}")
        law = _choice("adhesion.law", ad["law"], tuple(ADHESION_KEYS))
        _check_keys("adhesion", ad, ADHESION_KEYS[law], why=f"is not used by law {law!r}")
        _require("adhesion", ad, tuple(k for k in ADHESION_KEYS[law] if k not in ADHESION_OPTIONAL.get(law, ())),
                 f" for law {law!r}")
        adhesion = AdhesionSpec(**ad)

    # values no solid or contact can have (a unit slip, mostly), before the domain checks of Case
    check_case(sphere, flat, grid, load, adhesion)
    return Case(
        pair=pair,
        sphere=sphere.geometry,
        grid=grid,
        load=load,
        solver=solver,
        friction=friction,
        adhesion=adhesion,
    )


def _rigid(table: str, d: Mapping) -> bool:
    """A body table's ``rigid`` key (false when absent); a rigid body's table holds none of MATERIAL_KEYS."""
    rigid = _boolean(f"{table}.rigid", d.get("rigid", False))
    for key in MATERIAL_KEYS if rigid else ():
        if key in d:
            raise _unused_by_rigid(table, key)
    return rigid


def _load_from(ld: Mapping) -> LoadSpec:
    _check_keys("load", ld, LOAD_KEYS)
    if "path" in ld:
        for k in DEFAULT_PATH_KEYS:
            if k in ld:
                raise InputError(f"load.{k}", "must not be given together with load.path (the path lists every state)")
        return LoadSpec(states=_path_states(ld["path"]))
    if "delta_z" not in ld:
        raise InputError("load.delta_z", "is required (or give load.path)")
    if "cycles" in ld and not any(k in ld for k in ("delta_x_amplitude", "delta_y_amplitude")):
        raise _cycles_without_amplitude()
    return LoadSpec(**{k: ld[k] for k in DEFAULT_PATH_KEYS if k in ld})


def read_toml(path: str | PathLike, what: str = "case file") -> dict:
    """The table of a TOML file (strict UTF-8; a leading byte-order mark is tolerated).

    Raises:
        InputError: key = the file path when the file is missing, a directory (not a ``what``),
            unreadable, not UTF-8 or not TOML.
    """
    key = str(path)
    try:
        with open(path, "rb") as fh:
            raw = fh.read()
    except FileNotFoundError:
        raise InputError(key, "no such file") from None
    except IsADirectoryError:
        raise InputError(key, f"is a directory, not a {what}") from None
    except OSError as e:
        raise InputError(key, f"cannot be read: {e.strerror or e}") from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise InputError(key, f"is not UTF-8 text (byte 0x{raw[e.start]:02x} at offset {e.start})") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise InputError(key, "is not valid TOML: " + " ".join(str(e).split())) from None


def load_case(path: str | PathLike) -> Case:
    """Read, parse and validate a TOML case file.

    Raises:
        InputError: key = the file path when the file is missing, unreadable, not UTF-8 or not
            TOML; otherwise the dotted case-file key of the first problem.
    """
    return case_from_dict(read_toml(path, "case file"))


__all__ = [
    "AdhesionSpec",
    "Case",
    "FlatSpec",
    "FrictionSpec",
    "GridSpec",
    "LoadSpec",
    "SolverSpec",
    "SphereSpec",
    "case_from_dict",
    "load_case",
]

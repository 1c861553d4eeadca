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
import math
import re
from dataclasses import dataclass, field, replace
from os import PathLike
from pathlib import Path
from typing import Any, Mapping

try:
    import tomllib
except ModuleNotFoundError:  # Python < 3.11
    import tomli as tomllib

from ..errors import InputError
from ..fft.names import BACKENDS as FFT_BACKENDS  # FFT backends by name (warpcontact.fft)
from ..fft.names import DEVICE_KIND as FFT_DEVICE_KIND  # those that run on one kind of device only
from ..physics.geometry import MIN_CELLS, PROFILES, PUNCH_WALL_IN_RADII, Grid, Sphere
from .bodies import (FLAT_KEYS, MATERIAL_KEYS, SPHERE_KEYS, FlatSpec, SphereSpec, flat_dict, flat_from_table,  # noqa: F401
                     sphere_dict, sphere_from_table)
from .guards import profile_note
from ..physics.materials import MaterialPair
from .loads import (CYCLIC_KEYS, DEFAULT_PATH_KEYS, LOAD_KEYS, MAX_CYCLES, MAX_STEPS, LoadSpec,  # noqa: F401
                    _load_from)
from .plausibility import check_case, check_map_sampling
from .values import (_check_keys, _choice, _got, _integer, _is_bool, _list, _number, _positive, _require, _set,
                     _table)

#: Tables of a case file, in the order they are documented and written.
TABLES = ("sphere", "flat", "grid", "load", "solver", "friction", "adhesion")
#: Tables a case file must have.
REQUIRED_TABLES = ("sphere", "flat", "grid", "load")

GRID_KEYS = ("n", "size")
SOLVER_KEYS = ("device", "dtype", "tol", "max_iter", "max_turns", "fft", "nested", "nested_float32", "window",
               "preconditioner_float32", "preconditioner_grid", "response_float32")
#: the grids the preconditioners' circulants may live on (``SolverSettings.preconditioner_grid``)
PRECONDITIONER_GRIDS = ("periodic", "padded")
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

DTYPES = ("float64", "float32")
#: Default relative tolerance of the conjugate-gradient solves, per dtype.
DEFAULT_TOL = {"float64": 1e-10, "float32": 1e-5}
#: Largest accepted tolerance.
MAX_TOL = 1e-2
DEFAULT_MAX_ITER = 2000
#: coupling / adhesive fixed-point turns per load step (SolverSettings.max_turns)
DEFAULT_MAX_TURNS = 1000
#: von Mises ratio T_S / S_Y (MODEL.md section 5).
DEFAULT_K_VM = 1.0 / math.sqrt(3.0)
#: The suggested smallest domain, in Hertz contact radii.
SUGGESTED_SIZE_IN_A = 2.5

_DEVICE_RE = re.compile(r"cpu|cuda(:\d+)?")


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


#: The ``[grid]`` table is a :class:`~warpcontact.physics.geometry.Grid` (n cells per side, size in m).
GridSpec = Grid


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
            the cells per side (``SolverSettings.nested``): fewer iterations on large grids. true,
            false or "auto" (the default: from 512 cells per side on the CPU, 2048 on CUDA).
        nested_float32: in float64, the nested start's coarse grids are solved in float32
            (``SolverSettings.nested_float32``): they only start the fine step, whose own solves
            set the answer to the tolerance. true, false or "auto" (the default: from 1024 cells
            per side of the fine grid on the CPU, where it was measured to pay; never on CUDA).
        window: solve each step's shear, and its pressure, on the smallest window of the grid that
            holds the contact (``SolverSettings.window``): the same answer, smaller transforms
            where the contact is a fraction of the domain. true, false or "auto" (the default:
            the shear from 128 cells per side on the CPU and 1024 on CUDA, the pressure from 1024
            and 4096).
        preconditioner_float32: in float64, the tangential solves' preconditioner transforms in
            float32 (``SolverSettings.preconditioner_float32``): the same answer to the
            tolerance, cheaper iterations. true, false or "auto" (the default: from 2048 cells per
            side of a solve's grid or window on CUDA, 512 on the CPU).
        preconditioner_grid: the grid of the preconditioners' circulants
            (``SolverSettings.preconditioner_grid``): "periodic" (the default: T. Chan's circulants
            on the solve's own grid or window, a quarter of the padded grid's transform size) or
            "padded" (the DC-FFT's circulant on the padded grid).
        response_float32: in float64, the tangential solves' product of the operator with their
            conjugate direction transforms in float32 (``SolverSettings.response_float32``), the
            solves judged on the exact float64 residual: the same answer to the tolerance. true,
            false or "auto" (the default: where it was measured to pay).
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
    nested_float32: bool | str = "auto"
    window: bool | str = "auto"
    preconditioner_float32: bool | str = "auto"
    preconditioner_grid: str = "periodic"
    response_float32: bool | str = "auto"
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
        _choice("solver.preconditioner_grid", self.preconditioner_grid, PRECONDITIONER_GRIDS)
        for key in ("nested", "nested_float32", "window", "preconditioner_float32", "response_float32"):
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
                "max_turns": self.max_turns, "fft": self.fft, "nested": self.nested,
                "nested_float32": self.nested_float32, "window": self.window,
                "preconditioner_float32": self.preconditioner_float32, "preconditioner_grid": self.preconditioner_grid,
                "response_float32": self.response_float32}


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
        """The contact at the deepest state must fit in the domain (Hertz's, the punch's, Love's
        cone's), the domain in the sphere and in any height map, and a punch's approach stay far
        below its side wall."""
        shape, size = self.sphere, self.grid.size
        dz = self.load.delta_z_max
        a = shape.contact_radius(dz)
        if a is not None and dz > 0.0 and not 2.0 * a < size:
            what = {"flat_punch": "the punch's diameter 2 a (a = sphere.radius)",
                    "cone": f"the cone's contact diameter 2 a at the largest delta_z = {dz:.4g} m (Love: a = 2 "
                            "delta_z tan(half_angle) / pi)"}.get(
                shape.profile, f"the Hertz contact diameter at the largest delta_z = {dz:.4g} m (a = sqrt(R delta_z))")
            raise InputError(
                "grid.size",
                f"must exceed 2 a = {2.0 * a:.4g} m, {what}, got {size:.4g} m; use at least "
                f"{SUGGESTED_SIZE_IN_A * a:.4g} m ({SUGGESTED_SIZE_IN_A:g} a), more with adhesion"
                f"{profile_note(SUGGESTED_SIZE_IN_A * a, shape)}",
            )
        if shape.profile == "flat_punch" and not dz < 0.1 * PUNCH_WALL_IN_RADII * shape.radius:
            raise InputError("load.path" if self.load.explicit else "load.delta_z",
                             f"the largest delta_z = {dz:.4g} m reaches a tenth of the punch's radius "
                             f"{shape.radius:.4g} m: far beyond the small strains of the half-space model (the "
                             f"punch's side is a wall {PUNCH_WALL_IN_RADII:g} radius high)")
        if shape.profile == "sphere":
            corner = math.sqrt(2.0) * 0.5 * (self.grid.n - 1) * self.grid.dx
            if corner >= shape.radius:
                raise InputError(
                    "grid.size",
                    f"the domain's corner cells lie {corner:.4g} m from the centre, beyond the sphere radius "
                    f"{shape.radius:.4g} m; use grid.size below {math.sqrt(2.0) * shape.radius:.4g} m or "
                    "sphere.profile = 'paraboloid'",
                )
        shape.check_domain(self.grid)  # a height map must cover the domain

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
            "sphere": sphere_dict(self.sphere, self.pair.sphere),
            "flat": flat_dict(self.sphere, self.pair.flat),
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


def case_from_dict(d: Mapping, base: str | PathLike | None = None) -> Case:
    """Build and validate a [`Case`][warpcontact.Case] from parsed TOML (or ``Case.to_dict()`` output).
    ``base``: the folder that relative file paths (``height_map``) are taken from; None: the
    current folder.

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
    sphere = sphere_from_table(s, base)
    f = tables["flat"]
    _check_keys("flat", f, FLAT_KEYS)
    flat_spec = flat_from_table(f, base)
    flat = flat_spec.material
    pair = MaterialPair(sphere.material, flat)  # refuses two rigid bodies
    shape = replace(sphere.geometry, flat_map=flat_spec.surface)

    g = tables["grid"]
    _check_keys("grid", g, GRID_KEYS)
    _require("grid", g, GRID_KEYS)
    grid = _grid_from(g, shape.height_map or shape.flat_map)
    for surface in (shape.height_map, shape.flat_map):  # a map that misses the domain, before plausibility
        if surface is not None:
            surface.check_covers(grid)
            check_map_sampling(surface, grid)

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
        sphere=shape,
        grid=grid,
        load=load,
        solver=solver,
        friction=friction,
        adhesion=adhesion,
    )

def _grid_from(g: Mapping, surface) -> Grid:
    """The ``[grid]`` table: n and size as numbers, or "map" to take them from ``surface``, the
    sphere's height map (else the flat's): one cell per pixel, the map's side."""
    values = {}
    for key in GRID_KEYS:
        if g[key] != "map":
            continue
        if surface is None:
            raise InputError(f"grid.{key}", '"map" takes the grid from a height map (sphere.height_map or '
                                            "flat.height_map); the case has none: give a number")
        nx, ny = surface.heights.shape
        if nx != ny:
            raise InputError(f"grid.{key}", f'"map" needs a square map; {surface.key}.height_map is {nx} x {ny} '
                                            "pixels: give a number")
        values[key] = nx if key == "n" else nx * surface.pixel_size
    n = values.get("n") or _integer("grid.n", g["n"], MIN_CELLS)
    if n < MIN_CELLS:
        raise InputError("grid.n", f"= \"map\" gives {n} cells per side, fewer than {MIN_CELLS}")
    return Grid(n, values.get("size") or _positive("grid.size", g["size"], "m"))


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
    return case_from_dict(read_toml(path, "case file"), base=Path(path).resolve().parent)


__all__ = [
    "CYCLIC_KEYS",
    "FLAT_KEYS",
    "LOAD_KEYS",
    "MATERIAL_KEYS",
    "MAX_CYCLES",
    "MAX_STEPS",
    "PROFILES",
    "SPHERE_KEYS",
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

"""The sweep file: its base case, the swept keys and their values, the task, and every combination
built and validated as a case (the running and the outputs: :mod:`warpcontact.studies.sweep`).

A sweep file is TOML (the format, with an example, is in ``docs/sweeps.md``)::

    base = "table2_k080_dz5e-5.toml"        # or a [base] table holding a whole case
    [sweep]
    "friction.k_tau" = [0.5, 0.8, 0.95]     # dotted case keys -> lists of values
    "load.delta_z" = [1e-11, 5e-11]
    [run]
    task = "gross-slip"                     # or "solve", "pull-off", "fretting"; default: gross-slip with [friction]

Every combination is a case built by :func:`~warpcontact.records.case.case_from_dict` from the base's
``to_dict()`` with the swept values put in, so the case checks hold for every one of them; a
combination that fails them is refused before anything runs, its message naming the combination.
``"friction.law"`` and ``"adhesion.law"`` may also take ``"none"``: that combination's case has no
such table (the base's other keys of it, and other swept keys of it, are ignored there and listed
in its record's ``ignored``).
Mistakes raise :class:`~warpcontact.errors.InputError` naming the key (``sweep.friction.k_tau``,
``run.task``, ``base.sphere.E``).
"""

from __future__ import annotations

import difflib
import hashlib
import itertools
import json
import numbers
from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from typing import Mapping

from ..records.case import (
    ADHESION_KEYS,
    FLAT_KEYS,
    GRID_KEYS,
    LOAD_KEYS,
    SOLVER_KEYS,
    SPHERE_KEYS,
    Case,
    case_from_dict,
    load_case,
    read_toml,
    substitute,
)
from ..errors import InputError
from .tasks import TASKS  # what each case runs: its load path, gross slip or pull-off (tasks.run_task)

#: Tables of a sweep file.
SWEEP_TABLES = ("base", "sweep", "run")
#: Keys of the ``[run]`` table.
RUN_KEYS = ("task", "rel_tol", "scheduler")
#: Default bisection bracket of delta_x_max (relative), as in ``warpcontact gross-slip``.
DEFAULT_REL_TOL = 0.01
#: The case keys a sweep may vary: table -> keys (the case-file schema, docs/case-files.md).
CASE_SCHEMA = {
    "sphere": SPHERE_KEYS,
    "flat": FLAT_KEYS,
    "grid": GRID_KEYS,
    "load": LOAD_KEYS,
    "solver": SOLVER_KEYS,
    "friction": ("law", "mu", "k_tau", "k_vm", "hardness_cap"),
    "adhesion": tuple(dict.fromkeys(k for keys in ADHESION_KEYS.values() for k in keys)),
}
DOTTED_KEYS = tuple(f"{t}.{k}" for t, keys in CASE_SCHEMA.items() for k in keys)
#: Tables a sweep may switch off: where ``"<table>.law"`` is :data:`LAW_NONE`, the combination's case
#: has no such table (a frictionless contact, no adhesion).
SWITCHABLE_TABLES = ("friction", "adhesion")
#: The swept law value that switches its table off.
LAW_NONE = "none"


# ---------------------------------------------------------------------------------------------
# The sweep file.


@dataclass(frozen=True)
class SweepCase:
    """One combination of a sweep.

    Attributes:
        index: position in the sweep (0-based; the last swept key varies fastest).
        params: swept key -> value (as written in the sweep file, JSON-ready), in sweep order.
        id: short hash of ``params`` (12 hex digits), the name of its JSON file.
        label: readable form of ``params``, e.g. ``k_tau=0.8,delta_z=5e-11``.
        case: the validated case (command-line overrides applied).
        ignored: swept keys without effect in this combination: the keys of a table its law
            ``"none"`` switches off (:func:`ignored_keys`).
    """

    index: int
    params: dict
    id: str
    label: str
    case: Case
    ignored: tuple = ()


@dataclass(frozen=True)
class Sweep:
    """A validated sweep: the base case, the swept keys and values, the task, every combination.

    Attributes:
        base: the base case.
        keys: swept dotted case keys, in file order.
        values: per key, the list of values.
        task: one of ``tasks.TASKS``: "solve", "gross-slip", "pull-off" or "fretting".
        rel_tol: bisection bracket of delta_x_max (gross-slip).
        cases: every combination, in order.
        source: the sweep file, or None.
        scheduler: ``[run] scheduler``, the address of a dask scheduler to run the cases on
            (docs/scaling.md), or None.
    """

    base: Case
    keys: tuple
    values: tuple
    task: str
    rel_tol: float
    cases: tuple
    source: str | None = None
    scheduler: str | None = None


def jsonable(x):
    """``x`` as it reads back from JSON (tuples become lists; numbers keep their units), for
    comparing a case or its parameters with a stored record (a sweep's case, a fit's evaluation)."""
    return json.loads(json.dumps(x, allow_nan=True))


def case_id(params: Mapping) -> str:
    """Stable short id of a combination: the first 12 hex digits of the SHA-256 of its swept
    keys and values (canonical JSON)."""
    text = json.dumps([[k, v] for k, v in params.items()], sort_keys=True, separators=(",", ":"), allow_nan=True)
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def short_float(v: float) -> str:
    """``v`` as the shorter of repr and the shortest exact exponent form: 1e8 (not 100000000.0),
    6.708e-8, 0.8; the value reads back exactly (units: those of ``v``, unchanged). Labels of sweep
    cases, a fit's parameters in its messages and fitted.toml."""
    r = repr(v)
    if v == 0 or v != v or v in (float("inf"), float("-inf")):
        return r
    for digits in range(17):
        e = f"{v:.{digits}e}"
        if float(e) == v:
            break
    mant, exp = e.split("e")
    e = f"{mant}e{int(exp)}"
    return e if len(e) < len(r) else r


def _show_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return short_float(v)
    if isinstance(v, (str, numbers.Number)):
        return str(v)
    return json.dumps(v, separators=(",", ":"))


def case_label(params: Mapping) -> str:
    """``k_tau=0.8,delta_z=5e-11``: each swept key by its last part (the whole dotted key where
    two swept keys share it, as sphere.E and flat.E)."""
    short = [k.split(".", 1)[1] for k in params]
    names = [s if short.count(s) == 1 else k for k, s in zip(params, short)]
    return ",".join(f"{n}={_show_value(v)}" for n, v in zip(names, params.values()))


def _sweep_entries(table: Mapping) -> list:
    """(dotted key, value) pairs of the [sweep] table; TOML's unquoted dotted keys (friction.k_tau
    = [...]) arrive as nested tables and are flattened back."""
    out = []
    for k, v in table.items():
        if isinstance(v, Mapping):
            for sub, w in v.items():
                out.append((f"{k}.{sub}", w))
        else:
            out.append((str(k), v))
    return out


def near(key, choices) -> str:
    """``did you mean 'x'? `` for the choice nearest a mistyped ``key``, or nothing."""
    close = difflib.get_close_matches(str(key), list(choices), n=1)
    return f"did you mean {close[0]!r}? " if close else ""


def check_case_key(key: str, where: str) -> None:
    """``key`` must be a dotted key of the case-file schema; InputError(where, ...) otherwise (a sweep's
    ``sweep.<key>``, a fit's ``fit.<key>``)."""
    if key in DOTTED_KEYS:
        return
    hint = near(key, DOTTED_KEYS)
    if "." not in key:
        raise InputError(where, f"must be a dotted case key (table.key), such as 'friction.k_tau'; {hint}"
                                "see docs/case-files.md")
    table = key.split(".", 1)[0]
    if table not in CASE_SCHEMA:
        raise InputError(where, f"unknown case table {table!r}; {hint}expected one of {', '.join(CASE_SCHEMA)}")
    raise InputError(where, f"unknown case key; {hint}[{table}] has {', '.join(CASE_SCHEMA[table])} "
                            "(docs/case-files.md)")


def _check_values(key: str, v) -> list:
    if isinstance(v, (str, bytes, Mapping)) or not isinstance(v, (list, tuple)):
        kind = "table" if isinstance(v, Mapping) else type(v).__name__
        raise InputError(f"sweep.{key}", f"must be a list (TOML array) of values to try, got {kind} {v!r}")
    if len(v) == 0:
        raise InputError(f"sweep.{key}", "must list at least one value, got an empty list")
    seen = {}
    for i, x in enumerate(v):
        canon = json.dumps(x, sort_keys=True, allow_nan=True)
        if canon in seen:
            raise InputError(f"sweep.{key}", f"lists {_show_value(x)} twice (entries {seen[canon]} and {i})")
        seen[canon] = i
    return list(v)


def base_case(data: Mapping, source: Path | None) -> Case:
    """The base case of a sweep or fit file (SI units): ``data["base"]``, a table holding a whole case
    or the path of a case file (relative to ``source``, the file's own path, when given). InputError
    naming ``base`` (or ``base.<key>``, or the key in the base case file) when it is missing or wrong."""
    if "base" not in data:
        raise InputError("base", 'is required: a [base] table holding a whole case, or base = "case.toml" '
                                 "(relative to the sweep file)")
    b = data["base"]
    if isinstance(b, str):
        path = Path(b)
        if not path.is_absolute() and source is not None:
            path = source.parent / path
        try:
            return load_case(path)
        except InputError as e:
            if e.key == str(path):
                raise InputError("base", f"{path}: {e.problem}") from None
            raise InputError(e.key, f"{e.problem} (in the base case file {path})") from None
    if not isinstance(b, Mapping):
        raise InputError("base", f"must be a table holding a case or the path of a case file (string), got {b!r}")
    try:
        return case_from_dict(b)
    except InputError as e:
        raise InputError(f"base.{e.key}", e.problem) from None


def run_settings(data: Mapping, base: Case, run_keys=RUN_KEYS, default_rel_tol=DEFAULT_REL_TOL) -> tuple:
    """``(run, task, rel_tol)`` of the ``[run]`` table of a sweep or fit file (``run_keys``: the keys it
    may hold; a fit's has more, which the fit checks): the task (default gross-slip with friction,
    else solve) and the gross-slip bisection bracket."""
    run = data.get("run", {})
    if not isinstance(run, Mapping):
        raise InputError("run", f"must be a table ([run]), got {run!r}")
    for k in run:
        if k not in run_keys:
            raise InputError(f"run.{k}", f"unknown key; {near(k, run_keys)}expected one of {', '.join(run_keys)}")
    task = run.get("task", "gross-slip" if base.friction is not None else "solve")
    if not isinstance(task, str) or task not in TASKS:
        raise InputError("run.task", f"must be one of {', '.join(repr(t) for t in TASKS)}, got {task!r}")
    rel_tol = run.get("rel_tol", default_rel_tol)
    if isinstance(rel_tol, bool) or not isinstance(rel_tol, numbers.Real) or not 0.0 < float(rel_tol) <= 0.5:
        raise InputError("run.rel_tol", f"must be a number in (0, 0.5] (bisection bracket of delta_x_max), got {rel_tol!r}")
    if "rel_tol" in run and task != "gross-slip":
        raise InputError("run.rel_tol", "is used by task 'gross-slip' only")
    return run, task, float(rel_tol)


def run_scheduler(data: Mapping) -> str | None:
    """``[run] scheduler``: a dask scheduler's address (``tcp://host:8786``), or None."""
    v = data.get("run", {}).get("scheduler")
    if v is None:
        return None
    if not isinstance(v, str) or not v.strip():
        raise InputError("run.scheduler", f"must be a scheduler's address such as 'tcp://host:8786', got {v!r}")
    return v.strip()


def switched_off(params: Mapping) -> tuple:
    """The tables of :data:`SWITCHABLE_TABLES` that the combination ``params`` (dotted case key ->
    value) switches off: those whose swept law is ``"none"``."""
    return tuple(t for t in SWITCHABLE_TABLES if params.get(f"{t}.law") == LAW_NONE)


def ignored_keys(params: Mapping) -> tuple:
    """The swept keys of ``params`` without effect: the keys other than ``law`` of a table the
    combination switches off (``adhesion.sigma_max`` where ``adhesion.law`` is ``"none"``)."""
    off = switched_off(params)
    return tuple(k for k in params if k.split(".", 1)[0] in off and k.split(".", 1)[1] != "law")


def _build_case(base_dict: dict, params: Mapping, label: str, overrides: Mapping) -> Case:
    def wrap(e: InputError) -> InputError:
        key = f"sweep.{e.key}" if e.key in params else e.key
        return InputError(key, f"{e.problem} (in the sweep case {label})")

    d = substitute(base_dict, params)
    for table in switched_off(params):  # law "none": no such table, whatever else the base or sweep gives it
        d.pop(table, None)
    try:
        case = case_from_dict(d)
        return case.with_overrides(**overrides)
    except InputError as e:
        raise wrap(e) from None


def check_task(sc: SweepCase, task: str) -> None:
    """What ``task`` (one of TASKS) needs of the case ``sc``, checked before anything runs: a
    [friction] table and a positive deepest delta_z [m] for "gross-slip", an [adhesion] table for
    "pull-off". InputError naming ``run.task`` (``sweep.friction.law`` or ``sweep.adhesion.law`` where
    the combination switches the table off with ``"none"``; the swept ``sweep.load.delta_z``) and
    the case."""
    from .runner import adhesion_law, friction_law

    where = f" (in the sweep case {sc.label})"
    off = switched_off(sc.params)
    if task == "gross-slip" and "friction" in off:
        raise InputError("sweep.friction.law", "'none' leaves no friction, which task 'gross-slip' needs; use task = "
                                               f"'solve' to compare with and without friction{where}")
    if task == "pull-off" and "adhesion" in off:
        raise InputError("sweep.adhesion.law", "'none' leaves no adhesion, which task 'pull-off' needs; use task = "
                                               f"'solve' to compare with and without adhesion{where}")
    if task == "gross-slip":
        if sc.case.friction is None:
            raise InputError("run.task", "'gross-slip' needs a [friction] table in the base case (or swept friction.* "
                                         f"keys); use task = 'solve' for a frictionless sweep{where}")
        dz = sc.case.load.delta_z_max
        if not dz > 0:
            key = "sweep.load.delta_z" if "load.delta_z" in sc.params else "load.delta_z"
            raise InputError(key, f"gross-slip needs a positive normal approach; the deepest state of the path is "
                                  f"delta_z = {dz!r} m{where}")
    if task == "pull-off" and sc.case.adhesion is None:
        raise InputError("run.task", f"'pull-off' needs an [adhesion] table in the base case{where}")
    if task == "fretting":
        from .fretting import check_fretting_case

        if "friction" in off:
            raise InputError("sweep.friction.law", f"'none' leaves no friction, which task 'fretting' needs{where}")
        try:
            check_fretting_case(sc.case)
        except InputError as e:
            raise InputError("run.task" if e.key == "friction" else e.key, f"task 'fretting': {e.problem}{where}") \
                from None
    try:  # the laws check what the case checks do not (Tabor needs a finite yield strength)
        friction_law(sc.case)
        adhesion_law(sc.case)
    except InputError as e:
        raise InputError(e.key, e.problem + where) from None


def sweep_from_dict(data: Mapping, source: str | PathLike | None = None, device: str | None = None,
                    dtype: str | None = None, fft: str | None = None) -> Sweep:
    """Validate a parsed sweep file and build every combination.

    ``source`` (the sweep file's path) anchors a relative ``base = "case.toml"``; ``device``,
    ``dtype``, ``fft`` override the solver settings of every case (a swept solver key may not be
    overridden too).

    Raises:
        InputError: naming the key (``sweep.friction.k_tau``, ``run.task``, ``base.grid.n``) of the
            first problem; a combination that fails the case checks is named in the message.
    """
    if not isinstance(data, Mapping):
        raise InputError("sweep file", f"must hold tables [base], [sweep], [run], got {type(data).__name__}")
    src = Path(source) if source is not None else None
    for k in data:
        if k not in SWEEP_TABLES:
            what = "a case table belongs inside [base]; " if k in CASE_SCHEMA else ""
            raise InputError(str(k), f"unknown {'table' if isinstance(data[k], Mapping) else 'key'} of a sweep file; "
                                     f"{what}{near(k, SWEEP_TABLES)}expected {', '.join(SWEEP_TABLES)}")
    base = base_case(data, src)
    if "sweep" not in data:
        raise InputError("sweep", 'is required: a [sweep] table of dotted case keys and lists, e.g. '
                                  '"friction.k_tau" = [0.5, 0.8]')
    table = data["sweep"]
    if not isinstance(table, Mapping):
        raise InputError("sweep", f"must be a table of dotted case keys and lists, got {table!r}")
    entries = _sweep_entries(table)
    if not entries:
        raise InputError("sweep", 'must list at least one case key, e.g. "friction.k_tau" = [0.5, 0.8]')
    keys, values = [], []
    for key, v in entries:
        check_case_key(key, f"sweep.{key}")
        values.append(_check_values(key, v))
        keys.append(key)
    _, task, rel_tol = run_settings(data, base)

    overrides = {"device": device, "dtype": dtype, "fft": fft}
    for name, v in overrides.items():
        if v is not None and f"solver.{name}" in keys:
            raise InputError(f"sweep.solver.{name}", f"is swept, so it cannot also be overridden (--{name} / {name}=)")
    base_dict = base.to_dict()
    if base.solver.tol_default:  # a defaulted tol follows each case's dtype (swept or overridden)
        base_dict["solver"].pop("tol", None)

    cases = []
    for index, combo in enumerate(itertools.product(*values)):
        params = jsonable(dict(zip(keys, combo)))
        label = case_label(params)
        case = _build_case(base_dict, params, label, overrides)
        sc = SweepCase(index=index, params=params, id=case_id(params), label=label, case=case,
                       ignored=ignored_keys(params))
        check_task(sc, task)
        cases.append(sc)
    return Sweep(base=base, keys=tuple(keys), values=tuple(values), task=task, rel_tol=rel_tol, cases=tuple(cases),
                 source=str(src) if src is not None else None, scheduler=run_scheduler(data))


def load_sweep(path: str | PathLike, device: str | None = None, dtype: str | None = None,
               fft: str | None = None) -> Sweep:
    """Read, parse and validate a sweep file (TOML); see `sweep_from_dict`.

    Raises:
        InputError: key = the file path when it cannot be read or parsed, else as sweep_from_dict.
    """
    data = read_toml(path, "sweep file")
    return sweep_from_dict(data, source=path, device=device, dtype=dtype, fft=fft)

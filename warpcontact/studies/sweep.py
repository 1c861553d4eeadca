"""Parameter sweeps: the cartesian product of listed case values, each finished case written at once.

A sweep file is TOML (the format, with an example, is in ``docs/sweeps.md``)::

    base = "table2_k080_dz5e-5.toml"        # or a [base] table holding a whole case
    [sweep]
    "friction.k_tau" = [0.5, 0.8, 0.95]     # dotted case keys -> lists of values
    "load.delta_z" = [1e-11, 5e-11]
    [run]
    task = "gross-slip"                     # or "solve", "pull-off", "fretting"; default: gross-slip with [friction]

From Python::

    from .sweep import load_sweep, run_sweep

    sw = load_sweep("examples/sweep_k_tau.toml")      # every combination built and validated
    report = run_sweep(sw, "out/sweep")               # DIR/cases/<id>.json, DIR/sweep.csv
    report.records                                    # one dict per finished case, in sweep order

Every combination is a case built by :func:`~warpcontact.records.case.case_from_dict` from the base's
``to_dict()`` with the swept values put in, so the case checks hold for every one of them; a
combination that fails them is refused before anything runs, its message naming the combination.
``"friction.law"`` and ``"adhesion.law"`` may also take ``"none"``: that combination's case has no
such table (the base's other keys of it, and other swept keys of it, are ignored there and listed
in its record's ``ignored``).
Mistakes raise :class:`~warpcontact.errors.InputError` naming the key (``sweep.friction.k_tau``,
``run.task``, ``base.sphere.E``).

Output folder: ``DIR/cases/<id>.json`` per finished case (parameters, summary, elapsed_s, the case
dict), written atomically as soon as the case is done, and ``DIR/sweep.csv`` (one row per
finished case, parameter columns first), rewritten atomically after each case, and
``DIR/sweep.json``: ``complete`` (false until every case is finished and written),
``interrupted``, the counts and the finished ids (docs/faults.md). ``<id>`` is a
short hash of the swept values. A rerun skips each case whose JSON holds the same parameters,
task and case (solver settings included); a case that raised ``InputError`` (a contact reaching
the domain's edge, say) is recorded with ``"error"`` and the sweep goes on.
"""

from __future__ import annotations

import copy
import csv
import difflib
import hashlib
import io
import itertools
import json
import numbers
import sys
import time
import warnings
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Mapping

from .. import interrupts
from .._version import __version__
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
from ..errors import ConvergenceError, InputError, NonFiniteError, OutputError
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
#: Load keys of the default path, which an explicit ``load.path`` replaces (and the reverse).
#: Keys of a case's JSON summary in the CSV, first (the rest follow in the order met).
_CSV_FIXED = ("id", "label", "status", "converged")
#: InputError keys that concern the machine, not a case: they stop the sweep instead of being recorded.
_SETUP_KEYS = ("solver.device", "solver.fft", "solver.dtype")
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


# ---------------------------------------------------------------------------------------------
# Running.


@dataclass
class SweepReport:
    """What a run of a sweep did.

    Attributes:
        records: the JSON record of every finished case (computed now or before), in sweep order.
        computed: ids of the cases computed by this run.
        skipped: ids of the cases finished before (their JSON was kept).
        interrupted: a stop (Ctrl-C, SIGTERM, SIGHUP: ``stop_signal`` names it) ended the run;
            finished cases are written.
        elapsed_s: wall time of this run [s].
        total: number of cases in the sweep.
        stop_signal: "SIGINT", "SIGTERM", "SIGHUP" when interrupted, else None.
        write_error: the `warpcontact.errors.OutputError` that ended the run (a full disk,
            a read-only file system, ...), or None; the cases finished before it are on disk.
        batch: the batch engine's times ([`BatchStats`][warpcontact.studies.batch.BatchStats]), or None.
    """

    records: list = field(default_factory=list)
    computed: list = field(default_factory=list)
    skipped: list = field(default_factory=list)
    interrupted: bool = False
    elapsed_s: float = 0.0
    total: int = 0
    stop_signal: str | None = None
    write_error: Exception | None = None
    batch: object = None

    @property
    def errors(self) -> list:
        return [r for r in self.records if r.get("status") == "error"]

    @property
    def not_converged(self) -> list:
        """Records with no converged result: not converged, or an error recorded."""
        return [r for r in self.records if not r.get("converged")]

    @property
    def all_converged(self) -> bool:
        return len(self.records) == self.total and not self.not_converged


def _record_path(out: Path, sc: SweepCase) -> Path:
    return out / "cases" / f"{sc.id}.json"


def _identity(sweep: Sweep, sc: SweepCase) -> dict:
    """What a stored record must match to be reused."""
    ident = {"params": sc.params, "task": sweep.task, "case": jsonable(sc.case.to_dict())}
    if sweep.task == "gross-slip":
        ident["rel_tol"] = sweep.rel_tol
    return ident


def finished_record(out: str | PathLike, sweep: Sweep, sc: SweepCase) -> dict | None:
    """The stored record of a case when it was finished with the same parameters, task and case."""
    path = _record_path(Path(out), sc)
    try:
        rec = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(rec, dict):
        return None
    ident = _identity(sweep, sc)
    return rec if all(rec.get(k) == v for k, v in ident.items()) else None


def run_case(task: str, rel_tol: float, case: Case, keep_models: int = 1, on_state=None) -> dict:
    """One case of a sweep where the batch engine runs it (a worker, or this process): its outcome,
    ``summary`` or ``error`` (a case that raised InputError, NonFiniteError or ConvergenceError),
    ``warnings`` (their messages) and ``elapsed_s`` [s]. The model comes from the process's cache
    (:func:`warpcontact.studies.batch.cached_model`): a case of the last case's grid reuses it. On a worker
    pinned to a GPU a CUDA case runs on that GPU. ``on_state(index, total or None, summary)``
    follows its states. ``keep_models``: the models the process keeps [-] (``cached_model``'s
    ``keep``: 1 for a sweep; a fit's :func:`~warpcontact.studies.batch.models_to_keep`). An InputError about
    the machine (device, FFT, dtype) is raised: it stops the sweep; KeyboardInterrupt propagates
    (nothing is recorded)."""
    from .batch import cached_model, model_key, worker_device
    from .runner import build_model
    from .tasks import run_task

    device = worker_device(case.solver.device)
    if device != case.solver.device:
        case = case.with_overrides(device=device)
    t0 = time.perf_counter()
    summary = error = None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            s = case.solver
            model = cached_model(model_key(case.pair, case.sphere, case.grid, s.device, s.dtype, s.fft),
                                 lambda: build_model(case), keep=keep_models)
            summary = run_task(task, rel_tol, case, on_state or (lambda *a: None), model)
        except InputError as e:
            if e.key in _SETUP_KEYS:
                raise
            error = str(e)
        except (NonFiniteError, ConvergenceError) as e:
            error = f"{type(e).__name__}: {e}"
    outcome = {"elapsed_s": time.perf_counter() - t0, "warnings": list(dict.fromkeys(str(w.message) for w in caught))}
    if error:
        outcome["error"] = error
    else:
        outcome["summary"] = summary
    return outcome


def _csv_cell(v):
    if v is None:
        return ""
    if isinstance(v, (list, dict)):
        return json.dumps(v, separators=(",", ":"))
    return v


def flatten(prefix: str, v, out: dict) -> None:
    """Put the values of the nested summary ``v`` into ``out`` under flat names, the keys joined with
    '_' after ``prefix`` (force {"x": ...} -> force_x): a sweep.csv row, a fit's output names.
    Values keep their units (the summary's SI units: N, m, Pa)."""
    if isinstance(v, Mapping):
        for k, w in v.items():
            flatten(f"{prefix}_{k}" if prefix else str(k), w, out)
    else:
        out[prefix] = v


def csv_text(sweep: Sweep, records: list) -> str:
    """sweep.csv: one row per record, the swept keys first (named as in the sweep file), then id,
    label, status, converged, the summary (nested values joined with '_': force_x), elapsed_s,
    error, and, where a combination switches a table off (law ``"none"``), ``ignored``: its swept
    keys without effect, separated by spaces."""
    rows = []
    columns = dict.fromkeys([*sweep.keys, *_CSV_FIXED])
    for r in records:
        row = {k: _csv_cell(r["params"].get(k)) for k in sweep.keys}
        row.update(id=r["id"], label=r["label"], status=r["status"], converged=r["converged"])
        flat = {}
        flatten("", {k: v for k, v in (r.get("summary") or {}).items() if k not in ("converged", "note")}, flat)
        for k, v in flat.items():
            row[k] = _csv_cell(v)
            columns.setdefault(k, None)
        row["elapsed_s"] = r.get("elapsed_s")
        row["error"] = r.get("error", "")
        if r.get("ignored"):
            row["ignored"] = " ".join(r["ignored"])
        rows.append(row)
    fieldnames = [*columns, "elapsed_s", "error"]
    if any(r.get("ignored") for r in records):
        fieldnames.append("ignored")
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=fieldnames, restval="", lineterminator="\n")
    w.writeheader()
    w.writerows(rows)
    return buf.getvalue()


def _write_csv(out: Path, sweep: Sweep, records: list) -> None:
    from ..records.results import atomic_write_bytes

    data = csv_text(sweep, records).encode()
    path = out / "sweep.csv"
    try:
        if path.read_bytes() == data:
            return
    except OSError:
        pass
    atomic_write_bytes(path, data)


def _write_status(out: Path, sweep: Sweep, report: SweepReport, records: list, complete: bool) -> None:
    """DIR/sweep.json: whether the sweep is complete (every case finished and written), interrupted
    (and by which signal), the counts, and the ids of the finished cases in sweep order. Written at
    the start (complete: false), after each case and at the end, atomically."""
    from ..records.results import atomic_write_json

    atomic_write_json(out / "sweep.json", {
        "complete": complete,
        "interrupted": report.interrupted,
        "stop_signal": report.stop_signal,
        "total": len(sweep.cases),
        "finished": len(records),
        "not_converged": sum(1 for r in records if not r.get("converged")),
        "task": sweep.task,
        "keys": list(sweep.keys),
        "finished_ids": [r["id"] for r in records],
        "software": {"warpcontact": __version__},
    })


def _result_text(task: str, summary: dict) -> str:
    if task == "gross-slip":
        if summary["delta_x_max"] is None:
            return "not converged"
        mu = "undefined (F_z <= 0)" if summary["mu"] is None else f"{summary['mu']:.4f}"
        return f"delta_x_max {summary['delta_x_max']:.4e} m, mu {mu}"
    if task == "pull-off":
        if summary["pull_off_force"] is None:
            return "not converged"
        return f"pull-off force {summary['pull_off_force']:.4e} N (Tabor parameter {summary['tabor_parameter']:.3g})"
    if task == "fretting":
        if summary.get("energy") is None:
            return "no whole cycle converged"
        return (f"W {summary['energy']:.4e} J per cycle, Q* {summary['force_amplitude']:.4e} N, "
                f"A {summary['energy_ratio']:.4f}, {summary['regime']}")
    f = summary["force"]
    text = f"F_z {f['z']:.4e} N, F_x {f['x']:.4e} N, contact radius {summary['contact_radius']:.4e} m"
    return text if summary["converged"] else text + " (not converged)"


def _placement_device(sweep: Sweep) -> str:
    """The device that sizes a local cluster: CUDA when any case runs there."""
    devices = [sc.case.solver.device for sc in sweep.cases]
    return next((d for d in devices if str(d).startswith("cuda")), devices[0] if devices else "cpu")


def run_sweep(sweep: Sweep, out: str | PathLike, quiet: bool = False, log=None, placement=None,
              finish=None) -> SweepReport:
    """Run every case of ``sweep`` not finished before in ``out``; write each at once.

    The cases run where ``placement`` ([`Placement`][warpcontact.studies.batch.Placement]) says: in this process
    (the default), on a local cluster of worker processes, or on a cluster given by its scheduler's
    address (`warpcontact.studies.batch`). As each case finishes, in this process:
    ``out/cases/<id>.json`` (params, label, task, status "ok" / "not converged" / "error",
    converged, summary, elapsed_s [s], warnings, the case dict) and ``out/sweep.csv`` (every
    finished case of this sweep), both atomically. A case that raises InputError (not a device or
    FFT problem, which stops the sweep), NonFiniteError or ConvergenceError is recorded with
    ``error`` and the sweep continues; so is a case whose workers died every time it was tried.
    Ctrl-C stops the run; what finished is written and the report says ``interrupted`` (SIGTERM
    and SIGHUP likewise, where the command line handles them: `warpcontact.interrupts`). A
    write that fails (no space left, read-only file system, ...) ends the run with
    ``report.write_error`` set: the cases finished before are on disk and a rerun resumes.
    ``out/sweep.json`` says whether the sweep is complete (`_write_status`). Unless quiet, a
    result line per case goes to ``log`` (stderr), under a progress bar on a terminal (cases done,
    running, failed; `warpcontact.records.progress`); warnings and errors are printed either way.
    ``finish(records)``, when given, is called with every finished record in sweep order once the
    run's cases are done and sweep.csv is written, before sweep.json is marked complete (the command
    line draws ``out/sweep.png`` there); an OutputError or a stop it raises is handled as one met
    while writing a case.
    """
    from .batch import LostTask, Placement, Task, model_key, run_tasks
    from ..records.progress import Progress
    from ..records.results import atomic_write_json, output_error

    log = sys.stderr if log is None else log
    out = Path(out)
    t0 = time.perf_counter()
    report = SweepReport(total=len(sweep.cases))
    n = len(sweep.cases)
    width = len(str(n))
    records: dict[str, dict] = {}
    by_id = {sc.id: sc for sc in sweep.cases}

    def ordered():
        return [records[sc.id] for sc in sweep.cases if sc.id in records]

    for sc in sweep.cases:
        rec = finished_record(out, sweep, sc)
        if rec is not None:
            records[sc.id] = rec
            report.skipped.append(sc.id)
    if report.skipped and not quiet:
        print(f"sweep: {len(report.skipped)} of {n} case(s) finished before in {out}, skipped", file=log, flush=True)

    # a bar over the cases on a terminal, redrawn with the running case's states; a log gets a line per case
    progress = Progress("sweep", total=n, quiet=quiet, stream=log, start=len(records))

    def on_state(task, k, total, s):
        where = f"state {k + 1}/{total}" if total else f"state {k + 1} ({s.get('kind', '')})"
        progress.status(len(records), s["iterations"], s["residual"], f"{task.label}: {where}")

    def on_result(task, outcome):
        sc = by_id[task.key]
        error = outcome.get("error")
        summary = outcome.get("summary")
        rec = {
            "id": sc.id,
            "label": sc.label,
            "index": sc.index,
            **_identity(sweep, sc),
            "status": "error" if error else ("ok" if summary["converged"] else "not converged"),
            "converged": False if error else bool(summary["converged"]),
        }
        if sc.ignored:  # swept keys of a table switched off (law "none"): no effect on this case
            rec["ignored"] = list(sc.ignored)
        if error:
            rec["error"] = error
        else:
            rec["summary"] = summary
        rec.update(elapsed_s=outcome["elapsed_s"], warnings=outcome["warnings"],
                   software={"warpcontact": __version__})
        case = rec.pop("case")
        rec["case"] = case  # the long case dict last, for reading
        with interrupts.deferred():  # the record, the CSV and the status agree; a stop comes after
            atomic_write_json(_record_path(out, sc), rec)
            records[sc.id] = rec
            report.computed.append(sc.id)
            _write_csv(out, sweep, ordered())
            _write_status(out, sweep, report, ordered(), complete=False)
        what = f"error: {error}" if error else _result_text(sweep.task, summary)
        progress.write(f"sweep [{sc.index + 1:>{width}}/{n}] {sc.label}: {what} ({rec['elapsed_s']:.1f} s)")
        if quiet and error:
            progress.write(f"warpcontact: sweep case {sc.label}: error: {error} (recorded; the sweep goes on)",
                           always=True)
        for m in outcome["warnings"]:
            progress.write(f"warpcontact: warning: {sc.label}: {m}", always=True)
        return True

    def on_error(task, e):
        if isinstance(e, LostTask):  # recorded as a case's error; the others go on
            return on_result(task, {"error": str(e), "warnings": [], "elapsed_s": 0.0})
        raise e

    def group(case):
        s = case.solver
        return model_key(case.pair, case.sphere, case.grid, s.device, s.dtype, s.fft)

    tasks = [Task(sc.id, sc.label, run_case, (sweep.task, sweep.rel_tol, sc.case), group(sc.case))
             for sc in sweep.cases if sc.id not in records]
    placement = placement or Placement(workers=1)
    if placement.device == "cpu" and placement.scheduler is None:
        placement = Placement(placement.scheduler, placement.workers, _placement_device(sweep))
    try:
        try:
            out.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise output_error(out, e, "create the folder") from None
        with interrupts.deferred():
            _write_csv(out, sweep, ordered())
            _write_status(out, sweep, report, ordered(), complete=False)
        report.batch = run_tasks(tasks, on_result, placement, progress=progress, before=len(records),
                                 failed=lambda o: "error" in o or not o["summary"]["converged"],
                                 on_error=on_error, on_state=on_state)
        if finish is not None and records:
            finish(ordered())  # after the table; complete only once it is done
        with interrupts.deferred(raise_after=False):
            _write_status(out, sweep, report, ordered(), complete=len(records) == n)
    except KeyboardInterrupt as e:
        report.interrupted = True
        report.stop_signal = interrupts.signal_name(interrupts.stop_signal(e))
        with interrupts.deferred(raise_after=False):  # every record is whole (atomic writes)
            try:  # bring the CSV and the status up to date
                _write_csv(out, sweep, ordered())
                _write_status(out, sweep, report, ordered(), complete=False)
            except OutputError as w:
                report.write_error = w
    except OutputError as e:  # what finished is on disk; the rest cannot be written: stop
        report.write_error = e
        try:
            _write_status(out, sweep, report, ordered(), complete=False)
        except OutputError:
            pass
    finally:
        progress.close()
    report.records = ordered()
    report.elapsed_s = time.perf_counter() - t0
    return report


__all__ = [
    "Sweep",
    "SweepCase",
    "SweepReport",
    "base_case",
    "case_id",
    "case_label",
    "check_task",
    "csv_text",
    "finished_record",
    "flatten",
    "ignored_keys",
    "jsonable",
    "load_sweep",
    "run_case",
    "run_sweep",
    "short_float",
    "sweep_from_dict",
    "switched_off",
]

"""Parameter sweeps: the cartesian product of listed case values, each finished case written at once.

From Python::

    from warpcontact.studies.sweep import load_sweep, run_sweep

    sw = load_sweep("examples/sweep_k_tau.toml")      # every combination built and validated
    report = run_sweep(sw, "out/sweep")               # DIR/cases/<id>.json, DIR/sweep.csv
    report.records                                    # one dict per finished case, in sweep order

The sweep file is read and every combination built by :mod:`warpcontact.studies.sweep_spec`.

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

import csv
import io
import json
import sys
import time
import warnings
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Mapping

from .. import interrupts
from .._version import __version__
from ..records.case import Case
from ..errors import ConvergenceError, InputError, NonFiniteError, OutputError
from .sweep_spec import (
    Sweep,
    SweepCase,
    base_case,
    case_id,
    case_label,
    check_task,
    ignored_keys,
    jsonable,
    load_sweep,
    short_float,
    sweep_from_dict,
    switched_off,
)

#: Keys of a case's JSON summary in the CSV, first (the rest follow in the order met).
_CSV_FIXED = ("id", "label", "status", "converged")
#: seconds between rewrites of sweep.csv and sweep.json while the cases of a batched solve end
#: together (each case's own JSON is written as it ends; the table once more when the batch ends)
TABLE_EVERY_S = 0.5
#: InputError keys that concern the machine, not a case: they stop the sweep instead of being recorded.
_SETUP_KEYS = ("solver.device", "solver.fft", "solver.dtype")


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
        except (InputError, NonFiniteError, ConvergenceError) as e:
            error = recorded_error(e)
    outcome = {"elapsed_s": time.perf_counter() - t0, "warnings": list(dict.fromkeys(str(w.message) for w in caught))}
    if error:
        outcome["error"] = error
    else:
        outcome["summary"] = summary
    return outcome


def recorded_error(e: Exception) -> str:
    """The text a sweep records for a case that raised ``e`` (an InputError's message, or a
    NonFiniteError's or ConvergenceError's with its kind); ``e`` itself is raised where the sweep
    cannot go on (an InputError about the machine, ``_SETUP_KEYS``, or any other error)."""
    if isinstance(e, InputError) and e.key not in _SETUP_KEYS:
        return str(e)
    if isinstance(e, (NonFiniteError, ConvergenceError)):
        return f"{type(e).__name__}: {e}"
    raise e


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


def _csv_row(keys, r: dict) -> tuple[dict, list]:
    """One record's sweep.csv row and the names of its summary's columns, in order."""
    row = {k: _csv_cell(r["params"].get(k)) for k in keys}
    row.update(id=r["id"], label=r["label"], status=r["status"], converged=r["converged"])
    flat = {}
    flatten("", {k: v for k, v in (r.get("summary") or {}).items() if k not in ("converged", "note")}, flat)
    for k, v in flat.items():
        row[k] = _csv_cell(v)
    row["elapsed_s"] = r.get("elapsed_s")
    row["error"] = r.get("error", "")
    if r.get("ignored"):
        row["ignored"] = " ".join(r["ignored"])
    return row, list(flat)


def csv_text(sweep: Sweep, records: list, rows_made: dict | None = None) -> str:
    """sweep.csv: one row per record, the swept keys first (named as in the sweep file), then id,
    label, status, converged, the summary (nested values joined with '_': force_x), elapsed_s,
    error, and, where a combination switches a table off (law ``"none"``), ``ignored``: its swept
    keys without effect, separated by spaces. ``rows_made``: the rows of earlier calls by record
    id (kept there, and used again for the same record object), so that a sweep rewriting its
    table after each case does not flatten every summary again."""
    rows = []
    columns = dict.fromkeys([*sweep.keys, *_CSV_FIXED])
    rows_made = {} if rows_made is None else rows_made
    for r in records:
        made = rows_made.get(r["id"])
        if made is None or made[0] is not r:
            made = rows_made[r["id"]] = (r, *_csv_row(sweep.keys, r))
        rows.append(made[1])
        for k in made[2]:
            columns.setdefault(k, None)
    fieldnames = [*columns, "elapsed_s", "error"]
    if any(r.get("ignored") for r in records):
        fieldnames.append("ignored")
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=fieldnames, restval="", lineterminator="\n")
    w.writeheader()
    w.writerows(rows)
    return buf.getvalue()


def _write_csv(out: Path, sweep: Sweep, records: list, rows_made: dict | None = None) -> None:
    from ..records.results import atomic_write_bytes

    data = csv_text(sweep, records, rows_made).encode()
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
        tabor = summary.get("tabor_parameter")  # None where the shape is not a sphere's (no Hertz reference)
        return f"pull-off force {summary['pull_off_force']:.4e} N" + (
            f" (Tabor parameter {tabor:.3g})" if tabor is not None else "")
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


#: the tasks whose cases ``run_sweep`` may solve by batched solves: load paths
#: (``batch_solve.solve_batch``) and gross-slip searches (``batch_solve.gross_slip_batch``)
BATCHED_TASKS = ("solve", "gross-slip")


def batched_cases(task: str, cases: list, placement, batch: int | None = None, anywhere: bool = False) -> list:
    """The indices of those of ``cases`` (``Case``) that a many-case command (``run_sweep``,
    ``run_fit``) solves by batched solves (``run_batched``): with the task "solve", the cases
    ``batch_solve.batchable`` admits (``warpcontact.solve_batch``: normal contact, friction,
    friction with the SMC law on the DMT side); with "gross-slip", those of them with friction
    (``batch_solve.gross_slip_batch``); by default those on a CUDA device where the cases run in
    this process (``placement``; ``anywhere``: or on workers, which take them as groups,
    ``run_sweep``), and where ``batch`` (cases per batched solve) is given, those on any device
    wherever the others run; none where ``batch`` is 0, or where fewer than two cases qualify. On
    2 CPU cores a batch saves the launches' overhead but not their work, and each case there checks
    its own yield (docs/performance.md): one case at a time by default."""
    import warp as wp

    from ..numerics.device import resolve_device
    from .batch_solve import batchable

    if batch == 0 or task not in BATCHED_TASKS or (batch is None and not anywhere
                                                     and not placement.in_process(len(cases))):
        return []
    chosen = [i for i, case in enumerate(cases) if batchable(case) and (task == "solve" or case.friction is not None)
              and (batch is not None or wp.get_device(resolve_device(case.solver.device)).is_cuda)]
    return chosen if len(chosen) > 1 else []


def run_batched(task: str, rel_tol: float, cases: list, batch: int | None, on_outcome) -> None:
    """Solve ``cases`` (``Case``, chosen by ``batched_cases``) together in this process, as
    ``task`` asks ("solve": ``warpcontact.solve_batch``; "gross-slip":
    ``batch_solve.gross_slip_batch``), ``batch`` cases at a time (None: the device's default);
    ``on_outcome(i, outcome)`` as case i ends, with the outcome ``run_case`` gives of it (its
    summary as a row, or its error; its warnings' messages, not issued again; ``elapsed_s``: its
    batch's time from the start to the case's end)."""
    from .batch_solve import gross_slip_batch, solve_batch
    from .tasks import prepare

    with warnings.catch_warnings():  # each case's warnings are in its outcome
        warnings.simplefilter("ignore")
        prepared = [prepare(case) for case in cases]
        if task == "gross-slip":
            gross_slip_batch(prepared, rel_tol=rel_tol, batch=batch or None,
                             on_case=lambda i, entry: on_outcome(i, _searched_outcome(entry)))
        else:
            solve_batch(prepared, fields="none", batch=batch or None,
                        on_case=lambda i, result: on_outcome(i, _batched_outcome(result)))


def run_cases_batched(task: str, rel_tol: float, cases: list, batch: int | None, on_state=None) -> list:
    """Cases of one grid solved together (``run_batched``, ``batch`` at a time) where the batch
    engine runs them (a worker of ``--workers`` or ``--scheduler``, on its GPU, or this process):
    one outcome a case, in order, as ``run_case`` gives it. ``on_state`` is not called: the cases'
    states are solved together."""
    from .batch import worker_device

    cases = [c if worker_device(c.solver.device) == c.solver.device
             else c.with_overrides(device=worker_device(c.solver.device)) for c in cases]
    outcomes: list = [None] * len(cases)

    def on_outcome(i, outcome):
        outcomes[i] = outcome

    run_batched(task, rel_tol, cases, batch, on_outcome)
    if any(o is None for o in outcomes):
        raise RuntimeError("run_cases_batched: a batched solve ended without every case's outcome")
    return outcomes


#: a grid's cases solved together on several workers go as about this many tasks a worker (by
#: default, ``batched_groups``): a worker that starts late, or a GPU that is slower, takes fewer
TASKS_PER_WORKER = 4


def batched_groups(cases: list, batch: int | None, workers: int = 1) -> list[list[int]]:
    """The indices of ``cases`` (``Case``, those ``batched_cases`` chose) as the batch engine's
    tasks: the cases of one grid size, device and float type (as the batched solves group them),
    the largest grids first, ``batch`` at a time. By default a grid's cases are cut into
    ``TASKS_PER_WORKER`` tasks a worker (a local cluster's ``workers``, this process included) of
    equal size, at least ``FRICTION_MIN_BATCH`` cases a task (fewer with friction would be solved
    one at a time) and at most the device kind's ``DEFAULT_BATCH`` (the most a batched solve
    takes)."""
    from .batch_solve import DEFAULT_BATCH, FRICTION_MIN_BATCH

    grids: dict = {}
    for i, case in enumerate(cases):
        s = case.solver
        grids.setdefault((case.grid.n, str(s.device), str(s.dtype)), []).append(i)
    groups = []
    for (n, device, _), members in sorted(grids.items(), key=lambda g: -g[0][0]):
        if batch:
            groups.extend(members[first:first + batch] for first in range(0, len(members), batch))
            continue
        most = DEFAULT_BATCH["cuda" if device.startswith("cuda") else "cpu"]
        size = min(most, max(FRICTION_MIN_BATCH, -(-len(members) // (TASKS_PER_WORKER * max(1, workers)))))
        tasks = max(-(-len(members) // most), len(members) // size, 1)
        groups.extend(list(part) for part in _split_evenly(members, tasks))
    return groups


def batched_tasks(task: str, rel_tol: float, cases: list, own: list, batch: int | None, placement) -> tuple:
    """The batch engine's tasks of ``cases`` (``Case``, those ``batched_cases`` chose) solved
    together on its workers (``placement``): each group of ``batched_groups`` a task of
    ``run_cases_batched``, a lone case its own task (``own``: each case's task, as it would run
    alone, keyed by the case). Returns (the tasks, each group task's cases' own tasks by its key):
    ``batch.each_case`` hands a group's outcomes back case by case."""
    from .batch import Task, worker_environments

    workers = 1 if placement.scheduler is not None else len(worker_environments(placement, len(cases)))
    tasks, members = [], {}
    for group in batched_groups(cases, batch, workers):
        first = own[group[0]]
        if len(group) == 1:
            tasks.append(first)
            continue
        key = f"batch-{first.key}"
        members[key] = [own[i] for i in group]
        tasks.append(Task(key, f"{len(group)} cases from {first.label}, solved together", run_cases_batched,
                          (task, rel_tol, [cases[i] for i in group], batch or None), first.group, cases=len(group)))
    return tasks, members


def _split_evenly(items: list, parts: int) -> list:
    """``items`` in ``parts`` consecutive runs whose lengths differ by one at most."""
    q, r = divmod(len(items), parts)
    out, first = [], 0
    for k in range(parts):
        last = first + q + (k < r)
        out.append(items[first:last])
        first = last
    return out


def _searched_outcome(entry) -> dict:
    """A batched gross-slip search's entry ((summary, warnings), or the exception the case raised)
    as ``run_case``'s outcome."""
    from .tasks import result_row

    if isinstance(entry, BaseException):
        return {"elapsed_s": 0.0, "warnings": [], "error": recorded_error(entry)}
    summary, messages = entry
    return {"elapsed_s": summary.get("elapsed_s", 0.0), "warnings": list(messages), "summary": result_row(summary)}


def _batched_outcome(result) -> dict:
    """A batched case's result (a ``PathResult`` or the exception it raised) as ``run_case``'s
    outcome: the row ``run_task`` makes of a solve, or the error a sweep records (an InputError
    about the machine is raised: it stops the sweep)."""
    from .tasks import solve_row

    if isinstance(result, BaseException):
        return {"elapsed_s": 0.0, "warnings": [], "error": recorded_error(result)}
    return {"elapsed_s": result.elapsed_s, "warnings": list(result.warnings), "summary": solve_row(result)}


def run_sweep(sweep: Sweep, out: str | PathLike, quiet: bool = False, log=None, placement=None,
              finish=None, batch: int | None = None) -> SweepReport:
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
    ``batch``: cases per batched solve (``batched_cases``: with the task "solve", the cases of
    normal contact alone are solved together, by default on CUDA; 0: none); a batched case's
    ``elapsed_s`` is its batch's time from its start to the case's end, and while a batch's cases
    end together sweep.csv and sweep.json are rewritten at most every ``TABLE_EVERY_S`` (each
    case's JSON at once, the table again when the batch ends or stops).
    ``finish(records)``, when given, is called with every finished record in sweep order once the
    run's cases are done and sweep.csv is written, before sweep.json is marked complete (the command
    line draws ``out/sweep.png`` there); an OutputError or a stop it raises is handled as one met
    while writing a case.
    """
    from .batch import LostTask, Placement, Task, each_case, model_key, run_tasks
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

    rows_made: dict = {}  # sweep.csv's rows by record id (csv_text)

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

    def write_table():
        _write_csv(out, sweep, ordered(), rows_made)
        _write_status(out, sweep, report, ordered(), complete=False)

    def on_result(task, outcome, table: bool = True):
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
            if table:
                write_table()
        what = f"error: {error}" if error else _result_text(sweep.task, summary)
        progress.write(f"sweep [{sc.index + 1:>{width}}/{n}] {sc.label}: {what} ({rec['elapsed_s']:.1f} s)")
        if quiet and error:
            progress.write(f"warpcontact: sweep case {sc.label}: error: {error} (recorded; the sweep goes on)",
                           always=True)
        for m in outcome["warnings"]:
            progress.write(f"warpcontact: warning: {sc.label}: {m}", always=True)
        return True

    def on_error(task, e):
        if isinstance(e, LostTask):  # recorded as the error of its case (or cases); the others go on
            lost = {"error": str(e), "warnings": [], "elapsed_s": 0.0}
            return on_task(task, [lost] * task.cases if task.cases > 1 else lost)
        raise e

    def group(case):
        s = case.solver
        return model_key(case.pair, case.sphere, case.grid, s.device, s.dtype, s.fft)

    def task_of(sc):
        return Task(sc.id, sc.label, run_case, (sweep.task, sweep.rel_tol, sc.case), group(sc.case))

    pending = [sc for sc in sweep.cases if sc.id not in records]
    placement = placement or Placement(workers=1)
    if placement.device == "cpu" and placement.scheduler is None:
        placement = Placement(placement.scheduler, placement.workers, _placement_device(sweep))
    together = [pending[i] for i in batched_cases(sweep.task, [sc.case for sc in pending], placement, batch,
                                                  anywhere=True)]
    batched_ids = {sc.id for sc in together}
    tasks = [task_of(sc) for sc in pending if sc.id not in batched_ids]
    members: dict = {}  # the cases' own tasks of each task of cases solved together, by its key
    if together and not placement.in_process(len(pending)):  # the groups as tasks of the workers
        grouped, members = batched_tasks(sweep.task, sweep.rel_tol, [sc.case for sc in together],
                                         [task_of(sc) for sc in together], batch, placement)
        tasks, together = tasks + grouped, []

    in_groups = {t.key for case_tasks in members.values() for t in case_tasks}

    def on_case(task, outcome):  # the table at once, or once its group's cases are all written
        return on_result(task, outcome, table=task.key not in in_groups)

    def table_after_group():
        with interrupts.deferred():
            write_table()

    on_task = each_case(on_case, members, table_after_group)

    def run_together():
        """The batched cases, each written as it ends (a stop ends the batch: what ended is written)."""
        last = [time.perf_counter()]

        def on_outcome(i, outcome):
            table = time.perf_counter() - last[0] >= TABLE_EVERY_S
            on_result(task_of(together[i]), outcome, table)
            if table:
                last[0] = time.perf_counter()
            progress.status(len(records), extra=f"{len(records) - len(report.skipped)} case(s) solved, batched")

        run_batched(sweep.task, sweep.rel_tol, [sc.case for sc in together], batch, on_outcome)
        with interrupts.deferred():
            write_table()
    try:
        try:
            out.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise output_error(out, e, "create the folder") from None
        with interrupts.deferred():
            _write_csv(out, sweep, ordered(), rows_made)
            _write_status(out, sweep, report, ordered(), complete=False)
        if together:
            run_together()
        report.batch = run_tasks(tasks, on_task, placement, progress=progress, before=len(records),
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
                _write_csv(out, sweep, ordered(), rows_made)
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

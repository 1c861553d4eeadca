"""The fit's evaluations: a point's cases on the batch engine, cached on disk."""

from __future__ import annotations

import hashlib
import json
import math
import numbers
import time
from pathlib import Path

import numpy as np

from .. import interrupts
from .._version import __version__
from ..records.case import Case
from .sweep import flatten
from .sweep_spec import jsonable
from .fit_spec import Fit, _row_case, _show


class EvaluationFailed(RuntimeError):
    """A model evaluation that gave no usable output (an error recorded, a state not converged, an
    output the result does not give). Its message names the data line and the parameters."""


def evaluation_identity(task: str, rel_tol: float, case: Case) -> dict:
    """What a cached evaluation must match: the task, the bracket (gross-slip) and the case."""
    ident = {"task": task, "case": jsonable(case.to_dict())}
    if task == "gross-slip":
        ident["rel_tol"] = rel_tol
    return ident


def evaluation_hash(ident: dict) -> str:
    """First 16 hex digits of the SHA-256 of the identity (canonical JSON)."""
    text = json.dumps(ident, sort_keys=True, separators=(",", ":"), allow_nan=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


class _Evaluator:
    """The model at parameter points: every row's case, from the cache or the batch engine."""

    def __init__(self, fit: Fit, out: Path, placement, where: str | None = None, batch: int | None = None):
        self.fit, self.out, self.placement, self.batch = fit, out, placement, batch
        self.where = where  # the words for a local cluster of the fit's own; else each batch's
        self.folder = out / "evaluations"
        self.memory: dict = {}  # hash -> outcome
        self.requested = self.computed = self.cached = 0
        self.compute_s = 0.0
        self.data_name = Path(fit.data_file).name
        self.batches = []
        #: cases computed by batched solves (``run_batched``, here or on the workers)
        self.batched = 0

    def _load(self, h: str, ident: dict):
        if h in self.memory:
            return self.memory[h]
        try:
            rec = json.loads((self.folder / f"{h}.json").read_text())
        except (OSError, ValueError):
            return None
        if not isinstance(rec, dict) or any(rec.get(k) != v for k, v in ident.items()):
            return None
        self.memory[h] = rec
        return rec

    def outcomes(self, points: list) -> list:
        """For each point (parameter key -> value), each row's outcome (summary or error), in row
        order; the missing ones computed together, each written as it finishes: by batched solves
        where ``sweep.batched_cases`` takes them (the task "solve" or "gross-slip", the cases
        ``batch_solve.batchable`` admits; by default on CUDA, or with ``batch``), in this process or
        on several workers as tasks of a grid's cases (``sweep.batched_tasks``), the others on the
        batch engine one at a time."""
        from .batch import Task, each_case, model_key, models_to_keep, run_tasks
        from ..records.results import atomic_write_json
        from .sweep import batched_cases, batched_tasks, run_batched, run_case

        fit = self.fit
        plan, tasks, task_cases, pending = [], [], [], {}
        cases = [[_row_case(fit.base_dict, row, values, fit.overrides, self.data_name, fit.grid_size) for row in fit.rows]
                 for values in points]
        # the models of one point's rows, kept by each process across the fit's batches (the next
        # Jacobian's cases differ from these in the fitted values only)
        keep = max(models_to_keep(row_cases) for row_cases in cases) if cases else 1
        for values, row_cases in zip(points, cases):
            hashes = []
            for row, case in zip(fit.rows, row_cases):
                ident = evaluation_identity(fit.task, fit.rel_tol, case)
                h = evaluation_hash(ident)
                hashes.append(h)
                self.requested += 1
                if h in pending or self._load(h, ident) is not None:
                    self.cached += 1
                    continue
                s = case.solver
                pending[h] = (ident, row, values)
                tasks.append(Task(h, f"line {row.line} {_show(values)}", run_case, (fit.task, fit.rel_tol, case, keep),
                                  model_key(case.pair, case.sphere, case.grid, s.device, s.dtype, s.fft)))
                task_cases.append(case)
            plan.append(hashes)

        def on_result(task, outcome):
            ident, row, values = pending[task.key]
            rec = {**{k: v for k, v in ident.items() if k != "case"},
                   "line": row.line, "parameters": {k: float(v) for k, v in values.items()},
                   "status": "error" if "error" in outcome else
                   ("ok" if outcome["summary"]["converged"] else "not converged"),
                   **({"error": outcome["error"]} if "error" in outcome else {"summary": outcome["summary"]}),
                   "elapsed_s": outcome["elapsed_s"], "warnings": outcome["warnings"],
                   "software": {"warpcontact": __version__}, "case": ident["case"]}
            with interrupts.deferred():  # a stop comes after the record is whole
                atomic_write_json(self.folder / f"{task.key}.json", rec)
                self.memory[task.key] = rec
                self.computed += 1
            return True

        def on_error(task, e):
            from .batch import LostTask

            if isinstance(e, LostTask):  # recorded as the error of its case (or cases)
                lost = {"error": str(e), "warnings": [], "elapsed_s": 0.0}
                return each_case(on_result, members)(task, [lost] * task.cases if task.cases > 1 else lost)
            raise e

        if tasks:
            t0 = time.perf_counter()
            try:
                self.folder.mkdir(parents=True, exist_ok=True)
            except OSError as e:
                from ..records.results import output_error

                raise output_error(self.folder, e, "create the folder") from None
            together = batched_cases(fit.task, task_cases, self.placement, self.batch, anywhere=True)
            batched = set(together)
            rest, members = [t for i, t in enumerate(tasks) if i not in batched], {}
            if together and self.placement.in_process(len(tasks)):
                run_batched(fit.task, fit.rel_tol, [task_cases[i] for i in together], self.batch,
                            lambda k, outcome: on_result(tasks[together[k]], outcome))
            elif together:  # the groups as tasks of the workers
                grouped, members = batched_tasks(fit.task, fit.rel_tol, [task_cases[i] for i in together],
                                                 [tasks[i] for i in together], self.batch, self.placement)
                rest += grouped
            self.batched += len(together)
            if rest:
                self.batches.append(run_tasks(rest, each_case(on_result, members), self.placement,
                                              on_error=on_error, keep_models=True))
            self.compute_s += time.perf_counter() - t0
        return [[self.memory[h] for h in hashes] for hashes in plan]

    def model(self, points: list, undefined: list | None = None) -> list:
        """For each point, the model's outputs, an array (rows, outputs). EvaluationFailed where a
        case failed or did not converge, and where an output is undefined (mu of a cell in
        tension, say) unless ``undefined`` is given: then that output is NaN and the reason is
        appended to ``undefined``."""
        fit = self.fit
        result = []
        for values, recs in zip(points, self.outcomes(points)):
            y = np.empty((len(fit.rows), len(fit.outputs)))
            for i, (row, rec) in enumerate(zip(fit.rows, recs)):
                where = f"the case of {self.data_name} line {row.line} at {_show(values)}"
                if rec.get("status") == "error":
                    raise EvaluationFailed(f"{where} failed: {rec['error']}")
                if rec.get("status") != "ok":
                    raise EvaluationFailed(f"{where} did not converge (a state of its path); see {self.folder}")
                flat = {}
                flatten("", rec["summary"], flat)
                for j, o in enumerate(fit.outputs):
                    v = flat.get(o)
                    if v is None or isinstance(v, bool) or not isinstance(v, numbers.Real):
                        note = flat.get("mu_note") or "the result does not give it"
                        if undefined is None:
                            raise EvaluationFailed(f"{where} gives no {fit.columns[o]}: {note}")
                        undefined.append(f"{where} gives no {fit.columns[o]} ({note})")
                        v = math.nan
                    y[i, j] = float(v)
            result.append(y)
        return result

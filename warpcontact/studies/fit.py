"""Calibration: the case parameters that reproduce measurements, with their uncertainties.

A fit file is TOML, in the sweep file's style (the format, with an example, is in ``docs/fit.md``)::

    base = "case.toml"                      # or a [base] table holding a whole case
    [data]
    file = "data.csv"                       # one row per measurement, relative to the fit file
    [fit]
    "friction.k_tau" = { min = 0.3, max = 0.97, start = 0.6 }
    "adhesion.sigma_max" = { min = 1e5, max = 1e9, start = 1e6, scale = "log" }
    [run]
    task = "gross-slip"                     # or "solve", "pull-off"

The CSV's columns are dotted case keys (the conditions of each row, ``load.delta_z``) and measured
outputs named as the sweep's CSV names the result's keys (``mu``, ``delta_x_max``,
``pull_off_force``, ``force_z``; ``force.z`` is read as ``force_z``), with optional
``sigma_<output>`` columns (measurement errors, the weights).

From Python::

    from warpcontact.studies.fit import load_fit, run_fit

    fit = load_fit("examples/fit_k_tau.toml")    # the file, the CSV and every row's case checked
    report = run_fit(fit, "out/fit")              # DIR/fit.json, DIR/fit.png, DIR/fitted.toml
    report.parameters["friction.k_tau"]           # {"value": ..., "stderr": ..., "at_bound": None}

The algorithm: bounded nonlinear least squares (``scipy.optimize.least_squares``, trust-region
reflective) in unit parameters (each parameter's bounds mapped to [0, 1], linearly or in its
logarithm). The residuals and the forward-difference Jacobian are computed here: each model
evaluation is one case per data row, built as the sweep builds its cases (the base's dict with
the row's conditions and the parameters put in, through ``case_from_dict``: every case check
holds), and the cases of one residual vector, or of every column of one Jacobian, go to the
batch engine together (:func:`warpcontact.studies.batch.run_tasks`: at once on a local cluster's workers
or on a scheduler's). Every finished evaluation is written to ``DIR/evaluations/<hash>.json``
(atomically; the hash is of the case and the task), so a rerun replays the optimiser from the
cache and computes only what is missing. Mistakes raise :class:`~warpcontact.errors.InputError`
naming the key (``fit.friction.k_tau.min``, ``run.task``) or the CSV line (``data.csv line 3``).
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path

import numpy as np

from .. import interrupts
from .._version import __version__
from ..errors import OutputError
from .sweep_spec import short_float
from .fit_evaluations import EvaluationFailed, _Evaluator, evaluation_hash
from .fit_numerics import _correlation, _unit_steps, covariance, difference_step, model_noise
from .fit_outputs import _write_outputs, case_toml, fit_figure, fitted_case
from .fit_spec import OUTPUTS, Fit, Parameter, Row, _show, fit_from_dict, load_fit, read_data

#: The residual of each output a trial point does not give (mu of a cell pulled into tension):
#: in units of the weights, far above any point that gives them, so that the optimiser rejects
#: the step and shrinks its trust region.
BAD_POINT_RESIDUAL = 1e6
#: Relative standard error above which a parameter is reported as not fixed by the data.
UNIDENTIFIED_REL_STDERR = 1.0
#: least_squares' ftol and gtol; its xtol is the model's noise (:func:`model_noise`, at least
#: XTOL_MIN): a step under that fraction of the unit parameters' norm ends the fit, as a finer
#: one only follows the noise (gross-slip at rel_tol 1e-3: mu and delta_x_max scatter by up to 1e-3,
#: k_tau by about 4e-4 there). Gauss-Newton's error after such a step is a fraction of it. Below
#: 1e-6 no physical parameter is known, and a solve's noise (its tol, 1e-10) would let the
#: optimiser chase round-off until its evaluation limit.
FTOL = 1e-8
GTOL = 1e-8
XTOL_MIN = 1e-6

# ---------------------------------------------------------------------------------------------
# Running a fit.


@dataclass
class FitReport:
    """What a fit did (``result`` is what ``DIR/fit.json`` holds).

    Attributes:
        parameters: key -> {value, stderr, at_bound ("min", "max" or None), ...}; empty until the
            fit ended.
        correlation: the parameters' correlation matrix (None where undefined).
        residual_rms: RMS of the weighted residuals at the optimum.
        converged: the optimiser met a tolerance (not the evaluation limit, not a failed case).
        message: the optimiser's message, or what stopped the fit.
        evaluations: cases requested (rows x points), cached (found done: this run's or an
            earlier run's) and computed now.
        warnings: parameters the data do not fix, and other warnings of the fit.
        error: an evaluation that failed (EvaluationFailed's message), or None.
        interrupted, stop_signal: a stop (Ctrl-C, SIGTERM, SIGHUP) ended the run; finished
            evaluations are kept.
        write_error: the OutputError that ended the run, or None.
        elapsed_s: wall time [s].
        result: the fit.json dict.
    """

    parameters: dict = field(default_factory=dict)
    correlation: list = field(default_factory=list)
    residual_rms: float | None = None
    converged: bool = False
    message: str = ""
    evaluations: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)
    error: str | None = None
    interrupted: bool = False
    stop_signal: str | None = None
    write_error: Exception | None = None
    elapsed_s: float = 0.0
    result: dict = field(default_factory=dict)


def _weights(fit: Fit) -> np.ndarray:
    """Per row and output, what a residual is divided by: sigma, or the RMS of the output's data."""
    if fit.weighted:
        return np.array([[r.sigma[o] for o in fit.outputs] for r in fit.rows])
    data = np.array([[r.measured[o] for o in fit.outputs] for r in fit.rows])
    scale = np.sqrt((data ** 2).mean(axis=0))
    return np.broadcast_to(scale, data.shape).copy()




def _values(fit: Fit, u) -> dict:
    return {p.key: p.from_unit(ui) for p, ui in zip(fit.parameters, u)}




def run_fit(fit: Fit, out: str | PathLike, quiet: bool = False, log=None, placement=None,
            batch: int | None = None) -> FitReport:
    """Fit ``fit``'s parameters to its data; write ``out/fit.json``, ``out/fit.png``,
    ``out/fitted.toml`` and every evaluation in ``out/evaluations/``.

    The cases run where ``placement`` (:class:`warpcontact.studies.batch.Placement`) says: in this process
    (the default), on a local cluster started once for the fit, or on the workers of a scheduler
    given by address. Unless ``quiet``, a line per optimiser iteration goes to ``log`` (stderr);
    warnings (a parameter the data do not fix, a coarse grid) are printed either way. A stop
    (KeyboardInterrupt) keeps every finished evaluation and writes fit.json with ``interrupted``;
    a rerun replays the optimiser from the cache. An evaluation that fails (a case error, a state
    not converged) ends the fit with ``report.error``. A trial point whose cases do not give an
    output (mu of a cell in tension) is a bad point: each such output counts
    ``BAD_POINT_RESIDUAL``, the log says so, and the optimiser steps back; a difference step
    that reaches one is taken backwards. The start and the optimum must give every output.
    ``batch``: cases per batched solve, as a sweep's (``sweep.batched_cases``: with the task
    "solve" or "gross-slip", the cases ``batch_solve.batchable`` admits of each evaluation, by default on CUDA in
    this process; 0: one case at a time).
    """
    from scipy.optimize import least_squares

    from .batch import Placement, session
    from ..records.results import atomic_write_json, output_error

    log = sys.stderr if log is None else log
    out = Path(out)
    t0 = time.perf_counter()
    report = FitReport()
    placement = placement or Placement(workers=1)
    if placement.scheduler is None and placement.device == "cpu":
        device = fit.base.solver.device if fit.overrides.get("device") is None else fit.overrides["device"]
        placement = Placement(None, placement.workers, device)
    rel_step = difference_step(fit)
    data = np.array([[r.measured[o] for o in fit.outputs] for r in fit.rows])
    weights = _weights(fit)
    start = np.array([p.to_unit(p.start) for p in fit.parameters])
    state = {"iteration": 0, "best": None, "trace": []}

    def say(text):
        if not quiet:
            print(text, file=log, flush=True)

    def residuals_of(y):
        return ((y - data) / weights).ravel()

    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise output_error(out, e, "create the folder") from None
    names = ", ".join(p.key for p in fit.parameters)
    say(f"fit: {len(fit.parameters)} parameter(s) ({names}) to {len(fit.rows)} row(s) x {len(fit.outputs)} "
        f"output(s) ({', '.join(fit.columns[o] for o in fit.outputs)}) of {Path(fit.data_file).name}, task "
        f"{fit.task}; difference step {rel_step:.3g} relative" + (" ([run] diff_step)" if fit.diff_step else
        f" (sqrt of the model's noise {model_noise(fit):.3g})"))

    pending = len(fit.rows) * max(1, len(fit.parameters))
    ev = None

    def fun(u):
        values = _values(fit, u)
        undefined = [] if state["trace"] else None  # the start must give every output
        y, = ev.model([values], undefined)
        r = residuals_of(y)
        if undefined:  # a bad point: the optimiser steps back from it
            r = np.where(np.isfinite(r), r, BAD_POINT_RESIDUAL)
            say(f"fit: a trial point is counted as bad (residual {BAD_POINT_RESIDUAL:g} for each output it does "
                f"not give): {undefined[0]}" + (f", and {len(undefined) - 1} more" if len(undefined) > 1 else ""))
        rms = float(np.sqrt(np.mean(r ** 2)))
        if not undefined and (state["best"] is None or rms < state["best"][1]):
            state["best"] = (values, rms)
        state["trace"].append({"parameters": values, "residual_rms": rms, "undefined": len(undefined or ())})
        return r

    def jac_at(u, announce=True):
        u = np.asarray(u, dtype=float)
        steps = _unit_steps(fit, u, rel_step)
        points = [_values(fit, u)]
        for j, h in enumerate(steps):
            v = u.copy()
            v[j] += h
            points.append(_values(fit, v))
        undefined = []
        ys = ev.model(points, undefined)  # one batch: every column's cases at once (the centre is cached)
        if not np.all(np.isfinite(ys[0])):
            raise EvaluationFailed(f"the fit's point {undefined[0]}")
        columns = list(zip(ys[1:], steps))
        for j, (y, h) in enumerate(columns):  # a step into undefined outputs: the difference backwards
            if not np.all(np.isfinite(y)):
                v = u.copy()
                v[j] -= h
                back, = ev.model([_values(fit, v)], undefined)
                columns[j] = (back, -h) if np.all(np.isfinite(back)) else (ys[0], h)  # neither: a zero column
                say(f"fit: the difference step of fit.{fit.parameters[j].key} reaches a point that does not give "
                    f"every output ({undefined[-1]}): " + ("a backward difference" if np.all(np.isfinite(back))
                                                         else "its column is left zero this iteration"))
        r0 = residuals_of(ys[0])
        J = np.column_stack([(residuals_of(y) - r0) / h for y, h in columns]) if len(steps) \
            else np.zeros((r0.size, 0))
        if announce:
            state["iteration"] += 1
            rms = float(np.sqrt(np.mean(r0 ** 2)))
            say(f"fit [iteration {state['iteration']}] {_show(points[0])}: residual rms {rms:.4g} "
                f"({ev.computed} case(s) computed, {ev.cached} cached, {time.perf_counter() - t0:.1f} s)")
        return J

    result = None
    try:
        with session(placement, pending) as (where, where_text):
            ev = _Evaluator(fit, out, where, where_text, batch)
            # the trust-region subproblem in a 2-D subspace (lsmr), the variables scaled by the Jacobian's
            # columns: where the data cannot see a parameter (a zero column), 'exact' shrank the trust
            # region at nearly every step (two-parameter test: 24 evaluations instead of 5) and x_scale=1
            # let that parameter drift; with these it stays at its start. One parameter: 'exact' (lsmr's
            # subspace is then 1-D, and scipy's 2-D subproblem fails on it once a step is rejected)
            ls = least_squares(fun, start, jac=jac_at, bounds=(0.0, 1.0), method="trf", x_scale="jac",
                               tr_solver="exact" if len(fit.parameters) == 1 else "lsmr",
                               xtol=max(model_noise(fit), XTOL_MIN), ftol=FTOL, gtol=GTOL,
                               max_nfev=fit.max_evaluations)
            u = ls.x
            J = jac_at(u, announce=False)  # at the optimum (cached when the optimiser made it there)
            values = _values(fit, u)
            start_values = _values(fit, start)
            y_fit, y_start = ev.model([values, start_values])
            recs, = ev.outcomes([values])  # found done: the cases at the optimum, for their warnings
        case_warnings = list(dict.fromkeys(f"{Path(fit.data_file).name} line {row.line}, at the fitted values: {m}"
                                           for row, rec in zip(fit.rows, recs) for m in rec.get("warnings", [])))
        result = _result(fit, ls, u, J, values, y_fit, y_start, data, weights, residuals_of, rel_step, report,
                         case_warnings)
        report.converged = bool(ls.status > 0)
        report.message = str(ls.message)
    except EvaluationFailed as e:
        report.error = str(e)
        report.message = f"stopped: {e}"
    except KeyboardInterrupt as e:
        report.interrupted = True
        report.stop_signal = interrupts.signal_name(interrupts.stop_signal(e))
        report.message = f"interrupted ({report.stop_signal})"
    except OutputError as e:
        report.write_error = e
        report.message = f"stopped: {e}"
    report.elapsed_s = time.perf_counter() - t0
    report.evaluations = {"count": ev.requested if ev else 0, "cached": ev.cached if ev else 0,
                          "computed": ev.computed if ev else 0,
                          "residual_evaluations": len(state["trace"]), "iterations": state["iteration"],
                          "batched": ev.batched if ev else 0,
                          "where": (ev.where or ev.batches[-1].where) if ev and ev.batches else
                          ("this process, batched solves" if ev and ev.batched else None)}
    if result is None:  # stopped: fit.json says so, with the best point met
        result = {"complete": False, "converged": False, "interrupted": report.interrupted,
                  "stop_signal": report.stop_signal, "error": report.error, "message": report.message,
                  "best_so_far": None if state["best"] is None else
                  {"parameters": state["best"][0], "residual_rms": state["best"][1]}}
    result["evaluations"] = report.evaluations
    result["elapsed_s"] = report.elapsed_s
    result["software"] = {"warpcontact": __version__}
    report.result = result
    if report.write_error is None:
        with interrupts.deferred(raise_after=False):
            try:
                atomic_write_json(out / "fit.json", result)
                if result.get("complete"):
                    _write_outputs(fit, out, result)
            except OutputError as e:
                report.write_error = e
    for w in report.warnings:
        print(f"warpcontact: warning: {w}", file=log, flush=True)
    return report


def _result(fit, ls, u, J, values, y_fit, y_start, data, weights, residuals_of, rel_step, report,
            case_warnings=()) -> dict:
    """fit.json's dict at the optimum; the parameter warnings, then ``case_warnings`` (the solver's
    warnings of the cases at the optimum), go to ``report``."""
    r = residuals_of(y_fit)
    cov_u, s2, singular = covariance(J, r, fit.rescale_stderr)
    scale = np.array([p.d_value_d_unit(values[p.key]) for p in fit.parameters])
    with np.errstate(invalid="ignore", over="ignore"):
        cov = cov_u * np.outer(scale, scale)
    cov = np.where(np.isnan(cov), math.inf, cov)
    active = getattr(ls, "active_mask", np.zeros(len(fit.parameters)))
    params = {}
    for j, p in enumerate(fit.parameters):
        v = values[p.key]
        var = cov[j, j]
        stderr = math.sqrt(var) if math.isfinite(var) and var >= 0 else math.inf
        at = "min" if (active[j] < 0 or u[j] <= 0.0) else ("max" if (active[j] > 0 or u[j] >= 1.0) else None)
        rel = stderr / abs(v) if v != 0 else math.inf
        entry = {"value": v, "stderr": stderr, "relative_stderr": rel, "at_bound": at, "start": p.start,
                 "min": p.min, "max": p.max, "scale": p.scale, "identified": True}
        if not math.isfinite(stderr) or rel > UNIDENTIFIED_REL_STDERR:
            entry["identified"] = False
            why = ("the outputs do not change with it over the difference step (a singular J^T J)"
                   if not math.isfinite(stderr) else f"its relative stderr is {rel:.3g} > {UNIDENTIFIED_REL_STDERR:g}")
            report.warnings.append(f"fit.{p.key}: the data do not fix this parameter ({why}); its value "
                                   f"{short_float(v)} is where the optimiser stopped, not a measurement")
        if at is not None:
            report.warnings.append(f"fit.{p.key}: the fit ended on its {at} = {short_float(getattr(p, at))}; "
                                   "widen the bounds if the data allow it (the stderr is that of the linearised "
                                   "model there)")
        params[p.key] = entry
    dof = len(r) - len(fit.parameters)
    chi2 = float(r @ r) / dof if dof > 0 else None
    if fit.weighted and not fit.rescale_stderr and chi2 is not None and chi2 > 1.0 + 3.0 * math.sqrt(2.0 / dof):
        # 3 standard deviations of the reduced chi-square of a model that fits (mean 1, variance 2 / dof)
        report.warnings.append(f"reduced chi-square {chi2:.3g} with {dof} degree(s) of freedom: the model misses the "
                               "data by more than their sigma, and the stderr assume it does not ([run] "
                               f"rescale_stderr = true scales them by sqrt({chi2:.3g}))")
    if not fit.weighted and len(r) <= len(fit.parameters):
        report.warnings.append("as many measured values as parameters and no sigma columns: no residual variance "
                               "to scale the covariance by, so every stderr is inf; give sigma_<output> columns")
    report.warnings.extend(case_warnings)
    report.parameters = params
    identified = [params[p.key]["identified"] for p in fit.parameters]
    report.correlation = [[c if identified[i] and identified[j] else None for j, c in enumerate(row)]
                          for i, row in enumerate(_correlation(cov))]  # none where the data do not fix a parameter
    report.residual_rms = float(np.sqrt(np.mean(r ** 2)))
    outputs = {}
    for j, o in enumerate(fit.outputs):
        dev = y_fit[:, j] - data[:, j]
        rel = dev / np.where(data[:, j] != 0, data[:, j], 1.0)
        outputs[fit.columns[o]] = {"rms": float(np.sqrt(np.mean(dev ** 2))),
                                   "relative_rms": float(np.sqrt(np.mean(rel ** 2)))}

    def by_output(a, i):
        return {fit.columns[o]: float(a[i, j]) for j, o in enumerate(fit.outputs)}

    r2 = r.reshape(y_fit.shape)
    rows = [{"line": row.line, "conditions": row.conditions, "measured": by_output(data, i),
             "sigma": None if row.sigma is None else {fit.columns[o]: row.sigma[o] for o in fit.outputs},
             "model": by_output(y_fit, i), "model_at_start": by_output(y_start, i), "residual": by_output(r2, i)}
            for i, row in enumerate(fit.rows)]
    return {
        "complete": True,
        "converged": bool(ls.status > 0),
        "message": str(ls.message),
        "task": fit.task,
        **({"rel_tol": fit.rel_tol} if fit.task == "gross-slip" else {}),
        "parameters": params,
        "correlation": {"keys": [p.key for p in fit.parameters], "matrix": report.correlation},
        "residual_rms": report.residual_rms,
        "weights": "sigma columns (1 / sigma^2)" if fit.weighted else "1 / (RMS of each output's data)^2",
        "stderr_scaled_by_residual_variance": bool(fit.rescale_stderr),
        "reduced_chi_square": chi2,
        "difference_step": rel_step,
        "model_noise": model_noise(fit),
        "singular_values": singular,
        "warnings": list(report.warnings),
        "outputs": outputs,
        "rows": rows,
        "data_file": fit.data_file,
        "fit_file": fit.source,
    }

__all__ = [
    "EvaluationFailed",
    "Fit",
    "FitReport",
    "OUTPUTS",
    "Parameter",
    "Row",
    "case_toml",
    "covariance",
    "difference_step",
    "evaluation_hash",
    "fit_from_dict",
    "fit_figure",
    "fitted_case",
    "load_fit",
    "model_noise",
    "read_data",
    "run_fit",
]

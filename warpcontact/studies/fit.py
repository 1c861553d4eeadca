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

    from .fit import load_fit, run_fit

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

import copy
import csv
import hashlib
import json
import math
import numbers
import sys
import time
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Mapping

import numpy as np

from .. import interrupts
from .._version import __version__
from ..records.case import Case, case_from_dict, read_toml, substitute
from ..errors import InputError, OutputError
from .sweep import (
    CASE_SCHEMA,
    DOTTED_KEYS,
    SweepCase,
    base_case,
    check_case_key,
    check_task,
    flatten,
    jsonable,
    near,
    run_scheduler,
    run_settings,
    short_float,
)

#: Tables of a fit file.
FIT_TABLES = ("base", "data", "fit", "run")
#: Keys of one parameter's entry in ``[fit]``.
PARAMETER_KEYS = ("min", "max", "start", "scale")
SCALES = ("linear", "log")
#: Keys of ``[data]``.
DATA_KEYS = ("file",)
#: Keys of ``[run]``.
RUN_KEYS = ("task", "rel_tol", "scheduler", "max_evaluations", "rescale_stderr", "diff_step")
#: Bisection bracket of delta_x_max in a fit (relative). Finer than a sweep's 0.01: the difference
#: step must rise above this noise (see :func:`difference_step`), and at 0.01 it would be 10 % of
#: the parameter; 0.001 costs about 3 bisection states more per case (21 states instead of 18 at
#: n = 32, 0.95 s instead of 0.76 s on 2 CPU cores).
DEFAULT_REL_TOL = 1e-3
#: The residual of each output a trial point does not give (mu of a cell pulled into tension):
#: in units of the weights, far above any point that gives them, so that the optimiser rejects
#: the step and shrinks its trust region.
BAD_POINT_RESIDUAL = 1e6
#: Residual evaluations the optimiser may make (least_squares' max_nfev; Jacobians not counted).
DEFAULT_MAX_EVALUATIONS = 30
#: The outputs a data column may name, per task: the scalar keys of the task's result, flattened
#: as in the sweep's CSV (nested keys joined with '_': force_z).
OUTPUTS = {
    "gross-slip": ("mu", "delta_x_max", "delta_x_gross", "mu_elastic", "force_x", "force_y", "force_z",
                   "force_elastic_x", "force_elastic_y", "force_elastic_z", "stick_area", "contact_area",
                   "yield_margin"),
    "solve": ("force_x", "force_y", "force_z", "force_elastic_x", "force_elastic_y", "force_elastic_z",
              "contact_area", "contact_radius", "max_pressure", "stick_area", "adhesive_area", "yield_margin"),
    "pull-off": ("pull_off_force", "pull_off_delta_z", "work_of_adhesion", "tabor_parameter"),
}
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
# The fit file.


@dataclass(frozen=True)
class Parameter:
    """One fitted case key.

    Attributes:
        key: dotted case key (``friction.k_tau``).
        min, max: bounds (in the key's unit, SI).
        start: the optimiser's first value.
        scale: "linear" or "log": the optimiser works in (value - min) / (max - min), or in
            log(value / min) / log(max / min).
    """

    key: str
    min: float
    max: float
    start: float
    scale: str = "linear"

    @property
    def name(self) -> str:
        """The key's last part (``k_tau``), for progress lines."""
        return self.key.split(".", 1)[1]

    def to_unit(self, value: float) -> float:
        if self.scale == "log":
            return math.log(value / self.min) / math.log(self.max / self.min)
        return (value - self.min) / (self.max - self.min)

    def from_unit(self, u: float) -> float:
        u = min(max(float(u), 0.0), 1.0)
        if u == 0.0:
            return self.min
        if u == 1.0:
            return self.max
        if self.scale == "log":
            return float(self.min * math.exp(u * math.log(self.max / self.min)))
        return float(self.min + u * (self.max - self.min))

    def d_value_d_unit(self, value: float) -> float:
        """d value / d unit parameter at ``value``."""
        if self.scale == "log":
            return value * math.log(self.max / self.min)
        return self.max - self.min


@dataclass(frozen=True)
class Row:
    """One measurement: its CSV line, the case keys it sets, the measured outputs and their errors
    (None without sigma columns)."""

    line: int
    conditions: dict
    measured: dict
    sigma: dict | None


@dataclass(frozen=True)
class Fit:
    """A validated fit.

    Attributes:
        base: the base case.
        parameters: the fitted keys, in file order.
        rows: the measurements, in CSV order.
        outputs: measured outputs (flattened names, ``force_z``), in CSV order.
        columns: how the CSV names each output (``force.z`` or ``force_z``), by output.
        conditions: the case keys the CSV sets (its condition columns).
        task: "gross-slip", "solve" or "pull-off".
        rel_tol: bisection bracket of delta_x_max (gross-slip).
        weighted: the CSV has sigma columns (weights 1 / sigma^2; else each output is scaled by the
            RMS of its measured values).
        rescale_stderr: scale the covariance by the reduced chi-square (default: only without sigma
            columns).
        max_evaluations: residual evaluations the optimiser may make.
        diff_step: ``[run] diff_step``, the relative difference step, or None (chosen from the
            model's noise: :func:`difference_step`).
        data_file: the CSV's path.
        source: the fit file, or None.
        scheduler: ``[run] scheduler`` (a dask scheduler's address) or None.
        overrides: device, dtype, fft given on the command line (None: the case's).
    """

    base: Case
    parameters: tuple
    rows: tuple
    outputs: tuple
    columns: dict
    conditions: tuple
    task: str
    rel_tol: float
    weighted: bool
    rescale_stderr: bool
    max_evaluations: int
    diff_step: float | None
    data_file: str
    source: str | None = None
    scheduler: str | None = None
    overrides: dict = field(default_factory=dict)

    @property
    def base_dict(self) -> dict:
        """The base case as a dict (a defaulted tol left out, so it follows each case's dtype, as
        a sweep does)."""
        d = self.base.to_dict()
        if self.base.solver.tol_default:
            d["solver"].pop("tol", None)
        return d


def _real(where: str, v) -> float:
    if isinstance(v, bool) or not isinstance(v, numbers.Real) or not math.isfinite(float(v)):
        raise InputError(where, f"must be a finite number, got {v!r}")
    return float(v)


def _fit_entries(table: Mapping) -> list:
    """(dotted key, spec) pairs of the [fit] table; TOML's unquoted dotted keys (friction.k_tau =
    {...}) arrive as nested tables and are flattened back."""
    out = []
    for k, v in table.items():
        if isinstance(v, Mapping) and v and not any(s in v for s in PARAMETER_KEYS) \
                and all(isinstance(w, Mapping) for w in v.values()):
            out.extend((f"{k}.{sub}", w) for sub, w in v.items())
        else:
            out.append((str(k), v))
    return out


def _parameter(key: str, spec, base_dict: dict) -> Parameter:
    where = f"fit.{key}"
    check_case_key(key, where)
    table, name = key.split(".", 1)
    if table not in base_dict:
        raise InputError(where, f"the base case has no [{table}] table: a fitted key must be in the base case")
    if name not in base_dict[table]:
        raise InputError(where, f"the base case's [{table}] has no {name} (it has {', '.join(base_dict[table])}): "
                                "a fitted key must be in the base case")
    current = base_dict[table][name]
    if isinstance(current, bool) or not isinstance(current, numbers.Real):
        raise InputError(where, f"is not a number in the base case ({current!r}): only real-valued keys can be fitted")
    if isinstance(current, numbers.Integral):
        raise InputError(where, f"is an integer setting (base: {current!r}): only real-valued keys can be fitted")
    if not isinstance(spec, Mapping):
        raise InputError(where, "must be a table such as { min = 0.3, max = 0.97, start = 0.6 } "
                                f"(scale = \"log\" optional), got {spec!r}")
    for k in spec:
        if k not in PARAMETER_KEYS:
            raise InputError(f"{where}.{k}", f"unknown key; {near(k, PARAMETER_KEYS)}expected one of "
                                             f"{', '.join(PARAMETER_KEYS)}")
    for k in ("min", "max"):
        if k not in spec:
            raise InputError(f"{where}.{k}", "is required (the bound of the parameter)")
    lo, hi = _real(f"{where}.min", spec["min"]), _real(f"{where}.max", spec["max"])
    if not lo < hi:
        raise InputError(f"{where}.max", f"must exceed min = {lo!r}, got {hi!r}")
    scale = spec.get("scale", "linear")
    if scale not in SCALES:
        raise InputError(f"{where}.scale", f"must be one of {', '.join(repr(s) for s in SCALES)}, got {scale!r}")
    if scale == "log" and not lo > 0:
        raise InputError(f"{where}.min", f"must be positive for scale = \"log\", got {lo!r}")
    start = _real(f"{where}.start", spec["start"]) if "start" in spec else float(current)
    if not lo <= start <= hi:
        what = "start" if "start" in spec else "start (the base case's value, as no start is given)"
        raise InputError(f"{where}.start", f"{what} = {start!r} lies outside [min, max] = [{lo!r}, {hi!r}]")
    return Parameter(key=key, min=lo, max=hi, start=start, scale=scale)


def _run_settings(data: Mapping, base: Case) -> dict:
    run, task, rel_tol = run_settings(data, base, RUN_KEYS, DEFAULT_REL_TOL)  # task, rel_tol as in a sweep
    n = run.get("max_evaluations", DEFAULT_MAX_EVALUATIONS)
    if isinstance(n, bool) or not isinstance(n, numbers.Integral) or n < 1:
        raise InputError("run.max_evaluations", f"must be an integer >= 1, got {n!r}")
    rescale = run.get("rescale_stderr")
    if rescale is not None and not isinstance(rescale, bool):
        raise InputError("run.rescale_stderr", f"must be true or false, got {rescale!r}")
    step = run.get("diff_step")
    if step is not None and (isinstance(step, bool) or not isinstance(step, numbers.Real)
                             or not 0.0 < float(step) <= 0.5):
        raise InputError("run.diff_step", f"must be a number in (0, 0.5] (relative difference step), got {step!r}")
    return {"task": task, "rel_tol": rel_tol, "max_evaluations": int(n), "rescale_stderr": rescale,
            "diff_step": None if step is None else float(step), "scheduler": run_scheduler(data)}


def _cell_value(text: str):
    """A condition cell: an integer, a number, true/false or the text."""
    t = text.strip()
    for conv in (int, float):
        try:
            return conv(t)
        except ValueError:
            pass
    if t.lower() in ("true", "false"):
        return t.lower() == "true"
    return t


def _number_cell(where: str, column: str, text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise InputError(where, f"column {column}: {text.strip()!r} is not a number") from None
    if not math.isfinite(v):
        raise InputError(where, f"column {column}: {text.strip()!r} is not a finite number")
    return v


def read_data(path: Path, task: str, name: str | None = None) -> tuple:
    """Read and check the CSV of measurements.

    Returns (conditions, outputs, columns, rows, weighted): the condition keys, the outputs
    (flattened names), how the CSV names each output, the :class:`Row` s, whether sigma columns
    are given. InputError names ``<file> line <N>`` (the header is line 1) or ``data.file``.
    """
    name = name or path.name
    try:
        text = path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise InputError("data.file", f"{path}: no such file") from None
    except IsADirectoryError:
        raise InputError("data.file", f"{path} is a directory, not a CSV file") from None
    except UnicodeDecodeError as e:
        raise InputError("data.file", f"{path} is not UTF-8 text ({e.reason} at byte {e.start})") from None
    except OSError as e:
        raise InputError("data.file", f"{path} cannot be read: {e.strerror or e}") from None
    reader = csv.reader(text.splitlines())
    header = None
    records = []
    for cells in reader:
        if not cells or all(not c.strip() for c in cells) or cells[0].lstrip().startswith("#"):
            continue  # blank lines and comment lines
        if header is None:
            header = (reader.line_num, [c.strip() for c in cells])
        else:
            records.append((reader.line_num, cells))
    if header is None:
        raise InputError("data.file", f"{path} is empty: it needs a header line and one row per measurement")
    hline, names = header
    where = f"{name} line {hline}"
    for i, c in enumerate(names):
        if not c:
            raise InputError(where, f"column {i + 1} has no name")
        if names.index(c) != i:
            raise InputError(where, f"column {c!r} is named twice")
    outputs_allowed = OUTPUTS[task]
    conditions, outputs, sigmas, columns = [], [], {}, {}
    for c in names:
        if c.startswith("sigma_"):
            sigmas[c[len("sigma_"):].replace(".", "_")] = c
            continue
        flat = c.replace(".", "_")
        if flat in outputs_allowed:
            if flat in columns:
                raise InputError(where, f"columns {columns[flat]!r} and {c!r} name the same output")
            outputs.append(flat)
            columns[flat] = c
            continue
        if c in DOTTED_KEYS:
            conditions.append(c)
            continue
        if "." in c and c.split(".", 1)[0] in CASE_SCHEMA:
            table = c.split(".", 1)[0]
            raise InputError(where, f"column {c!r}: unknown case key; {near(c, DOTTED_KEYS)}[{table}] has "
                                    f"{', '.join(CASE_SCHEMA[table])}")
        raise InputError(where, f"column {c!r} is neither a case key (table.key) nor an output of task {task!r}; "
                                f"{near(flat, outputs_allowed)}its outputs are {', '.join(outputs_allowed)}")
    for out, col in sigmas.items():
        if out not in columns:
            raise InputError(where, f"column {col!r}: no measured column {out!r} to weigh")
    if not outputs:
        raise InputError(where, f"no measured output among the columns; task {task!r} gives "
                                f"{', '.join(outputs_allowed)}")
    weighted = bool(sigmas)
    if weighted and set(sigmas) != set(outputs):
        missing = [columns[o] for o in outputs if o not in sigmas]
        raise InputError(where, f"sigma columns are given for some outputs but not for {', '.join(missing)}: "
                                "give sigma_<output> for every output or for none")
    if not records:
        raise InputError(f"{name} line {hline}", "holds a header but no measurement: give one row per measurement")
    rows = []
    index = {c: i for i, c in enumerate(names)}
    for line, cells in records:
        where = f"{name} line {line}"
        if len(cells) != len(names):
            raise InputError(where, f"has {len(cells)} cells, the header {len(names)}")
        for c, i in index.items():
            if not cells[i].strip():
                raise InputError(where, f"column {c}: empty cell (every row needs every column)")
        measured = {o: _number_cell(where, columns[o], cells[index[columns[o]]]) for o in outputs}
        sigma = None
        if weighted:
            sigma = {}
            for o in outputs:
                s = _number_cell(where, sigmas[o], cells[index[sigmas[o]]])
                if not s > 0:
                    raise InputError(where, f"column {sigmas[o]}: must be positive (a measurement error), got {s!r}")
                sigma[o] = s
        rows.append(Row(line=line, conditions={c: _cell_value(cells[index[c]]) for c in conditions},
                        measured=measured, sigma=sigma))
    if not weighted:
        for o in outputs:
            if not any(r.measured[o] != 0 for r in rows):
                raise InputError(f"{name} line {hline}", f"column {columns[o]}: every value is 0, so it sets no scale "
                                                         f"for its residuals: give sigma_{columns[o]} columns")
    return tuple(conditions), tuple(outputs), columns, tuple(rows), weighted


def _row_case(fit_base: dict, row: Row, values: Mapping, overrides: Mapping, data_name: str) -> Case:
    """The case of one data row at the parameter ``values``: the sweep's build (the base's dict
    with the row's conditions and the values put in, through case_from_dict)."""
    params = {**row.conditions, **{k: float(v) for k, v in values.items()}}
    try:
        case = case_from_dict(substitute(fit_base, params))
        return case.with_overrides(**overrides)
    except InputError as e:
        if e.key in row.conditions:
            raise InputError(f"{data_name} line {row.line}", f"column {e}") from None
        key = f"fit.{e.key}" if e.key in values else e.key
        raise InputError(key, f"{e.problem} (the case of {data_name} line {row.line} at {_show(values)})") from None


def fit_from_dict(data: Mapping, source: str | PathLike | None = None, device: str | None = None,
                  dtype: str | None = None, fft: str | None = None) -> Fit:
    """Validate a parsed fit file, read its CSV and check every row's case at the start, at each
    parameter's bounds (the others at their start) and what the task needs of it.

    ``source`` (the fit file's path) anchors a relative ``base`` and ``[data] file``; ``device``,
    ``dtype``, ``fft`` override the solver settings of every case.

    Raises:
        InputError: naming the key (``fit.friction.k_tau.min``, ``run.task``, ``data.file``) or the
            CSV line (``data.csv line 3``) of the first problem.
    """
    if not isinstance(data, Mapping):
        raise InputError("fit file", f"must hold tables [base], [data], [fit], [run], got {type(data).__name__}")
    for k in data:
        if k not in FIT_TABLES:
            raise InputError(str(k), f"unknown table; {near(k, FIT_TABLES)}a fit file has {', '.join(FIT_TABLES)}")
    src = Path(source) if source is not None else None
    base = base_case(data, src)
    run = _run_settings(data, base)
    task = run["task"]

    d = data.get("data")
    if not isinstance(d, Mapping):
        raise InputError("data", 'is required: a [data] table with file = "measurements.csv" '
                                 "(relative to the fit file)" if d is None else f"must be a table, got {d!r}")
    for k in d:
        if k not in DATA_KEYS:
            raise InputError(f"data.{k}", f"unknown key; expected {', '.join(DATA_KEYS)}")
    if "file" not in d or not isinstance(d["file"], str) or not d["file"].strip():
        raise InputError("data.file", f"must name the CSV of measurements, got {d.get('file')!r}")
    data_path = Path(d["file"])
    if not data_path.is_absolute() and src is not None:
        data_path = src.parent / data_path
    conditions, outputs, columns, rows, weighted = read_data(data_path, task)

    table = data.get("fit")
    if not isinstance(table, Mapping) or not table:
        raise InputError("fit", 'is required: a [fit] table of dotted case keys and their bounds, e.g. '
                                '"friction.k_tau" = { min = 0.3, max = 0.97, start = 0.6 }')
    base_dict = base.to_dict()
    if base.solver.tol_default:
        base_dict["solver"].pop("tol", None)
    parameters = []
    for key, spec in _fit_entries(table):
        p = _parameter(key, spec, base.to_dict())
        if key in conditions:
            raise InputError(f"fit.{key}", f"is also a column of {data_path.name}: a key is either fitted or "
                                           "set by the data")
        parameters.append(p)
    n_measured = len(rows) * len(outputs)
    if n_measured < len(parameters):
        raise InputError("fit", f"{len(parameters)} parameters cannot be fixed by {n_measured} measured value(s) "
                                f"({len(rows)} row(s) x {len(outputs)} output(s))")
    overrides = {"device": device, "dtype": dtype, "fft": fft}
    for name, v in overrides.items():
        if v is not None and (f"solver.{name}" in conditions or any(p.key == f"solver.{name}" for p in parameters)):
            raise InputError(f"--{name}", f"solver.{name} is set by the fit file, so it cannot be overridden")

    # every row's case at the start, and at each parameter's bounds (the others at their start)
    start = {p.key: p.start for p in parameters}
    points = [start] + [{**start, p.key: b} for p in parameters for b in (p.min, p.max)]
    for row in rows:
        for values in points:
            case = _row_case(base_dict, row, values, overrides, data_path.name)
            if values is start:
                label = f"{data_path.name} line {row.line}"
                check_task(SweepCase(0, {**row.conditions, **values}, "", label, case), task)
    return Fit(base=base, parameters=tuple(parameters), rows=rows, outputs=outputs, columns=columns,
               conditions=conditions, task=task, rel_tol=run["rel_tol"], weighted=weighted,
               rescale_stderr=run["rescale_stderr"] if run["rescale_stderr"] is not None else not weighted,
               max_evaluations=run["max_evaluations"], diff_step=run["diff_step"], data_file=str(data_path),
               source=str(src) if src is not None else None, scheduler=run["scheduler"], overrides=overrides)


def load_fit(path: str | PathLike, device: str | None = None, dtype: str | None = None,
             fft: str | None = None) -> Fit:
    """Read, parse and validate a fit file (TOML) and its CSV; see :func:`fit_from_dict`.

    Raises:
        InputError: key = the file path when it cannot be read or parsed, else as fit_from_dict.
    """
    data = read_toml(path, "fit file")
    return fit_from_dict(data, source=path, device=device, dtype=dtype, fft=fft)


# ---------------------------------------------------------------------------------------------
# The numerics: noise, difference step, covariance.


def model_noise(fit: Fit) -> float:
    """The relative noise of the model's outputs [-], what the difference step must rise above.

    gross-slip: delta_x_max is the lower end of a bisection bracket of relative width rel_tol, and
    mu = F_x / F_z is read at that end, so both are known to rel_tol: a parameter change that moves
    the bracket's last decision shifts them by up to rel_tol (between such decisions they are
    smooth: at n = 32, k_tau 0.68 to 0.72, mu / mu_b varied by 2e-4 with no jump). solve and
    pull-off: the iterative solvers stop at the relative residual ``solver.tol``."""
    start = {p.key: p.start for p in fit.parameters}
    case = _row_case(fit.base_dict, fit.rows[0], start, fit.overrides, Path(fit.data_file).name)
    tol = float(case.solver.tol)  # every row's: the tol follows the dtype, which a row cannot set apart
    return max(fit.rel_tol, tol) if fit.task == "gross-slip" else tol


def difference_step(fit: Fit) -> float:
    """The forward-difference step, relative to each parameter (linear scale: of its value; log
    scale: of its logarithm) [-]: ``[run] diff_step``, else sqrt(model_noise).

    A forward difference of outputs carrying relative noise eps over a relative step h errs by
    about 2 eps / h (the noise) + h / 2 (the curvature over one unit of the parameter); the sum is
    least at h ~ sqrt(eps). A step much smaller than that divides the noise by a small number and
    gives a garbage Jacobian; at eps = rel_tol = 1e-3 the step is 3.2 % (k_tau = 0.7: 0.022)."""
    if fit.diff_step is not None:
        return fit.diff_step
    return math.sqrt(model_noise(fit))


def _unit_steps(fit: Fit, u: np.ndarray, rel_step: float) -> np.ndarray:
    """Per parameter, the signed step in unit parameters at ``u``: forward, or backward where the
    forward step would leave the bounds."""
    steps = []
    for p, ui in zip(fit.parameters, u):
        value = p.from_unit(ui)
        if p.scale == "log":
            h = rel_step / math.log(p.max / p.min)
        else:
            typical = max(abs(value), 0.1 * (p.max - p.min))  # a parameter near 0: a step of the span
            h = rel_step * typical / (p.max - p.min)
        h = min(h, 0.5)
        steps.append(h if ui + h <= 1.0 else -h)
    return np.array(steps)


def covariance(J: np.ndarray, r: np.ndarray, rescale: bool) -> tuple[np.ndarray, float, list]:
    """The parameters' covariance from the weighted Jacobian ``J`` (dr/dparameter, m x p) and the
    weighted residuals ``r`` at the optimum: (J^T J)^-1, times the reduced chi-square
    s^2 = r.r / (m - p) where ``rescale``. Directions J cannot see (singular values under
    max(m, p) * machine epsilon * the largest) give infinite variance to every parameter with a
    share in them. Returns (covariance, s^2 used (1 without rescaling), the singular values)."""
    m, p = J.shape
    s2 = 1.0
    if rescale:
        s2 = float(r @ r) / (m - p) if m > p else math.inf
    if p == 0:
        return np.zeros((0, 0)), s2, []
    U, S, Vt = np.linalg.svd(J, full_matrices=False)
    cut = max(m, p) * np.finfo(float).eps * (S[0] if S.size else 0.0)
    keep = S > cut
    V = Vt.T
    cov = (V[:, keep] / S[keep] ** 2) @ V[:, keep].T * s2
    blind = V[:, ~keep]
    if blind.size:
        share = np.sqrt((blind ** 2).sum(axis=1))
        for j in np.nonzero(share > 1e-6)[0]:
            cov[j, :] = cov[:, j] = math.inf
    if not math.isfinite(s2):
        cov[:] = math.inf
    return cov, s2, [float(s) for s in S]


def _correlation(cov: np.ndarray) -> list:
    p = cov.shape[0]
    out = []
    for i in range(p):
        row = []
        for j in range(p):
            c, a, b = cov[i, j], cov[i, i], cov[j, j]
            ok = all(math.isfinite(x) for x in (c, a, b)) and a > 0 and b > 0
            row.append(float(c / math.sqrt(a * b)) if ok else None)
        out.append(row)
    return out


# ---------------------------------------------------------------------------------------------
# Evaluations: cases on the batch engine, cached on disk.


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

    def __init__(self, fit: Fit, out: Path, placement, where: str | None = None):
        self.fit, self.out, self.placement = fit, out, placement
        self.where = where  # the words for a local cluster of the fit's own; else each batch's
        self.folder = out / "evaluations"
        self.memory: dict = {}  # hash -> outcome
        self.requested = self.computed = self.cached = 0
        self.compute_s = 0.0
        self.data_name = Path(fit.data_file).name
        self.batches = []

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
        order; the missing ones computed together, each written as it finishes."""
        from .batch import Task, model_key, models_to_keep, run_tasks
        from ..records.results import atomic_write_json
        from .sweep import run_case

        fit = self.fit
        plan, tasks, pending = [], [], {}
        cases = [[_row_case(fit.base_dict, row, values, fit.overrides, self.data_name) for row in fit.rows]
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

            if isinstance(e, LostTask):
                return on_result(task, {"error": str(e), "warnings": [], "elapsed_s": 0.0})
            raise e

        if tasks:
            t0 = time.perf_counter()
            try:
                self.folder.mkdir(parents=True, exist_ok=True)
            except OSError as e:
                from ..records.results import output_error

                raise output_error(self.folder, e, "create the folder") from None
            stats = run_tasks(tasks, on_result, self.placement, on_error=on_error, keep_models=True)
            self.batches.append(stats)
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


def _show(values: Mapping) -> str:
    """``k_tau=0.7,sigma_max=1e+06``: parameter values by their keys' last part, 6 digits."""
    return ",".join(f"{k.split('.', 1)[1]}={float(v):.6g}" for k, v in values.items())


def _values(fit: Fit, u) -> dict:
    return {p.key: p.from_unit(ui) for p, ui in zip(fit.parameters, u)}


def _fmt(v) -> str:
    return "inf" if v is None or not math.isfinite(v) else f"{v:.4g}"


def run_fit(fit: Fit, out: str | PathLike, quiet: bool = False, log=None, placement=None) -> FitReport:
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
            ev = _Evaluator(fit, out, where, where_text)
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
                          "where": (ev.where or ev.batches[-1].where) if ev and ev.batches else None}
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


# ---------------------------------------------------------------------------------------------
# The fitted case file and the plot.


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, numbers.Integral):
        return str(int(v))
    if isinstance(v, numbers.Real):
        v = float(v)
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        text = short_float(v)
        return text if any(c in text for c in ".en") else text + ".0"
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise TypeError(f"no TOML form for {v!r}")


def case_toml(case: dict, header: str = "") -> str:
    """A case dict (``Case.to_dict()``: tables of scalars and arrays) as a TOML case file."""
    lines = [header.rstrip("\n")] if header else []
    for table, keys in case.items():
        if lines:
            lines.append("")
        lines.append(f"[{table}]")
        for k, v in keys.items():
            if v is not None:
                lines.append(f"{k} = {_toml_value(v)}")
    return "\n".join(lines) + "\n"


def fitted_case(fit: Fit, values: Mapping) -> dict:
    """The base case's dict with the fitted values put in (the base's conditions, not a row's)."""
    d = copy.deepcopy(fit.base.to_dict())
    for key, v in values.items():
        table, name = key.split(".", 1)
        d[table][name] = float(v)
    return d


def _write_outputs(fit: Fit, out: Path, result: dict) -> None:
    import io

    from ..records.results import atomic_write_bytes

    values = {k: e["value"] for k, e in result["parameters"].items()}
    d = fitted_case(fit, values)
    case_from_dict(d)  # the fitted case passes the case checks (the bounds were checked on every row)
    lines = [f"# The base case of {fit.source or 'a fit'} with the fitted values (warpcontact fit; fit.json):"]
    for k, e in result["parameters"].items():
        lines.append(f"#   {k} = {short_float(e['value'])} +- {_fmt(e['stderr'])}"
                     + ("" if e["identified"] else "  (NOT fixed by the data)"))
    lines.append(f"# residual rms {result['residual_rms']:.4g}; converged: {str(result['converged']).lower()}")
    atomic_write_bytes(out / "fitted.toml", case_toml(d, "\n".join(lines)).encode())
    buf = io.BytesIO()
    fit_figure(fit, result).savefig(buf, format="png", dpi=110)
    atomic_write_bytes(out / "fit.png", buf.getvalue())


def fit_figure(fit: Fit, result: dict):
    """Data against the fitted model, one panel per output: against the first condition key the
    rows vary, else against the CSV line. Data with error bars (sigma columns), the model at the fit
    and at the start."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    rows = result["rows"]
    varying = [k for k in fit.conditions if len({json.dumps(r["conditions"][k]) for r in rows}) > 1]
    numeric = varying and all(isinstance(r["conditions"][varying[0]], numbers.Real) for r in rows)
    if numeric:  # the first condition the rows vary (delta_z, say; a domain sized with it follows it)
        xkey = varying[0]
        x = np.array([float(r["conditions"][xkey]) for r in rows])
    else:
        xkey = None
        x = np.array([r["line"] for r in rows], dtype=float)
    order = np.argsort(x, kind="stable")
    n = len(fit.outputs)
    fig = Figure(figsize=(4.2 * n, 3.4), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, n, squeeze=False)[0]
    shown = ", ".join(f"{k.split('.', 1)[1]} = {e['value']:.6g} ± "
                      f"{'inf' if not math.isfinite(e['stderr']) else format(e['stderr'], '.2g')}"
                      for k, e in result["parameters"].items())
    for ax, o in zip(axes, fit.outputs):
        col = fit.columns[o]
        meas = np.array([r["measured"][col] for r in rows])
        model = np.array([r["model"][col] for r in rows])
        start = np.array([r["model_at_start"][col] for r in rows])
        err = None if rows[0]["sigma"] is None else np.array([r["sigma"][col] for r in rows])
        ax.errorbar(x[order], meas[order], yerr=None if err is None else err[order], fmt="o", color="black",
                    capsize=3, label="measured")
        ax.plot(x[order], start[order], "s--", color="0.65", ms=4, label="model at start")
        ax.plot(x[order], model[order], "x-", color="tab:red", label="model, fitted")
        ax.set_xlabel(xkey if xkey else "CSV line")
        if xkey and np.all(x > 0) and x.max() / x.min() > 20:
            ax.set_xscale("log")
        ax.set_ylabel(col)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(f"warpcontact fit ({fit.task}): {shown}", fontsize=9)
    return fig


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
    "fitted_case",
    "load_fit",
    "model_noise",
    "read_data",
    "run_fit",
]

"""The fit file: its parameters, its data rows and the cases they make (``docs/fit.md``)."""

from __future__ import annotations

import csv
import math
import numbers
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Mapping

from ..errors import InputError
from ..records.case import Case, case_from_dict, read_toml, substitute
from .sweep_spec import (
    CASE_SCHEMA,
    DOTTED_KEYS,
    SweepCase,
    base_case,
    check_case_key,
    check_task,
    near,
    run_scheduler,
    run_settings,
)

#: Tables of a fit file.
FIT_TABLES = ("base", "data", "fit", "run")
#: Keys of one parameter's entry in ``[fit]``.
PARAMETER_KEYS = ("min", "max", "start", "scale")
SCALES = ("linear", "log")
#: Keys of ``[data]``.
DATA_KEYS = ("file",)
#: Keys of ``[run]``.
RUN_KEYS = ("task", "rel_tol", "scheduler", "max_evaluations", "rescale_stderr", "diff_step", "grid_size")
#: What ``grid.size`` may say in a CSV row (or ``[run] grid_size`` for every row) to give each case
#: the domain its own adhesion law needs, the cell side kept (:func:`rule_grid`): "law" grows the
#: base's domain until it holds the law's tail at the path's deepest approach; "table2" is the
#: Table 2 cell's domain (:func:`warpcontact.studies.table2.cell_grid`: grid.n cells over 3 Hertz
#: radii, grown likewise).
GRID_SIZE_RULES = ("law", "table2")
#: Bisection bracket of delta_x_max in a fit (relative). Finer than a sweep's 0.01: the difference
#: step must rise above this noise (see :func:`difference_step`), and at 0.01 it would be 10 % of
#: the parameter; 0.001 costs about 3 bisection states more per case (21 states instead of 18 at
#: n = 32, 0.95 s instead of 0.76 s on 2 CPU cores).
DEFAULT_REL_TOL = 1e-3
#: Residual evaluations the optimiser may make (least_squares' max_nfev; Jacobians not counted).
DEFAULT_MAX_EVALUATIONS = 30
#: The outputs a data column may name, per task: the scalar keys of the task's result, flattened
#: as in the sweep's CSV (nested keys joined with '_': force_z).
OUTPUTS = {
    "gross-slip": ("mu", "delta_x_max", "delta_x_gross", "mu_elastic", "force_x", "force_y", "force_z",
                   "force_elastic_x", "force_elastic_y", "force_elastic_z", "stick_area", "contact_area",
                   "yield_margin"),
    "solve": ("force_x", "force_y", "force_z", "force_elastic_x", "force_elastic_y", "force_elastic_z",
              "contact_area", "contact_radius", "max_pressure", "mean_gap", "stick_area", "adhesive_area",
              "yield_margin"),
    "pull-off": ("pull_off_force", "pull_off_delta_z", "work_of_adhesion", "tabor_parameter"),
}



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
        grid_size: ``[run] grid_size``, a rule of :data:`GRID_SIZE_RULES` for every row's domain, or
            None (each row's grid.size, a number or a rule, else the base's).
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
    grid_size: str | None = None

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
    rule = run.get("grid_size")
    if rule is not None and rule not in GRID_SIZE_RULES:
        raise InputError("run.grid_size", f"must be one of {', '.join(repr(r) for r in GRID_SIZE_RULES)} (the "
                                          f"domain of every row follows the adhesion law), got {rule!r}")
    return {"task": task, "rel_tol": rel_tol, "max_evaluations": int(n), "rescale_stderr": rescale,
            "diff_step": None if step is None else float(step), "scheduler": run_scheduler(data), "grid_size": rule}


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


def rule_grid(case: Case, rule: str, size: float):
    """The domain of ``case`` under a rule of :data:`GRID_SIZE_RULES`, from the case's own sphere,
    adhesion law and deepest approach delta_z_max; the cell count follows so that the cell side
    stays that of ``case.grid.n`` cells over ``size`` [m] ("law": the base's side) or over 3 Hertz
    radii ("table2"). Returns a :class:`~warpcontact.physics.geometry.Grid`.

    Raises:
        InputError: key "grid.size" where the rule does not apply (no adhesion law for "law", a
            shape other than a sphere or paraboloid on a flat, no approach for "table2").
    """
    from ..records.guards import grid_holding, suggested_adhesive_size
    from .runner import adhesion_law
    from .table2 import Table2Settings, cell_grid

    shape, dz, n = case.sphere, case.load.delta_z_max, case.grid.n
    if not shape.hertzian:
        raise _not_hertzian(rule, shape.description)
    if rule == "law":
        if case.adhesion is None:
            raise InputError("grid.size", '= "law" sizes the domain by the adhesion law\'s tail; the case has no '
                                          "[adhesion]: give grid.size as a number, or \"table2\"")
        return grid_holding(n, size, suggested_adhesive_size(shape.radius, dz, adhesion_law(case)))
    if not dz > 0.0:
        raise InputError("grid.size", f'= "table2" spans 3 Hertz radii sqrt(R delta_z) of the deepest approach; the '
                                      f"case's delta_z_max is {dz!r}")
    return cell_grid(dz, Table2Settings(n=n), adhesion_law(case), radius=shape.radius)


def _not_hertzian(rule: str, what: str) -> InputError:
    return InputError("grid.size", f"= {rule!r} sizes the domain from a sphere's or paraboloid's gap; the case has "
                                   f"{what}: give grid.size as a number")


def dict_rule_grid(d: Mapping, rule: str):
    """:func:`rule_grid` of a case dict ``d`` (its ``grid.size`` a number: the rule's "law" side to
    grow from). A first build on a domain of one sphere radius (any contact a case may hold fits in
    it) reads the sphere, the law and the approach; warnings wait for the build on the rule's grid."""
    import copy
    import warnings

    sphere, flat = d.get("sphere"), d.get("flat")
    profile = sphere.get("profile", "sphere") if isinstance(sphere, Mapping) else None
    if profile not in ("sphere", "paraboloid"):
        raise _not_hertzian(rule, f"sphere.profile = {profile!r}")
    if isinstance(flat, Mapping) and flat.get("height_map") is not None:
        raise _not_hertzian(rule, "a flat with a height map")
    probe = copy.deepcopy(dict(d))
    probe["grid"] = {**d["grid"], "size": sphere.get("radius", 1.0)}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        case = case_from_dict(probe)
    return rule_grid(case, rule, float(d["grid"]["size"]))


def _rule_case(d: dict, rule: str) -> Case:
    """The case of the dict ``d`` on the domain of ``rule`` (:func:`dict_rule_grid`), every case
    check made on that grid."""
    grid = dict_rule_grid(d, rule)
    return case_from_dict({**d, "grid": {"n": grid.n, "size": grid.size}})


def _row_case(fit_base: dict, row: Row, values: Mapping, overrides: Mapping, data_name: str,
              grid_size: str | None = None) -> Case:
    """The case of one data row at the parameter ``values``: the sweep's build (the base's dict
    with the row's conditions and the values put in, through case_from_dict). A grid.size of
    :data:`GRID_SIZE_RULES` (the row's, else ``grid_size``, the fit's ``[run] grid_size``) gives
    the case the domain of its own parameters (:func:`rule_grid`, from the base's grid.size)."""
    params = {**row.conditions, **{k: float(v) for k, v in values.items()}}
    rule = params.get("grid.size", grid_size)
    rule = rule if isinstance(rule, str) and rule in GRID_SIZE_RULES else None
    try:
        if rule is None:
            case = case_from_dict(substitute(fit_base, params))
        else:
            d = substitute(fit_base, {k: v for k, v in params.items() if k != "grid.size"})
            case = _rule_case(d, rule)
        return case.with_overrides(**overrides)
    except InputError as e:
        if e.key in row.conditions:
            raise InputError(f"{data_name} line {row.line}", f"column {e}") from None
        if rule is not None and e.key == "grid.size":
            raise InputError("run.grid_size", f"{e.problem} (the case of {data_name} line {row.line} at "
                                              f"{_show(values)})") from None
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
    for row in rows:
        v = row.conditions.get("grid.size")
        if isinstance(v, str) and v not in GRID_SIZE_RULES + ("map",):
            raise InputError(f"{data_path.name} line {row.line}",
                             f"column grid.size: {v!r} is neither a number (m) nor one of "
                             f"{', '.join(repr(r) for r in GRID_SIZE_RULES + ('map',))}; {near(v, GRID_SIZE_RULES)}"
                             "'law' and 'table2' give the case the domain its adhesion law needs")

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
    if run["grid_size"] is not None:
        if "grid.size" in conditions:
            raise InputError("run.grid_size", f"the grid.size column of {data_path.name} sets each row's domain "
                                              "(a number, 'law' or 'table2'): give the rule there or here, not both")
        if any(p.key == "grid.size" for p in parameters):
            raise InputError("run.grid_size", "grid.size is a fitted parameter: a domain cannot be both fitted "
                                              "and follow the law")
    overrides = {"device": device, "dtype": dtype, "fft": fft}
    for name, v in overrides.items():
        if v is not None and (f"solver.{name}" in conditions or any(p.key == f"solver.{name}" for p in parameters)):
            raise InputError(f"--{name}", f"solver.{name} is set by the fit file, so it cannot be overridden")

    # every row's case at the start, and at each parameter's bounds (the others at their start)
    start = {p.key: p.start for p in parameters}
    points = [start] + [{**start, p.key: b} for p in parameters for b in (p.min, p.max)]
    for row in rows:
        for values in points:
            case = _row_case(base_dict, row, values, overrides, data_path.name, run["grid_size"])
            if values is start:
                label = f"{data_path.name} line {row.line}"
                check_task(SweepCase(0, {**row.conditions, **values}, "", label, case), task)
    return Fit(base=base, parameters=tuple(parameters), rows=rows, outputs=outputs, columns=columns,
               conditions=conditions, task=task, rel_tol=run["rel_tol"], weighted=weighted,
               rescale_stderr=run["rescale_stderr"] if run["rescale_stderr"] is not None else not weighted,
               max_evaluations=run["max_evaluations"], diff_step=run["diff_step"], data_file=str(data_path),
               source=str(src) if src is not None else None, scheduler=run["scheduler"], overrides=overrides,
               grid_size=run["grid_size"])


def load_fit(path: str | PathLike, device: str | None = None, dtype: str | None = None,
             fft: str | None = None) -> Fit:
    """Read, parse and validate a fit file (TOML) and its CSV; see :func:`fit_from_dict`.

    Raises:
        InputError: key = the file path when it cannot be read or parsed, else as fit_from_dict.
    """
    data = read_toml(path, "fit file")
    return fit_from_dict(data, source=path, device=device, dtype=dtype, fft=fft)


def _show(values: Mapping) -> str:
    """``k_tau=0.7,sigma_max=1e+06``: parameter values by their keys' last part, 6 digits."""
    return ",".join(f"{k.split('.', 1)[1]}={float(v):.6g}" for k, v in values.items())

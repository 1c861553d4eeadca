"""The fit's outputs: fit.json's companions, the fitted case file and the plot."""

from __future__ import annotations

import copy
import json
import math
import numbers
from pathlib import Path
from typing import Mapping

import numpy as np

from ..records.case import case_from_dict
from .sweep_spec import short_float
from .fit_spec import Fit, dict_rule_grid


def _fmt(v) -> str:
    return "inf" if v is None or not math.isfinite(v) else f"{v:.4g}"


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
    """The base case's dict with the fitted values put in (the base's conditions, not a row's); with
    ``[run] grid_size``, on the domain the rule gives the base at those values."""
    d = copy.deepcopy(fit.base.to_dict())
    for key, v in values.items():
        table, name = key.split(".", 1)
        d[table][name] = float(v)
    if fit.grid_size is not None:
        grid = dict_rule_grid(d, fit.grid_size)
        d["grid"] = {"n": int(grid.n), "size": float(grid.size)}
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



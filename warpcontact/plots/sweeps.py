"""A sweep's results against its swept values (:func:`sweep_figure`) and a fretting sweep's map
over two swept keys (:func:`fretting_map`), from the sweep's case records."""

from __future__ import annotations

import math

import numpy as np
from matplotlib.figure import Figure

from .base import SERIES_COLORS, _figure, si_scale

#: The SI unit of a swept case key, by its last part (docs/case-files.md); a key not listed is drawn
#: as its bare value.
_KEY_UNITS = {**dict.fromkeys(("radius", "size", "delta_z", "delta_x", "delta_y", "delta_n", "delta_t", "h_0", "rho",
                               "z0", "delta_x_amplitude", "delta_y_amplitude"), "m"),
              **dict.fromkeys(("E", "yield_strength", "hardness", "sigma_max", "tau_max", "sigma_0"), "Pa"),
              "w": "J/m$^2$"}

#: What a sweep's figure draws of each row's summary, per task: (path into the summary, axis label,
#: SI unit or "" for a ratio). A solve's second panel is F_x where a row has a tangential force,
#: else the contact radius (:func:`_sweep_quantities`).
SWEEP_QUANTITIES = {
    "gross-slip": ((("delta_x_max",), "gross-slip displacement $\\delta_{x,max}$", "m"),
                   (("mu",), "friction coefficient $\\mu = F_x / F_z$ at gross slip", "")),
    "pull-off": ((("pull_off_force",), "pull-off force (most tensile $F_z$)", "N"),),
    "fretting": ((("energy",), "energy dissipated per cycle, last cycle", "J"),
                 (("energy_ratio",), "Fouvry's energy ratio $A = W / (4 \\delta^* Q^*)$", "")),
    "solve": ((("force", "z"), "normal force $F_z$, last state", "N"),
              (("force", "x"), "tangential force $F_x$, last state", "N")),
}
_CONTACT_RADIUS = (("contact_radius",), "contact radius, last state", "m")


def _summary_value(rec, path):
    """The number at ``path`` in a sweep record's summary, or None (no summary, a withheld result)."""
    v = rec.get("summary") or {}
    for k in path:
        v = v.get(k) if isinstance(v, dict) else None
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        return None
    return float(v)


def _sweep_quantities(records, task):
    """The (path, label, unit) of each panel of a sweep's figure (:data:`SWEEP_QUANTITIES`)."""
    quantities = SWEEP_QUANTITIES.get(task, SWEEP_QUANTITIES["solve"])
    if quantities is SWEEP_QUANTITIES["solve"]:
        tangential = any(_summary_value(r, ("force", "x")) or _summary_value(r, ("force", "y")) for r in records)
        if not tangential:  # a normal approach: F_x is zero in every row, the contact radius says more
            quantities = (quantities[0], _CONTACT_RADIUS)
    return quantities


def _show(v) -> str:
    """A swept value as a label: 0.8, 5e-11, smc, none, true; a list (a load path) as compact JSON."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return f"{v:.6g}"
    if isinstance(v, (str, int)):
        return str(v)
    import json

    return json.dumps(v, separators=(",", ":"))


def _key_name(key: str, keys) -> str:
    """A swept key by its last part (``k_tau``), the whole dotted key where two swept keys share it."""
    short = [k.split(".", 1)[-1] for k in keys]
    last = key.split(".", 1)[-1]
    return last if short.count(last) == 1 else key


def sweep_figure(records, keys, task: str) -> Figure:
    """The results of a sweep against its swept values: one panel per quantity, against the first
    swept key, one line per value of the second swept key (per combination of the others, where
    more are swept).

    ``records``: a sweep's case records in sweep order (``run_sweep``'s ``report.records``, or the
    files of OUT/cases: ``params``, ``status``, ``summary``); ``keys``: the swept dotted keys in the
    sweep file's order; ``task``: "gross-slip" (delta_x_max [m] and mu), "pull-off" (pull-off force
    [N]), "fretting" (the last cycle's energy [J] and Fouvry's ratio A; ``fretting_map`` draws the
    plane of two keys) or "solve" (the last state's F_z [N], and F_x [N] where a row has a
    tangential force, else the contact radius [m]). Axes in the data's own scale (:func:`si_scale`); a numeric first key
    spanning more than a factor 20 on a log axis; values that are not all numbers (law names, a
    load path) as category labels in sweep order. A case that recorded an error or whose result
    was withheld leaves a gap; a point that did not converge is drawn hollow in red. Where a table
    is switched off (law "none"), a note names the swept keys ignored there."""
    import json

    keys = list(keys)
    if not keys:
        raise ValueError("a sweep's figure needs at least one swept key")
    xkey, series_keys = keys[0], keys[1:]
    xs = [r["params"].get(xkey) for r in records]
    numeric = bool(xs) and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                               for v in xs)
    x_scale, x_unit = 1.0, ""
    if numeric:
        unit = _KEY_UNITS.get(xkey.split(".", 1)[-1])
        if unit:
            x_scale, x_unit = si_scale(xs, unit)
        categories = None
    else:  # category labels in the order the sweep lists them
        categories = list(dict.fromkeys(json.dumps(v, sort_keys=True) for v in xs))

    def x_of(v):
        return float(v) / x_scale if numeric else float(categories.index(json.dumps(v, sort_keys=True)))

    series = {}  # the values of the other swept keys -> that line's records, in sweep order
    for r in records:
        series.setdefault(json.dumps([r["params"].get(k) for k in series_keys]), []).append(r)
    legend_scale = {}  # a numeric swept key with a unit: its values in one prefix (sigma_max = 18.39 MPa)
    for k in series_keys:
        vals = [r["params"].get(k) for r in records]
        unit = _KEY_UNITS.get(k.split(".", 1)[-1])
        if unit and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in vals):
            legend_scale[k] = si_scale(vals, unit)

    def shown(k, v):
        if k in legend_scale:
            factor, unit = legend_scale[k]
            return f"{v / factor:.4g} {unit}"
        return _show(v)

    quantities = _sweep_quantities(records, task)
    fig = _figure((5.4 * len(quantities) + 0.6, 4.4))
    axes = fig.subplots(1, len(quantities), squeeze=False)[0]
    marked = False
    for ax, (path, label, unit) in zip(axes, quantities):
        values = [_summary_value(r, path) for r in records]
        scale, shown_unit = si_scale(values, unit) if unit else (1.0, "")
        for i, (combo, rows) in enumerate(series.items()):
            pts = sorted((x_of(r["params"].get(xkey)), _summary_value(r, path), r.get("status") == "ok") for r in rows)
            x = np.array([p[0] for p in pts])
            y = np.array([np.nan if p[1] is None else p[1] / scale for p in pts])
            name = ", ".join(f"{_key_name(k, keys)} = {shown(k, v)}" for k, v in zip(series_keys, json.loads(combo)))
            color = SERIES_COLORS[i % len(SERIES_COLORS)]
            ax.plot(x, y, "-o", color=color, ms=4, lw=1.4, label=name or None)
            bad = [j for j, p in enumerate(pts) if not p[2] and p[1] is not None]
            if bad:
                ax.plot(x[bad], y[bad], "o", mfc="white", mec="red", ms=7, mew=1.4,
                        label=None if marked else "not converged")
                marked = True
        if not any(v is not None for v in values):
            ax.text(0.5, 0.5, "no result: every case recorded an error\nor did not converge", transform=ax.transAxes,
                    ha="center", va="center", color="0.4")
        if numeric:
            pos = [float(v) for v in xs]
            if min(pos) > 0 and max(pos) / min(pos) > 20:
                ax.set_xscale("log")
        else:
            ax.set_xticks(range(len(categories)))
            ax.set_xticklabels([_show(json.loads(c)) for c in categories])
            ax.set_xlim(-0.5, len(categories) - 0.5)
        ax.set_xlabel(f"{xkey} [{x_unit}]" if x_unit else xkey)
        ax.set_ylabel(f"{label} [{shown_unit}]" if shown_unit else f"{label} [-]")
        ax.grid(True, color="0.9", linewidth=0.5)
        if series_keys or marked:
            ax.legend(fontsize="small", loc="best")
    n_ok = sum(1 for r in records if r.get("status") == "ok")
    fig.suptitle(f"sweep, task {task}: {len(records)} case(s), {n_ok} converged", fontsize="medium")
    ignored = sorted({k for r in records for k in r.get("ignored", ())})
    if ignored:
        off = sorted({k.split(".", 1)[0] for k in ignored})
        fig.text(0.5, 0.0, f"law = none switches [{'], ['.join(off)}] off: {', '.join(ignored)} ignored there",
                 color="dimgray", fontsize="small", ha="center", va="top")
    return fig


def fretting_map(records, keys) -> Figure:
    """A fretting sweep over two numeric keys (the normal approach and the amplitude, say) as a map:
    each case a marker at its two values, coloured by the energy dissipated in its last cycle (log
    scale) and shaped by its regime (circle: partial slip, square: gross slip; hollow red: not
    converged or no result), with Fouvry's A written beside it; where the cases carry Mindlin and
    Deresiewicz's closed form and one key is an amplitude, the closed form's transition delta* =
    delta_s over the other key, dashed. ``records``: the sweep's case records (``params``,
    ``status``, ``summary``); ``keys``: the swept keys, the first two drawn (x, y)."""
    from matplotlib.colors import LogNorm

    keys = list(keys)
    if len(keys) < 2:
        raise ValueError("a fretting map needs two swept keys")
    xkey, ykey = keys[:2]
    pts = [(r["params"].get(xkey), r["params"].get(ykey), r) for r in records]
    if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for x, y, _ in pts for v in (x, y)):
        raise ValueError(f"a fretting map needs numeric values of {xkey} and {ykey}")
    def scale(i, key):  # the axis of a swept key in its values' own prefix (5 nm), a bare number without a unit
        unit = _KEY_UNITS.get(key.split(".", 1)[-1])
        return si_scale([p[i] for p in pts], unit) if unit else (1.0, "")

    (xs, xu), (ys, yu) = scale(0, xkey), scale(1, ykey)
    energies = [_summary_value(r, ("energy",)) for _, _, r in pts]
    positive = [e for e in energies if e is not None and e > 0.0]
    fig = _figure((6.8, 5.0))
    ax = fig.add_subplot()
    norm = LogNorm(min(positive), max(positive)) if positive and min(positive) < max(positive) else None
    drawn = None
    for regime, marker in (("partial slip", "o"), ("gross slip", "s")):
        sel = [(x, y, e, r) for (x, y, r), e in zip(pts, energies)
               if e is not None and (r.get("summary") or {}).get("regime") == regime and r.get("status") == "ok"]
        if sel:
            drawn = ax.scatter([x / xs for x, *_ in sel], [y / ys for _, y, *_ in sel], c=[e for *_, e, _ in sel],
                               cmap="viridis", norm=norm, marker=marker, s=70, edgecolors="k", linewidths=0.5)
            ax.plot([], [], marker, mfc="0.8", mec="k", mew=0.5, ms=8, label=regime)  # the legend's, uncoloured
    bad = [(x, y) for (x, y, r), e in zip(pts, energies) if e is None or r.get("status") != "ok"]
    if bad:
        ax.plot([x / xs for x, _ in bad], [y / ys for _, y in bad], "o", mfc="white", mec="red", ms=8, mew=1.4,
                label="not converged or no result")
    for x, y, r in pts:
        a = _summary_value(r, ("energy_ratio",))
        if a is not None:
            ax.annotate(f"{a:.2f}", (x / xs, y / ys), xytext=(5, 5), textcoords="offset points", fontsize="x-small")
    amplitude = [i for i, k in enumerate((xkey, ykey)) if k.endswith("_amplitude")]
    line = sorted({(p[1 - amplitude[0]], _summary_value(p[2], ("closed_form", "delta_gross"))) for p in pts}
                  ) if len(amplitude) == 1 else []
    line = [(o, d) for o, d in line if d is not None]
    if line:
        other = [o for o, _ in line]
        d_s = [d for _, d in line]
        xy = (np.array(other) / xs, np.array(d_s) / ys) if amplitude[0] == 1 else (np.array(d_s) / xs,
                                                                                  np.array(other) / ys)
        ax.plot(*xy, "k--", lw=1.0, label="Mindlin-Deresiewicz: $\\delta^* = \\delta_s$ (A = 0.2)")
    if drawn is not None:
        fig.colorbar(drawn, ax=ax, label="energy dissipated per cycle [J]")
    ax.set_xlabel(f"{xkey} [{xu}]" if xu else xkey)
    ax.set_ylabel(f"{ykey} [{yu}]" if yu else ykey)
    ax.set_title(f"fretting map: {len(records)} case(s); markers: regime, labels: A", fontsize="medium")
    ax.grid(alpha=0.3)
    ax.legend(fontsize="small", loc="best")
    return fig

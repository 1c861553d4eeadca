"""Figures of solved states, after the paper's Figures 1 and 2; a pull-off's force-approach curve
(:func:`pull_off_curve`), a fretting run's loops and energies (:func:`fretting_loop`,
:func:`fretting_energy`) and a sweep's results against its swept values (:func:`sweep_figure`).

Every function of a state takes ``fields``, a mapping of numpy arrays as written to ``fields.npz`` by
``warpcontact solve`` (``results.state_fields`` stacked over the states of the path, SI units,
row = y, column = x, plus the cell centres ``x``, ``y`` [m] and ``delta`` (n_states, 3) [m]),
and returns a :class:`matplotlib.figure.Figure` drawn with the Agg canvas. Nothing touches
pyplot or the global backend, so these are safe to call from a library, a test or a thread.

Colours follow the paper: the elastic contact area A_c in blue, the stick area A_st in orange,
the adhesive contact area A_adh in yellow (MATLAB's first three line colours). Cells that are in
contact but not in stick (the slip cells) are the blue ones; A_st is drawn over A_c.

``pressure``, ``shear_x``, ``shear_y`` are the elastic contact tractions. Adhesion adds
``adhesive_mask`` (A_adh, cells outside A_c within the law's range), ``adhesive_pressure`` (<= 0,
tension) and ``adhesive_shear_x``, ``adhesive_shear_y``; a solve without adhesion writes them as
zeros, and older files lack them. Either way the figures draw no yellow and their legends say
that the file has no adhesion. ``shear_limit`` (q_max of each cell [Pa]) is optional too.
"""

from __future__ import annotations

import io
import math
import os
import secrets
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import ListedColormap
from matplotlib.figure import Figure
from matplotlib.patches import Patch

#: The paper's colours: A_c blue, A_st orange, A_adh yellow.
CONTACT_COLOR = "#0072BD"
STICK_COLOR = "#D95319"
ADHESIVE_COLOR = "#EDB120"

#: Margin around the contact in the zoomed maps, as a fraction of the contact's extent.
MARGIN = 0.15

NM = 1e9
MPA = 1e-6

_OUT, _SLIP, _STICK, _ADH = 0, 1, 2, 3


# ----------------------------------------------------------------------------------------------
# helpers


def _figure(figsize, layout="constrained") -> Figure:
    fig = Figure(figsize=figsize, layout=layout)
    FigureCanvasAgg(fig)  # an Agg canvas of its own: draw(), buffer_rgba() and savefig() work
    return fig


def _n_states(fields) -> int:
    return int(np.shape(fields["pressure"])[0])


def _state_index(fields, index: int) -> int:
    n = _n_states(fields)
    if not -n <= index < n:
        raise IndexError(f"state {index} is out of range: the file holds {n} state(s) (0 ... {n - 1})")
    return index % n


def _state(fields, key, k):
    """One state's 2-D field, or None when the key is absent."""
    if key not in fields:
        return None
    a = np.asarray(fields[key])
    return a[k] if a.ndim == 3 else a


def _edges(c: np.ndarray) -> np.ndarray:
    """Cell edges from cell centres (a uniform grid)."""
    c = np.asarray(c, dtype=float)
    if c.size < 2:
        raise ValueError("need at least two cell centres per axis to know the cell size")
    h = (c[-1] - c[0]) / (c.size - 1)
    return np.concatenate([c - h / 2, [c[-1] + h / 2]])


def _cell_area(fields) -> float:
    """Area of one cell [m^2]."""
    ex, ey = _edges(fields["x"]), _edges(fields["y"])
    return abs(ex[1] - ex[0]) * abs(ey[1] - ey[0])


def _extent_nm(fields):
    """(left, right, bottom, top) of the grid in nm, for imshow with origin='lower'."""
    ex, ey = _edges(fields["x"]) * NM, _edges(fields["y"]) * NM
    return ex[0], ex[-1], ey[0], ey[-1]


ADHESIVE_KEYS = ("adhesive_mask", "adhesive_pressure", "adhesive_shear_x", "adhesive_shear_y")


def has_adhesion(fields) -> bool:
    """True when the file holds adhesive areas or tractions (a solve without adhesion writes zeros)."""
    return any(k in fields and np.any(np.asarray(fields[k]) != 0) for k in ADHESIVE_KEYS)


def _total(fields, key, adhesive_key, k):
    """(field of state k with the adhesive part added when the file has adhesion, True if it was added)."""
    a = _state(fields, key, k)
    b = _state(fields, adhesive_key, k) if has_adhesion(fields) else None
    return (a, False) if b is None else (a + b, True)


def _masks(fields, k):
    """(contact, stick, adhesive) boolean maps of state k; adhesive is None without adhesion.

    Stick is kept inside contact (A_st is part of A_c), adhesive outside it.
    """
    contact = _state(fields, "contact_mask", k)
    if contact is None:
        contact = _state(fields, "pressure", k) > 0
    contact = np.asarray(contact, dtype=bool)
    stick = _state(fields, "stick_mask", k)
    if stick is None:
        status = _state(fields, "status", k)
        stick = status == 1 if status is not None else np.zeros_like(contact)
    stick = np.asarray(stick, dtype=bool) & contact
    adh = _state(fields, "adhesive_mask", k) if has_adhesion(fields) else None
    if adh is not None:
        adh = np.asarray(adh, dtype=bool) & ~contact
    return contact, stick, adh


def _category_map(contact, stick, adh):
    cat = np.full(contact.shape, _OUT, dtype=np.int8)
    if adh is not None:
        cat[adh] = _ADH
    cat[contact] = _SLIP
    cat[stick] = _STICK
    return cat


def _zoom_window(fields, k):
    """((x0, x1), (y0, y1)) in nm: a square around the contact (and adhesive rim) plus 15 %.

    The whole grid when nothing is in contact.
    """
    contact, _, adh = _masks(fields, k)
    region = contact | adh if adh is not None else contact
    x0, x1, y0, y1 = _extent_nm(fields)
    lo_x, hi_x, lo_y, hi_y = min(x0, x1), max(x0, x1), min(y0, y1), max(y0, y1)
    if not region.any():
        return (lo_x, hi_x), (lo_y, hi_y)
    ex, ey = _edges(fields["x"]) * NM, _edges(fields["y"]) * NM
    rows, cols = np.nonzero(region)
    xa = np.sort([ex[cols.min()], ex[cols.max() + 1]])
    ya = np.sort([ey[rows.min()], ey[rows.max() + 1]])
    half = max(xa[1] - xa[0], ya[1] - ya[0]) * (1 + 2 * MARGIN) / 2
    cx, cy = xa.mean(), ya.mean()
    # keep the window on the grid: shift it inwards, shrink only when the grid is smaller
    def clamp(c, lo, hi):
        h = min(half, (hi - lo) / 2)
        c = min(max(c, lo + h), hi - h)
        return c - h, c + h

    return clamp(cx, lo_x, hi_x), clamp(cy, lo_y, hi_y)


def area_formatter(areas_m2):
    """A formatter of areas [m^2] in nm^2 with one number of decimals for all of ``areas_m2``, enough
    to give the smallest non-zero one 3 significant figures (at most 4 decimals), so that the areas
    of one legend add up as printed (stick 2.000 + slip 0.293 = contact 2.293 nm^2)."""
    nonzero = [abs(a) * NM * NM for a in areas_m2 if a]
    smallest = min(nonzero) if nonzero else 1.0
    decimals = int(min(4, max(0, 2 - math.floor(math.log10(smallest)))))

    def fmt(a_m2: float) -> str:
        return f"{a_m2 * NM * NM:,.{decimals}f} nm$^2$"

    return fmt


def _fmt_area(a_m2: float) -> str:
    """One area [m^2] in nm^2 with 3 significant figures or more."""
    return area_formatter([a_m2])(a_m2)


def _nm(v: float) -> str:
    """A length [m] in nm, 4 significant figures (0.05, 22.36)."""
    return f"{v * NM:.4g}"


def _state_title(fields, k, name=None) -> str:
    """``name`` (default: the state's index in the file) and the state's rigid displacements in nm."""
    n = _n_states(fields)
    if name is not None:
        s = name
    else:
        s = f"state {k} (of 0-{n - 1})" if n > 1 else f"state {k}"  # (one state: no range to name)
    if "delta" in fields:
        d = np.asarray(fields["delta"])
        if d.ndim == 2 and d.shape[0] == n and d.shape[1] >= 3:
            dx, dy, dz = (float(v) for v in d[k, :3])
            s += f":  $\\delta_z$ = {_nm(dz)} nm,  $\\delta_x$ = {_nm(dx)} nm"
            if dy:
                s += f",  $\\delta_y$ = {_nm(dy)} nm"
    return s


def _nm_axes(ax, fields, k):
    (x0, x1), (y0, y1) = _zoom_window(fields, k)
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    ax.set_xlabel("x [nm]")
    ax.set_ylabel("y [nm]")


def _imshow(ax, fields, data, **kw):
    ey = _edges(fields["y"])
    origin = "lower" if ey[-1] > ey[0] else "upper"
    x0, x1, y0, y1 = _extent_nm(fields)
    return ax.imshow(data, extent=(x0, x1, min(y0, y1), max(y0, y1)), origin=origin,
                     interpolation="nearest", **kw)


def _draw_area_map(ax, fields, k, legend_loc="outside"):
    """The paper's map of A_c (blue), A_st (orange) and A_adh (yellow) into ``ax``."""
    contact, stick, adh = _masks(fields, k)
    cat = _category_map(contact, stick, adh)
    cmap = ListedColormap(["white", CONTACT_COLOR, STICK_COLOR, ADHESIVE_COLOR])
    _imshow(ax, fields, cat, cmap=cmap, vmin=-0.5, vmax=3.5)
    _nm_axes(ax, fields, k)
    ax.grid(True, color="0.85", linewidth=0.5)
    ax.set_axisbelow(False)

    dA = _cell_area(fields)
    a_c, a_st = contact.sum() * dA, stick.sum() * dA
    a_adh = adh.sum() * dA if adh is not None else 0.0
    fmt = area_formatter([a_c, a_st, a_c - a_st, a_adh])  # one number of decimals: the areas add up
    handles = [
        Patch(facecolor=CONTACT_COLOR, edgecolor="none",
              label=f"$A_c$ elastic contact: {fmt(a_c)}  (blue: slip, {fmt(a_c - a_st)})"),
        Patch(facecolor=STICK_COLOR, edgecolor="none", label=f"$A_{{st}}$ stick area: {fmt(a_st)}"),
    ]
    if adh is not None:
        handles.append(Patch(facecolor=ADHESIVE_COLOR, edgecolor="none",
                             label=f"$A_{{adh}}$ adhesive contact: {fmt(a_adh)}"))
    else:
        handles.append(Patch(facecolor="none", edgecolor="0.6", linestyle="--",
                             label="$A_{adh}$ adhesive contact: none (no adhesion in this file)"))
    ax.text(0.99, 0.01, f"cell {math.sqrt(dA) * NM:.3g} nm", transform=ax.transAxes, ha="right", va="bottom",
            fontsize="x-small", color="0.4")
    if legend_loc == "outside":  # at the foot of the figure, below the axes' label
        leg = ax.figure.legend(handles=handles, loc="lower center", bbox_to_anchor=(0.5, 0.01), frameon=False,
                               fontsize="small", handlelength=1.4)
    elif legend_loc == "below":  # under the axes' label, inside the constrained layout
        leg = ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.12), frameon=False,
                        fontsize="x-small", handlelength=1.2)
    else:
        leg = ax.legend(handles=handles, loc=legend_loc, fontsize="x-small", framealpha=0.85, handlelength=1.2)
    return leg


# ----------------------------------------------------------------------------------------------
# public figures


def area_map(fields: dict, index: int = -1, title=None, name=None) -> Figure:
    """The paper-style map of one state: A_c blue (its slip cells), A_st orange, A_adh yellow.

    Axes in nm with equal aspect, zoomed to the contact plus a 15 % margin; the legend gives each
    area in nm^2. ``title`` defaults to the state and its rigid displacements in nm; ``name``
    (e.g. "gross slip") names the state there in place of its index in the file.
    """
    k = _state_index(fields, index)
    # fixed margins: the constrained layout misplaces an equal-aspect axes above a figure legend
    fig = _figure((5.6, 6.2), layout=None)
    ax = fig.add_axes((0.14, 0.215, 0.82, 0.71))
    _draw_area_map(ax, fields, k)
    ax.set_title(_state_title(fields, k, name) if title is None else title, fontsize="medium")
    return fig


def field_maps(fields: dict, index: int = -1, name=None) -> Figure:
    """2 x 2 maps of one state: pressure [MPa], shear magnitude [MPa], gap [nm], area map.

    All four share the zoomed window of the area map. The gap's colour range is clipped to the
    gaps seen inside that window (its 90th percentile), so the contact and its rim show. The title
    names the state (``name``, default its index in the file) and its rigid displacements in nm.
    """
    k = _state_index(fields, index)
    fig = _figure((11.0, 9.6))
    axs = fig.subplots(2, 2)
    contact, _, _ = _masks(fields, k)

    p, with_adh = _total(fields, "pressure", "adhesive_pressure", k)
    p = p * MPA
    ax = axs[0, 0]
    im = _imshow(ax, fields, p, cmap="viridis", vmin=min(0.0, float(p.min())), vmax=max(float(p.max()), 1e-12))
    fig.colorbar(im, ax=ax, label="pressure [MPa]", shrink=0.9)
    ax.set_title("pressure $p = p_c + p_{adh}$ (tension < 0)" if with_adh else "contact pressure $p_c$",
                 fontsize="medium")
    _nm_axes(ax, fields, k)

    qx, with_adh = _total(fields, "shear_x", "adhesive_shear_x", k)
    qy, _ = _total(fields, "shear_y", "adhesive_shear_y", k)
    q = np.hypot(qx, qy) * MPA
    ax = axs[0, 1]
    sheared = bool(q.max() > 0)
    im = _imshow(ax, fields, q, cmap="plasma", vmin=0.0, vmax=float(q.max()) if sheared else 1.0)
    bar = fig.colorbar(im, ax=ax, label="shear magnitude $|q|$ [MPa]", shrink=0.9)
    if not sheared:  # a frictionless state without adhesive shear: say so, not a scale of rounding
        bar.set_ticks([0.0])
        ax.text(0.5, 0.5, "no shear in this state", transform=ax.transAxes, ha="center", va="center",
                color="white", fontsize="large")
    ax.set_title("shear $|q|$, adhesive part included" if with_adh else "shear $|q| = \\sqrt{q_x^2 + q_y^2}$",
                 fontsize="medium")
    _nm_axes(ax, fields, k)

    g = _state(fields, "gap", k) * NM
    ax = axs[1, 0]
    (x0, x1), (y0, y1) = _zoom_window(fields, k)
    xc, yc = np.asarray(fields["x"]) * NM, np.asarray(fields["y"]) * NM
    inside = ((xc >= x0) & (xc <= x1))[None, :] & ((yc >= y0) & (yc <= y1))[:, None]
    seen = g[inside] if inside.any() else g.ravel()
    vmax = float(np.percentile(seen, 90)) if seen.size else 1.0
    if not vmax > 0:
        vmax = float(g.max()) if g.max() > 0 else 1.0
    im = _imshow(ax, fields, g, cmap="gray", vmin=0.0, vmax=vmax)
    fig.colorbar(im, ax=ax, label="gap $h$ [nm]", shrink=0.9, extend="max")
    if contact.any() and not contact.all():
        ax.contour(xc, yc, contact.astype(float), levels=[0.5], colors="white", linewidths=0.9)
    ax.set_title("gap $h$ (colour range clipped; white line: edge of $A_c$)", fontsize="medium")
    _nm_axes(ax, fields, k)

    ax = axs[1, 1]
    _draw_area_map(ax, fields, k, legend_loc="below")
    ax.set_title("areas: $A_c$ blue, $A_{st}$ orange, $A_{adh}$ yellow", fontsize="medium")

    fig.suptitle(_state_title(fields, k, name))
    return fig


def profile(fields: dict, index: int = -1, name=None) -> Figure:
    """Pressure, shear_x and (when the file has it) the shear limit along x through the centre row.

    The centre row is the row nearest y = 0 (the sphere's axis). Stick cells of the row are shaded
    orange. Tractions in the data's own scale (kPa, MPa, GPa: :func:`si_scale`) against x in nm,
    over the zoomed window of the area map. The title names the state as :func:`field_maps` does.
    """
    k = _state_index(fields, index)
    fig = _figure((7.0, 4.4))
    ax = fig.add_subplot()
    xc, yc = np.asarray(fields["x"]) * NM, np.asarray(fields["y"]) * NM
    row = int(np.argmin(np.abs(yc)))
    contact, stick, _ = _masks(fields, k)
    dx = abs(xc[1] - xc[0]) if xc.size > 1 else 1.0

    first = True
    for j in np.nonzero(stick[row])[0]:
        ax.axvspan(xc[j] - dx / 2, xc[j] + dx / 2, color=STICK_COLOR, alpha=0.18, linewidth=0,
                   label="stick cells ($A_{st}$)" if first else None)
        first = False

    tractions = [_state(fields, key, k)[row] for key in ("pressure", "shear_x", "adhesive_pressure")
                 if key in fields]
    scale, unit = si_scale([float(np.abs(t).max()) for t in tractions], "Pa")  # GPa for an AFM tip, kPa for a gel
    p = _state(fields, "pressure", k)[row] / scale
    ax.plot(xc, p, "-", color="black", lw=1.6, label="contact pressure $p_c$")
    ax.plot(xc, _state(fields, "shear_x", k)[row] / scale, "-", color=CONTACT_COLOR, lw=1.6,
            label="contact shear $q_x$")
    qmax = _state(fields, "shear_limit", k)
    if qmax is not None:
        qm = np.where(contact[row], qmax[row], np.nan) / scale
        frictionless = not np.any(np.asarray(fields["shear_limit"]) != 0)
        ax.plot(xc, qm, "--", color=STICK_COLOR, lw=1.4,
                label="shear limit $q_{max}(p)$" + (" (frictionless: 0)" if frictionless else ""))
    if has_adhesion(fields):
        padh = _state(fields, "adhesive_pressure", k)
        if padh is not None:
            ax.plot(xc, padh[row] / scale, ":", color=ADHESIVE_COLOR, lw=1.8, label="adhesive pressure $p_{adh}$")
        qadh = _state(fields, "adhesive_shear_x", k)
        if qadh is not None:
            ax.plot(xc, qadh[row] / scale, "-.", color=ADHESIVE_COLOR, lw=1.4, label="adhesive shear $q_{adh,x}$")
    ax.axhline(0.0, color="0.6", lw=0.6)
    (x0, x1), _ = _zoom_window(fields, k)
    ax.set_xlim(x0, x1)
    ax.set_xlabel("x [nm]")
    ax.set_ylabel(f"traction [{unit}]")
    ax.grid(True, color="0.9", linewidth=0.5)
    note = "" if qmax is not None else "  (no shear limit in this file: written before it was kept)"
    ax.set_title(f"{_state_title(fields, k, name)}\nprofile along x at y = {yc[row]:.2f} nm{note}", fontsize="medium")
    ax.legend(fontsize="small", loc="best")
    return fig


#: SI prefixes for an axis in the data's own scale: factor -> prefix (micro: the micro sign, U+00B5).
_PREFIXES = ((1e9, "G"), (1e6, "M"), (1e3, "k"), (1.0, ""), (1e-3, "m"), (1e-6, "\u00b5"), (1e-9, "n"),
             (1e-12, "p"), (1e-15, "f"))


def si_scale(values, unit: str):
    """(factor, label) putting ``values`` [unit] in the prefix where the largest |value| lies in
    [0.5, 500): an nN curve in nN, a 0.6 nm approach in nm, 4.4 GPa in GPa (``value / factor`` is
    drawn)."""
    peak = max((abs(float(v)) for v in values if v is not None and math.isfinite(float(v))), default=0.0)
    for factor, prefix in _PREFIXES:
        if peak >= 0.5 * factor:
            return factor, prefix + unit
    return _PREFIXES[-1][0], _PREFIXES[-1][1] + unit


def pull_off_curve(result: dict) -> Figure:
    """The force-approach curve of a pull-off result (``warpcontact pull-off``'s result.json, or
    ``wc.pull_off``'s dict): total F_z against delta_z on the approach and retract branches, the
    states that located the jumps and refined the pull-off, each jump as a dashed arrow, the
    pull-off point, and the DMT (2 pi R w) and JKR (1.5 pi R w) pull-off forces when the result
    has them. Both axes in the data's own scale (an nN curve in nN)."""
    curve = result["curve"]
    forces = [c["force"]["z"] for c in curve] + [result.get("dmt_pull_off"), result.get("jkr_pull_off")]
    f_scale, f_unit = si_scale(forces, "N")
    z_scale, z_unit = si_scale([c["delta"]["z"] for c in curve], "m")
    fig = _figure((6.4, 4.4))
    ax = fig.add_subplot()
    for branch, style in (("approach", "-o"), ("retract", "-s")):
        pts = [(c["delta"]["z"] / z_scale, c["force"]["z"] / f_scale) for c in curve if c.get("branch") == branch]
        if pts:
            x, y = zip(*pts)
            ax.plot(x, y, style, ms=3, label=branch)
    refined = [c for c in result.get("refined") or [] if c.get("purpose") != "start in contact"]
    if refined:  # the bisections that place the jumps and the substeps around the pull-off
        ax.plot([c["delta"]["z"] / z_scale for c in refined], [c["force"]["z"] / f_scale for c in refined], ".",
                color="0.45", ms=3, label="located / refined")
    for e in result.get("contact_events") or []:
        if e.get("jump"):  # the jump: from the last state before to the first after, dashed
            z = e["delta_z_after"] / z_scale
            ax.annotate("", xy=(z, e["force_after"] / f_scale), xytext=(z, e["force_before"] / f_scale),
                        arrowprops={"arrowstyle": "->", "ls": "--", "color": "0.3", "lw": 0.8})
    if result.get("pull_off_force") is not None:
        ax.plot([result["pull_off_delta_z"] / z_scale], [result["pull_off_force"] / f_scale], "k*", ms=9,
                label=f"pull-off {result['pull_off_force'] / f_scale:.4g} {f_unit}")
    for key, ls, name in (("dmt_pull_off", "--", "DMT $-2\\pi R w$"), ("jkr_pull_off", ":", "JKR $-1.5\\pi R w$")):
        if result.get(key) is not None:
            ax.axhline(result[key] / f_scale, color="0.5", ls=ls, lw=0.8,
                       label=f"{name} = {result[key] / f_scale:.4g} {f_unit}")
    ax.axhline(0.0, color="0.8", lw=0.6)
    ax.set_xlabel(f"approach $\\delta_z$ [{z_unit}]")
    ax.set_ylabel(f"$F_z$ [{f_unit}] (total: contact and adhesion; tension < 0)")
    tabor = result.get("tabor_parameter")
    ax.set_title("approach and retraction" + (f", Tabor parameter {tabor:.3g}" if tabor is not None else ""),
                 fontsize="medium")
    ax.legend(fontsize="small")
    ax.grid(alpha=0.3)
    return fig


def _fretting_axis(result: dict):
    """(ux, uy, name): the displacement's direction in a fretting result (that of its farthest
    tangential approach) and the subscript that names it: x, y, or t (along the direction) for both."""
    far = max(result["states"], key=lambda s: math.hypot(s["delta"]["x"], s["delta"]["y"]))
    ax_, ay_ = far["delta"]["x"], far["delta"]["y"]
    d = math.hypot(ax_, ay_) or 1.0
    name = "x" if ay_ == 0.0 else "y" if ax_ == 0.0 else "t"
    return ax_ / d, ay_ / d, name


def fretting_loop(result: dict) -> Figure:
    """The fretting loops of a fretting result (``warpcontact fretting``'s result.json, or
    ``wc.fretting``'s dict): the
    tangential force against the tangential approach, F_x against delta_x (along the displacement's
    direction where both amplitudes are given), the first quarter dashed and each whole cycle in a
    colour of its own, and Mindlin and Deresiewicz's loop (black, dashed) where the closed form
    applies. Both axes in the data's own scale."""
    from .physics.reference import mindlin_deresiewicz_loop

    states = result["states"]
    ux, uy, name = _fretting_axis(result)
    d = np.array([s["delta"]["x"] * ux + s["delta"]["y"] * uy for s in states])
    f = np.array([s["force"]["x"] * ux + s["force"]["y"] * uy for s in states])
    cycles = result.get("cycles") or []
    ref = result.get("closed_form")
    d_scale, d_unit = si_scale(d, "m")
    f_scale, f_unit = si_scale(list(f) + ([ref["force_amplitude"]] if ref else []), "N")
    e_scale, e_unit = si_scale([c["energy"] for c in cycles if c["energy"] is not None]
                               + ([ref["energy"]] if ref else []), "J")
    fig = _figure((6.4, 4.8))
    ax = fig.add_subplot()
    first = cycles[0]["first_state"] if cycles else len(states) - 1
    start = next((i for i, s in enumerate(states) if s["delta"]["x"] or s["delta"]["y"]), first)
    ax.plot(np.r_[0.0, d[start:first + 1]] / d_scale, np.r_[0.0, f[start:first + 1]] / f_scale, "--", color="0.5",
            lw=1.0, label="first quarter")
    for i, c in enumerate(cycles):
        seg = slice(c["first_state"], c["last_state"] + 1)
        energy = "" if c["energy"] is None else f", W = {c['energy'] / e_scale:.4g} {e_unit}"
        ax.plot(d[seg] / d_scale, f[seg] / f_scale, "-o", ms=2.5, lw=1.2, color=SERIES_COLORS[i % len(SERIES_COLORS)],
                label=f"cycle {c['cycle']}{energy}")
    if ref:
        amp = result["displacement_amplitude"]
        grid = np.linspace(-amp, amp, 401)
        down, up = mindlin_deresiewicz_loop(ref["normal_force"], ref["contact_radius"], ref["mu"], ref["compliance"],
                                            amp, grid)
        ax.plot(np.r_[grid[::-1], grid] / d_scale, np.r_[down[::-1], up] / f_scale, "k--", lw=1.0,
                label=f"Mindlin-Deresiewicz, W = {ref['energy'] / e_scale:.4g} {e_unit}")
    ax.axhline(0.0, color="0.8", lw=0.6)
    ax.axvline(0.0, color="0.8", lw=0.6)
    ax.set_xlabel(f"tangential approach $\\delta_{name}$ [{d_unit}]")
    ax.set_ylabel(f"tangential force $F_{name}$ [{f_unit}]")
    p = result.get("normal_force")
    p_text = "" if p is None else ", $F_z$ = {:.4g} {}".format(p / si_scale([p], "N")[0], si_scale([p], "N")[1])
    regime = cycles[-1]["regime"] if cycles and cycles[-1].get("regime") else None
    ax.set_title("fretting loop" + p_text + (f", {regime}" if regime else ""), fontsize="medium")
    ax.legend(fontsize="small", loc="upper left")
    ax.grid(alpha=0.3)
    return fig


def fretting_energy(result: dict) -> Figure:
    """The energy dissipated in each whole cycle of a fretting result [J], with the integration's
    error estimate as error bars, the partial- and gross-slip cycles marked apart, Fouvry's ratio A
    of each cycle written beside it, and Mindlin and Deresiewicz's energy where the closed form
    applies."""
    cycles = [c for c in result.get("cycles") or [] if c.get("energy") is not None]
    ref = result.get("closed_form")
    e_scale, e_unit = si_scale([c["energy"] for c in cycles] + ([ref["energy"]] if ref else []), "J")
    fig = _figure((6.4, 4.4))
    ax = fig.add_subplot()
    for regime, marker, color in (("partial slip", "o", CONTACT_COLOR), ("gross slip", "s", STICK_COLOR)):
        rows = [c for c in cycles if c["regime"] == regime]
        if rows:
            ax.errorbar([c["cycle"] for c in rows], [c["energy"] / e_scale for c in rows],
                        yerr=[c["energy_error"] / e_scale for c in rows], fmt=marker, color=color, ms=6, capsize=3,
                        label=regime)
    for c in cycles:
        if c.get("energy_ratio") is not None:
            ax.annotate(f"A = {c['energy_ratio']:.3f}", (c["cycle"], c["energy"] / e_scale), xytext=(6, 6),
                        textcoords="offset points", fontsize="x-small")
    if ref:
        ax.axhline(ref["energy"] / e_scale, color="k", ls="--", lw=1.0,
                   label=f"Mindlin-Deresiewicz {ref['energy'] / e_scale:.4g} {e_unit} (A = {ref['energy_ratio']:.3f})")
    if not cycles:
        ax.text(0.5, 0.5, "no whole cycle finished, or none converged", transform=ax.transAxes, ha="center",
                va="center", color="0.4")
    ax.set_xlabel("cycle")
    ax.set_ylabel(f"energy dissipated per cycle [{e_unit}]")
    ax.xaxis.get_major_locator().set_params(integer=True)
    ax.set_title("energy per cycle (error bars: trapezoid against Simpson)", fontsize="medium")
    ax.legend(fontsize="small")
    ax.grid(alpha=0.3)
    return fig


#: Line colours of a sweep's series: the paper's (MATLAB's) colour order.
SERIES_COLORS = (CONTACT_COLOR, STICK_COLOR, ADHESIVE_COLOR, "#7E2F8E", "#77AC30", "#4DBEEE", "#A2142F")

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


def save(fig: Figure, path, dpi=None) -> None:
    """Write ``fig`` as a PNG at ``path``, whole or not at all (a temporary file, then os.replace)."""
    path = Path(path)
    buf = io.BytesIO()
    # tight: the canvas grows to hold text placed outside it (the case caption of `figure`)
    fig.savefig(buf, format="png", dpi=dpi if dpi is not None else "figure", bbox_inches="tight", pad_inches=0.08)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.parent / f".{path.name}.{secrets.token_hex(6)}.tmp"
    # O_EXCL: a name of our own; mode 0666 less the umask, an ordinary file's mode (not mkstemp's 0600)
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(buf.getvalue())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


__all__ = ["area_map", "area_formatter", "field_maps", "fretting_energy", "fretting_loop", "fretting_map", "profile",
           "pull_off_curve", "save", "si_scale", "has_adhesion", "sweep_figure", "CONTACT_COLOR", "STICK_COLOR",
           "ADHESIVE_COLOR"]

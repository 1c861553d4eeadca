"""Figures of one solved state, after the paper's Figures 1 and 2: the map of the contact, stick
and adhesive areas (:func:`area_map`), the maps of its fields (:func:`field_maps`) and a profile
through the centre (:func:`profile`).

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

import math

import numpy as np
from matplotlib.colors import ListedColormap
from matplotlib.figure import Figure
from matplotlib.patches import Patch

from .base import ADHESIVE_COLOR, CONTACT_COLOR, STICK_COLOR, _figure, si_scale

#: Margin around the contact in the zoomed maps, as a fraction of the contact's extent.
MARGIN = 0.15

NM = 1e9
MPA = 1e-6

_OUT, _SLIP, _STICK, _ADH = 0, 1, 2, 3


# ----------------------------------------------------------------------------------------------
# helpers


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

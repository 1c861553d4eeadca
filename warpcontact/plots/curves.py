"""Curves of a run's load path: a pull-off's force-approach curve (:func:`pull_off_curve`), a
fretting run's loops and energies per cycle (:func:`fretting_loop`, :func:`fretting_energy`) and a
contact's area, patches and mean gap against the load (:func:`contact_load`), each from the run's
result (its result.json, or the Python API's dict)."""

from __future__ import annotations

import math

import numpy as np
from matplotlib.figure import Figure

from .base import CONTACT_COLOR, SERIES_COLORS, STICK_COLOR, _figure, si_scale


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


def contact_load(result: dict) -> Figure:
    """The contact area, the number of contact patches (where the result has them: shapes other
    than the sphere) and the mean gap of every state against its normal force F_z (total,
    adhesion included), in the order of the path: what a rough contact is read by."""
    states = result["states"]
    f_scale, f_unit = si_scale([s["force"]["z"] for s in states], "N")
    l_scale, l_unit = si_scale([math.sqrt(s["contact_area"]) for s in states], "m")  # the area in (prefix m)^2
    a_scale, a_unit = l_scale ** 2, f"{l_unit}$^2$"
    g_scale, g_unit = si_scale([s["mean_gap"] for s in states], "m")
    force = [s["force"]["z"] / f_scale for s in states]
    panels = [("contact area", [s["contact_area"] / a_scale for s in states], f"[{a_unit}]")]
    if all(s.get("contact_patches") is not None for s in states):
        panels.append(("contact patches", [s["contact_patches"] for s in states], ""))
    panels.append(("mean gap", [s["mean_gap"] / g_scale for s in states], f"[{g_unit}]"))
    fig = _figure((4.0 * len(panels), 3.6))
    for k, (name, values, unit) in enumerate(panels):
        ax = fig.add_subplot(1, len(panels), k + 1)
        ax.plot(force, values, "-o", ms=3, color=CONTACT_COLOR)
        ax.set_xlabel(f"$F_z$ [{f_unit}]")
        ax.set_ylabel(f"{name} {unit}".strip())
        ax.grid(alpha=0.3)
    fig.suptitle("the contact against the load", fontsize="medium")
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
    from ..physics.reference import mindlin_deresiewicz_loop

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

"""Approach and retraction under displacement control: force-displacement curve and pull-off."""

from __future__ import annotations

import math
import numbers
import time

import numpy as np

from .errors import InputError
from .guards import warn_if_adhesion_at_edge
from .results import state_summary
from .state import ContactState


def tabor_parameter(pair, radius: float, work_of_adhesion: float, length: float) -> float:
    """Tabor's parameter mu = (R w^2 / (E*^2 z0^3))^(1/3) with the law's length z0 [-]."""
    return (radius * work_of_adhesion**2 / (pair.E_star**2 * length**3)) ** (1.0 / 3.0)


def find_jump(branch: list, into_contact: bool) -> dict | None:
    """The jump into contact (``into_contact``) or out of it along one branch of the curve: the
    first pair of consecutive states where the contact area turns from zero to positive (or back).
    Returns delta_z and total F_z [m, N] of the states before and after (the jump lies between
    them: refine the steps to narrow it), or None where the branch has no such pair."""
    for before, after in zip(branch, branch[1:]):
        if (before["contact_area"] > 0) != into_contact and (after["contact_area"] > 0) == into_contact:
            return {"delta_z_before": before["delta"]["z"], "delta_z_after": after["delta"]["z"],
                    "force_before": before["force"]["z"], "force_after": after["force"]["z"]}
    return None


def approach_retract(model, solver, delta_start: float, delta_max: float, delta_end: float, steps: int,
                     on_state=None) -> dict:
    """Solve delta_z from ``delta_start`` up to ``delta_max`` and back down to ``delta_end`` [m],
    ``steps`` equal steps each way. Returns the curve (delta_z [m], total and elastic F_z [N],
    contact and adhesive areas [m^2]), pull_off_force [N] (the most tensile total F_z, negative)
    and where it occurred, the jumps into and out of contact (:func:`find_jump`), and whether
    every state converged. Warns once
    (:class:`~warpcontact.guards.AdhesionAtEdgeWarning`) when the law's tail reaches the domain's
    edge."""
    if isinstance(steps, bool) or not isinstance(steps, numbers.Integral) or steps < 1:
        raise InputError("steps", f"must be an integer >= 1 (steps each way), got {steps!r}")
    t0 = time.perf_counter()
    state = ContactState(model)
    up = np.linspace(delta_start, delta_max, steps + 1)
    down = np.linspace(delta_max, delta_end, steps + 1)[1:]
    curve = []
    converged = True
    edge_warned = False  # the adhesive tail cut by the domain: one warning per curve
    for k, dz in enumerate(np.concatenate([up, down])):
        info = solver.step(state, (0.0, 0.0, float(dz)))
        converged = converged and info.converged
        if not edge_warned:
            edge_warned = warn_if_adhesion_at_edge(state, solver.adhesion, delta_max)
        s = state_summary(state, solver.adhesion)
        s["branch"] = "approach" if k <= steps else "retract"
        curve.append(s)
        if on_state is not None:
            on_state(k, 2 * steps + 1, s)
    forces = np.array([c["force"]["z"] for c in curve])
    i = int(np.argmin(forces))
    return {
        "pull_off_force": float(forces[i]),
        "pull_off_delta_z": curve[i]["delta"]["z"],
        "jump_in": find_jump(curve[: steps + 1], into_contact=True),
        "jump_out": find_jump(curve[steps:], into_contact=False),
        "converged": bool(converged),
        "curve": curve,
        "elapsed_s": time.perf_counter() - t0,
    }

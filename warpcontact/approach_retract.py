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


def approach_retract(model, solver, delta_start: float, delta_max: float, delta_end: float, steps: int,
                     on_state=None) -> dict:
    """Solve delta_z from ``delta_start`` up to ``delta_max`` and back down to ``delta_end`` [m],
    ``steps`` equal steps each way. Returns the curve (delta_z [m], total and elastic F_z [N],
    contact and adhesive areas [m^2]), pull_off_force [N] (the most tensile total F_z, negative)
    and where it occurred, and whether every state converged. Warns once
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
        "converged": bool(converged),
        "curve": curve,
        "elapsed_s": time.perf_counter() - t0,
    }

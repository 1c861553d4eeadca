"""Gross slip and the static friction coefficient (MODEL.md section 7)."""

from __future__ import annotations

import math
import time

import numpy as np

from warpcontact.kernels.tangential import STICK

from ..errors import ConvergenceError, InputError
from ..records.guards import warn_if_adhesion_at_edge
from ..physics.reference import hertz
from ..records.results import state_summary
from ..numerics.state import ContactState


def stick_cells(state) -> int:
    """Number of stick cells of a solved state."""
    return int(np.count_nonzero(state.status.numpy() == STICK))


def estimate_delta_x_max(pair, radius: float, delta_z: float, friction) -> float:
    """Mindlin's delta_x at gross slip with the friction law's slope at zero pressure [m]:
    3 mu P / (16 a) ((2 - nu1)/G1 + (2 - nu2)/G2), mu = Coulomb's mu or Tabor's mu_b, with
    Hertz's P and a for a sphere of ``radius`` [m] at ``delta_z`` [m]."""
    h = hertz(pair, radius, delta_z)
    return mindlin_estimate(pair, h["force"], h["a"], friction)


def mindlin_estimate(pair, force: float, a: float, friction) -> float:
    """Mindlin's delta_x at gross slip [m] for normal force ``force`` [N] on a contact of radius
    ``a`` [m]: 3 mu P / (16 a) ((2 - nu1)/G1 + (2 - nu2)/G2) (the bracket's first step of any shape)."""
    mu = getattr(friction, "mu", None)
    if mu is None:
        mu = friction.mu_b
    return 3.0 * mu * max(force, 0.0) / (16.0 * a) * pair.mindlin_compliance


#: why mu is None: a net tensile (or zero) normal load
MU_UNDEFINED = "F_z <= 0 at gross slip: adhesion holds the sphere in tension, F_x / F_z is not a friction coefficient"


def friction_coefficient(force: dict):
    """F_x / F_z [-] of a force dict [N]; None where F_z <= 0 (adhesion holds the sphere in
    tension, so the ratio is no friction coefficient: never a negative or infinite mu)."""
    return force["x"] / force["z"] if force["z"] > 0 else None


def find_gross_slip(
    model, solver, delta_z: float, normal_steps: int = 4, tangential_steps: int = 10, rel_tol: float = 0.01,
    delta_y: float = 0.0, on_state=None, at_max=None,
) -> dict:
    """Largest delta_x with stick cells left (delta_x_max) and mu = F_x / F_z there.

    The path: delta_z in ``normal_steps`` steps with friction active, then delta_x in steps of
    1/``tangential_steps`` of Mindlin's estimate until a state has no stick cell; then bisection
    between the last stick state and that one, each trial solved from the last stick state (the
    history), until the bracket is narrower than ``rel_tol`` of its lower end.

    Returns a dict: delta_x_max [m] (lower end of the final bracket), delta_x_gross [m] (upper
    end), mu (F_x / F_z, total forces; None with ``mu_note`` where F_z <= 0, see
    ``friction_coefficient``), mu_elastic (F_x / F_z of the contact pressure alone), force and
    force_elastic [N] at delta_x_max, converged (every state on the way converged), the states of
    the path (summaries), elapsed_s, and with ``at_max`` the keys of the dict ``at_max(state)``
    returns for the solved state at delta_x_max (the check of the elastic assumption there:
    ``yielding.state_yield_keys``).
    """
    if isinstance(rel_tol, bool) or not isinstance(rel_tol, (int, float)) or not 0.0 < rel_tol < 1.0:
        raise InputError("rel_tol", f"must lie in (0, 1), got {rel_tol!r}")
    for key, v in (("normal_steps", normal_steps), ("tangential_steps", tangential_steps)):
        if isinstance(v, bool) or not isinstance(v, int) or v < 1:
            raise InputError(key, f"must be an integer >= 1, got {v!r}")
    t0 = time.perf_counter()
    pair, radius = model.pair, model.sphere.radius
    state = ContactState(model)
    path = []
    converged = True

    def solve(st, approach, kind):
        nonlocal converged
        info = solver.step(st, approach)
        converged = converged and info.converged
        summary = state_summary(st, solver.adhesion)
        summary["kind"] = kind
        summary["stick_cells"] = stick_cells(st)
        path.append(summary)
        if on_state is not None:
            on_state(len(path) - 1, summary)
        return summary

    for k in range(1, normal_steps + 1):
        solve(state, (0.0, 0.0, delta_z * k / normal_steps), "normal")
    warn_if_adhesion_at_edge(state, solver.adhesion, delta_z)
    if model.sphere.hertzian:
        step = estimate_delta_x_max(pair, radius, delta_z, solver.friction) / tangential_steps
    else:  # Mindlin's estimate with the solved normal force and contact radius in place of Hertz's
        a = math.sqrt(max(path[-1]["contact_area"], model.grid.cell_area) / math.pi)
        step = mindlin_estimate(pair, path[-1]["force"]["z"], a, solver.friction) / tangential_steps
    last_stick = ContactState(model)
    last_stick.copy_from(state)
    lo, lo_summary, hi = 0.0, path[-1], None
    for k in range(1, 20 * tangential_steps + 1):
        s = solve(state, (k * step, delta_y, delta_z), "load")
        if s["stick_cells"] == 0:
            hi = k * step
            break
        lo, lo_summary = k * step, s
        last_stick.copy_from(state)
    if hi is None:
        raise ConvergenceError(
            f"no gross slip up to delta_x = {20 * tangential_steps * step:.3e} m (20 x Mindlin's estimate with the "
            "friction law's slope): the stick area did not vanish; the interface holds far more than the law's "
            "friction (strong adhesion?)"
        )
    trial = ContactState(model)
    while (hi - lo) > rel_tol * max(lo, 1e-300):
        mid = 0.5 * (lo + hi)
        trial.copy_from(last_stick)
        s = solve(trial, (mid, delta_y, delta_z), "bisect")
        if s["stick_cells"] == 0:
            hi = mid
        else:
            lo, lo_summary = mid, s
            last_stick.copy_from(trial)
    force, elastic = lo_summary["force"], lo_summary["force_elastic"]
    mu = friction_coefficient(force)
    return {
        "delta_x_max": lo,
        "delta_x_gross": hi,
        "mu": mu,
        **({"mu_note": MU_UNDEFINED} if mu is None else {}),
        "mu_elastic": friction_coefficient(elastic),
        "force": force,
        "force_elastic": elastic,
        "converged": bool(converged),
        "stick_area": lo_summary["stick_area"],
        "contact_area": lo_summary["contact_area"],
        **(at_max(last_stick) if at_max is not None else {}),  # the state at delta_x_max
        "states": path,
        "elapsed_s": time.perf_counter() - t0,
    }

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


class GrossSlipSearch:
    """The gross-slip search of one case as a sequence of states to solve, whoever solves them:
    :func:`find_gross_slip` one state at a time, ``studies/batch_solve.py``'s ``gross_slip_batch``
    many cases' states in one batched step.

    The path: delta_z in ``normal_steps`` steps with friction active, then delta_x in steps of
    1/``tangential_steps`` of Mindlin's estimate until a state has no stick cell; then bisection
    between the last stick state and that one, each trial solved from the last stick state (the
    history), until the bracket is narrower than ``rel_tol`` of its lower end.

    ``next()`` gives the next state to solve, (approach (delta_x, delta_y, delta_z) [m], whether
    it starts from the last stick state), or None when the search has ended; ``record(state,
    info)`` takes the solved state and says whether it is the new last stick state (the solver
    keeps it); ``result(last_stick)`` the search's dict (``find_gross_slip``'s).
    """

    def __init__(self, model, friction, adhesion, delta_z: float, normal_steps: int = 4, tangential_steps: int = 10,
                 rel_tol: float = 0.01, delta_y: float = 0.0, on_state=None, at_max=None):
        if isinstance(rel_tol, bool) or not isinstance(rel_tol, (int, float)) or not 0.0 < rel_tol < 1.0:
            raise InputError("rel_tol", f"must lie in (0, 1), got {rel_tol!r}")
        for key, v in (("normal_steps", normal_steps), ("tangential_steps", tangential_steps)):
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise InputError(key, f"must be an integer >= 1, got {v!r}")
        self.t0 = time.perf_counter()
        self.model, self.friction, self.adhesion = model, friction, adhesion
        self.delta_z, self.delta_y = delta_z, delta_y
        self.normal_steps, self.tangential_steps, self.rel_tol = normal_steps, tangential_steps, rel_tol
        self.on_state, self.at_max = on_state, at_max
        self.path: list = []
        self.converged = True
        self.phase, self.k = "normal", 0
        self.step = None  # the load phase's delta_x step [m]
        self.lo, self.lo_summary, self.hi = 0.0, None, None
        self._trial = None  # the bisection's delta_x being solved

    def next(self):
        """The next state: (approach [m], starts from the last stick state), or None at the end."""
        if self.phase == "normal":
            return (0.0, 0.0, self.delta_z * (self.k + 1) / self.normal_steps), False
        if self.phase == "load":
            if self.k >= 20 * self.tangential_steps:
                raise ConvergenceError(
                    f"no gross slip up to delta_x = {20 * self.tangential_steps * self.step:.3e} m (20 x Mindlin's "
                    "estimate with the friction law's slope): the stick area did not vanish; the interface holds "
                    "far more than the law's friction (strong adhesion?)"
                )
            return ((self.k + 1) * self.step, self.delta_y, self.delta_z), False
        if self.phase == "bisect":
            if (self.hi - self.lo) <= self.rel_tol * max(self.lo, 1e-300):
                self.phase = "done"
                return None
            self._trial = 0.5 * (self.lo + self.hi)
            return (self._trial, self.delta_y, self.delta_z), True
        return None

    def record(self, state, info) -> bool:
        """Take the solved state of the last ``next()``; whether it is the new last stick state."""
        self.converged = self.converged and info.converged
        summary = state_summary(state, self.adhesion)
        summary["kind"] = self.phase  # "normal", "load" or "bisect"
        summary["stick_cells"] = stick_cells(state)
        self.path.append(summary)
        if self.on_state is not None:
            self.on_state(len(self.path) - 1, summary)
        self.k += 1
        if self.phase == "normal":
            if self.k < self.normal_steps:
                return False
            warn_if_adhesion_at_edge(state, self.adhesion, self.delta_z)
            model = self.model
            if model.sphere.hertzian:
                estimate = estimate_delta_x_max(model.pair, model.sphere.radius, self.delta_z, self.friction)
            else:  # Mindlin's estimate with the solved normal force and contact radius in place of Hertz's
                a = math.sqrt(max(summary["contact_area"], model.grid.cell_area) / math.pi)
                estimate = mindlin_estimate(model.pair, summary["force"]["z"], a, self.friction)
            self.step = estimate / self.tangential_steps
            self.phase, self.k, self.lo_summary = "load", 0, summary
            return True
        stuck = summary["stick_cells"] > 0
        if self.phase == "load":
            if not stuck:
                self.hi = self.k * self.step
                self.phase = "bisect"
                return False
            self.lo, self.lo_summary = self.k * self.step, summary
            return True
        if stuck:  # bisect
            self.lo, self.lo_summary = self._trial, summary
        else:
            self.hi = self._trial
        return stuck

    def result(self, last_stick) -> dict:
        """The search's dict (:func:`find_gross_slip`), ``last_stick`` the state at delta_x_max."""
        force, elastic = self.lo_summary["force"], self.lo_summary["force_elastic"]
        mu = friction_coefficient(force)
        return {
            "delta_x_max": self.lo,
            "delta_x_gross": self.hi,
            "mu": mu,
            **({"mu_note": MU_UNDEFINED} if mu is None else {}),
            "mu_elastic": friction_coefficient(elastic),
            "force": force,
            "force_elastic": elastic,
            "converged": bool(self.converged),
            "stick_area": self.lo_summary["stick_area"],
            "contact_area": self.lo_summary["contact_area"],
            **(self.at_max(last_stick) if self.at_max is not None else {}),  # the state at delta_x_max
            "states": self.path,
            "elapsed_s": time.perf_counter() - self.t0,
        }


def find_gross_slip(
    model, solver, delta_z: float, normal_steps: int = 4, tangential_steps: int = 10, rel_tol: float = 0.01,
    delta_y: float = 0.0, on_state=None, at_max=None,
) -> dict:
    """Largest delta_x with stick cells left (delta_x_max) and mu = F_x / F_z there.

    The path (:class:`GrossSlipSearch`): delta_z in ``normal_steps`` steps with friction active,
    then delta_x in steps of 1/``tangential_steps`` of Mindlin's estimate until a state has no
    stick cell; then bisection between the last stick state and that one, each trial solved from
    the last stick state (the history), until the bracket is narrower than ``rel_tol`` of its
    lower end.

    Returns a dict: delta_x_max [m] (lower end of the final bracket), delta_x_gross [m] (upper
    end), mu (F_x / F_z, total forces; None with ``mu_note`` where F_z <= 0, see
    ``friction_coefficient``), mu_elastic (F_x / F_z of the contact pressure alone), force and
    force_elastic [N] at delta_x_max, converged (every state on the way converged), the states of
    the path (summaries), elapsed_s, and with ``at_max`` the keys of the dict ``at_max(state)``
    returns for the solved state at delta_x_max (the check of the elastic assumption there:
    ``yielding.state_yield_keys``).
    """
    search = GrossSlipSearch(model, solver.friction, solver.adhesion, delta_z, normal_steps, tangential_steps,
                             rel_tol, delta_y, on_state, at_max)
    return solve_search(search, solver)


def solve_search(search: GrossSlipSearch, solver) -> dict:
    """Run ``search`` with ``solver`` (a ``ContactSolver`` of its model), one state at a time; its
    result dict."""
    model = search.model
    state, last_stick = ContactState(model), ContactState(model)
    while (step := search.next()) is not None:
        approach, from_last_stick = step
        if from_last_stick:
            state.copy_from(last_stick)
        info = solver.step(state, approach)
        if search.record(state, info):
            last_stick.copy_from(state)
    return search.result(last_stick)

"""From a case to solved states: builds the model and solver, walks the load path."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

from . import __version__
from .adhesion import SMC, Dugdale
from .friction import Coulomb, TaborVonMises
from .guards import warn_if_adhesion_at_edge, warn_if_coarse
from .resources import check_fits
from .model import ContactModel
from .results import state_fields, state_summary
from .solvers.contact import ContactSolver
from .state import ContactState


def friction_law(case):
    """The shear-limit law of a case, or None for a frictionless contact."""
    fr = case.friction
    if fr is None:
        return None
    if fr.law == "coulomb":
        return Coulomb(fr.mu)
    kw = {} if fr.k_vm is None else {"k_vm": fr.k_vm}
    return TaborVonMises(fr.k_tau, case.pair.softer.yield_strength, **kw)


def adhesion_law(case):
    """The adhesion law of a case, or None."""
    ad = case.adhesion
    if ad is None:
        return None
    if ad.law == "smc":
        return SMC(ad.sigma_max, ad.tau_max, ad.delta_n, ad.delta_t)
    return Dugdale(ad.sigma_0, ad.h_0)


def build(case):
    """(model, solver, state) for a case; a case that will not fit in memory is refused first."""
    s = case.solver
    check_fits(case.grid.n, s.dtype, s.device, case.friction is not None, s.fft, adhesion=case.adhesion is not None)
    model = ContactModel(case.pair, case.sphere, case.grid, device=s.device, dtype=s.dtype, fft=s.fft)
    cap = case.pair.softer.hardness if case.friction is not None and case.friction.hardness_cap else math.inf
    solver = ContactSolver(model, friction_law(case), tol=s.tol, max_iter=s.max_iter, max_outer=s.max_turns,
                           pressure_cap=cap, adhesion=adhesion_law(case))
    return model, solver, ContactState(model)


@dataclass
class PathResult:
    """Summaries of every solved state of a path, and the fields of each (numpy, SI)."""

    case: object
    model: object
    states: list = field(default_factory=list)
    fields: list = field(default_factory=list)
    elapsed_s: float = 0.0
    interrupted: bool = False

    @property
    def converged(self) -> bool:
        return bool(self.states) and all(s["converged"] for s in self.states)

    def summary(self) -> dict:
        """result.json content: the last state's quantities at top level, every state listed."""
        last = self.states[-1] if self.states else {}
        m = self.model
        return {
            **last,
            "converged": self.converged,
            "interrupted": self.interrupted,
            "n_states": len(self.states),
            "states": self.states,
            "device": str(m.device),
            "dtype": m.dtype_name,
            "fft": m.fft_name,
            "elapsed_s": self.elapsed_s,
            "software": {"warpcontact": __version__},
            "case": self.case.to_dict(),
        }

    def stacked_fields(self) -> dict:
        """Fields of every state stacked along a first axis (state index), plus coordinates."""
        import numpy as np

        out = {k: np.stack([f[k] for f in self.fields]) for k in self.fields[0]} if self.fields else {}
        out["x"] = self.model.grid.x
        out["y"] = self.model.grid.y
        out["delta"] = np.array([[s["delta"]["x"], s["delta"]["y"], s["delta"]["z"]] for s in self.states])
        return out


def run_path(case, on_state=None, keep_fields: bool = True) -> PathResult:
    """Solve every state of the case's load path in order (slip history carried along).

    ``on_state(index, total, summary)`` is called after each state (progress, saving). Warns
    (guards: a coarse contact; the adhesive tail cut by the domain, once per path).
    """
    t0 = time.perf_counter()
    model, solver, state = build(case)
    result = PathResult(case=case, model=model)
    path = case.load.path()
    edge_warned = False  # the adhesive tail cut by the domain: one warning per path
    try:
        for k, approach in enumerate(path):
            solver.step(state, approach)
            warn_if_coarse(state)
            if not edge_warned:
                edge_warned = warn_if_adhesion_at_edge(state, solver.adhesion, case.load.delta_z_max)
            summary = state_summary(state, solver.adhesion)
            result.states.append(summary)
            if keep_fields:
                result.fields.append(state_fields(state, solver.adhesion))
            result.elapsed_s = time.perf_counter() - t0
            if on_state is not None:
                on_state(k, len(path), summary, result)
    except KeyboardInterrupt:
        result.interrupted = True
    result.elapsed_s = time.perf_counter() - t0
    return result

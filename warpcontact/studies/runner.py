"""From a case to solved states: builds the model and solver, walks the load path."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

from .._version import __version__
from ..physics.adhesion import SMC, Dugdale, Exponential, LennardJones93
from ..physics.friction import Coulomb, TaborVonMises
from ..records.guards import RunChecks, warn_if_adhesion_at_edge
from ..numerics.resources import check_fits
from ..numerics.model import ContactModel
from ..records.progress import show_turn
from ..records.results import state_fields, state_summary
from ..solvers.contact import ContactSolver
from ..solvers.settings import SolverSettings
from ..numerics.state import ContactState
from ..numerics.yielding import yield_keys


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
        return SMC(ad.sigma_max, ad.tau_max, ad.delta_n, ad.delta_t, contact_shear=ad.contact_shear or "bounded")
    if ad.law == "exponential":
        return Exponential(ad.w, ad.rho)
    if ad.law == "lj93":
        return LennardJones93(ad.w, ad.z0)
    optional = {k: getattr(ad, k) for k in ("smoothing", "ramps") if getattr(ad, k) is not None}
    return Dugdale(ad.sigma_0, ad.h_0, **optional)


def build_model(case) -> ContactModel:
    """The contact model of a case (materials, sphere, grid, device, float type, FFT backend); a case
    that will not fit in memory is refused first."""
    s = case.solver
    check_fits(case.grid.n, s.dtype, s.device, case.friction is not None, s.fft, adhesion=case.adhesion is not None)
    return ContactModel(case.pair, case.sphere, case.grid, device=s.device, dtype=s.dtype, fft=s.fft)


def pressure_cap(case) -> float:
    """A case's cap of the contact pressure [Pa]: the softer body's hardness where its friction
    law asks for it (``friction.hardness_cap``), else inf."""
    return case.pair.softer.hardness if case.friction is not None and case.friction.hardness_cap else math.inf


def build(case, model=None, **choices):
    """(model, solver, state) for a case. ``model``: a model built for the same materials, sphere,
    grid, device, float type and FFT backend to reuse (:mod:`warpcontact.studies.batch` keeps one per
    worker); by default one is built (:func:`build_model`). ``choices``: solver settings
    (:class:`~warpcontact.solvers.settings.SolverSettings`) beyond the case's ``[solver]`` table."""
    s = case.solver
    if model is None:
        model = build_model(case)
    cap = pressure_cap(case)
    settings = SolverSettings(tol=s.tol, max_iter=s.max_iter, max_turns=s.max_turns, nested=s.nested,
                              nested_float32=s.nested_float32, window=s.window,
                              preconditioner_float32=s.preconditioner_float32,
                              preconditioner_grid=s.preconditioner_grid, response_float32=s.response_float32,
                              **choices)
    # a long step's turns on the progress line open now (solve, gross-slip, pull-off)
    solver = ContactSolver(model, friction_law(case), adhesion_law(case), pressure_cap=cap, settings=settings,
                           on_turn=show_turn)
    return model, solver, ContactState(model)


#: what ``fields`` of :func:`run_path` may keep: every state's fields, the last state's, none
FIELDS_CHOICES = ("all", "last", "none")


@dataclass
class PathResult:
    """Summaries of every solved state of a path, and the fields kept (numpy, SI).

    ``fields`` holds the fields of the states listed in ``field_states`` (their indices in
    ``states``): every state, the last one or none (``run_path``'s ``fields``). ``interrupted``:
    a stop (Ctrl-C, SIGTERM, SIGHUP) ended the path early; ``stop_signal`` names it.
    """

    case: object
    model: object
    states: list = field(default_factory=list)
    fields: list = field(default_factory=list)
    field_states: list = field(default_factory=list)
    elapsed_s: float = 0.0
    interrupted: bool = False
    stop_signal: str | None = None
    #: the elastic assumption checked at the last state (``yielding.yield_check``); None until then
    yield_check: dict | None = None
    #: the messages of the warnings its checks gave, where a batch solved it (``solve_batch``: the
    #: warnings of many cases come together; they are issued as well); empty otherwise
    warnings: list = field(default_factory=list)

    @property
    def converged(self) -> bool:
        return bool(self.states) and all(s["converged"] for s in self.states)

    def summary(self, complete: bool = False) -> dict:
        """result.json content: the last state's quantities at top level, every state listed.

        ``complete``: every state of the path is solved and every output of the run written (the
        caller says so in its last write); False while the run goes on, so that a file left by a
        killed run reads as partial, and after a stop. ``interrupted``: a stop (``stop_signal``)
        ended the path before its last state; the states finished are listed.
        """
        last = self.states[-1] if self.states else {}
        m = self.model
        out = {
            **last,
            "converged": self.converged,
            "complete": bool(complete),
            "interrupted": self.interrupted,
            "n_states": len(self.states),
            "n_states_planned": len(self.case.load.path()),
            "states": self.states,
            "device": str(m.device),
            "dtype": m.dtype_name,
            "fft": m.fft_name,
            "elapsed_s": self.elapsed_s,
            "software": {"warpcontact": __version__},
            "case": self.case.to_dict(),
        }
        if self.interrupted:
            out["stop_signal"] = self.stop_signal
        if self.yield_check is not None:  # a body's von Mises maximum against its yield strength
            out.update(yield_keys(self.yield_check))
        return out

    def stacked_fields(self, in_memory: bool = True) -> dict:
        """The fields kept stacked along a first axis, plus coordinates: ``state_index`` [-] (the
        index in ``states`` of each entry), ``delta`` [m] (each entry's approach x, y, z), ``x``,
        ``y`` [m] (cell centres). ``in_memory`` False: each field a ``files.Stack`` of the states'
        arrays, which ``files.atomic_write_npz`` writes as stacked without a stacked copy (the
        solve command's fields.npz: 1.8 GB at n = 1024 for Figure 2's 16 states)."""
        import numpy as np

        from ..files import Stack

        def stacked(k):
            parts = [f[k] for f in self.fields]
            return np.stack(parts) if in_memory else Stack(parts)

        out = {k: stacked(k) for k in self.fields[0]} if self.fields else {}
        out["x"] = self.model.grid.x
        out["y"] = self.model.grid.y
        out["state_index"] = np.array(self.field_states, dtype=np.int64)
        out["delta"] = np.array([[self.states[i]["delta"][c] for c in "xyz"] for i in self.field_states],
                                dtype=np.float64).reshape(-1, 3)
        return out


class PathRecorder:
    """What a path keeps of each solved state, whoever solved it (``run_path``, the batched
    solves of ``warpcontact.studies.batch_solve``): the summary, the fields asked for, the
    checks' warnings (one each per path), ``on_state``; at the end the last state's yield check.
    Its ``result`` is the path's [`PathResult`][warpcontact.studies.runner.PathResult].

    ``on_state(index, total, summary, result)`` and ``fields`` as ``run_path``'s; ``started``: the
    ``time.perf_counter()`` the path's ``elapsed_s`` counts from (default: now)."""

    def __init__(self, case, model, fields: str = "all", on_state=None, adhesion=None, friction=None,
                 started: float | None = None):
        self.result = PathResult(case=case, model=model)
        self.fields, self.on_state = fields, on_state
        self.adhesion, self.friction = adhesion, friction
        self.total = len(case.load.path())
        self.edge_warned = False  # the adhesive tail cut by the domain: one warning per path
        self.checks = RunChecks(case)  # resolution and yield: one warning each per path
        self.started = time.perf_counter() if started is None else started

    def record(self, k: int, state, sums=None):
        """State ``k`` of the path, solved in ``state``: summarised (``sums``: its summary's sums
        when they are made already, as ``state_summary``'s), its fields kept as asked, ``on_state``
        called (a stop that arrives meanwhile waits until the lists are in step)."""
        from .. import interrupts

        result = self.result
        if not self.edge_warned:
            self.edge_warned = warn_if_adhesion_at_edge(state, self.adhesion, result.case.load.delta_z_max)
        summary = state_summary(state, self.adhesion, sums)
        self.checks.observe(summary, decisive=self.checks.decisive(summary))
        kept = state_fields(state, self.adhesion, self.friction) if self.fields != "none" else None
        with interrupts.deferred():  # the lists, and what on_state writes, stay in step
            result.states.append(summary)
            if kept is not None:
                if self.fields == "last":  # the last finished state's: the one a stop leaves last
                    result.fields.clear()
                    result.field_states.clear()
                result.fields.append(kept)
                result.field_states.append(k)
            result.elapsed_s = time.perf_counter() - self.started
            if self.on_state is not None:
                self.on_state(k, self.total, summary, result)

    def finish(self, state, check: dict | None = None):
        """The last state against the bodies' yield strengths (below the surface), from the
        state's tractions where they are (on the device: nothing copied to the host); ``check``:
        that check already made (``yielding.batch_yield_checks``)."""
        from ..numerics.yielding import state_yield_check

        result = self.result
        if result.states:
            if check is None:
                check = state_yield_check(state, self.friction is not None, self.adhesion is not None)
            result.yield_check = check
            self.checks.yielded(result.yield_check, result.states[-1])


def run_path(case, on_state=None, keep_fields: bool = True, fields: str = "all", on_start=None,
             model=None) -> PathResult:
    """Solve every state of the case's load path in order (slip history carried along).

    ``on_start(result)`` is called once the model is built, before the first state (a first
    write); ``on_state(index, total, summary, result)`` after each state (progress, saving),
    inside :func:`interrupts.deferred`: a stop that arrives while it writes lets it finish, the
    state counted, and is raised after it. ``fields``: whose fields to keep, "all" states', the
    last finished state's ("last") or "none" (``keep_fields=False`` is "none"). A stop (Ctrl-C,
    SIGTERM, SIGHUP) ends the path: the states finished are kept and ``interrupted`` is set; a
    stop during the model's set-up propagates (nothing is solved). Warns once per path each
    (guards): a coarse grid at the deepest approach (:class:`~warpcontact.records.guards.RunChecks`), the
    pressure above a yield strength, the adhesive tail cut by the domain. ``model``: as :func:`build`'s.
    """
    from .. import interrupts

    if fields not in FIELDS_CHOICES:
        raise ValueError(f"fields must be one of {FIELDS_CHOICES}, got {fields!r}")
    if not keep_fields:
        fields = "none"
    t0 = time.perf_counter()
    model, solver, state = build(case, model)
    recorder = PathRecorder(case, model, fields, on_state, solver.adhesion, solver.friction, started=t0)
    result = recorder.result
    try:
        if on_start is not None:
            with interrupts.deferred():
                on_start(result)
        for k, approach in enumerate(case.load.path()):
            solver.step(state, approach)
            recorder.record(k, state)
        recorder.finish(state)
    except KeyboardInterrupt as e:
        result.interrupted = True
        result.stop_signal = interrupts.signal_name(interrupts.stop_signal(e))
    result.elapsed_s = time.perf_counter() - t0
    return result

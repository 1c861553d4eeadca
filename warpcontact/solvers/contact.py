"""One load step of the coupled problem: normal and tangential solves in turns (MODEL.md 4)."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import warp as wp

from warpcontact.kernels import adhesion as ak
from warpcontact.kernels import coupling as ck

from .. import interrupts
from ..numerics.resources import allocation_refused
from ..numerics.state import EDGE_SHARE_AT_FIRST_TURN, SolveInfo, check_contact_fits
from .adhesive import AdhesiveNormalSolver
from .fixed_point import AndersonMixing
from .normal import NormalSolver
from .tangential import TangentialSolver


#: iteration limit of the adhesive minimisation before a step falls back to the fixed point (the
#: Maugis-Dugdale curves at lambda 0.5-2 took 19-460 iterations per state)
ADHESIVE_MAX_ITER = 1000
#: the minimised turns' inner tolerance: TURN_TOL_FACTOR x the last turn's change, at most
#: TURN_TOL_CAP (and at least the solvers' own). Adhesive Table 2 cell k_tau 0.8, delta_z 1e-4 um,
#: n = 64 (80 cells with the adhesive tail), CPU: 1e-4 / 1e-3 took 8 turns at most per state, 113
#: in all, 788 inner iterations; 1e-3 / 1e-2: 13, 170, 792; every solve at full tolerance: 8,
#: 107, 1815. Anderson mixing over the turns (depth 2-5) took more turns with loose solves
#: (199-242) and as many with exact ones, at twice the inner iterations.
TURN_TOL_CAP = 1e-4
#: with adhesion and friction, the turns are lagged (the adhesive tractions a fixed point of their
#: own, updated from the last gap and slip each turn) where the law's Maugis parameter
#: (``adhesion.maugis_parameter``) is under this, the DMT side, and minimised (each turn's normal
#: solve the whole adhesive minimisation) from it on. On the DMT side both converge and the lagged
#: turns cost less: Table 2's adhesive cells (SMC, lambda 0.056), the same delta_x_max and mu
#: within 3e-5 relative, H100 at n = 256: 1.55-2.05 s against 6.25-12.1 s per cell at delta_z =
#: 1e-5 um, 1.10 against 1.85 s at 1e-4 um; 2 CPU cores at n = 48, 12 cells: 23.8 against 27.5 s
#: (``bench/coupled_turns.py``, a probe in git history). Towards JKR the lagged turns crawl or
#: diverge (hundreds of turns per state at Tabor parameter 5.7).
LAGGED_TURNS_MAX_MAUGIS = 0.1
TURN_TOL_FACTOR = 1e-3


#: the lagged turns stall (``stalled``) where their change has not halved in STALL_TURNS
#: turns; from there the shear is mixed by Anderson's method over the last STALL_MIXING_DEPTH
#: turns. The plain turns converge linearly; near the von Mises crossover (p -> S_Y) q_max(p) has
#: an unbounded slope, and a few cells there can hold the plain turns in a cycle for ever
#: (docs/model.md, "The turns").
STALL_TURNS = 10
STALL_MIXING_DEPTH = 5


def stalled(changes) -> bool:
    """Whether the last ``STALL_TURNS`` turns failed to halve the change (the least of the 4
    turns before them against the least of the last 4: a cycle's changes go up and down)."""
    if len(changes) < STALL_TURNS + 4:
        return False
    return min(changes[-4:]) > 0.5 * min(changes[-STALL_TURNS - 4:-STALL_TURNS])


def starting_residual(info) -> float:
    """The relative residual a solve started from (its last residual if it made no iteration)."""
    return info.history[0] if info.iterations > 0 and info.history else info.residual


#: the turns' inner tolerance (``ContactSolver.turn_tolerance``): the first turn's, and the ratio
#: to the measure it follows
TURN_TOL_START = 1e-3
TURN_TOL_RATIO = 0.01
#: the nested start (``ContactSolver.nested``): the coarsest grid solved (cells per side), and the
#: tolerance of the coarse solves (their answer is a starting guess: it needs to be as good as the
#: coarse grid's discretisation, not the fine tolerance)
NESTED_MIN_N = 64
NESTED_COARSE_TOL = 1e-6
#: ``nested = "auto"`` (the default): the nested start from these grids on (cells per side), by
#: device kind: where it was measured to cost less than it saves (bench/scaling.py, rows
#: coupled-precond and coupled-nested side by side; docs/performance.md). 2 CPU cores: 1.1-1.8x
#: faster at n = 512 and 1024 (0.8x at 256); H100: 1.6x and 2.3x at 4096 (float64), even at 1024,
#: slower at 256; at 8192 the plain start did not end a step in 260 s, the nested 18-20 s
NESTED_AUTO_N = {"cpu": 512, "cuda": 2048}


class ContactSolver:
    """Solves a state at given rigid shifts (delta_x, delta_y, delta_z) from the slip history.

    With friction, the normal and the tangential problems are solved in turns, each with the
    other's coupling displacement held fixed (Dundurs coupling on whenever D != 0). With adhesion
    and no friction, a step is one adhesive normal solve (``AdhesiveNormalSolver``: elastic and
    adhesive energy minimised together, non-penetration as a bound), which converges where the
    fixed point below crawls or diverges (large Tabor parameters); where it does not converge in
    ``ADHESIVE_MAX_ITER`` iterations (seen on the DMT side and on coarse grids) the step is solved
    by the fixed point from its iterate.
    With adhesion and friction the turns are of two kinds (``turns``, chosen by the law's Maugis
    parameter against ``LAGGED_TURNS_MAX_MAUGIS``): minimised, each turn's normal solve the whole
    adhesive normal problem (the same minimisation, the shear's coupling held fixed), so that the
    turns are those of the elastic coupling and of the shear limit's dependence on the pressure;
    the SMC law's adhesive shear follows the last gap and slip (``_minimised_turns``); or lagged,
    on the DMT side where they converge and cost less: each turn first updates the adhesive
    tractions from the last gap and slip (Anderson-mixed), and they enter both solves as known
    tractions (MODEL.md section 6). A step whose turns of one kind do not converge in
    ``max_outer`` is solved by the other from its iterate (the lagged ones alone with a hardness
    cap, which the minimisation does not know).
    Turns stop when the contact pressure, the shear and the adhesive tractions all change by
    less than ``outer_tol`` (relative, 2-norm) from one turn to the next, in a turn solved at full
    tolerance. Identical materials without adhesion decouple (D = 0): one turn is exact.

    Args:
        model: the contact model.
        friction: a shear-limit law (``warpcontact.physics.friction``) or None for frictionless contact.
        adhesion: an adhesion law (``warpcontact.physics.adhesion``) or None.
        tol: relative residual of the inner solves (default by dtype, see NormalSolver).
        outer_tol: relative change that ends the turns (default 100 tol: 1e-8 in float64, 1e-3 in
            float32).
        max_iter: iteration limit of each inner solve.
        max_outer: limit on the turns of a step (1000: the adhesive fixed point at Tabor parameter
            5.7 took 493 turns, the Table 2 cells fewer than 200).
        pressure_cap: upper bound of the contact pressure [Pa], e.g. the softer body's hardness
            (elastic-perfectly-plastic surface); inf for none.
        relax: mixing of the adhesive fixed point (``AndersonMixing``'s beta). Its residual is
            |law(h, s) - t| / |law(h, s)|.
        use_graphs: replay the inner solvers' iterations as CUDA graphs (default: on CUDA).
        preconditioned: precondition the normal solves (``NormalSolver.preconditioned``; default
            True). In the turns the plain normal solves took most of a coupled step's iterations
            and grew with the grid (warm-started, each cut its residual by about 0.8 per
            iteration at n = 512-1024); preconditioned, with the residual-based turn tolerance
            (``turn_tolerance``): Table 1 pair, Tabor + von Mises (k_tau 0.8), delta_z = 1e-10 m
            then delta_x = 2e-11 m, R = 10 um, 2 CPU cores: n = 64: 34 and 56 inner iterations
            against 125 and 159; n = 256: 53 and 76 against 163 and 230; n = 1024: 80 and 140
            against 345 and 484 (9.8 s and 18.1 s against 26.0 s and 33.5 s), forces the same
            to 1e-9 (``bench/scaling.py``, rows coupled-precond and coupled-before).
    """

    def __init__(self, model, friction=None, tol=None, outer_tol=None, max_iter: int = 2000, max_outer: int = 1000,
                 pressure_cap: float = math.inf, adhesion=None, relax: float = 0.5, use_graphs: bool | None = None,
                 preconditioned: bool | None = None):
        self.model = model
        self.friction = friction
        self.adhesion = adhesion
        #: the adhesive normal problem as one minimisation (adhesion without friction)
        self.adhesive = None
        #: steps whose minimisation did not converge and were solved by the fixed point instead
        self.adhesive_fallbacks = 0
        #: steps whose turns of the chosen kind did not converge and were solved by the other kind
        self.turn_fallbacks = 0
        #: the turns of a step with adhesion and friction: "minimised" or "lagged" (see the class
        #: docstring; set from the law's Maugis parameter, and "lagged" with a hardness cap)
        self.turns = "lagged"
        if adhesion is not None:
            if math.isfinite(pressure_cap) and friction is None:
                from ..errors import InputError

                raise InputError("solver.pressure_cap", "a hardness cap is not available with adhesion "
                                                        "without friction")
            if not math.isfinite(pressure_cap):  # (the lagged turns alone know the cap)
                self.adhesive = AdhesiveNormalSolver(model, adhesion,
                                                     max_iter=min(int(max_iter), ADHESIVE_MAX_ITER))
                from ..physics.adhesion import maugis_parameter

                dmt = maugis_parameter(adhesion, model.sphere.radius, model.pair.E_star) < LAGGED_TURNS_MAX_MAUGIS
                self.turns = "lagged" if dmt else "minimised"
        self.normal = NormalSolver(model, tol, max_iter, pressure_cap=pressure_cap, use_graphs=use_graphs,
                                   preconditioned=True if preconditioned is None else preconditioned)
        self.tol = self.normal.tol
        self.outer_tol = 100 * self.tol if outer_tol is None else float(outer_tol)
        self.max_outer = int(max_outer)
        self.relax = float(relax)
        #: how the lagged turns set their inner tolerance: "residual" (TURN_TOL_RATIO x the coupled
        #: residual of the last turn: the relative residual its normal solve started from, or its
        #: tangential solve's start where the turn's change confirms it; never looser than the
        #: turn before) or "change" (TURN_TOL_RATIO x the last turn's change, the schedule before:
        #: a turn whose solves started converged measured no change, so the next one solved at
        #: full tolerance; bench/scaling.py's row coupled-before) or "exact" (every turn at the
        #: solvers' own tolerance: fewer, more exact turns; bench/scaling.py's row coupled-exact)
        self.turn_tolerance = "residual"
        #: called after each turn of a step as ``on_turn(turn, change)``: the turn (from 1 in each
        #: run of the turns: a retry or a fallback counts afresh) and its relative change [-], the
        #: number the turns stop on; the progress line shows them during a long step. None: nothing
        #: is called. Made from what each turn reads already (no extra read from the device).
        self.on_turn: Callable[[int, float], None] | None = None
        #: the nested start of a step with friction and no adhesion: the step is solved first on
        #: the grid of half the cells per side over the same domain (itself nested, down to
        #: ``NESTED_MIN_N``), from the fine state's slip history and tractions restricted to it,
        #: and its tractions and cell statuses start the fine step. The slip front then starts
        #: within a coarse cell of its place: the projected tangential iteration moves it by
        #: about one cell per iteration, so from the last state's front a step that moves it far
        #: costs as many iterations as cells it moves (``bench/scaling.py``, row coupled-nested).
        #: Needs an even n with n / 2 >= NESTED_MIN_N; otherwise the step starts as without.
        #: True, False, or "auto": from NESTED_AUTO_N cells per side on (by device kind).
        self.nested: bool | str = "auto"
        #: the minimised turns' shear mixed by Anderson's method (``_minimised_turns``); False: the
        #: plain fixed point x <- G(x) (``bench/scaling.py --adhesion``, rows coupled-precond and
        #: coupled-unmixed). With the SMC law the mixing holds the fourth field it needs only where
        #: the solver chose the minimised turns (``turns``) itself; turns set to "minimised" later,
        #: or reached as a fallback from the lagged ones, run plain
        self.turn_mixing = True
        #: inner iterations of the coarse grids in the last nested start (0 without)
        self.nested_iterations = 0
        self._coarse = None  # (ContactSolver, ContactState) of the half grid, made when first needed
        self._turn_mixing = None  # the lagged turns' mixing after a stall (``_stall_mixing``)
        f = model.field
        self.known_z, self.known_x, self.known_y = f(), f(), f()
        self.previous = [f(), f(), f()]
        self.change = model.scalars(6)
        #: the adhesive tractions' displacements of a turn, and the scratch of a turn's slip and
        #: of the minimised turns' coupling shear: with adhesion only (n = 8192 float64: 0.5 GiB
        #: each)
        self.adhesive_z = self.adhesive_x = self.adhesive_y = self.scratch_x = self.scratch_y = None
        if adhesion is not None:
            # the lagged turns' adhesive fixed point over the pressure (and the shears with friction);
            # the minimised turns' fixed point over the shears (4 fields with the SMC law): one
            # mixing for both, as a step runs one kind of turns at a time (a fourth component only
            # where the minimised turns are the solver's own: a lagged solver's fallback to them
            # runs them plain)
            components = 1
            if friction is not None:
                components = 4 if adhesion.has_shear and self.turns == "minimised" else 3
            self.mixing = AndersonMixing(model, components, beta=self.relax)
            self.adhesive_z, self.adhesive_x, self.adhesive_y = f(), f(), f()
        if friction is not None:
            self.tangential = TangentialSolver(model, tol, max_iter, use_graphs=use_graphs)
            self.target_x, self.target_y = f(), f()
            self.shear_limit = f()
            if adhesion is not None:
                self.scratch_x, self.scratch_y = f(), f()
            if self.adhesive is not None:  # the minimised turns: the shear their normal solves hold fixed
                self.has_adhesive_shear = adhesion.has_shear
                self.coupling_shear = [f() for _ in range(4 if self.has_adhesive_shear else 2)]
                self.total_pressure, self.scratch_z = f(), f()

    @property
    def coupled(self) -> bool:
        return self.friction is not None and self.model.operator.coupled

    @property
    def iterative(self) -> bool:
        """Whether a step needs turns (coupling or adhesion)."""
        return self.coupled or self.adhesion is not None

    def _known_displacements(self, state, normal: bool = True, tangential: bool = True):
        """Displacements of the tractions held fixed in a turn: the coupling of the other unknown,
        plus the adhesive tractions' (computed once per update in ``_update_adhesion``). ``normal``:
        known_z, for a normal solve (from the shear); ``tangential``: known_x, known_y, for a
        tangential solve (the adhesive tractions' alone: the tangential solve adds the pressure's
        K_tp p itself, on the window it solves on). Each solve of a turn needs only its own: half the
        transforms of making all three before each. With the solves' shortcuts of a turn (no
        second convolution where a solve settles at once, ``displacement_current``), a coupled
        step at n = 256 (``bench_iteration.py``'s, CPU) made 855 forward transforms instead of 929,
        the adhesive one 1436 instead of 1754 (42 turns instead of 46: the iterates differ in
        rounding from the second turn on)."""
        m = self.model
        if normal:
            self.known_z.zero_()
            if self.coupled:
                m.operator.cross_normal(state.shear_x, state.shear_y, self.known_z)
            if self.adhesion is not None:
                m.launch(ak.add_to, dim=m.n_cells, inputs=[self.adhesive_z.flatten()], outputs=[self.known_z.flatten()])
        if tangential:  # (the pressure's coupling K_tp p: the tangential solve adds it, on its window)
            self.known_x.zero_()
            self.known_y.zero_()
            if self.adhesion is not None and self.friction is not None:
                for src, dst in ((self.adhesive_x, self.known_x), (self.adhesive_y, self.known_y)):
                    m.launch(ak.add_to, dim=m.n_cells, inputs=[src.flatten()], outputs=[dst.flatten()])

    def _update_slip(self, state, dx, dy, final: bool = False):
        """state.slip <- delta - u_t for the current tractions, u_t = K_tt q (state.disp_x/y)
        plus the known displacements. The total u_t goes to state.disp_x/y only when ``final``
        (during the turns state.disp_x/y must stay K_tt q)."""
        m = self.model
        L = m.length_scale
        self.tangential.whole_displacement(state)  # where the last solve left them on its window
        known_x = self.known_x if self.iterative else self.tangential.no_displacement
        known_y = self.known_y if self.iterative else self.tangential.no_displacement
        m.launch(
            ck.accumulate_slip,
            dim=m.n_cells,
            inputs=[state.disp_x.flatten(), state.disp_y.flatten(), known_x.flatten(), known_y.flatten(),
                    m.scalar(dx / L), m.scalar(dy / L)],
            outputs=[state.slip_x.flatten(), state.slip_y.flatten(),
                     (state.disp_x if final else self.scratch_x).flatten(), (state.disp_y if final else self.scratch_y).flatten()],
        )

    def step(self, state, approach) -> SolveInfo:
        """Solve ``state`` at ``approach`` = (delta_x, delta_y, delta_z) [m].

        ``state`` holds the previous state of the path (its slip is the history s_prev; its
        tractions are the starting guess) and is overwritten with the new one.
        """
        m = self.model
        dx, dy, dz = (float(a) for a in approach)
        L = m.length_scale
        spent_iterations = spent_turns = 0  # of a first attempt that did not converge (reported in the step's)
        if self.adhesive is not None and self.friction is None:  # adhesion without friction: one adhesive solve
            for a in (state.shear_x, state.shear_y, state.adhesive_shear_x, state.adhesive_shear_y):
                a.zero_()
            info = self.adhesive.solve(state, dz)
            if info.converged or not hasattr(self.adhesion, "tractions"):  # a law with no fixed point to fall to
                state.approach = (dx, dy, dz)
                info = SolveInfo(converged=info.converged, iterations=info.iterations, residual=info.residual,
                                 outer_iterations=1, history=info.history)
                state.info = info
                check_contact_fits(state)
                return info
            # not converged in ADHESIVE_MAX_ITER: the lagged fixed point below from its iterate
            # (measured: at Tabor parameter 0.07, n = 64, and at n = 32 the minimisation stalls on
            # some states where the fixed point converges: the DMT side)
            self.adhesive_fallbacks += 1
            spent_iterations += info.iterations
        if self.friction is None:
            state.shear_x.zero_()
            state.shear_y.zero_()
        else:
            m.launch(
                ck.stick_target,
                dim=m.n_cells,
                inputs=[state.slip_x.flatten(), state.slip_y.flatten(), m.scalar(dx / L), m.scalar(dy / L)],
                outputs=[self.target_x.flatten(), self.target_y.flatten()],
            )
        if self.adhesive is not None and self.friction is not None and self.turns == "minimised":
            info = self._minimised_turns(state, dx, dy, dz)
            if info.converged or not hasattr(self.adhesion, "tractions"):
                state.approach = (dx, dy, dz)
                state.info = info
                check_contact_fits(state)
                return info
            # not converged: the lagged turns below from its iterate (its work counted in the step's)
            self.turn_fallbacks += 1
            spent_iterations += info.iterations
            spent_turns += info.outer_iterations
        self.nested_iterations = 0
        if self.uses_nested and self.friction is not None and self.adhesion is None:
            self._nested_start(state, (dx, dy, dz))
        normal_info, tangential_info, outer, converged_turns, iterations = self._turns(state, dx, dy, dz)
        iterations += spent_iterations
        outer += spent_turns
        if self.adhesion is not None and not converged_turns:
            # The warm start can sit where a solution no longer exists (the jump out of contact
            # after pull-off): the same step once more from zero tractions. At Tabor parameter 5.7
            # (n = 128) the last state of the retraction, past pull-off, did not converge in 1000
            # turns from the previous state's tractions; from a fresh state it converges in 11.
            for a in (state.pressure, state.shear_x, state.shear_y, state.adhesive_pressure, state.adhesive_shear_x,
                      state.adhesive_shear_y):
                a.zero_()
            normal_info, tangential_info, retry_outer, converged_turns, retry_iterations = self._turns(state, dx, dy, dz)
            outer += retry_outer
            iterations += retry_iterations
            if not converged_turns and self.adhesive is not None and self.friction is not None \
                    and self.turns == "lagged":  # the minimised turns from this iterate
                self.turn_fallbacks += 1
                info = self._minimised_turns(state, dx, dy, dz)
                if info.converged:
                    info = SolveInfo(converged=True, iterations=iterations + info.iterations,
                                     residual=info.residual, outer_iterations=outer + info.outer_iterations,
                                     history=info.history)
                    state.approach = (dx, dy, dz)
                    state.info = info
                    check_contact_fits(state)
                    return info
        if self.iterative:  # gap and u_z with the final tractions held fixed
            # known_x, known_y: the last turn's adhesive part; _update_slip adds the pressure's
            # K_tp p where the last tangential solve left it to make (and nothing reads them
            # without friction)
            self._known_displacements(state, tangential=False)
            final = self.normal.solve(state, dz, self.known_z, displacement_current=True)  # as the turns left it
            iterations += final.iterations
            normal_info = final
            if self.friction is not None:
                self._update_slip(state, dx, dy, final=True)
        state.approach = (dx, dy, dz)
        residual = max(normal_info.residual, tangential_info.residual if tangential_info else 0.0)
        converged = normal_info.converged and (tangential_info is None or tangential_info.converged) and converged_turns
        info = SolveInfo(converged=bool(converged), iterations=iterations, residual=residual, outer_iterations=outer,
                         history=normal_info.history)
        state.info = info
        check_contact_fits(state)
        return info

    @property
    def uses_nested(self) -> bool:
        """Whether a step with friction and no adhesion starts nested (``nested``; "auto": n of at
        least NESTED_AUTO_N of the device's kind)."""
        if self.nested == "auto":
            kind = "cuda" if self.model.device.is_cuda else "cpu"
            return self.model.grid.n >= NESTED_AUTO_N[kind]
        return bool(self.nested)

    def _coarse_pair(self):
        """The solver and state of the half grid (``nested``), or None where n does not halve."""
        m = self.model
        n = m.grid.n
        if n % 2 or n // 2 < NESTED_MIN_N:
            return None
        if self._coarse is None:
            from ..physics.geometry import Grid
            from ..numerics.state import ContactState

            coarse_model = m.on_grid(Grid(n // 2, m.grid.size))
            tol = max(self.tol, NESTED_COARSE_TOL)
            coarse = ContactSolver(coarse_model, self.friction, tol=tol, max_iter=self.normal.max_iter,
                                   max_outer=self.max_outer, pressure_cap=self.normal.pressure_cap,
                                   use_graphs=self.normal.use_graphs)
            coarse.turn_tolerance = self.turn_tolerance
            coarse.nested = True
            self._coarse = (coarse, ContactState(coarse_model))
        return self._coarse

    def _nested_start(self, state, approach) -> None:
        """Solve the step on the half grid from ``state`` restricted to it, and start ``state``'s
        step from its tractions and statuses (``nested``). A coarse step that does not converge
        leaves ``state`` as it was."""
        from warpcontact.kernels import grids as gk

        pair = self._coarse_pair()
        if pair is None:
            return
        coarse, cstate = pair
        coarse.tangential.window = self.tangential.window
        m, cm = self.model, coarse.model
        half = cm.grid.shape
        for name, scale in (("slip_x", 0.5), ("slip_y", 0.5), ("pressure", 1.0), ("shear_x", 1.0), ("shear_y", 1.0)):
            wp.launch(gk.restrict_mean, dim=half, inputs=[getattr(state, name), m.scalar(scale)],
                      outputs=[getattr(cstate, name)], device=m.device)
        wp.launch(gk.restrict_status, dim=half, inputs=[state.status], outputs=[cstate.status], device=m.device)
        info = coarse.step(cstate, approach)
        self.nested_iterations = info.iterations + coarse.nested_iterations
        if not info.converged:
            return
        for name in ("pressure", "shear_x", "shear_y"):
            wp.launch(gk.prolong_constant, dim=m.grid.shape, inputs=[getattr(cstate, name)],
                      outputs=[getattr(state, name)], device=m.device)
        wp.launch(gk.prolong_constant, dim=m.grid.shape, inputs=[cstate.status], outputs=[state.status],
                  device=m.device)

    def _turns(self, state, dx: float, dy: float, dz: float):
        """The turns of a step from the tractions in ``state``: (normal info, tangential info,
        turns, whether the turns converged, inner iterations)."""
        m = self.model
        iterations = 0
        normal_info = tangential_info = None
        for prev, cur in zip(self.previous, (state.pressure, state.shear_x, state.shear_y)):
            wp.copy(prev, cur)
        change = math.inf
        coupled = math.inf  # the coupled residual (below)
        outer = 0
        converged_turns = not self.iterative
        changes = []  # each turn's change (the stall test); None once a stall was met
        mixing = None  # Anderson mixing of the shear, from a stall on
        while outer < self.max_outer:
            interrupts.check()
            outer += 1
            # inexact turns: early ones solve loosely, the last one at full tolerance
            if not self.iterative or self.turn_tolerance == "exact":
                turn_tol = self.tol
            elif self.turn_tolerance == "change":  # 1/100 of the last turn's change
                turn_tol = max(self.tol, min(TURN_TOL_START, TURN_TOL_RATIO * change))
            else:  # 1/100 of the coupled residual, never looser than the last turn's
                turn_tol = max(self.tol, min(TURN_TOL_START if outer == 1 else turn_tol, TURN_TOL_RATIO * coupled))
            adhesive_change = self._update_adhesion(state, first=outer == 1) if self.adhesion is not None else 0.0
            if self.iterative:
                self._known_displacements(state, tangential=False)
            # from the second turn on, state.disp_z is K p of the pressure the last turn's solve left
            normal_info = self.normal.solve(state, dz, self.known_z if self.iterative else None, tol=turn_tol,
                                            displacement_current=outer > 1)
            iterations += normal_info.iterations
            if outer == 1 and self.iterative:  # a contact far past the domain's edge: stop now, not at max_outer
                check_contact_fits(state, (dx, dy, dz), EDGE_SHARE_AT_FIRST_TURN)
            if self.friction is not None:
                self.friction.shear_limit(m, state.pressure.flatten(), self.shear_limit.flatten())
                if self.iterative:
                    self._known_displacements(state, normal=False)
                tangential_info = self.tangential.solve(
                    state, self.target_x, self.target_y, self.shear_limit,
                    self.known_x if self.iterative else None, self.known_y if self.iterative else None, tol=turn_tol,
                    pressure=state.pressure if self.coupled else None, whole=False,
                )
                iterations += tangential_info.iterations
                if self.adhesion is not None:  # the adhesive shear follows the current slip
                    self._update_slip(state, dx, dy)
                elif not self.iterative:
                    self._update_slip(state, dx, dy, final=True)
            if not self.iterative:
                break
            if mixing is not None:  # x <- Anderson's next shear from G(x) (the state's shear)
                change = max(self._mixed_change(state, mixing), adhesive_change)
            else:
                change = max(self._relative_change(state), adhesive_change)
            # the coupled residual: where the normal solve started (how far the last tangential
            # update moved its problem), and where the tangential one started, as far as the
            # turn's change confirms it (the plain tangential solve reclassifies its slip cells
            # at every start, which alone can make a start residual of 1e-2)
            tangential_start = starting_residual(tangential_info) if tangential_info is not None else 0.0
            coupled = max(starting_residual(normal_info), min(change, tangential_start))
            if self.on_turn is not None:
                self.on_turn(outer, change)
            if change < self.outer_tol and turn_tol == self.tol:
                converged_turns = True
                break
            if mixing is not None:  # not converged: the next turn from the mixed shear
                wp.copy(state.shear_x, self.previous[1])
                wp.copy(state.shear_y, self.previous[2])
            elif changes is not None and self.friction is not None:
                changes.append(change)
                if stalled(changes):  # one try per step: no room for the mixing leaves the turns plain
                    mixing = self._stall_mixing()
                    changes = None
        return normal_info, tangential_info, outer, converged_turns, iterations

    def _stall_mixing(self):
        """The Anderson mixing of the lagged turns' shear after a stall (``stalled``), made when
        first needed; None where the device has no room for it (the turns go on unmixed)."""
        if self._turn_mixing is None:
            try:
                self._turn_mixing = AndersonMixing(self.model, 2, beta=1.0, depth=STALL_MIXING_DEPTH)
            except (MemoryError, RuntimeError) as e:
                if not allocation_refused(e):
                    raise
                return None
        self._turn_mixing.reset()
        return self._turn_mixing

    def _mixed_change(self, state, mixing) -> float:
        """A turn's change with the shear mixed: the larger of the pressure's relative change and
        |G(x) - x| / |G(x)| of the shear (G(x): the shear the turn's tangential solve returned, in
        ``state``; x: the shear it started from, in ``self.previous``, which then holds Anderson's
        next shear)."""
        m = self.model
        self.change.zero_()
        m.launch_reduce(ck.change_sums, [state.pressure.flatten(), 0], [self.previous[0].flatten(), self.change])
        for image, shear in zip(mixing.residual, (state.shear_x, state.shear_y)):
            wp.copy(image, shear.flatten())
        shear_change = mixing.step([self.previous[1].flatten(), self.previous[2].flatten()])
        s = self.change.numpy().astype(np.float64)
        dp = math.sqrt(s[0] / s[1]) if s[1] > 0 else 0.0
        return max(dp, shear_change)

    def _minimised_turns(self, state, dx: float, dy: float, dz: float) -> SolveInfo:
        """A step with adhesion and friction: turns whose normal solve is the whole adhesive
        normal problem (``AdhesiveNormalSolver``, the shear's coupling held fixed), so that the
        turns are those of the elastic coupling and of the shear limit's dependence on the
        pressure alone.

        A turn maps the shear x that its normal solve holds fixed (with the SMC law: and the
        adhesive shear) to the shear its tangential solve returns (and the law's adhesive shear
        at the new gap and slip); the next turn's x is Anderson's combination of the turns so far
        (``AndersonMixing`` with beta = 1: the first turn's is G(x)). The plain iteration x <- G(x)
        contracts by a constant factor per turn (about 0.62 on ``bench/scaling.py --adhesion``'s
        problem: 30-34 turns at n = 128), which Anderson's least squares removes (12-14 turns:
        ``turn_mixing``). The change of a turn is the larger of |G(x) - x| / max(|G(x)|, |p|) and
        the relative change of the total normal traction p. Early turns solve loosely (tolerance
        ``TURN_TOL_FACTOR`` x the last change, at most ``TURN_TOL_CAP``); the turns end when the
        change is under ``outer_tol`` in a turn solved at full tolerance, and the normal solve is
        then made once more against the final shear G(x)."""
        m = self.model
        x = self.coupling_shear
        sources = [state.shear_x, state.shear_y]
        if self.has_adhesive_shear:
            sources += [state.adhesive_shear_x, state.adhesive_shear_y]
        for src, dst in zip(sources, x):
            wp.copy(dst, src)
        mixing = self.mixing
        mixing.reset()
        mixed = self.turn_mixing and len(mixing.residual) >= len(x)
        iterations = outer = 0
        change = math.inf
        converged = False
        tangential_info = None
        while outer < self.max_outer:
            interrupts.check()
            outer += 1
            turn_tol = max(self.tol, min(TURN_TOL_CAP, TURN_TOL_FACTOR * change))
            normal_info = self._adhesive_normal(state, dz, x, max(self.adhesive.tol, turn_tol), warm=outer > 1)
            iterations += normal_info.iterations
            if outer == 1:  # a contact far past the domain's edge: stop now, not at max_outer
                check_contact_fits(state, (dx, dy, dz), EDGE_SHARE_AT_FIRST_TURN)
            self.friction.shear_limit(m, state.pressure.flatten(), self.shear_limit.flatten())
            # the total normal traction, and (slots 0, 1) its change since the last turn
            wp.copy(self.total_pressure, state.pressure)
            m.launch(ak.add_to, dim=m.n_cells, inputs=[state.adhesive_pressure.flatten()],
                     outputs=[self.total_pressure.flatten()])
            self.change.zero_()
            m.launch_reduce(ck.change_sums, [self.total_pressure.flatten(), 0],
                            [self.previous[0].flatten(), self.change])
            self._tangential_known(state, x)
            tangential_info = self.tangential.solve(state, self.target_x, self.target_y, self.shear_limit,
                                                    self.known_x, self.known_y, tol=turn_tol, whole=False)
            iterations += tangential_info.iterations
            self._update_slip(state, dx, dy)
            if self.has_adhesive_shear:  # the law's adhesive shear at the turn's gap and slip
                self.adhesion.tractions(m, state, self.scratch_z, self.scratch_x, self.scratch_y)
                wp.copy(state.adhesive_shear_x, self.scratch_x)
                wp.copy(state.adhesive_shear_y, self.scratch_y)
            # x <- the next iterate from G(x) (the mixing's norms: |G(x) - x|^2 and |G(x)|^2)
            if mixed:
                for src, image in zip(sources, mixing.residual):
                    wp.copy(image, src.flatten())
                mixing.step([a.flatten() for a in x], beta=1.0)
            else:  # (slots 2, 3) of the change, and x <- G(x)
                for src, dst in zip(sources, x):
                    m.launch_reduce(ck.change_sums, [src.flatten(), 2], [dst.flatten(), self.change])
            sums = self.change.numpy().astype(np.float64)
            shear_sums = mixing.norms if mixed else (sums[2], sums[3])
            pressure_change = math.sqrt(sums[0] / sums[1]) if sums[1] > 0 else 0.0
            scale = max(shear_sums[1], sums[1])
            shear_change = math.sqrt(shear_sums[0] / scale) if scale > 0 else 0.0
            change = max(pressure_change, shear_change)
            if self.on_turn is not None:
                self.on_turn(outer, change)
            if change < self.outer_tol and turn_tol == self.tol and normal_info.converged:
                converged = tangential_info.converged
                break
        for src, dst in zip(sources, x):  # the final normal solve against the shear G(x) the state holds
            wp.copy(dst, src)
        final = self._adhesive_normal(state, dz, x, self.adhesive.tol, warm=True)
        iterations += final.iterations
        self._update_slip(state, dx, dy, final=True)
        converged = converged and final.converged
        residual = max(final.residual, tangential_info.residual if tangential_info else 0.0)
        return SolveInfo(converged=bool(converged), iterations=iterations, residual=residual, outer_iterations=outer,
                         history=final.history)

    def _adhesive_normal(self, state, dz: float, shear, tol: float, warm: bool = False) -> SolveInfo:
        """The adhesive normal solve with the normal displacement of ``shear`` (contact shear
        x, y [and adhesive shear x, y]) held fixed; zero unless the materials are coupled."""
        m = self.model
        self.known_z.zero_()
        if self.coupled:
            wp.copy(self.scratch_x, shear[0])
            wp.copy(self.scratch_y, shear[1])
            if len(shear) > 2:
                m.launch(ak.add_to, dim=m.n_cells, inputs=[shear[2].flatten()], outputs=[self.scratch_x.flatten()])
                m.launch(ak.add_to, dim=m.n_cells, inputs=[shear[3].flatten()], outputs=[self.scratch_y.flatten()])
            m.operator.cross_normal(self.scratch_x, self.scratch_y, self.known_z)
        return self.adhesive.solve(state, dz, self.known_z, tol=tol, warm=warm)

    def _tangential_known(self, state, shear):
        """known_x, known_y <- the tangential displacement of the total normal traction
        (``total_pressure``; coupling only) and of the adhesive shear ``shear[2:]`` (if any), held
        fixed in the tangential solve."""
        m = self.model
        if not self.coupled and len(shear) == 2:
            self.known_x.zero_()
            self.known_y.zero_()
            return
        if len(shear) == 2:
            m.operator.cross_tangential(self.total_pressure, self.known_x, self.known_y)
            return
        if not self.coupled:
            self.scratch_z.zero_()
            pressure = self.scratch_z
        else:
            pressure = self.total_pressure
        m.operator.coupled_apply(pressure, shear[2], shear[3], self.scratch_z, self.known_x, self.known_y)

    def _update_adhesion(self, state, first: bool) -> float:
        """One accelerated step of the adhesive fixed point t = law(h, s) (history reset on the
        ``first`` turn of a step), then the adhesive tractions' displacements for the turn.
        Returns the residual |law - t| / |law| before the step."""
        m = self.model
        mixing = self.mixing
        if first:
            mixing.reset()
        if self.friction is not None:
            iterates = (state.adhesive_pressure, state.adhesive_shear_x, state.adhesive_shear_y)
            self.adhesion.tractions(m, state, *mixing.residual[:3])
        else:  # the adhesive shear does not act back without friction: taken as the law gives it
            iterates = (state.adhesive_pressure,)
            self.adhesion.tractions(m, state, mixing.residual[0], state.adhesive_shear_x, state.adhesive_shear_y)
        residual = mixing.step(iterates)
        op = m.operator
        if self.friction is not None:  # the adhesive tractions' displacements, for the whole turn
            op.coupled_apply(state.adhesive_pressure, state.adhesive_shear_x, state.adhesive_shear_y,
                             self.adhesive_z, self.adhesive_x, self.adhesive_y)
        else:
            op.normal(state.adhesive_pressure, self.adhesive_z)
        return residual

    def _relative_change(self, state) -> float:
        """Largest relative change of pressure and shear since the last turn; updates the copies."""
        m = self.model
        self.change.zero_()
        for slot, (prev, cur) in zip((0, 2, 4), zip(self.previous, (state.pressure, state.shear_x, state.shear_y))):
            m.launch_reduce(ck.change_sums, [cur.flatten(), slot], [prev.flatten(), self.change])
        s = self.change.numpy().astype(np.float64)
        dp = math.sqrt(s[0] / s[1]) if s[1] > 0 else 0.0
        qn = s[3] + s[5]
        dq = math.sqrt((s[2] + s[4]) / qn) if qn > 0 else 0.0
        return max(dp, dq)

"""The ways a coupled step is solved (its strategies), behind ``ContactSolver.step``.

A strategy solves a step of a [`ContactSolver`][warpcontact.solvers.contact.ContactSolver] from the
tractions in the state, with the solver's buffers and inner solvers, and returns its
[`SolveInfo`][warpcontact.numerics.state.SolveInfo]; the solver tries its strategies in order, the
next from the last one's iterate, until one converges (``ContactSolver.strategies``):

- [`AdhesiveSolve`][warpcontact.solvers.turns.AdhesiveSolve]: adhesion without friction, one adhesive normal minimisation;
- [`LaggedTurns`][warpcontact.solvers.turns.LaggedTurns]: normal and tangential solves in turns, each holding the other's coupling
  displacement (and the adhesive tractions, a fixed point of their own) fixed;
- [`MinimisedTurns`][warpcontact.solvers.turns.MinimisedTurns]: with adhesion and friction, turns whose normal solve is the whole
  adhesive minimisation;
- [`NestedStart`][warpcontact.solvers.turns.NestedStart]: a wrapper that starts any of them from the step solved on the grid of
  half the cells per side.

Which strategies a step uses, and why: docs/model.md, "The turns".
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import warp as wp

from warpcontact.kernels import adhesion as ak
from warpcontact.kernels import coupling as ck

from .. import interrupts
from ..numerics.resources import allocation_refused
from ..numerics.state import EDGE_SHARE_AT_FIRST_TURN, SolveInfo, check_contact_fits
from .fixed_point import LocalAndersonMixing
from .settings import NESTED_FLOAT32_AUTO, float32_chosen

#: the minimised turns' inner tolerance: TURN_TOL_FACTOR x the last turn's change, at most
#: TURN_TOL_CAP (and at least the solvers' own): loose early turns cost fewer inner iterations
TURN_TOL_CAP = 1e-4
TURN_TOL_FACTOR = 1e-3
#: the lagged turns' inner tolerance (``SolverSettings.turn_tolerance``): the first turn's, and
#: the ratio to the measure it follows
TURN_TOL_START = 1e-3
TURN_TOL_RATIO = 0.01
#: the lagged turns stall (``stalled``) where their change has not halved in STALL_TURNS turns;
#: from there the shear is mixed by Anderson's method with coefficients of each cell's own
#: (``LocalAndersonMixing``: cycles of a few cells at the von Mises crossover, docs/model.md,
#: "The turns' stall")
STALL_TURNS = 10
#: the nested start: the coarsest grid solved (cells per side), and the tolerance of the coarse
#: solves (a starting guess needs the coarse grid's accuracy, not the fine tolerance)
NESTED_MIN_N = 64
NESTED_COARSE_TOL = 1e-6


def stalled(changes) -> bool:
    """Whether the last ``STALL_TURNS`` turns failed to halve the change (the least of the 4
    turns before them against the least of the last 4: a cycle's changes go up and down)."""
    if len(changes) < STALL_TURNS + 4:
        return False
    return min(changes[-4:]) > 0.5 * min(changes[-STALL_TURNS - 4:-STALL_TURNS])


def ratio(change: float, norm: float) -> float:
    """sqrt(change / norm): a relative change from the sums of ``change_sums`` (0 where the norm is)."""
    return math.sqrt(change / norm) if norm > 0 else 0.0


def starting_residual(info) -> float:
    """The relative residual a solve started from (its last residual if it made no iteration)."""
    return info.history[0] if info.iterations > 0 and info.history else info.residual


class AdhesiveSolve:
    """Adhesion without friction: the step is one adhesive normal solve (elastic and adhesive
    energy minimised together, non-penetration as a bound: ``AdhesiveNormalSolver``)."""

    #: the solver's counter of steps this strategy handed on unconverged
    fallback_counter = "adhesive_fallbacks"

    def __init__(self, solver):
        self.solver = solver

    def solve(self, state, dx: float, dy: float, dz: float) -> SolveInfo:
        for a in (state.shear_x, state.shear_y, state.adhesive_shear_x, state.adhesive_shear_y):
            a.zero_()
        info = self.solver.adhesive.solve(state, dz)
        return SolveInfo(converged=info.converged, iterations=info.iterations, residual=info.residual,
                         outer_iterations=1, history=info.history)


class LaggedTurns:
    """Normal and tangential solves in turns, each with the other's coupling displacement held
    fixed; with adhesion, each turn first updates the adhesive tractions from the last gap and
    slip (Anderson-mixed) and they enter both solves as known tractions (MODEL.md section 6).

    Turns stop when the pressure, the shear and the adhesive tractions change by less than
    ``outer_tol`` (relative, 2-norm) in a turn solved at full tolerance; early turns solve loosely
    (``SolverSettings.turn_tolerance``). Turns that stall (``stalled``) are Anderson-mixed from
    there. With adhesion, turns that do not converge are tried once more from zero tractions (the
    warm start can sit where no solution is left: the jump out of contact after pull-off). The
    step ends with a normal solve against the final tractions (its gap and u_z)."""

    fallback_counter = "turn_fallbacks"
    #: the mixing made at the first stall, from the model (bench/path_parts.py --stall-mixing
    #: global replaces it by a function, as a staticmethod)
    stall_mixing_type = LocalAndersonMixing

    def __init__(self, solver):
        self.solver = solver
        self._stall_mixing = None  # made at the first stall

    def solve(self, state, dx: float, dy: float, dz: float) -> SolveInfo:
        s = self.solver
        on_window = s.settings.window_turns and s.iterative and s.friction is not None and s.adhesion is None
        normal_info, tangential_info, outer, converged, iterations, judged = self._turns(state, dx, dy, dz, on_window)
        if s.adhesion is not None and not converged:  # once more from zero tractions
            for a in (state.pressure, state.shear_x, state.shear_y, state.adhesive_pressure, state.adhesive_shear_x,
                      state.adhesive_shear_y):
                a.zero_()
            normal_info, tangential_info, retry_outer, converged, retry_iterations, judged = self._turns(
                state, dx, dy, dz, on_window)
            outer += retry_outer
            iterations += retry_iterations
        if s.iterative:  # gap and u_z with the final tractions held fixed
            # known_x, known_y: the last turn's adhesive part; update_slip adds the pressure's
            # K_tp p where the last tangential solve left it to make
            while True:
                s.known_displacements(state, tangential=False)
                normal_info = s.normal.solve(state, dz, s.known_z, displacement_current=judged)
                iterations += normal_info.iterations
                if judged or not converged or s.pressure_change(state) < s.outer_tol:
                    break
                # the whole grid moved the window turns' answer (a contact grown past their window)
                # by more than a turn may: the turns again from it, each normal solve judged (not
                # where the window turns did not converge: a problem restricted to a window is as
                # well posed as the whole one, and turns that stall there stall on the whole grid:
                # Figure 2a's path with the hardness cap at n = 4096, states 3 and 4, either way)
                normal_info, tangential_info, more, converged, more_iterations, judged = self._turns(
                    state, dx, dy, dz, on_window=False)
                outer += more
                iterations += more_iterations
            if s.friction is not None:
                s.update_slip(state, dx, dy, final=True)
        residual = max(normal_info.residual, tangential_info.residual if tangential_info else 0.0)
        converged = normal_info.converged and (tangential_info is None or tangential_info.converged) and converged
        return SolveInfo(converged=bool(converged), iterations=iterations, residual=residual, outer_iterations=outer,
                         history=normal_info.history)

    def _turn_tolerance(self, outer: int, change: float, coupled: float, last: float) -> float:
        """The inner tolerance of turn ``outer`` (``SolverSettings.turn_tolerance``)."""
        s = self.solver
        if not s.iterative or s.settings.turn_tolerance == "exact":
            return s.tol
        if s.settings.turn_tolerance == "change":  # 1/100 of the last turn's change
            return max(s.tol, min(TURN_TOL_START, TURN_TOL_RATIO * change))
        # 1/100 of the coupled residual, never looser than the last turn's
        return max(s.tol, min(TURN_TOL_START if outer == 1 else last, TURN_TOL_RATIO * coupled))

    def _turns(self, state, dx: float, dy: float, dz: float, on_window: bool):
        """The turns from the tractions in ``state``: (normal info, tangential info, turns,
        whether the turns converged, inner iterations, whether ``state.disp_z`` is K p of the last
        pressure: its normal solve judged on the whole grid). ``on_window``: from the second turn
        on, the normal solves on the first turn's window alone (``NormalSolver.solve_on_window``,
        ``SolverSettings.window_turns``), where it ran on one."""
        s = self.solver
        m = s.model
        iterations = 0
        normal_info = tangential_info = None
        for prev, cur in zip(s.previous, (state.pressure, state.shear_x, state.shear_y)):
            wp.copy(prev, cur)
        s.shear_normal_current = False  # (the shear of another step, or zeroed for a retry)
        change = math.inf
        coupled = math.inf  # the coupled residual (below)
        turn_tol = math.inf
        outer = 0
        converged = not s.iterative
        changes = []  # each turn's change (the stall test); None once a stall was met
        mixing = None  # Anderson mixing of the shear, from a stall on
        judged = True  # state.disp_z is K p of state.pressure (the last normal solve judged on the whole grid)
        while outer < s.settings.max_turns:
            interrupts.check()
            outer += 1
            turn_tol = self._turn_tolerance(outer, change, coupled, turn_tol)
            adhesive_change = s.update_adhesion(state, first=outer == 1) if s.adhesion is not None else 0.0
            windowed = s.normal.solve_on_window(state, dz, state.shear_x, state.shear_y, tol=turn_tol) \
                if on_window and outer > 1 else None
            if windowed is None:
                if s.iterative:
                    s.known_displacements(state, tangential=False)
                # from the second turn on, state.disp_z is K p of the pressure the last turn's solve
                # left where that solve was judged on the whole grid
                normal_info = s.normal.solve(state, dz, s.known_z if s.iterative else None, tol=turn_tol,
                                             displacement_current=outer > 1 and judged)
                judged = True
            else:
                normal_info, judged = windowed, False
            iterations += normal_info.iterations
            if outer == 1 and s.iterative:  # a contact far past the domain's edge: stop now, not at max_turns
                check_contact_fits(state, (dx, dy, dz), EDGE_SHARE_AT_FIRST_TURN)
            if s.friction is not None:
                s.friction.shear_limit(m, state.pressure.flatten(), s.shear_limit.flatten())
                if s.iterative:
                    s.known_displacements(state, normal=False)
                tangential_info = s.tangential.solve(
                    state, s.target_x, s.target_y, s.shear_limit,
                    s.known_x if s.iterative else None, s.known_y if s.iterative else None, tol=turn_tol,
                    pressure=state.pressure if s.coupled else None, whole=False,
                )
                iterations += tangential_info.iterations
                if s.adhesion is not None:  # the adhesive shear follows the current slip
                    s.update_slip(state, dx, dy)
                elif not s.iterative:
                    s.update_slip(state, dx, dy, final=True)
            if not s.iterative:
                break
            if mixing is not None:  # x <- Anderson's next shear from G(x) (the state's shear)
                change = max(self._mixed_change(state, mixing), adhesive_change)
            else:
                change = max(s.relative_change(state), adhesive_change)
            # the coupled residual: where the normal solve started (how far the last tangential
            # update moved its problem), and where the tangential one started, as far as the
            # turn's change confirms it (the plain tangential solve reclassifies its slip cells
            # at every start, which alone can make a start residual of 1e-2)
            tangential_start = starting_residual(tangential_info) if tangential_info is not None else 0.0
            coupled = max(starting_residual(normal_info), min(change, tangential_start))
            if s.on_turn is not None:
                s.on_turn(outer, change)
            if change < s.outer_tol and turn_tol == s.tol:
                converged = True
                break
            if mixing is not None:  # not converged: the next turn from the mixed shear
                wp.copy(state.shear_x, s.previous[1])
                wp.copy(state.shear_y, s.previous[2])
                s.shear_normal_current = False
            elif changes is not None and s.friction is not None:
                changes.append(change)
                if stalled(changes):  # one try per step: no room for the mixing leaves the turns plain
                    mixing = self._mixing_after_stall()
                    changes = None
        return normal_info, tangential_info, outer, converged, iterations, judged

    def _mixing_after_stall(self):
        """The local Anderson mixing of the turns' shear after a stall (``stalled``), made when
        first needed; None where the device has no room for it (the turns go on unmixed)."""
        if self._stall_mixing is None:
            try:
                self._stall_mixing = self.stall_mixing_type(self.solver.model)
            except (MemoryError, RuntimeError) as e:
                if not allocation_refused(e):
                    raise
                return None
        self._stall_mixing.reset()
        return self._stall_mixing

    def _mixed_change(self, state, mixing) -> float:
        """A turn's change with the shear mixed: the larger of the pressure's relative change and
        |G(x) - x| / |G(x)| of the shear (G(x): the shear the turn's tangential solve returned, in
        ``state``; x: the shear it started from, in ``previous``, which then holds Anderson's next
        shear)."""
        s = self.solver
        pressure_change = s.pressure_change(state)
        for image, shear in zip(mixing.residual, (state.shear_x, state.shear_y)):
            wp.copy(image, shear.flatten())
        shear_change = mixing.step([s.previous[1].flatten(), s.previous[2].flatten()])
        return max(pressure_change, shear_change)


class MinimisedTurns:
    """With adhesion and friction: turns whose normal solve is the whole adhesive normal problem
    (``AdhesiveNormalSolver``, the shear's coupling held fixed), so that the turns are those of the
    elastic coupling and of the shear limit's dependence on the pressure alone.

    A turn maps the shear x that its normal solve holds fixed (with the SMC law: and the adhesive
    shear) to the shear its tangential solve returns (and the law's adhesive shear at the new gap
    and slip); the next turn's x is Anderson's combination of the turns so far (``AndersonMixing``
    with beta = 1, where ``SolverSettings.turn_mixing``), which removes the plain iteration's
    constant contraction per turn. The change of a turn is the larger of |G(x) - x| / max(|G(x)|,
    |p|) and the relative change of the total normal traction p. Early turns solve loosely
    (``TURN_TOL_FACTOR`` x the last change, at most ``TURN_TOL_CAP``); the turns end when the
    change is under ``outer_tol`` in a turn solved at full tolerance, and the normal solve is then
    made once more against the final shear G(x)."""

    fallback_counter = "turn_fallbacks"

    def __init__(self, solver):
        self.solver = solver
        f = solver.model.field
        #: the shear the turns' normal solves hold fixed (with the SMC law, its adhesive shear too)
        self.has_adhesive_shear = solver.adhesion.has_shear
        self.coupling_shear = [f() for _ in range(4 if self.has_adhesive_shear else 2)]
        self.total_pressure, self.scratch_z = f(), f()

    def solve(self, state, dx: float, dy: float, dz: float) -> SolveInfo:
        s = self.solver
        m = s.model
        x = self.coupling_shear
        sources = [state.shear_x, state.shear_y]
        if self.has_adhesive_shear:
            sources += [state.adhesive_shear_x, state.adhesive_shear_y]
        for src, dst in zip(sources, x):
            wp.copy(dst, src)
        mixing = s.mixing
        mixing.reset()
        mixed = s.settings.turn_mixing and len(mixing.residual) >= len(x)
        iterations = outer = 0
        change = math.inf
        converged = False
        tangential_info = None
        while outer < s.settings.max_turns:
            interrupts.check()
            outer += 1
            turn_tol = max(s.tol, min(TURN_TOL_CAP, TURN_TOL_FACTOR * change))
            normal_info = self._adhesive_normal(state, dz, x, max(s.adhesive.tol, turn_tol), warm=outer > 1)
            iterations += normal_info.iterations
            if outer == 1:  # a contact far past the domain's edge: stop now, not at max_turns
                check_contact_fits(state, (dx, dy, dz), EDGE_SHARE_AT_FIRST_TURN)
            s.friction.shear_limit(m, state.pressure.flatten(), s.shear_limit.flatten())
            # the total normal traction, and its change since the last turn (slot CHANGE_PRESSURE)
            wp.copy(self.total_pressure, state.pressure)
            m.launch(ak.add_to, dim=m.n_cells, inputs=[state.adhesive_pressure.flatten()],
                     outputs=[self.total_pressure.flatten()])
            s.change.zero_()
            m.launch_reduce(ck.change_sums, [self.total_pressure.flatten(), ck.CHANGE_PRESSURE],
                            [s.previous[0].flatten(), s.change])
            self._tangential_known(x)
            tangential_info = s.tangential.solve(state, s.target_x, s.target_y, s.shear_limit,
                                                 s.known_x, s.known_y, tol=turn_tol, whole=False)
            iterations += tangential_info.iterations
            s.update_slip(state, dx, dy)
            if self.has_adhesive_shear:  # the law's adhesive shear at the turn's gap and slip
                s.adhesion.tractions(m, state, self.scratch_z, s.scratch_x, s.scratch_y)
                wp.copy(state.adhesive_shear_x, s.scratch_x)
                wp.copy(state.adhesive_shear_y, s.scratch_y)
            # x <- the next iterate from G(x) (the mixing's norms: |G(x) - x|^2 and |G(x)|^2)
            if mixed:
                for src, image in zip(sources, mixing.residual):
                    wp.copy(image, src.flatten())
                mixing.step([a.flatten() for a in x], beta=1.0)
            else:  # the shear's change (slot CHANGE_SHEAR_X), and x <- G(x)
                for src, dst in zip(sources, x):
                    m.launch_reduce(ck.change_sums, [src.flatten(), ck.CHANGE_SHEAR_X], [dst.flatten(), s.change])
            sums = s.change.numpy().astype(np.float64)
            shear_sums = mixing.norms if mixed else (sums[ck.CHANGE_SHEAR_X], sums[ck.CHANGE_SHEAR_X + 1])
            pressure_change = ratio(sums[ck.CHANGE_PRESSURE], sums[ck.CHANGE_PRESSURE + 1])
            shear_change = ratio(shear_sums[0], max(shear_sums[1], sums[ck.CHANGE_PRESSURE + 1]))
            change = max(pressure_change, shear_change)
            if s.on_turn is not None:
                s.on_turn(outer, change)
            if change < s.outer_tol and turn_tol == s.tol and normal_info.converged:
                converged = tangential_info.converged
                break
        for src, dst in zip(sources, x):  # the final normal solve against the shear G(x) the state holds
            wp.copy(dst, src)
        final = self._adhesive_normal(state, dz, x, s.adhesive.tol, warm=True)
        iterations += final.iterations
        s.update_slip(state, dx, dy, final=True)
        converged = converged and final.converged
        residual = max(final.residual, tangential_info.residual if tangential_info else 0.0)
        return SolveInfo(converged=bool(converged), iterations=iterations, residual=residual, outer_iterations=outer,
                         history=final.history)

    def _adhesive_normal(self, state, dz: float, shear, tol: float, warm: bool = False) -> SolveInfo:
        """The adhesive normal solve with the normal displacement of ``shear`` (contact shear
        x, y [and adhesive shear x, y]) held fixed; zero unless the materials are coupled."""
        s = self.solver
        m = s.model
        s.known_z.zero_()
        if s.coupled:
            wp.copy(s.scratch_x, shear[0])
            wp.copy(s.scratch_y, shear[1])
            if len(shear) > 2:
                m.launch(ak.add_to, dim=m.n_cells, inputs=[shear[2].flatten()], outputs=[s.scratch_x.flatten()])
                m.launch(ak.add_to, dim=m.n_cells, inputs=[shear[3].flatten()], outputs=[s.scratch_y.flatten()])
            m.operator.cross_normal(s.scratch_x, s.scratch_y, s.known_z)
        return s.adhesive.solve(state, dz, s.known_z, tol=tol, warm=warm)

    def _tangential_known(self, shear):
        """known_x, known_y <- the tangential displacement of the total normal traction
        (``total_pressure``; coupling only) and of the adhesive shear ``shear[2:]`` (if any), held
        fixed in the tangential solve."""
        s = self.solver
        op = s.model.operator
        if not s.coupled and len(shear) == 2:
            s.known_x.zero_()
            s.known_y.zero_()
            return
        if len(shear) == 2:
            op.cross_tangential(self.total_pressure, s.known_x, s.known_y)
            return
        if not s.coupled:
            self.scratch_z.zero_()
            pressure = self.scratch_z
        else:
            pressure = self.total_pressure
        op.coupled_apply(pressure, shear[2], shear[3], self.scratch_z, s.known_x, s.known_y)


class NestedStart:
    """A strategy started from the step solved on the grid of half the cells per side over the
    same domain (itself nested where its own size takes the nested start: with "auto" from
    ``NESTED_AUTO_N`` on, forced on down to ``NESTED_MIN_N``), from the fine state's slip history and
    tractions restricted to it: its tractions and cell statuses start the fine step. The slip
    front then starts within a coarse cell of its place, where the projected tangential iteration
    moves it by about one cell per iteration (``SolverSettings.nested``). In a float64 model the
    coarse grids are float32 where ``SolverSettings.nested_float32`` chooses it. A grid that does not
    halve (odd n, or n / 2 under NESTED_MIN_N), or a coarse step that does not converge, leaves
    the fine step to start as without."""

    def __init__(self, inner):
        self.inner = inner
        self.solver = inner.solver
        self.fallback_counter = inner.fallback_counter
        self._coarse = None  # (ContactSolver, ContactState) of the half grid, made when first needed

    def solve(self, state, dx: float, dy: float, dz: float) -> SolveInfo:
        self.solver.nested_iterations = self._start(state, (dx, dy, dz))
        return self.inner.solve(state, dx, dy, dz)

    def _coarse_pair(self):
        """The solver and state of the half grid, or None where n does not halve."""
        s = self.solver
        m = s.model
        n = m.grid.n
        if n % 2 or n // 2 < NESTED_MIN_N:
            return None
        if self._coarse is None:
            from ..physics.geometry import Grid
            from ..numerics.state import ContactState

            float32 = float32_chosen(s.settings.nested_float32, NESTED_FLOAT32_AUTO, n, m.device.is_cuda,
                                     m.dtype_name == "float64")
            coarse_model = m.on_grid(Grid(n // 2, m.grid.size), "float32" if float32 else None)
            # the half grid starts nested in its turn where the fine one's choice says so for it: "auto"
            # by its own size (``NESTED_AUTO_N``), forced on all the way down where forced on
            nested = True if s.settings.nested is True else "auto"
            settings = replace(s.settings, tol=max(s.tol, NESTED_COARSE_TOL), nested=nested, use_graphs=s.normal.use_graphs)
            coarse = type(s)(coarse_model, s.friction, pressure_cap=s.normal.pressure_cap, settings=settings)
            self._coarse = (coarse, ContactState(coarse_model))
        return self._coarse

    def _start(self, state, approach) -> int:
        """Solve the step on the half grid from ``state`` restricted to it, and start ``state``'s
        step from its tractions and statuses; the coarse grids' inner iterations."""
        from warpcontact.kernels import grids as gk

        pair = self._coarse_pair()
        if pair is None:
            return 0
        coarse, cstate = pair
        m, cm = self.solver.model, coarse.model
        half = cm.grid.shape
        for name, scale in (("slip_x", 0.5), ("slip_y", 0.5), ("pressure", 1.0), ("shear_x", 1.0), ("shear_y", 1.0)):
            wp.launch(gk.restrict_mean, dim=half, inputs=[getattr(state, name), cm.scalar(scale)],
                      outputs=[getattr(cstate, name)], device=m.device)
        wp.launch(gk.restrict_status, dim=half, inputs=[state.status], outputs=[cstate.status], device=m.device)
        info = coarse.step(cstate, approach)
        iterations = info.iterations + coarse.nested_iterations
        if not info.converged:
            return iterations
        for name in ("pressure", "shear_x", "shear_y"):
            wp.launch(gk.prolong_constant, dim=m.grid.shape, inputs=[getattr(cstate, name)],
                      outputs=[getattr(state, name)], device=m.device)
        wp.launch(gk.prolong_constant, dim=m.grid.shape, inputs=[cstate.status], outputs=[state.status],
                  device=m.device)
        return iterations

"""One load step of the coupled problem: normal and tangential solves in turns (MODEL.md 4)."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import warp as wp

from warpcontact.kernels import adhesion as ak
from warpcontact.kernels import coupling as ck

from ..numerics.state import SolveInfo, check_contact_fits
from .turns import AdhesiveSolve, LaggedTurns, MinimisedTurns, NestedStart, ratio
from .adhesive import AdhesiveNormalSolver
from .fixed_point import AndersonMixing
from .normal import NormalSolver
from .settings import SolverSettings
from .tangential import TangentialSolver


#: iteration limit of the adhesive minimisation before a step falls back to the lagged turns
#: (the Maugis-Dugdale curves at lambda 0.5-2 took 19-460 iterations per state)
ADHESIVE_MAX_ITER = 1000
#: with adhesion and friction, ``turns = "auto"`` takes the lagged turns where the law's Maugis
#: parameter (``adhesion.maugis_parameter``) is under this, the DMT side, where they converge and
#: cost less, and the minimised turns from it on, where the lagged ones crawl or diverge
#: (docs/model.md, "The turns")
LAGGED_TURNS_MAX_MAUGIS = 0.1
#: ``nested = "auto"``: the nested start from these grids on (cells per side), by device kind,
#: where it was measured to cost less than it saves (docs/performance.md)
NESTED_AUTO_N = {"cpu": 512, "cuda": 2048}


def turns_of(adhesion, radius: float, e_star: float, choice: str = "auto") -> str:
    """The turns of a step with ``adhesion`` and friction where the minimisation is available:
    "minimised" or "lagged" (``choice``, ``SolverSettings.turns``; "auto": by the law's Maugis
    parameter on a sphere of ``radius`` [m] and a pair of ``e_star`` [Pa] against
    ``LAGGED_TURNS_MAX_MAUGIS``)."""
    if choice != "auto":
        return choice
    from ..physics.adhesion import maugis_parameter

    return "lagged" if maugis_parameter(adhesion, radius, e_star) < LAGGED_TURNS_MAX_MAUGIS else "minimised"


class ContactSolver:
    """Solves a state at given rigid shifts (delta_x, delta_y, delta_z) from the slip history.

    With friction, the normal and the tangential problems are solved in turns, each with the
    other's coupling displacement held fixed (Dundurs coupling on whenever D != 0); identical
    materials without adhesion decouple (D = 0) and one turn is exact. With adhesion and no
    friction, a step is one adhesive normal solve (elastic and adhesive energy minimised
    together, non-penetration as a bound), which converges where a fixed point crawls or diverges
    (large Tabor parameters). With adhesion and friction the turns are lagged (the adhesive
    tractions a fixed point of their own) or minimised (each turn's normal solve the whole
    adhesive minimisation), by ``settings.turns``.

    A step runs the solver's ``strategies`` (``warpcontact.solvers.turns``) in order, each
    from the last one's iterate, until one converges: the minimisation or the turns chosen first,
    then the other kind where the law allows it (a law with a fixed point: ``tractions``; the
    lagged turns alone know a hardness cap). The nested start wraps the first strategy where
    ``settings.nested`` asks for it (friction, no adhesion). A step's iterations and turns count
    every strategy it ran.

    Args:
        model: the contact model.
        friction: a shear-limit law (``warpcontact.physics.friction``) or None for frictionless contact.
        adhesion: an adhesion law (``warpcontact.physics.adhesion``) or None.
        pressure_cap: upper bound of the contact pressure [Pa], e.g. the softer body's hardness
            (elastic-perfectly-plastic surface); inf for none.
        settings: the solvers' choices ([`SolverSettings`][warpcontact.solvers.settings.SolverSettings]),
            fixed for the solver's life; default: the defaults.
        on_turn: called after each turn of a step as ``on_turn(turn, change)``: the turn (from 1
            in each strategy's run) and its relative change [-], the number the turns stop on
            (the progress line of a long step). Made from what each turn reads already.
        **choices: settings replaced by name (``ContactSolver(model, law, max_turns=50)``).
    """

    #: with adhesion, a turn's slip after a tangential solve on a window, and the shear's normal
    #: displacement that the next turn's normal solve holds fixed, from one forward transform of
    #: pressure and shear (``ElasticOperator.coupled_shear``: six transforms of the whole grid where
    #: the separate products make ten); with or without adhesion, a step's final slip after a solve
    #: on a window likewise, without the normal displacement (five transforms where the separate
    #: products make seven); False: the separate products (``bench/paths.py --choices
    #: slip-separate`` compares them)
    shared_transforms = True

    def __init__(self, model, friction=None, adhesion=None, *, pressure_cap: float = math.inf,
                 settings: SolverSettings | None = None, on_turn: Callable[[int, float], None] | None = None,
                 **choices):
        settings = SolverSettings.of(settings, **choices)
        self.model = model
        self.settings = settings
        self.friction = friction
        self.adhesion = adhesion
        self.on_turn = on_turn
        if adhesion is not None and friction is None and math.isfinite(pressure_cap):
            from ..errors import InputError

            raise InputError("solver.pressure_cap", "a hardness cap is not available with adhesion without friction")
        #: the adhesive normal problem as one minimisation (with adhesion, without a hardness cap)
        self.adhesive = None
        if adhesion is not None and not math.isfinite(pressure_cap):
            self.adhesive = AdhesiveNormalSolver(model, adhesion, max_iter=min(settings.max_iter, ADHESIVE_MAX_ITER))
        self.normal = NormalSolver(model, settings, pressure_cap=pressure_cap)
        #: relative residual of the inner solves (``settings.tol`` or the float type's default)
        self.tol = self.normal.tol
        #: relative change of the tractions that ends the turns (``settings.outer_tol``; 100 tol)
        self.outer_tol = 100 * self.tol if settings.outer_tol is None else float(settings.outer_tol)
        #: steps whose minimisation (adhesion alone) did not converge and went on by the turns
        self.adhesive_fallbacks = 0
        #: steps whose turns of the first kind did not converge and went on by the other kind
        self.turn_fallbacks = 0
        #: inner iterations of the coarse grids in the last nested start (0 without)
        self.nested_iterations = 0
        f = model.field
        self.known_z, self.known_x, self.known_y = f(), f(), f()
        self.previous = [f(), f(), f()]
        self.change = model.scalars(ck.N_CHANGE_SUMS)
        #: the adhesive tractions' displacements of a turn, and the scratch of a turn's slip:
        #: with adhesion only (n = 8192 float64: 0.5 GiB each)
        self.adhesive_z = self.adhesive_x = self.adhesive_y = self.scratch_x = self.scratch_y = None
        if adhesion is not None:
            # the lagged turns' adhesive fixed point over the pressure (and the shears with
            # friction); the minimised turns' fixed point over the shears (4 fields with the SMC
            # law): one mixing for both, as a step runs one kind of turns at a time (a fourth
            # component only where the minimised turns come first: as a fallback they run plain)
            components = 1
            if friction is not None:
                components = 4 if adhesion.has_shear and self.turns == "minimised" else 3
            self.mixing = AndersonMixing(model, components, beta=settings.relax)
            self.adhesive_z, self.adhesive_x, self.adhesive_y = f(), f(), f()
        if friction is not None:
            self.tangential = TangentialSolver(model, settings)
            self.target_x, self.target_y = f(), f()
            self.shear_limit = f()
            if adhesion is not None:
                self.scratch_x, self.scratch_y = f(), f()
                #: the shear's normal displacement K_zt q made with a turn's slip (``update_slip``),
                #: which the next normal solve holds fixed where the shear has not changed since
                #: (``shear_normal_current``)
                self.shear_normal = f()
        self.shear_normal_current = False
        #: how a step is solved: tried in order, each from the last one's iterate, until one converges
        self.strategies = self._strategies()

    @property
    def turns(self) -> str:
        """The turns of a step with adhesion and friction (``turns_of``); "lagged" wherever the
        minimisation is not available."""
        if self.adhesive is None:
            return "lagged"
        return turns_of(self.adhesion, self.model.sphere.radius, self.model.pair.E_star, self.settings.turns)

    @property
    def coupled(self) -> bool:
        return self.friction is not None and self.model.operator.coupled

    @property
    def iterative(self) -> bool:
        """Whether a step needs turns (coupling or adhesion)."""
        return self.coupled or self.adhesion is not None

    @property
    def uses_nested(self) -> bool:
        """Whether a step with friction and no adhesion starts nested (``settings.nested``;
        "auto": n of at least NESTED_AUTO_N of the device's kind)."""
        if self.settings.nested == "auto":
            kind = "cuda" if self.model.device.is_cuda else "cpu"
            return self.model.grid.n >= NESTED_AUTO_N[kind]
        return self.settings.nested

    def _strategies(self) -> list:
        """The strategies of a step, in the order they are tried (class docstring)."""
        falls_back = self.adhesion is not None and hasattr(self.adhesion, "tractions")  # a law with a fixed point
        if self.adhesive is not None and self.friction is None:
            first = AdhesiveSolve(self)
            return [first, LaggedTurns(self)] if falls_back else [first]
        if self.adhesive is not None:  # adhesion and friction, no cap: both kinds of turns
            lagged, minimised = LaggedTurns(self), MinimisedTurns(self)
            if self.turns == "lagged":
                return [lagged, minimised]
            return [minimised, lagged] if falls_back else [minimised]
        lagged = LaggedTurns(self)
        if self.friction is not None and self.adhesion is None and self.uses_nested:
            return [NestedStart(lagged)]
        return [lagged]

    def step(self, state, approach) -> SolveInfo:
        """Solve ``state`` at ``approach`` = (delta_x, delta_y, delta_z) [m].

        ``state`` holds the previous state of the path (its slip is the history s_prev; its
        tractions are the starting guess) and is overwritten with the new one.
        """
        m = self.model
        dx, dy, dz = (float(a) for a in approach)
        L = m.length_scale
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
        self.nested_iterations = 0
        iterations = turns_run = 0
        for k, strategy in enumerate(self.strategies):
            if k:  # the last strategy did not converge: this one from its iterate
                failed = self.strategies[k - 1].fallback_counter
                setattr(self, failed, getattr(self, failed) + 1)
            info = strategy.solve(state, dx, dy, dz)
            iterations += info.iterations
            turns_run += info.outer_iterations
            if info.converged:
                break
        info = SolveInfo(converged=info.converged, iterations=iterations, residual=info.residual,
                         outer_iterations=turns_run, history=info.history)
        state.approach = (dx, dy, dz)
        state.info = info
        check_contact_fits(state)
        return info

    def known_displacements(self, state, normal: bool = True, tangential: bool = True):
        """Displacements of the tractions held fixed in a turn: the coupling of the other unknown,
        plus the adhesive tractions' (computed once per update in ``update_adhesion``). ``normal``:
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
            if self.coupled and self.shear_normal_current:  # made with the last turn's slip, of this shear
                wp.copy(self.known_z, self.shear_normal)
            elif self.coupled:
                m.operator.cross_normal(state.shear_x, state.shear_y, self.known_z)
            if self.adhesion is not None:
                m.launch(ak.add_to, dim=m.n_cells, inputs=[self.adhesive_z.flatten()], outputs=[self.known_z.flatten()])
        if tangential:  # (the pressure's coupling K_tp p: the tangential solve adds it, on its window)
            self.shear_normal_current = False  # (a tangential solve follows: the shear changes)
            self.known_x.zero_()
            self.known_y.zero_()
            if self.adhesion is not None and self.friction is not None:
                for src, dst in ((self.adhesive_x, self.known_x), (self.adhesive_y, self.known_y)):
                    m.launch(ak.add_to, dim=m.n_cells, inputs=[src.flatten()], outputs=[dst.flatten()])

    def update_slip(self, state, dx, dy, final: bool = False):
        """state.slip <- delta - u_t for the current tractions, u_t = K_tt q (state.disp_x/y)
        plus the known displacements. The total u_t goes to state.disp_x/y only when ``final``
        (during the turns state.disp_x/y hold K_tt q, or, after a turn's slip from shared
        transforms (``shared_transforms``), nothing a turn reads: the final slip makes them)."""
        m = self.model
        L = m.length_scale
        known_x = self.known_x if self.iterative else self.tangential.no_displacement
        known_y = self.known_y if self.iterative else self.tangential.no_displacement
        pressure = None
        if self.shared_transforms and (final or self.adhesion is not None):
            pressure = self.tangential.pending_pressure(state, take=final)
        if pressure is not None and final:
            # the step's final slip where the last tangential solve ran on a window: K_tt q + K_tp p
            # from one transform of each traction (two inverse transforms of the whole grid fewer
            # than K_tp p added to the known displacements, then K_tt q; the same sum)
            m.operator.coupled_shear(pressure, state.shear_x, state.shear_y, None, state.disp_x, state.disp_y)
            disp_x, disp_y = state.disp_x, state.disp_y
        elif pressure is not None:
            # a turn's slip where the last tangential solve ran on a window: K_tt q + K_tp p from one
            # transform of each traction, with the shear's K_zt q for the next turn's normal solve
            # (``known_displacements``); state.disp_x/y are made by the step's final slip
            m.operator.coupled_shear(pressure, state.shear_x, state.shear_y, self.shear_normal, self.scratch_x,
                                     self.scratch_y)
            self.shear_normal_current = True
            disp_x, disp_y = self.scratch_x, self.scratch_y
        else:
            self.tangential.whole_displacement(state)  # where the last solve left them on its window
            disp_x, disp_y = state.disp_x, state.disp_y
        m.launch(
            ck.accumulate_slip,
            dim=m.n_cells,
            inputs=[disp_x.flatten(), disp_y.flatten(), known_x.flatten(), known_y.flatten(),
                    m.scalar(dx / L), m.scalar(dy / L)],
            outputs=[state.slip_x.flatten(), state.slip_y.flatten(),
                     (state.disp_x if final else self.scratch_x).flatten(), (state.disp_y if final else self.scratch_y).flatten()],
        )

    def update_adhesion(self, state, first: bool) -> float:
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

    def pressure_change(self, state) -> float:
        """Relative change of the pressure since the last turn (``previous``); updates its copy."""
        self.change.zero_()
        self.model.launch_reduce(ck.change_sums, [state.pressure.flatten(), ck.CHANGE_PRESSURE],
                                 [self.previous[0].flatten(), self.change])
        sums = self.change.numpy().astype(np.float64)
        return ratio(sums[ck.CHANGE_PRESSURE], sums[ck.CHANGE_PRESSURE + 1])

    def relative_change(self, state) -> float:
        """Largest relative change of pressure and shear since the last turn; updates the copies."""
        m = self.model
        self.change.zero_()
        slots = (ck.CHANGE_PRESSURE, ck.CHANGE_SHEAR_X, ck.CHANGE_SHEAR_Y)
        for slot, prev, cur in zip(slots, self.previous, (state.pressure, state.shear_x, state.shear_y)):
            m.launch_reduce(ck.change_sums, [cur.flatten(), slot], [prev.flatten(), self.change])
        s = self.change.numpy().astype(np.float64)
        x, y = ck.CHANGE_SHEAR_X, ck.CHANGE_SHEAR_Y
        return max(ratio(s[ck.CHANGE_PRESSURE], s[ck.CHANGE_PRESSURE + 1]), ratio(s[x] + s[y], s[x + 1] + s[y + 1]))

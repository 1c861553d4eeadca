"""Displacement-driven normal contact: Polonsky & Keer (1999) without the force constraint."""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from warpcontact.kernels import normal as nk
from warpcontact.kernels import reduce

from ..state import SolveInfo
from .base import ProjectedCG, default_tolerance, raise_non_finite  # noqa: F401  (re-export)


def one_convolution_supported(device, use_graphs: bool) -> bool:
    """Whether the one-convolution iteration can run on ``device``: its captured graphs need
    conditional nodes (CUDA toolkit and driver 12.4+); without graphs (CPU, or CUDA eager, where
    the host reads the decision each iteration) it always can."""
    return not use_graphs or wp.is_conditional_graph_supported()


class NormalSolver(ProjectedCG):
    """Projected conjugate gradients for the contact pressure at a given rigid approach.

    Polonsky, I. A. & Keer, L. M. (1999), "A numerical method for solving rough contact problems
    based on the multi-level multi-summation and conjugate gradient techniques", Wear 231,
    206-219, in its displacement-driven form: delta_z is an input, no force constraint
    (MODEL.md section 4).

    The relative residual of a pressure p with gap g = h0 - delta_z + K p + u_known is
    ``sqrt(sum_{p>0} g^2 + sum_{p=0, g<0} g^2) / sqrt(sum_{p>0} (delta_z - h0 - u_known)^2)``:
    the misfit of the contact conditions relative to the rigid interference they absorb.

    Args:
        model: the :class:`~warpcontact.model.ContactModel`.
        tol: relative residual to reach (default: 1e-10 in float64, 1e-5 in float32).
        max_iter: iteration limit; a solve that reaches it returns ``converged = False``.
        check_every: iterations between reads of the residual on the host.
        pressure_cap: upper bound of the pressure [Pa] (hardness), inf for none.
        one_convolution: carry K p incrementally between projections: one convolution per
            iteration instead of two (default: on, where the device supports it).
        use_graphs: replay iterations as CUDA graphs (default: on CUDA).
    """

    def __init__(self, model, tol=None, max_iter: int = 2000, check_every=None, pressure_cap: float = math.inf,
                 one_convolution: bool | None = None, use_graphs: bool | None = None):
        super().__init__(model, nk.N_SUMS, nk.N_SCALARS, tol, max_iter, check_every, use_graphs)
        #: upper bound of the pressure [Pa] (the softer body's hardness: elastic-perfectly-plastic
        #: surface; MODEL.md section 5); inf for none
        self.pressure_cap = float(pressure_cap)
        big = np.finfo(model.np_dtype).max
        self._cap = model.scalar(min(self.pressure_cap / model.traction_scale, big))
        self.direction = model.field()
        self.response = model.field()
        self.guess_sums = model.scalars(nk.N_GUESS_SUMS)
        self.no_displacement = model.field()
        #: carry u = K p incrementally (one convolution per iteration, two after a projection);
        #: default: wherever the device can decide (CPU; CUDA with conditional graph nodes, 12.4+)
        supported = one_convolution_supported(model.device, self.use_graphs)
        self.one_convolution = supported if one_convolution is None else bool(one_convolution)
        if self.one_convolution and not supported:
            raise ValueError("one_convolution: needs CUDA graph conditional nodes (CUDA toolkit and driver 12.4+) "
                             "on this device")
        #: 1: recompute K p at the start of the next iteration (set by the device)
        self.recompute = wp.zeros(1, dtype=wp.int32, device=model.device)
        #: iterations between exact recomputations of K p in the one-convolution mode
        self.exact_every = 50
        #: recompute K p once the bound on what the carried u misses exceeds this fraction of the
        #: violation (``kernels/normal.py``, ``normal_recompute_flag``); 0: after every projection.
        #: A captured graph keeps the value it was captured with: set it before the first solve.
        self.deferral = 0.1
        self._column_norm = model.scalar(model.operator.column_norm("zz"))
        self.deferred = model.scalars(1)

    def _gap(self, state, known, exact: bool = True):
        """state.disp_z <- K p (unless ``exact`` is False: then state.disp_z already holds it);
        state.gap <- gap; sums <- residual sums of the current pressure (approach from
        ``settings``)."""
        m = self.model
        if exact:
            m.operator.normal(state.pressure, state.disp_z)
        m.launch_reduce(
            nk.normal_gap,
            [m.initial_gap.flatten(), state.disp_z.flatten(), known.flatten(), state.pressure.flatten(), self.settings, self._cap],
            [state.gap.flatten(), self.sums],
        )

    def solve(self, state, approach_z: float, known_displacement: wp.array | None = None, tol=None) -> SolveInfo:
        """Solve for ``state.pressure`` at the rigid approach ``approach_z`` [m].

        Starts from the pressure already in ``state`` (warm start along a path) or, if it is zero,
        from the rigid interference. ``known_displacement`` (scaled, (n, n)) is a normal
        displacement from other tractions (shear coupling, adhesion) held fixed during the solve.
        Fills ``state.pressure``, ``state.disp_z``, ``state.gap``. ``tol`` overrides the
        solver's tolerance for this solve.
        """
        m = self.model
        known = self.no_displacement if known_displacement is None else known_displacement
        approach = float(m.np_dtype(approach_z / m.length_scale))  # as the kernels see it
        self._set(nk.P_APPROACH, approach)
        self._initial_guess(state, known)
        p, g, t, r = (a.flatten() for a in (state.pressure, state.gap, self.direction, self.response))
        self.direction.zero_()  # no leftover from an earlier (possibly failed) solve
        # One convolution per iteration: u = K p is carried as u - tau K t, and recomputed (a
        # second convolution, at the start of the next iteration) once what the projections
        # changed since the last recompute may matter (``deferral``), near convergence after a
        # projection, and every ``exact_every`` iterations (rounding). The device decides
        # (``self.recompute``, read by a conditional node of the captured graph), so the host
        # never waits for it.
        # mode[0]: carry K p incrementally; switched off for the rest of the solve as soon as an
        # exact check contradicts the carried displacement (the carried u said "converged", the
        # recomputed one does not), which then behaves exactly like the two-convolution iteration.
        mode = [self.one_convolution]
        arrays = (state.pressure.ptr, state.gap.ptr, state.disp_z.ptr, known.ptr)

        def recompute_displacement():
            m.operator.normal(state.pressure, state.disp_z)

        def body(carry: bool):
            self.sums.zero_()
            if carry:  # K p only when the last iteration's flag asks (a conditional node in a graph)
                wp.capture_if(self.recompute, on_true=recompute_displacement)
            self._gap(state, known, exact=not carry)
            m.launch(nk.normal_direction, dim=m.n_cells, inputs=[g, p, self._cap, self.sums, self.scalars], outputs=[t])
            m.operator.normal(self.direction, self.response)
            m.launch_reduce(nk.normal_step_sums, [g, t, r, p, self._cap], [self.sums])
            m.launch_reduce(nk.normal_update, [g, t, self._cap, self.settings], [p, self.sums])
            if carry:
                m.launch(nk.normal_displacement_step, dim=m.n_cells, inputs=[r, self.sums, self.settings],
                         outputs=[state.disp_z.flatten()])
            m.launch(reduce.cg_advance, dim=1, inputs=[self.sums, self.scalars], outputs=[self.history])
            if carry:
                m.launch(nk.normal_recompute_flag, dim=1,
                         inputs=[self.sums, self.scalars, self.settings, self.exact_every, self._column_norm,
                                 m.scalar(self.deferral), self.deferred],
                         outputs=[self.recompute])

        def iteration():
            self._device_step(arrays + (mode[0],), lambda: body(mode[0]))

        checks = [0]

        def final_fields():
            self.sums.zero_()
            self._gap(state, known)
            self.recompute.zero_()  # state.disp_z is K p now
            self.deferred.zero_()
            residual = self._relative_residual(nk.S_VIOL, nk.S_RHS)
            checks[0] += 1
            if checks[0] > 1 and not residual < self.active_tol:
                mode[0] = False  # the carried u disagreed with the exact one: recompute from now on
            return residual

        def on_non_finite(it):
            raise_non_finite("normal solve", state, ("pressure", "gap", "disp_z"), it)

        return self._run(iteration, final_fields, on_non_finite, tol)

    def _initial_guess(self, state, known):
        """Unless the state holds a pressure already (warm start): p = c s, with s = sqrt(max(b -
        b_max / 2, 0)), b = max(delta_z - h0 - u_known, 0) the rigid interference, and c the
        least-squares fit of K p to b on the support of s, capped at the hardness. For a
        paraboloid s is the Hertz pressure's shape on the Hertz contact area (an elastic contact
        closes half the rigid interference), so a Hertz solve starts near its answer: 125 -> 52
        iterations at n = 256, 127 -> 74 at 512, 153 -> 87 at 1024 (CPU, against the old guess
        c b, whose support was twice the contact area). On the device; one scalar comes back
        (whether p > 0 anywhere)."""
        m = self.model
        p = state.pressure.flatten()
        self.guess_sums.zero_()
        m.launch_reduce(nk.count_positive, [p], [self.guess_sums])
        if self.guess_sums.numpy()[nk.G_POSITIVE] > 0:
            return
        h0, u_known = m.initial_gap.flatten(), known.flatten()
        m.launch_reduce(nk.guess_max_interference, [h0, u_known, self.settings], [self.guess_sums])
        m.launch(nk.guess_shape, m.n_cells, [h0, u_known, self.settings, self.guess_sums], [p])
        m.operator.normal(state.pressure, self.response)
        m.launch_reduce(nk.guess_fit_sums, [h0, u_known, self.settings, p, self.response.flatten()], [self.guess_sums])
        m.launch(nk.guess_scale, m.n_cells, [self.guess_sums, self._cap], [p])

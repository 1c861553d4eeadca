"""Displacement-driven normal contact: Polonsky & Keer (1999) without the force constraint."""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from warpcontact.kernels import normal as nk

from ..errors import NonFiniteError
from ..state import SolveInfo


def default_tolerance(dtype) -> float:
    """Relative residual a solve aims for: 1e-10 in float64, 1e-5 in float32 (its rounding floor
    on these sums is about 1e-6)."""
    return 1e-10 if dtype == wp.float64 else 1e-5


class NormalSolver:
    """Projected conjugate gradients for the contact pressure at a given rigid approach.

    Polonsky, I. A. & Keer, L. M. (1999), Wear 231, 206-219, in its displacement-driven form:
    delta_z is an input, no force constraint (MODEL.md section 4).

    The relative residual of a pressure p with gap g = h0 - delta_z + K p + u_known is
    ``sqrt(sum_{p>0} g^2 + sum_{p=0, g<0} g^2) / sqrt(sum_{p>0} (delta_z - h0 - u_known)^2)``:
    the misfit of the contact condition relative to the rigid interference it must absorb.

    Args:
        model: the :class:`~warpcontact.model.ContactModel`.
        tol: relative residual to reach (default: :func:`default_tolerance`).
        max_iter: iteration limit; a solve that reaches it returns ``converged = False``.
        check_every: iterations between reads of the residual on the host (1 on CPU, where a
            read is free; 8 on CUDA, where it synchronises).
    """

    def __init__(self, model, tol: float | None = None, max_iter: int = 2000, check_every: int | None = None):
        self.model = model
        self.tol = default_tolerance(model.dtype) if tol is None else float(tol)
        self.max_iter = int(max_iter)
        self.check_every = check_every or (1 if model.device.is_cpu else 8)
        self.direction = model.field()
        self.response = model.field()
        self.gap_buffer = model.field()
        self.no_displacement = model.field()
        self.sums = model.scalars(nk.N_SUMS)
        self.scalars = model.scalars(nk.N_SCALARS)
        self.history = model.scalars(self.max_iter + 1)

    # -- kernel launches ------------------------------------------------------------------------
    def _launch_reduce(self, kernel, inputs, outputs):
        m = self.model
        r = m.reduction
        wp.launch_tiled(
            kernel,
            dim=[r.num_blocks],
            inputs=inputs + r.args(m.n_cells),
            outputs=outputs,
            block_dim=r.block_dim,
            device=m.device,
        )

    def _gap(self, state, approach, known):
        """state.disp_z <- K p; state.gap <- gap; sums <- residual sums of the current pressure."""
        m = self.model
        m.operator.normal(state.pressure, state.disp_z)
        self._launch_reduce(
            nk.normal_gap,
            [m.initial_gap.flatten(), state.disp_z.flatten(), known.flatten(), state.pressure.flatten(), approach],
            [state.gap.flatten(), self.sums],
        )

    def _iteration(self, state, approach, known):
        m = self.model
        n = m.n_cells
        p, g, t, r = (a.flatten() for a in (state.pressure, state.gap, self.direction, self.response))
        self.sums.zero_()
        self._gap(state, approach, known)
        wp.launch(nk.normal_direction, dim=n, inputs=[g, p, self.sums, self.scalars], outputs=[t], device=m.device)
        m.operator.normal(self.direction, self.response)
        self._launch_reduce(nk.normal_step_sums, [g, t, r, p], [self.sums])
        self._launch_reduce(nk.normal_update, [g, t], [p, self.sums])
        wp.launch(nk.normal_advance, dim=1, inputs=[self.sums, self.scalars], outputs=[self.history], device=m.device)

    # -- public ---------------------------------------------------------------------------------
    def solve(self, state, approach_z: float, known_displacement: wp.array | None = None) -> SolveInfo:
        """Solve for ``state.pressure`` at the rigid approach ``approach_z`` [m].

        Starts from the pressure already in ``state`` (warm start along a path) or, if it is zero,
        from the rigid interference. ``known_displacement`` (scaled, (n, n)) is a normal
        displacement from other tractions (shear coupling, adhesion) held fixed during the solve.
        Fills ``state.pressure``, ``state.disp_z``, ``state.gap``.
        """
        m = self.model
        known = self.no_displacement if known_displacement is None else known_displacement
        approach = m.scalar(approach_z / m.length_scale)
        if not np.any(state.pressure.numpy() > 0):
            self._initial_guess(state, float(approach), known)
        self.scalars.zero_()
        self.history.fill_(-1.0)
        it = 0
        residual = self._final_fields(state, approach, known, it)
        while residual >= self.tol and it < self.max_iter:
            self._iteration(state, approach, known)
            it += 1
            if it % self.check_every == 0 or it == self.max_iter:
                hist = float(self.history.numpy()[it - 1])
                if not math.isfinite(hist):
                    self._raise_non_finite(state, it)
                if hist < self.tol or it == self.max_iter:
                    residual = self._final_fields(state, approach, known, it)
        hist = self.history.numpy()[:it]
        return SolveInfo(converged=bool(residual < self.tol), iterations=it, residual=residual, history=hist.tolist())

    def _final_fields(self, state, approach, known, iteration) -> float:
        """Gap and displacement of the current pressure; returns its relative residual."""
        self.sums.zero_()
        self._gap(state, approach, known)
        residual = self._residual_from_sums()
        if not math.isfinite(residual):
            self._raise_non_finite(state, iteration)
        return residual

    def _residual_from_sums(self) -> float:
        s = self.sums.numpy().astype(np.float64)
        if s[nk.S_RHS] > 0:
            return math.sqrt(s[nk.S_VIOL] / s[nk.S_RHS])
        return 0.0 if s[nk.S_VIOL] == 0 else 1.0

    def _initial_guess(self, state, approach: float, known):
        """p = c * max(delta_z - h0 - u_known, 0), with c the least-squares fit of K p to it."""
        m = self.model
        b = approach - m.initial_gap.numpy().astype(np.float64) - known.numpy().astype(np.float64)
        p0 = np.where(b > 0, b, 0.0)
        if not np.any(p0 > 0):
            return
        state.pressure.assign(p0.astype(m.np_dtype))
        m.operator.normal(state.pressure, self.response)
        u = self.response.numpy().astype(np.float64)
        mask = p0 > 0
        c = float(np.dot(u[mask], b[mask]) / np.dot(u[mask], u[mask]))
        state.pressure.assign((p0 * c).astype(m.np_dtype))

    def _raise_non_finite(self, state, iteration):
        for name in ("pressure", "gap", "disp_z"):
            a = getattr(state, name).numpy()
            bad = np.argwhere(~np.isfinite(a))
            if bad.size:
                iy, ix = bad[0]
                raise NonFiniteError(
                    f"normal solve: non-finite {name} at iteration {iteration}, cell (row {iy}, column {ix})"
                )
        raise NonFiniteError(f"normal solve: non-finite residual at iteration {iteration}")

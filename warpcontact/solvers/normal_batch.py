"""Displacement-driven normal contact of B cases of one grid size, solved together.

The projected conjugate gradients of [`NormalSolver`][warpcontact.solvers.normal.NormalSolver]
(Polonsky & Keer 1999, preconditioned by the circulant inverse of K_zz) with a case axis: every
kernel (``kernels/normal_batch.py``) and every transform (``fft/batch.py``) is launched once for
all B cases, each case with its own approach, tolerance, iterate, conjugacy and convergence. A
converged case stops changing while the others go on; the solve ends when every case has ended.

As the single solver, an iteration carries the gap (g <- g - tau K t: two batched transform
pairs, M g and K t) and recomputes it exactly (a third, K p) only where the carried one may be
wrong: for every case at once, when what any active case's projections changed may matter (the
single solver's ``deferral`` bound), every ``EXACT_EVERY`` iterations, or when a case's carried
residual comes near its tolerance (a case stops on its exact residual). The iterations loop on
the device while a case is active, in a CUDA graph captured once where conditional nodes are
supported (the host waits once a solve); elsewhere the host reads two counts an iteration
(``flags``). What the single solver does besides to spare launches (sums in Fourier space) is not
done here: one batched launch serves many cases. The iterates
differ from the single solver's in rounding and in the path to the solution; the converged
pressures agree within the tolerance.
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from warpcontact.kernels import normal as nk
from warpcontact.kernels import normal_batch as bk
from warpcontact.kernels import reduce as rk
from warpcontact.kernels import spectral_batch as sbk

from ..fft.batch import BatchConvolution
from ..numerics.device import numpy_dtype
from ..numerics.launch import BatchLaunches, CapturedGraphs, graphs_supported
from ..numerics.state import SolveInfo

#: iterations between exact recomputations of the carried gap (rounding), and the share of the
#: violation the carried gap may miss, as the single solver's defaults (``SolverSettings``)
EXACT_EVERY = 50
DEFERRAL = 0.1


def row_infos(solver, active, tol) -> list:
    """One ``SolveInfo`` per row of a batched ``solver`` (its ``launches``, ``sums``, ``residual``,
    ``start_residual`` and ``scalars``), from each row's residual sums and iterations, its
    ``history`` the residual it started from; a row not ``active``: not converged, no iteration."""
    solver.launches.cases(bk.batch_residual, [solver.sums], [solver.residual])
    residual = solver.residual.numpy().astype(np.float64)
    start = solver.start_residual.numpy().astype(np.float64)
    iterations = solver.scalars.numpy()[:, rk.C_ITER].astype(np.int64)
    return [SolveInfo(converged=bool(on and math.isfinite(r) and r < t), iterations=int(k) if on else 0,
                      residual=float(r) if on else math.nan, history=[float(r0)] if on else [])
            for on, r, r0, k, t in zip(active, residual, start, iterations, tol)]


class BatchNormalSolver:
    """Normal contact of up to ``batch`` cases of an n x n grid at once, in scaled units.

    Args:
        n: cells per side.
        batch: cases B the buffers hold.
        device: a Warp device.
        dtype: ``wp.float32`` or ``wp.float64``.

    The caller fills ``initial_gap`` (B, n^2) (h0 / dx of each case) and calls
    [`solve`][warpcontact.solvers.normal_batch.BatchNormalSolver.solve]; ``pressure`` (p / E*),
    ``gap`` (h / dx) and ``displacement`` (u_z / dx) then hold each case's solution, one row a
    case. A case whose pressure is zero starts from the single solver's Hertz-shaped guess, the
    others from their pressure (a warm start along a path).
    """

    def __init__(self, n: int, batch: int, device, dtype):
        self.n, self.batch = int(n), int(batch)
        self.device = wp.get_device(device)
        self.dtype = dtype
        self.np_dtype = numpy_dtype(dtype)
        self.n_cells = self.n * self.n
        cells = (self.batch, self.n_cells)

        def field():
            return wp.zeros(cells, dtype=dtype, device=self.device)

        self.initial_gap, self.pressure, self.gap, self.displacement = field(), field(), field(), field()
        #: each case's normal displacement of tractions held fixed (h = h0 - delta_z + u_z + known;
        #: the shear's, K_zt q, in a coupled step; zero unless the caller fills it)
        self.known = field()
        self.interference, self.direction, self.shape = field(), field(), field()
        self.convolution = BatchConvolution(self.n, self.batch, self.device, dtype)
        self.sums = wp.zeros((self.batch, bk.N_BATCH_SUMS), dtype=dtype, device=self.device)
        self.scalars = wp.zeros((self.batch, rk.N_SCALARS), dtype=dtype, device=self.device)
        self.parameters = wp.zeros((self.batch, rk.N_PARAMETERS), dtype=dtype, device=self.device)
        self.guess_sums = wp.zeros((self.batch, nk.N_GUESS_SUMS), dtype=dtype, device=self.device)
        self.pressure_cap = wp.zeros(self.batch, dtype=dtype, device=self.device)
        self.residual = wp.zeros(self.batch, dtype=dtype, device=self.device)
        #: each case's relative residual at the start of the last solve (the turns' schedule)
        self.start_residual = wp.zeros(self.batch, dtype=dtype, device=self.device)
        self.active = wp.zeros(self.batch, dtype=wp.int32, device=self.device)
        #: ``batch_advance``'s counts: active cases, cases whose next iteration needs an exact gap
        self.flags = wp.zeros(2, dtype=wp.int32, device=self.device)
        #: each case's L1 change by projections since its last exact gap (scaled)
        self.deferred = wp.zeros(self.batch, dtype=dtype, device=self.device)
        #: the counts as the device loop's conditions
        self._going, self._exact = self.flags[bk.F_ACTIVE:bk.F_ACTIVE + 1], self.flags[bk.F_EXACT:bk.F_EXACT + 1]
        #: the launches, recorded once and replayed
        self.launches = BatchLaunches(self.batch, self.n_cells, self.device)
        #: a solve's device work as a CUDA graph (where conditional nodes are supported), captured
        #: once an iteration has run eagerly (its kernels loaded)
        self.graphs = CapturedGraphs(self.device, graphs_supported(self.device), type(self).__name__)
        self._body_ran = False
        self._cells, self._reduce, self._cases = self.launches.cells, self.launches.reduce, self.launches.cases

    # -- the solve --------------------------------------------------------------------------
    def solve(self, approach_z, tol, max_iter, pressure_cap=None, active=None) -> list:
        """Solve every case at its rigid approach ``approach_z[b]`` (scaled: delta_z / dx) to the
        relative residual ``tol`` (a number, or one per case) within ``max_iter`` iterations (a
        number, or one per case). ``pressure_cap``: each case's cap / E* (None: none).
        ``active``: which rows to solve (booleans, one per row; default all); the others are
        left as they are. Returns one ``SolveInfo`` (``warpcontact.numerics.state``) per
        row (for a row not solved: not converged, no iteration)."""
        rows = self.batch
        big = float(np.finfo(self.np_dtype).max)

        def per_row(values, dtype=np.float64):  # a number for every row, or the first rows' values
            out = np.zeros(rows, dtype=dtype)
            out[: np.size(values) if np.ndim(values) else rows] = values
            return out

        active = per_row(True if active is None else active, bool)

        tol, max_iter = per_row(tol), per_row(max_iter).astype(np.int64)
        parameters = np.zeros((rows, rk.N_PARAMETERS))
        parameters[:, rk.P_APPROACH] = per_row(approach_z)
        parameters[:, rk.P_TOL] = tol
        parameters[:, rk.P_MAX_ITER] = max_iter
        self.parameters.assign(parameters.astype(self.np_dtype))
        caps = np.full(rows, big) if pressure_cap is None else np.minimum(per_row(pressure_cap), big)
        self.pressure_cap.assign(caps.astype(self.np_dtype))
        self.active.assign(active.astype(np.int32))
        self.graphs.launch("solve", self._iterations, ready=lambda: self._body_ran)
        return row_infos(self, active, tol)

    def _iterations(self):
        """The device work of a solve: the start (each case's interference, first guess and exact
        gap), the iterations while a case is active (a loop on the device, ``wp.capture_while`` on
        the count of active cases, each iteration followed by the exact gaps where a case asks for
        them, ``wp.capture_if``; where the launches are not captured the host reads both counts
        each iteration) and every row's exact gap, displacement and residual."""
        self.scalars.zero_()
        self.sums.zero_()
        self.direction.zero_()
        self._cells(bk.batch_interference, [self.initial_gap, self.known, self.parameters], [self.interference])
        self._guess()
        self._exact_gap()
        self._cases(bk.batch_residual, [self.sums], [self.start_residual])
        self._going.fill_(1)  # at least one iteration: a case active at its start is judged by ``batch_advance``
        wp.capture_while(self._going, self._iteration)
        self._exact_gap()

    def _guess(self):
        """The first guess of each case whose pressure is zero (``NormalSolver._guess``)."""
        c = self.convolution
        self.guess_sums.zero_()
        self._reduce(bk.batch_count_positive, [self.pressure], [self.guess_sums])
        self._reduce(bk.batch_max_interference, [self.interference], [self.guess_sums])
        self._cells(bk.batch_guess_shape, [self.interference, self.guess_sums, self.n], [self.shape, c.source])
        c.apply()
        self._reduce(bk.batch_guess_fit_sums, [self.interference, self.shape, c.result, self.n],
                     [self.guess_sums])
        self._cells(bk.batch_guess_scale, [self.guess_sums, self.shape, self.pressure_cap], [self.pressure])

    def _exact_gap(self):
        """The exact gap, displacement and residual sums of every case's pressure."""
        c = self.convolution
        self._cases(bk.batch_clear_residual, [], [self.sums, self.deferred])
        self._cells(sbk.batch_pad, [self.pressure, self.n], [c.source])
        c.apply()
        self._reduce(bk.batch_gap, [c.result, self.interference, self.pressure, self.pressure_cap, self.n],
                     [self.gap, self.displacement, self.sums])

    def _iteration(self):
        """One preconditioned conjugate-gradient iteration of every active case, from the gap and
        residual sums of its iterate (exact, or carried by the last iteration); then the exact gaps
        where a case's next iteration needs its own (``flags[F_EXACT]``)."""
        self._body_ran = True
        self.flags.zero_()
        self._step()
        wp.capture_if(self._exact, on_true=self._exact_gap)

    def _step(self):
        """The conjugate-gradient step of every active case and ``batch_advance``'s counts."""
        c = self.convolution
        cap = self.pressure_cap
        self._cells(bk.batch_free_gap, [self.gap, self.pressure, cap, self.n], [c.inverse_source])
        c.apply(inverse=True)
        self._reduce(bk.batch_free_gap_sum, [self.gap, self.pressure, cap, c.inverse_result, self.n], [self.sums])
        self._cells(bk.batch_direction,
                    [self.gap, self.pressure, cap, c.inverse_result, self.sums, self.scalars, self.n],
                    [self.direction, c.source])
        c.apply()
        self._reduce(bk.batch_step_sums, [self.gap, self.direction, c.result, self.n], [self.sums])
        self._reduce(bk.batch_update, [self.direction, c.result, self.n, self.interference, cap, self.parameters,
                                       self.active], [self.pressure, self.gap, self.sums])
        self._cases(bk.batch_advance, [self.sums, self.parameters, EXACT_EVERY, self.dtype(c.column_norm),
                                       self.dtype(DEFERRAL)], [self.scalars, self.active, self.deferred, self.flags])

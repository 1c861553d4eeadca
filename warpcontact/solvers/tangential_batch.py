"""Partial slip of B cases of one grid size, solved together.

The bounded conjugate gradients of [`TangentialSolver`][warpcontact.solvers.tangential.TangentialSolver]
(after Chen & Wang 2008) with a case axis: every kernel (``kernels/tangential_batch.py``) and
every transform ([`BatchElasticOperator`][warpcontact.fft.batch.BatchElasticOperator]) is launched
once for all B cases, each case with its own material pair, shear limit, target, tolerance,
iterate, conjugacy and convergence. A converged case stops changing while the others go on; the
solve ends when every case has ended: the iterations loop on the device while a case is active
(``wp.capture_while``), in a CUDA graph captured once where conditional nodes are supported (the
host waits once a solve); elsewhere the host reads that count each iteration.

Preconditioned (the default, as the single solver): the direction is built from z = M g on the
stick cells, M each case's circulant inverse of K_tt (its pair's 2x2 blocks per wavenumber,
floored as the single solver floors them), and the Jacobi-scaled tangent part of g on slip
cells. Unlike the single solver, g is not carried: an iteration makes K q (the exact g), M g and
K t, three batched transform pairs, where the plain iteration (Chen & Wang's Jacobi scaling,
``preconditioned=False``) makes two but takes about twice the iterations.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from warpcontact.kernels import reduce as rk
from warpcontact.kernels import tangential as tk
from warpcontact.kernels import tangential_batch as tbk

from ..fft.batch import BatchElasticOperator
from ..numerics.device import numpy_dtype
from ..numerics.launch import BatchLaunches, CapturedGraphs, graphs_supported
from .normal_batch import row_infos

#: iterations between restarts of the conjugacy (the single solver's ``restart_every``)
RESTART_EVERY = 100


class BatchTangentialSolver:
    """The shear of up to ``batch`` cases of an n x n grid under their disk bounds, in scaled units.

    Args:
        operator: the cases' [`BatchElasticOperator`][warpcontact.fft.batch.BatchElasticOperator]
            (its rows' pairs set).
        stiffness: each row's self-influence of K_tt (``BatchElasticOperator.set_pairs``).
        preconditioned: build the directions from the circulant inverse of K_tt on the stick
            cells; False: the plain iteration (Jacobi scaling).

    The caller fills ``target_x/y`` (delta - s_prev), ``shear_limit`` (q_max) and ``known``
    (the tangential displacement of tractions held fixed) and calls
    [`solve`][warpcontact.solvers.tangential_batch.BatchTangentialSolver.solve]; ``shear``
    (q / E*, the start and the answer), ``status`` (0 out of contact, 1 stick, 2 slip) and
    ``disp`` (K_tt q) then hold each case's solution, one row a case. Vector fields are (2, B,
    n^2) arrays (x, y: transformed in one batched call), their components ``shear_x``,
    ``shear_y`` etc. views of them.
    """

    def __init__(self, operator: BatchElasticOperator, stiffness, preconditioned: bool = True):
        self.operator = operator
        self.preconditioned = bool(preconditioned)
        self.n, self.batch = operator.n, operator.batch
        self.device, self.dtype = operator.device, operator.dtype
        self.np_dtype = numpy_dtype(self.dtype)
        self.n_cells = self.n * self.n
        cells = (self.batch, self.n_cells)

        def field():
            return wp.zeros(cells, dtype=self.dtype, device=self.device)

        def pair():  # x and y of a vector field in one array (2, B, n^2): transformed together
            return wp.zeros((2, *cells), dtype=self.dtype, device=self.device)

        self.shear, self.disp, self.known, self.direction, self.response = (pair() for _ in range(5))
        #: g on the stick cells and M of it (the preconditioned iteration's)
        self.stick_gradient = self.preconditioned_gradient = None
        if self.preconditioned:
            self.stick_gradient, self.preconditioned_gradient = pair(), pair()
        self.shear_x, self.shear_y = self.shear[0], self.shear[1]
        self.disp_x, self.disp_y = self.disp[0], self.disp[1]
        self.known_x, self.known_y = self.known[0], self.known[1]
        self.dir_x, self.dir_y = self.direction[0], self.direction[1]
        self.resp_x, self.resp_y = self.response[0], self.response[1]
        self.target_x, self.target_y, self.shear_limit, self.grad_x, self.grad_y = (field() for _ in range(5))
        self.status = wp.zeros(cells, dtype=wp.int32, device=self.device)
        self.stiffness = wp.array(np.asarray(stiffness, dtype=self.np_dtype), device=self.device)
        self.sums = wp.zeros((self.batch, tk.N_SUMS), dtype=self.dtype, device=self.device)
        self.scalars = wp.zeros((self.batch, rk.N_SCALARS), dtype=self.dtype, device=self.device)
        self.parameters = wp.zeros((self.batch, rk.N_PARAMETERS), dtype=self.dtype, device=self.device)
        self.residual = wp.zeros(self.batch, dtype=self.dtype, device=self.device)
        self.active = wp.zeros(self.batch, dtype=wp.int32, device=self.device)
        self.flags = wp.zeros(1, dtype=wp.int32, device=self.device)
        #: the launches, recorded once and replayed
        self.launches = BatchLaunches(self.batch, self.n_cells, self.device)
        #: a solve's device work as a CUDA graph (where conditional nodes are supported), captured
        #: once an iteration has run eagerly (its kernels loaded)
        self.graphs = CapturedGraphs(self.device, graphs_supported(self.device), type(self).__name__)
        self._body_ran = False
        self._cells, self._reduce, self._cases = self.launches.cells, self.launches.reduce, self.launches.cases

    def set_stiffness(self, stiffness):
        """Each row's self-influence of K_tt (its pair's: ``BatchElasticOperator.set_pairs``)."""
        self.stiffness.assign(np.asarray(stiffness, dtype=self.np_dtype))

    # -- the solve ------------------------------------------------------------------------------
    def solve(self, tol, max_iter, active) -> list:
        """Solve the rows where ``active`` (booleans, one per row) to the relative residual ``tol``
        (one per row) within ``max_iter`` iterations (one per row); the other rows are left as
        they are. Returns one ``SolveInfo`` per row (a row not solved: not converged, no iteration)."""
        active = np.asarray(active, dtype=bool)
        tol = np.asarray(tol, dtype=np.float64)
        max_iter = np.asarray(max_iter, dtype=np.int64)
        parameters = np.zeros((self.batch, rk.N_PARAMETERS))
        parameters[:, rk.P_TOL] = tol
        parameters[:, rk.P_MAX_ITER] = max_iter
        self.parameters.assign(parameters.astype(self.np_dtype))
        self.active.assign(active.astype(np.int32))
        self.graphs.launch("solve", self._iterations, ready=lambda: self._body_ran)
        return row_infos(self, active, tol)

    def _iterations(self):
        """The device work of a solve: the start, the iterations while a case is active (a loop
        on the device: ``wp.capture_while`` on ``flags``, which the host reads each iteration
        where the launches are not captured) and every row's exact g, K_tt q and residual."""
        self.scalars.zero_()
        self.sums.zero_()
        self.direction.zero_()
        self._cells(tbk.batch_tangential_classify, [self.shear_limit, self.active, int(self.preconditioned)],
                    [self.shear_x, self.shear_y, self.status])
        self.flags.fill_(1)  # at least one iteration: a case active at its start is judged by ``advance``
        wp.capture_while(self.flags, self._iteration)
        self._gradient()

    def _iteration(self):
        """One iteration of every active case; ``flags`` then counts the cases still active."""
        self._body_ran = True
        self._gradient()
        self._direction()
        self.operator.tangential(self.direction, self.response)
        self._reduce(tbk.batch_tangential_step_sums,
                     [self.grad_x, self.grad_y, self.dir_x, self.dir_y, self.resp_x, self.resp_y, self.shear_x,
                      self.shear_y, self.shear_limit, self.status], [self.sums])
        self._reduce(tbk.batch_tangential_update,
                     [self.grad_x, self.grad_y, self.dir_x, self.dir_y, self.shear_limit, self.stiffness,
                      self.parameters, self.active], [self.shear_x, self.shear_y, self.status, self.sums])
        self.flags.zero_()
        self._cases(tbk.batch_tangential_advance, [self.sums, self.parameters, RESTART_EVERY],
                    [self.scalars, self.active, self.flags])

    def _gradient(self):
        """K_tt q into ``disp``, the exact g and each row's residual sums (zeroed before; slot
        S_G without the stick cells' part where preconditioned: ``_direction`` adds it)."""
        self.sums.zero_()
        self.operator.tangential(self.shear, self.disp)
        self._reduce(tbk.batch_tangential_residual,
                     [self.disp_x, self.disp_y, self.known_x, self.known_y, self.target_x, self.target_y,
                      self.shear_x, self.shear_y, self.shear_limit, self.status, self.stiffness,
                      int(not self.preconditioned)],
                     [self.grad_x, self.grad_y, self.sums])

    def _direction(self):
        """Each row's conjugate direction: preconditioned, z = M g on the stick cells (with
        their g . z into slot S_G first, for the conjugacy), or the plain one."""
        common = [self.shear_x, self.shear_y, self.shear_limit, self.status, self.stiffness, self.sums, self.scalars]
        if not self.preconditioned:
            self._cells(tbk.batch_tangential_direction, [self.grad_x, self.grad_y, *common], [self.dir_x, self.dir_y])
            return
        stick, z = self.stick_gradient, self.preconditioned_gradient
        self._cells(tbk.batch_stick_gradient, [self.grad_x, self.grad_y, self.status], [stick[0], stick[1]])
        self.operator.tangential_inverse(stick, z)
        self._reduce(tbk.batch_stick_energy, [self.grad_x, self.grad_y, z[0], z[1], self.status], [self.sums])
        self._cells(tbk.batch_tangential_direction_preconditioned, [self.grad_x, self.grad_y, z[0], z[1], *common],
                    [self.dir_x, self.dir_y])

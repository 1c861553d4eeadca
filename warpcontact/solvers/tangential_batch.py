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
cells, and g is carried (g <- g - tau K t): an iteration makes M g and K t, two batched transform
pairs, and K q (the exact g, a third) only where a case asks for it, for every row at once: after
a released cell, every ``EXACT_EVERY`` iterations and where the bound on what its carried g
misses passes ``DEFERRAL`` of its violation, as the single solver decides. A case stops where its
carried g meets its tolerance; after the loop every row's g is made exact and judged, and the
cases it does not agree with go on from it (``RESUMES`` times at most), as the single solver's
settled loop does.
The plain iteration (Chen & Wang's Jacobi scaling, ``preconditioned=False``) makes K q and K t
from the exact g each iteration and takes about twice the iterations.
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from warpcontact.kernels import normal_batch as bk
from warpcontact.kernels import reduce as rk
from warpcontact.kernels import tangential as tk
from warpcontact.kernels import tangential_batch as tbk

from ..fft.batch import BatchElasticOperator
from ..numerics.device import numpy_dtype
from ..numerics.launch import BatchLaunches, CapturedGraphs, graphs_supported
from .normal_batch import DEFERRAL, EXACT_EVERY, row_infos

#: iterations between restarts of the conjugacy (the single solver's ``restart_every``)
RESTART_EVERY = 100
#: times a solve goes on from the exact g of cases that stopped on their carried g where the exact
#: one does not meet the tolerance (the single solver's disagreements); past them such a case is
#: reported as not converged
RESUMES = 3


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
        slots = tk.N_SUMS_PRECONDITIONED if self.preconditioned else tk.N_SUMS
        self.sums = wp.zeros((self.batch, slots), dtype=self.dtype, device=self.device)
        #: each row's L1 change by projections since its last exact g (scaled), and its bound on
        #: ||K_tt c||_2 / ||c||_1 (its pair's: ``BatchElasticOperator.column_norms``)
        self.deferred = wp.zeros(self.batch, dtype=self.dtype, device=self.device)
        self.column_norm = wp.array(np.asarray(operator.column_norms, dtype=self.np_dtype), device=self.device)
        self.scalars = wp.zeros((self.batch, rk.N_SCALARS), dtype=self.dtype, device=self.device)
        self.parameters = wp.zeros((self.batch, rk.N_PARAMETERS), dtype=self.dtype, device=self.device)
        self.residual = wp.zeros(self.batch, dtype=self.dtype, device=self.device)
        #: each case's relative residual at the start of the last solve (the turns' schedule; inf
        #: for the plain iteration, which makes its exact g inside its iterations)
        self.start_residual = wp.zeros(self.batch, dtype=self.dtype, device=self.device)
        self.active = wp.zeros(self.batch, dtype=wp.int32, device=self.device)
        self.flags = wp.zeros(2, dtype=wp.int32, device=self.device)
        #: the counts as the device loop's conditions
        self._going, self._exact = self.flags[tbk.F_ACTIVE:tbk.F_ACTIVE + 1], self.flags[tbk.F_EXACT:tbk.F_EXACT + 1]
        #: the launches, recorded once and replayed
        self.launches = BatchLaunches(self.batch, self.n_cells, self.device)
        #: a solve's device work as a CUDA graph (where conditional nodes are supported), captured
        #: once an iteration has run eagerly (its kernels loaded)
        self.graphs = CapturedGraphs(self.device, graphs_supported(self.device), type(self).__name__)
        self._body_ran = False
        self._cells, self._reduce, self._cases = self.launches.cells, self.launches.reduce, self.launches.cases

    def set_stiffness(self, stiffness):
        """Each row's self-influence of K_tt (its pair's: ``BatchElasticOperator.set_pairs``), and
        its column norm (the operator's, set with it)."""
        self.stiffness.assign(np.asarray(stiffness, dtype=self.np_dtype))
        self.column_norm.assign(np.asarray(self.operator.column_norms, dtype=self.np_dtype))

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
        infos = row_infos(self, active, tol)
        for _ in range(RESUMES if self.preconditioned else 0):
            # a case stopped on its carried g where its exact g does not meet the tolerance: on from it
            again = np.array([on and not i.converged and math.isfinite(i.residual) and i.iterations < limit
                              for on, i, limit in zip(active, infos, max_iter)])
            if not again.any():
                break
            self.active.assign(again.astype(np.int32))
            self.graphs.launch("resume", self._carried_loop, ready=lambda: self._body_ran)
            infos = row_infos(self, active, tol)
        return infos

    def _iterations(self):
        """The device work of a solve: the start, the iterations while a case is active (a loop
        on the device: ``wp.capture_while`` on ``flags``, which the host reads each iteration
        where the launches are not captured) and every row's exact g, K_tt q and residual."""
        self.scalars.zero_()
        self.sums.zero_()
        self.direction.zero_()
        self._cells(tbk.batch_tangential_classify, [self.shear_limit, self.active, int(self.preconditioned)],
                    [self.shear_x, self.shear_y, self.status])
        if self.preconditioned:
            self._gradient()
            self._cases(bk.batch_residual, [self.sums], [self.start_residual])
            self._carried_loop()
            return
        self.start_residual.fill_(math.inf)
        self._going.fill_(1)  # at least one iteration: a case active at its start is judged by ``advance``
        wp.capture_while(self._going, self._iteration)
        self._gradient()

    def _carried_loop(self):
        """The carried iterations of the active rows from their exact g (a solve's start, or the
        last one's where a case is resumed), then every row's exact g."""
        self._going.fill_(1)  # at least one iteration: a case active at its start is judged by ``advance``
        self._exact.zero_()
        wp.capture_while(self._going, self._carried_iteration)
        self._gradient()

    def _iteration(self):
        """One plain iteration of every active case, from its exact g; ``flags`` then counts the
        cases still active."""
        self._body_ran = True
        self._gradient()
        self._direction()
        self._step()
        self._reduce(tbk.batch_tangential_update,
                     [self.grad_x, self.grad_y, self.dir_x, self.dir_y, self.shear_limit, self.stiffness,
                      self.parameters, self.active], [self.shear_x, self.shear_y, self.status, self.sums])
        self.flags.zero_()
        self._cases(tbk.batch_tangential_advance, [self.sums, self.parameters, RESTART_EVERY],
                    [self.scalars, self.active, self.flags])

    def _carried_iteration(self):
        """One preconditioned iteration of every active case with g carried (g <- g - tau K t):
        first the exact g of every row where a case asked for it (``flags[F_EXACT]``:
        ``wp.capture_if``); ``flags`` then counts the cases still active and those that ask."""
        self._body_ran = True
        wp.capture_if(self._exact, on_true=self._gradient)
        self._direction()
        self._step()
        self._reduce(tbk.batch_tangential_carried_update,
                     [self.dir_x, self.dir_y, self.resp_x, self.resp_y, self.shear_limit, self.stiffness,
                      self.parameters, self.active],
                     [self.shear_x, self.shear_y, self.status, self.grad_x, self.grad_y, self.sums])
        self.flags.zero_()
        self._cases(tbk.batch_tangential_carried_advance,
                    [self.sums, self.parameters, RESTART_EVERY, EXACT_EVERY, self.column_norm, self.dtype(DEFERRAL)],
                    [self.scalars, self.active, self.deferred, self.flags])

    def _step(self):
        """K t of the direction into ``response`` and each row's step sums (S_GT, S_RT)."""
        self.operator.tangential(self.direction, self.response)
        self._reduce(tbk.batch_tangential_step_sums,
                     [self.grad_x, self.grad_y, self.dir_x, self.dir_y, self.resp_x, self.resp_y, self.shear_x,
                      self.shear_y, self.shear_limit, self.status], [self.sums])

    def _gradient(self):
        """K_tt q into ``disp``, the exact g and each row's residual sums (zeroed before, with
        what its carried g missed; slot S_G without the stick cells' part where preconditioned:
        ``_direction`` adds it)."""
        self.sums.zero_()
        self.deferred.zero_()
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

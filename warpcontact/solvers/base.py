"""What the projected conjugate-gradient solvers share: buffers of scalars, launches, the loop."""

from __future__ import annotations

import math
from collections import OrderedDict

import numpy as np
import warp as wp

from warpcontact.kernels.reduce import N_SETTINGS, P_TOL

from .. import interrupts
from ..state import SolveInfo


def default_tolerance(dtype) -> float:
    """Relative residual a solve aims for: 1e-10 in float64, 1e-5 in float32 (whose rounding
    floor on these sums is about 1e-6)."""
    return 1e-10 if dtype == wp.float64 else 1e-5


class ProjectedCG:
    """Base of the normal and tangential solvers.

    Subclasses pass ``_run`` the device work of one iteration (which records the residual of the
    iterate it started from in ``self.history``) and a function that computes the fields and
    relative residual of the current iterate. Scalars stay on the device; the residual is read
    back every ``check_every`` iterations (every iteration on the CPU, where a read is free).

    Besides every ``check_every`` iterations, the residual is read after iterations 1, 2 and 4
    (``early_checks``): the solves of a coupled or adhesive step's turns start near their
    solution and often need 1-4 iterations, and the ones that run on past convergence until the
    next read do full iterations (an adhesive Table 2 cell at n = 256 on an H100: 8640 inner
    iterations with reads every 8 only; see README "Performance").

    On CUDA each iteration is replayed as a CUDA graph (``use_graphs``): captured the first time
    a set of arrays is seen (:meth:`_device_step`), then launched with one call, so the host no
    longer pays a launch per kernel and per FFT. The values of a solve that the kernels read
    (tolerance, approach) live in the device array ``settings``, so one graph serves every solve.
    """

    #: iterations between restarts of the conjugacy (beta = 0); 0 for none. Restarts cure the
    #: stalls of conjugate directions built while the active set was changing.
    restart_every = 0
    #: captured graphs kept per solver (one per set of arrays and iteration variant), oldest dropped
    max_graphs = 8
    #: iterations after which the residual is also read (warm-started solves end early)
    early_checks = (1, 2, 4)

    def __init__(self, model, n_sums: int, n_scalars: int, tol=None, max_iter: int = 2000, check_every=None,
                 use_graphs: bool | None = None):
        self.model = model
        self.tol = default_tolerance(model.dtype) if tol is None else float(tol)
        self.max_iter = int(max_iter)
        self.check_every = check_every or (1 if model.device.is_cpu else 8)
        self.sums = model.scalars(n_sums)
        self.scalars = model.scalars(n_scalars)
        self.history = model.scalars(self.max_iter + 1)
        #: per-solve values read by the kernels (slots P_* of kernels/reduce.py)
        self.settings = model.scalars(N_SETTINGS)
        self._settings = np.zeros(N_SETTINGS)
        #: replay iterations as captured CUDA graphs (default: on CUDA devices)
        self.use_graphs = model.device.is_cuda if use_graphs is None else bool(use_graphs)
        if self.use_graphs and not model.device.is_cuda:
            raise ValueError("use_graphs: CUDA graphs need a CUDA device")
        self._graphs: OrderedDict = OrderedDict()

    def _set(self, slot: int, value: float):
        """settings[slot] <- value, sent to the device at once (a few bytes, before the solve)."""
        self._settings[slot] = value
        self.settings.assign(self._settings.astype(self.model.np_dtype))

    def _device_step(self, key, body):
        """Run ``body()``, the device work of one iteration: eagerly, or on CUDA from a graph
        captured the first time ``key`` (the arrays ``body`` touches and its variant) is seen.

        The first time, ``body`` runs eagerly (loading its kernels and FFT plans) and is then
        captured, which does not run it again.
        """
        if not self.use_graphs:
            body()
            return
        graph = self._graphs.get(key)
        if graph is not None:
            self._graphs.move_to_end(key)
            wp.capture_launch(graph)
            return
        body()
        with wp.ScopedCapture(device=self.model.device, force_module_load=False) as capture:
            body()
        self._graphs[key] = capture.graph
        while len(self._graphs) > self.max_graphs:
            self._graphs.popitem(last=False)

    def _relative_residual(self, viol_slot: int, rhs_slot: int) -> float:
        s = self.sums.numpy().astype(np.float64)
        if not (math.isfinite(s[viol_slot]) and math.isfinite(s[rhs_slot])):
            return math.nan  # a non-finite traction or displacement: the caller raises NonFiniteError
        if s[rhs_slot] > 0:
            return math.sqrt(s[viol_slot] / s[rhs_slot])
        return 0.0 if s[viol_slot] == 0 else 1.0

    def _run(self, iteration, final_fields, on_non_finite, tol=None) -> SolveInfo:
        """The loop: iterate until the residual of the current iterate is under ``tol``
        (default ``self.tol``; the update kernels read it from ``settings``)."""
        tol = self.tol if tol is None else tol
        self.active_tol = tol
        self._set(P_TOL, tol)
        self.scalars.zero_()
        self.history.fill_(-1.0)
        it = 0
        residual = final_fields()
        while not residual < tol and it < self.max_iter:
            if not math.isfinite(residual):
                on_non_finite(it)
            if self.restart_every and it and it % self.restart_every == 0:
                self.scalars[0:1].zero_()  # G_old = 0: the next direction is the (preconditioned) gradient
            interrupts.check()
            iteration()
            it += 1
            if it % self.check_every == 0 or it in self.early_checks or it == self.max_iter:
                recorded = float(self.history.numpy()[it - 1])
                if not math.isfinite(recorded):
                    on_non_finite(it)
                if recorded < tol or it == self.max_iter:
                    residual = final_fields()
        if not math.isfinite(residual):
            on_non_finite(it)
        hist = self.history.numpy()[:it].astype(np.float64)
        return SolveInfo(converged=bool(residual < tol), iterations=it, residual=residual, history=hist.tolist())


def raise_non_finite(solver_name: str, state, names, iteration: int):
    """Raise NonFiniteError naming the first non-finite field and cell."""
    from ..errors import NonFiniteError

    for name in names:
        a = getattr(state, name).numpy()
        bad = np.argwhere(~np.isfinite(a))
        if bad.size:
            iy, ix = bad[0]
            raise NonFiniteError(f"{solver_name}: non-finite {name} at iteration {iteration}, cell (row {iy}, column {ix})")
    raise NonFiniteError(f"{solver_name}: non-finite residual at iteration {iteration}")

"""What the projected conjugate-gradient solvers share: buffers of scalars, launches, the loop."""

from __future__ import annotations

import math
from collections import OrderedDict

import numpy as np
import warp as wp

from warpcontact.kernels.reduce import C_ITER, C_RESIDUAL, N_SETTINGS, P_CHUNK, P_MAX_ITER, P_TOL

from .. import interrupts
from ..state import SolveInfo


def default_tolerance(dtype) -> float:
    """Relative residual a solve aims for: 1e-10 in float64, 1e-5 in float32 (whose rounding
    floor on these sums is about 1e-6)."""
    return 1e-10 if dtype == wp.float64 else 1e-5


class ProjectedCG:
    """Base of the normal and tangential solvers.

    A subclass gives :meth:`_run` the device work of one iteration (``body``: its last kernel
    calls :func:`warpcontact.kernels.reduce.advance`, which records the residual of the iterate the
    iteration started from, counts the iteration and sets the loop flag) and a function that
    computes the fields and relative residual of the current iterate. Scalars stay on the device.

    The iterations run in a loop on the device (``wp.capture_while`` on ``self.loop``): one launch
    runs up to ``iterations_per_launch`` iterations and stops as soon as the residual of the
    iterate an iteration starts from is under the tolerance, is not finite, or the iteration
    limit is reached; the host then reads two numbers (iteration count, last residual), checks
    for interrupts, and launches again or finishes. A solve that starts near its solution (the
    turns of a coupled or adhesive step: often 1-4 iterations) stops at the iteration where it
    converged, with one read.

    On CUDA (``use_graphs``) the launch is a CUDA graph captured the first time a set of arrays is
    seen: with conditional graph nodes (CUDA 12.4+) the whole loop, a while node around the
    iteration, so the host waits once per launch; without them, a graph of one iteration, with the
    flag read after each. The values of a solve that the kernels read (tolerance, approach,
    iteration limit) live in the device array ``settings``, so one graph serves every solve. On
    the CPU the loop runs eagerly and reads the flag after each iteration (a read is free there).
    """

    #: iterations between restarts of the conjugacy (beta = 0); 0 for none. Restarts cure the
    #: stalls of conjugate directions built while the active set was changing.
    restart_every = 0
    #: captured graphs kept per solver (one per set of arrays and iteration variant), oldest dropped
    max_graphs = 8
    #: iterations per launch of the device loop at most: the host checks for interrupts between
    #: launches (one read of two numbers each)
    iterations_per_launch = 64

    def __init__(self, model, n_sums: int, n_scalars: int, tol=None, max_iter: int = 2000, use_graphs: bool | None = None):
        self.model = model
        self.tol = default_tolerance(model.dtype) if tol is None else float(tol)
        self.max_iter = int(max_iter)
        self.sums = model.scalars(n_sums)
        self.scalars = model.scalars(n_scalars)
        self.history = model.scalars(self.max_iter + 1)
        #: per-solve values read by the kernels (slots P_* of kernels/reduce.py)
        self.settings = model.scalars(N_SETTINGS)
        self._settings = np.zeros(N_SETTINGS)
        #: the device loop's flag: 1 while the iterations go on (kernels/reduce.py, ``advance``)
        self.loop = wp.zeros(1, dtype=wp.int32, device=model.device)
        #: replay iterations as captured CUDA graphs (default: on CUDA devices)
        self.use_graphs = model.device.is_cuda if use_graphs is None else bool(use_graphs)
        if self.use_graphs and not model.device.is_cuda:
            raise ValueError("use_graphs: CUDA graphs need a CUDA device")
        #: the loop itself inside the graph (a conditional while node: CUDA 12.4+)
        self.graph_loop = self.use_graphs and wp.is_conditional_graph_supported()
        self._graphs: OrderedDict = OrderedDict()

    def _stage(self, slot: int, value: float):
        """settings[slot] <- value on the host; :meth:`_upload` sends them."""
        self._settings[slot] = value

    def _upload(self):
        """Send the staged settings to the device (a few bytes)."""
        self.settings.assign(self._settings.astype(self.model.np_dtype))

    def _begin(self, tol=None):
        """Start a solve: stage its tolerance (default ``self.tol``), iteration limit and launch
        length, send the settings (with what the subclass staged), reset the carried scalars."""
        self.active_tol = self.tol if tol is None else float(tol)
        self._stage(P_TOL, self.active_tol)
        self._stage(P_MAX_ITER, self.max_iter)
        self._stage(P_CHUNK, max(1, int(self.iterations_per_launch)))
        self._upload()
        self.scalars.zero_()
        self.history.fill_(-1.0)

    def _graph(self, key, work):
        """The CUDA graph of ``work()`` for ``key`` (the arrays it touches and its variant), or None
        the first time: then ``work`` runs eagerly (loading its kernels and FFT plans) and is
        captured for the next time, which does not run it again."""
        graph = self._graphs.get(key)
        if graph is not None:
            self._graphs.move_to_end(key)
            return graph
        work()
        with wp.ScopedCapture(device=self.model.device, force_module_load=False) as capture:
            work()
        self._graphs[key] = capture.graph
        while len(self._graphs) > self.max_graphs:
            self._graphs.popitem(last=False)
        return None

    def _launch_iterations(self, key, body):
        """Iterations of ``body`` until the loop flag drops (see the class docstring)."""

        def loop():
            self.loop.fill_(1)
            wp.capture_while(self.loop, body)

        if not self.use_graphs:
            loop()
        elif self.graph_loop:
            graph = self._graph(("loop", *key), loop)
            if graph is not None:
                wp.capture_launch(graph)
        else:
            graph = self._graph(("iteration", *key), body)
            if graph is None:  # the first iteration ran eagerly: go on while its flag asks
                wp.capture_while(self.loop, body)
            else:
                self.loop.fill_(1)
                wp.capture_while(self.loop, graph)  # the host reads the flag after each iteration

    def _relative_residual(self, viol_slot: int, rhs_slot: int) -> float:
        s = self.sums.numpy().astype(np.float64)
        if not (math.isfinite(s[viol_slot]) and math.isfinite(s[rhs_slot])):
            return math.nan  # a non-finite traction or displacement: the caller raises NonFiniteError
        if s[rhs_slot] > 0:
            return math.sqrt(s[viol_slot] / s[rhs_slot])
        return 0.0 if s[viol_slot] == 0 else 1.0

    def _run(self, key, body, final_fields, on_non_finite) -> SolveInfo:
        """The solve after :meth:`_begin`: iterate until the residual of the current iterate is
        under the tolerance (``final_fields`` judges it) or the iteration limit."""
        tol = self.active_tol
        it = 0
        residual = final_fields()
        while not residual < tol and it < self.max_iter:
            if not math.isfinite(residual):
                on_non_finite(it)
            interrupts.check()
            self._launch_iterations(key, body)
            scalars = self.scalars.numpy()
            it, recorded = int(scalars[C_ITER]), float(scalars[C_RESIDUAL])
            if not math.isfinite(recorded):
                on_non_finite(it)
            if recorded < tol or it >= self.max_iter:
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

"""What the projected conjugate-gradient solvers share: buffers of scalars, launches, the loop."""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from warpcontact.kernels.reduce import (
    C_ITER, C_STOP, N_PARAMETERS, P_CHUNK, P_MAX_ITER, P_TOL, S_RHS, S_VIOL, loop_start,
)

from .. import interrupts
from ..numerics.launch import CapturedGraphs, graphs_supported
from ..numerics.state import SolveInfo
from .settings import PRECONDITIONER_FLOAT32_AUTO, RESPONSE_FLOAT32_AUTO, SolverSettings, float32_chosen


def default_tolerance(dtype) -> float:
    """Relative residual a solve aims for: 1e-10 in float64, 1e-5 in float32 (whose rounding
    floor on these sums is about 1e-6)."""
    return 1e-10 if dtype == wp.float64 else 1e-5


class ProjectedCG:
    """Base of the normal and tangential solvers.

    A solve is one launch of device work, or a few: ``start`` (what the solve sets up on the
    device), ``exact`` (the exact fields and residual sums of the current iterate), then the
    iterations in a loop on the device (``wp.capture_while`` on ``self.loop``, ``body`` the device
    work of one iteration, whose last kernel calls ``warpcontact.kernels.reduce.advance``:
    it records the residual of the iterate the iteration started from, counts the iteration and
    sets the loop flag). The loop settles as soon as an iterate's residual is under the tolerance,
    is not finite, or the iteration limit is reached, and ``exact`` then runs again (unless it
    settled before the first iteration, where the sums are exact already); it also stops
    after ``settings.iterations_per_launch`` iterations, where the host checks for interrupts and launches
    it again (nothing else changes there, so the results do not depend on the launch length). The
    host reads the scalars once per launch, and the sums once the loop settled. A solve that
    starts near its solution (the turns of a coupled or adhesive step: often 0-4 iterations)
    stops at the iteration where it converged.

    On CUDA (``use_graphs``, default where conditional graph nodes are supported: CUDA 12.4+) the
    launch is a CUDA graph captured the first time a set of arrays is seen, so a solve waits for
    the device once per launch. The values of a solve that the kernels read (tolerance, approach,
    iteration limit) live in the device array ``parameters``, so one graph serves every solve. On
    the CPU, and on CUDA without graphs, the same work runs eagerly and the host reads the loop's
    flag after each iteration (free on the CPU).
    """

    #: iterations between restarts of the conjugacy (beta = 0); 0 for none. Restarts cure the
    #: stalls of conjugate directions built while the active set was changing.
    restart_every = 0
    #: captured graphs kept per solver (two per set of arrays: the first launch of a solve and the
    #: later ones), oldest dropped
    max_graphs = 8

    def __init__(self, model, settings: SolverSettings, n_sums: int, n_scalars: int):
        self.model = model
        #: the solver's choices ([`SolverSettings`][warpcontact.solvers.settings.SolverSettings]), fixed
        self.settings = settings
        #: relative residual a solve aims for (``settings.tol``, or the float type's default)
        self.tol = default_tolerance(model.dtype) if settings.tol is None else float(settings.tol)
        #: iteration limit of a solve
        self.max_iter = int(settings.max_iter)
        self.sums = model.scalars(n_sums)
        self.scalars = model.scalars(n_scalars)
        self.history = model.scalars(self.max_iter + 1)
        #: per-solve values read by the kernels (slots P_* of kernels/reduce.py)
        self.parameters = model.scalars(N_PARAMETERS)
        self._parameters = np.zeros(N_PARAMETERS)
        #: the device loop's flag: 1 while the iterations go on; and 1 when it settled (converged,
        #: at the limit or not finite: the launch then makes the residual exact)
        self.loop = wp.zeros(1, dtype=wp.int32, device=model.device)
        self.refresh = wp.zeros(1, dtype=wp.int32, device=model.device)
        #: the inner loop's flag where iterations may start with a conditional step (``_run``'s
        #: ``prelude``): 1 while the iterations go on without it
        self.inner_loop = wp.zeros(1, dtype=wp.int32, device=model.device)
        # replay launches as captured CUDA graphs (``settings.use_graphs``; by default on CUDA
        # devices with conditional nodes)
        supported = graphs_supported(model.device)
        use_graphs = supported if settings.use_graphs is None else bool(settings.use_graphs)
        if use_graphs and not supported:
            raise ValueError("settings.use_graphs: the solver's graphs need a CUDA device with conditional graph "
                             "nodes (CUDA toolkit and driver 12.4+)")
        #: the solves' captured graphs (two per set of arrays: the first launch of a solve and the later ones)
        self.graphs = CapturedGraphs(model.device, use_graphs, type(self).__name__, self.max_graphs)
        #: the parts of an iteration (the code of a loop body) that have run eagerly: their kernels
        #: are loaded for this float type; a capture waits until they have (see _launch)
        self._ran_eagerly: set = set()

    @property
    def float32_preconditioner(self) -> bool:
        """Whether the preconditioner transforms in float32 beside float64 fields
        (``settings.preconditioner_float32``; "auto": ``PRECONDITIONER_FLOAT32_AUTO``)."""
        return self._float32(self.settings.preconditioner_float32, PRECONDITIONER_FLOAT32_AUTO)

    @property
    def float32_response(self) -> bool:
        """Whether the conjugate direction's response K t transforms in float32 beside float64
        fields (``settings.response_float32``; "auto": ``RESPONSE_FLOAT32_AUTO``)."""
        return self._float32(self.settings.response_float32, RESPONSE_FLOAT32_AUTO)

    def _float32(self, choice, auto_from: dict) -> bool:
        m = self.model
        return float32_chosen(choice, auto_from, m.grid.n, m.device.is_cuda, m.dtype == wp.float64)

    def preconditioner_transforms(self, preconditioned: bool = True):
        """Where the preconditioner's circulant inverse runs (``ElasticOperator.inverse_transforms``):
        on the grid itself or the padded grid (``settings.preconditioner_grid``), in float32 where
        ``float32_preconditioner``; the operator's own padded transforms where not ``preconditioned``
        (nothing made)."""
        return self.model.operator.inverse_transforms(
            self.float32_preconditioner and preconditioned,
            periodic=preconditioned and self.settings.preconditioner_grid == "periodic")

    def _stage(self, slot: int, value: float):
        """parameters[slot] <- value on the host; ``_upload`` sends them."""
        self._parameters[slot] = value

    def _upload(self):
        """Send the staged parameters to the device (a few bytes)."""
        self.parameters.assign(self._parameters.astype(self.model.np_dtype))

    def _begin(self, tol=None):
        """Start a solve: stage its tolerance (default ``self.tol``), iteration limit and launch
        length, and send the parameters (with what the subclass staged)."""
        self.active_tol = self.tol if tol is None else float(tol)
        self._stage(P_TOL, self.active_tol)
        self._stage(P_MAX_ITER, self.max_iter)
        self._stage(P_CHUNK, self.settings.iterations_per_launch)
        self._upload()

    @property
    def use_graphs(self) -> bool:
        """Whether launches replay captured CUDA graphs (False after a capture failed)."""
        return self.graphs.enabled

    @use_graphs.setter
    def use_graphs(self, on: bool):
        self.graphs.enabled = bool(on)

    @property
    def graph_count(self) -> int:
        """CUDA graphs captured and kept."""
        return len(self.graphs.graphs)

    @property
    def capture_failure(self) -> str | None:
        """Why a capture failed, after which the solver launches eagerly (None: none failed)."""
        return self.graphs.failure

    def _launch(self, key, work, needs=()):
        """Run ``work()``: eagerly, or from the CUDA graph captured for ``key`` (``CapturedGraphs``).

        ``needs``: the conditional parts of ``work`` (names in ``_ran_eagerly``) whose kernels must
        be loaded before a capture. A loop that converged at its start (zero iterations) never ran
        its body eagerly, and a generic kernel's overload for this float type made for the first
        time inside a capture is a module load there, which fails the capture (CUDA error 901: a
        float32 tangential solve starting from its solution). Until every part has run, ``work``
        runs eagerly and nothing is captured."""
        self.graphs.launch(key, work, ready=lambda: set(needs) <= self._ran_eagerly)

    def _relative_residual(self, viol_slot: int, rhs_slot: int) -> float:
        s = self.sums.numpy().astype(np.float64)
        if not (math.isfinite(s[viol_slot]) and math.isfinite(s[rhs_slot])):
            return math.nan  # a non-finite traction or displacement: the caller raises NonFiniteError
        if s[rhs_slot] > 0:
            return math.sqrt(s[viol_slot] / s[rhs_slot])
        return 0.0 if s[viol_slot] == 0 else 1.0

    def _run(self, key, start, exact, body, on_non_finite, on_disagreement=None, start_exact=None,
             prelude=None) -> SolveInfo:
        """The solve after ``_begin`` (see the class docstring). ``exact`` fills the slots
        S_VIOL and S_RHS of ``sums`` (zeroed before) for the current iterate; ``start_exact``
        (default ``exact``) does it right after ``start()``, for a start that made part of it
        already. ``on_disagreement()`` is called when an iteration's residual said "converged"
        and the exact one does not (the normal solver then recomputes its gap at every
        iteration).

        ``prelude`` = (flag, step): an iteration starts with ``step()`` where ``flag[0]`` is 1 (the
        normal solver's recompute of K p: a few iterations in a solve). In a graph, an IF node in
        every iteration would cost more than a turn of the loop (about 4 us each on an H100), so
        the loop has two levels instead: the
        inner loop runs the iterations while ``inner_loop[0]`` is 1 (the body's last kernel sets it
        to 0 when the loop stops or the flag is raised), the outer loop runs ``step()`` if the flag
        is raised and enters the inner loop again. The iterations are the same either way."""
        tol = self.active_tol
        ran = self._ran_eagerly

        def part(f):  # a part of the iteration by its code: the same kernels on every solve
            return getattr(f, "__code__", f)

        def marked(f):
            def run():
                ran.add(part(f))
                f()

            return run

        # the loop body must have run eagerly before a capture; the prelude and the refresh launch
        # the kernels of ``exact`` (both solvers), which the start runs
        needs = (part(body),)
        body = marked(body)

        def iterations():
            if prelude is None:
                wp.capture_while(self.loop, body)
                return
            flag, step = prelude

            def turn():
                wp.capture_if(flag, on_true=step)
                self.inner_loop.fill_(1)  # the outer loop runs while the loop does
                wp.capture_while(self.inner_loop, body)

            wp.capture_while(self.loop, turn)

        def refresh(exact=exact):
            self.sums.zero_()
            exact()

        def work(first: bool):
            if first:
                self.scalars.zero_()
                self.history.fill_(-1.0)
                start()
                refresh(exact if start_exact is None else start_exact)
            self.model.launch(loop_start, 1, [self.sums, self.parameters, int(first)],
                              [self.scalars, self.loop, self.refresh])
            iterations()
            wp.capture_if(self.refresh, on_true=refresh)

        self._launch(("first", *key), lambda: work(True), needs)
        last = -1
        while True:
            scalars = self.scalars.numpy()
            it = int(scalars[C_ITER])
            if scalars[C_STOP]:  # settled: the sums are the exact residual's
                residual = self._relative_residual(S_VIOL, S_RHS)
                if not math.isfinite(residual):
                    on_non_finite(it)
                # (it == last: the device saw the tolerance met where the host, in float64, does not)
                if residual < tol or it >= self.max_iter or it == last:
                    break
                if on_disagreement is not None:  # the carried residual said "converged", the exact one does not
                    on_disagreement()
                last = it
            interrupts.check()
            self._launch(("again", *key), lambda: work(False), needs)
        hist = self.history.numpy()[:it].astype(np.float64)
        return SolveInfo(converged=bool(residual < tol), iterations=it, residual=residual, history=hist.tolist())


def raise_non_finite(solver_name: str, state, names, iteration: int):
    """Raise NonFiniteError naming the first non-finite field and cell (of the whole grid: a window
    of it, ``SolverSettings.window``, adds its first row and column ``row0``, ``col0``)."""
    from ..errors import NonFiniteError

    for name in names:
        a = getattr(state, name).numpy()
        bad = np.argwhere(~np.isfinite(a))
        if bad.size:
            iy, ix = bad[0] + (getattr(state, "row0", 0), getattr(state, "col0", 0))
            raise NonFiniteError(f"{solver_name}: non-finite {name} at iteration {iteration}, cell (row {iy}, column {ix})")
    raise NonFiniteError(f"{solver_name}: non-finite residual at iteration {iteration}")

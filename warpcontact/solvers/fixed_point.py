"""Anderson acceleration of fixed points: the adhesive tractions t = law(h(t), s(t)) (MODEL.md section 6).

Each turn of ContactSolver evaluates the law at the last gap and slip (G(t)) and asks this class
for the next tractions. Plain relaxation t <- t + beta (G - t) converges slowly or not at all when
the law is stiff against the elastic compliance of the adhesive zone (large Tabor parameters):
the error modes of that zone have gains of both signs and many sizes, and no one beta damps them
all. Anderson mixing (Walker & Ni 2011, "Anderson acceleration for fixed-point iterations", SIAM J.
Numer. Anal. 49, 1715) combines the last ``depth`` residuals by least squares: for a linear map it
is equivalent to GMRES, and it keeps the cost to a few reductions per turn.

Device work per turn: one pass to form the residual and the new history column, ``depth`` passes
of dot products, one update pass. The host solves a depth x depth least-squares problem.

``LocalAndersonMixing`` gives each cell coefficients of its own, from the residuals of the cells
around it: the lagged turns' mixing after a stall, whose error modes are many small clusters of
cells (docs/model.md, "The turns' stall").
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from warpcontact.kernels import fixed_point as fk
from warpcontact.kernels import reduce as rk

from ..numerics.launch import FlatRows, Rows, Sums, products

#: history columns kept (5 reached the tolerance in the fewest turns on the Table 2 cases)
DEPTH = 5
#: columns whose Gram matrix is worse conditioned than this are dropped, oldest first
MAX_CONDITION = 1e10
#: a residual this many times the smallest of the load step so far restarts the mixing (history
#: forgotten). Without it, at Tabor parameter 5.7 the residual fell to 2e-5 and then climbed back
#: to 0.15 and stayed there for 1000 turns (n = 128, the first state of the pull-off curve); with
#: it the state converged in 605 turns after 2 restarts.
RESTART_GROWTH = 10.0


class MixingHistory:
    """The host's side of the Anderson mixing of one fixed point: the history columns in use
    (oldest first), their Gram matrix, the load step's smallest residual, and the least-squares
    coefficients of a step (``AndersonMixing``, one per case of ``BatchAndersonMixing``)."""

    def __init__(self, depth: int):
        self.depth = int(depth)
        self.reset()

    def reset(self):
        """Forget the history (a new load step)."""
        self.forget()
        self.best = math.inf  # smallest residual of this load step

    def forget(self):
        self.columns: list[int] = []  # used history columns, oldest first
        self.gram = np.zeros((self.depth, self.depth))
        self.has_previous = False
        self.next = 0

    def record(self) -> int:
        """The column this step's dF, dX go to (made the newest used column where there is a
        previous step: ``has_previous``)."""
        column = self.next
        if self.has_previous:
            if column in self.columns:
                self.columns.remove(column)
            self.columns.append(column)
            self.next = (column + 1) % self.depth
        return column

    def coefficients(self, column: int, products, rhs) -> np.ndarray:
        """gamma = argmin |f - dF gamma| over the used columns through the normal equations (the
        newest ``column``'s row of the Gram matrix ``products[j]`` = dF_column . dF_j, ``rhs[j]``
        = dF_j . f), dropping the oldest columns while the Gram matrix is ill-conditioned."""
        for j in self.columns:
            self.gram[column, j] = self.gram[j, column] = products[j]
        gamma = np.zeros(self.depth)
        while self.columns:
            idx = np.array(self.columns)
            g = self.gram[np.ix_(idx, idx)]
            if np.all(np.isfinite(g)) and np.linalg.cond(g) < MAX_CONDITION:
                gamma[idx] = np.linalg.solve(g, np.asarray(rhs)[idx])
                return gamma
            self.columns.pop(0)
        return gamma

    def judged(self, residual: float):
        """After a step of ``residual``: a residual this many times the step's smallest
        (``RESTART_GROWTH``) restarts the mixing from here (the history forgotten)."""
        self.has_previous = True
        self.best = min(self.best, residual)
        if residual > RESTART_GROWTH * self.best:  # the mixing has gone astray: start it again from here
            self.forget()
            self.best = residual


class AndersonMixing:
    """Anderson mixing for a vector of ``len(iterates)`` (n, n) fields held by the caller.

    Args:
        model: the contact model (device, dtype, reductions).
        components: number of fields in the vector (1: the adhesive pressure; 3: with the shears).
        beta: mixing of the residual (the relaxation of the first step after a reset).
        depth: history columns.
    """

    def __init__(self, model, components: int, beta: float = 0.5, depth: int = DEPTH):
        self.model = model
        self.beta = float(beta)
        self.depth = int(depth)
        n = model.n_cells
        z = lambda *shape: wp.zeros(shape, dtype=model.dtype, device=model.device)  # noqa: E731
        self.residual = [z(n) for _ in range(components)]  # G(x) on entry, then f = G(x) - x
        self.previous_residual = [z(n) for _ in range(components)]
        self.previous_iterate = [z(n) for _ in range(components)]
        self.residual_diff = [z(self.depth, n) for _ in range(components)]
        self.iterate_diff = [z(self.depth, n) for _ in range(components)]
        self.sums = z(fk.GRAM_SLOTS + 2 * self.depth)
        self.gamma = z(self.depth)
        #: |G(x) - x|^2 and |G(x)|^2 of the last step, summed over its components
        self.norms = (0.0, 0.0)
        self.history = MixingHistory(self.depth)

    def reset(self):
        """Forget the history (a new load step)."""
        self.history.reset()

    def step(self, iterates, beta: float | None = None) -> float:
        """x <- the next iterate, from ``self.residual`` = G(x) filled by the caller (its first
        ``len(iterates)`` components); returns the residual |G(x) - x| / |G(x)| before the step (0
        when G(x) = 0); ``norms`` then holds |G(x) - x|^2 and |G(x)|^2. ``beta``: this step's
        mixing of the residual (default: the mixing's own)."""
        beta = self.beta if beta is None else float(beta)
        column = self._record(iterates)
        sums = self._combine(iterates, column, beta)
        self.norms = (float(sums[fk.S_RESIDUAL]), float(sums[fk.S_IMAGE]))
        residual = math.sqrt(sums[fk.S_RESIDUAL] / sums[fk.S_IMAGE]) if sums[fk.S_IMAGE] > 0 else 0.0
        self.history.judged(residual)
        return residual

    def _record(self, iterates) -> int:
        """f = G(x) - x into ``residual``, the norms' sums, and (after a first step) the history
        column of dF and dX, made the newest used column; returns that column."""
        m = self.model
        h = self.history
        column = h.next
        self.sums.zero_()
        for k, x in enumerate(iterates):  # (on the CPU split by rows over its threads: ``Rows``)
            m.launch_reduce(
                fk.anderson_residual, [Rows(x.flatten()), column, int(h.has_previous), self.depth],
                [Rows(self.residual[k]), Rows(self.previous_residual[k]), Rows(self.previous_iterate[k]),
                 FlatRows(self.residual_diff[k]), FlatRows(self.iterate_diff[k]), Sums(self.sums)],
            )
        return h.record()

    def _combine(self, iterates, column: int, beta: float) -> np.ndarray:
        """x <- x + beta f - sum_j gamma_j (dX_j + beta dF_j), gamma the least-squares
        coefficients of the whole field; returns the sums read back."""
        m = self.model
        h = self.history
        for j in h.columns:
            for k in range(len(iterates)):
                # dF_column . dF_j into the Gram matrix's slot j, dF_j . f into the right side's
                diff = self.residual_diff[k]
                m.launch_reduce(rk.sums_of_products,
                                products((Rows(diff[column]), Rows(diff[j]), fk.GRAM_SLOTS + j),
                                         (Rows(diff[j]), Rows(self.residual[k]), fk.GRAM_SLOTS + self.depth + j)),
                                [Sums(self.sums)])
        s = self.sums.numpy().astype(np.float64)
        gamma = np.zeros(self.depth)
        if h.columns:
            gamma = h.coefficients(column, s[fk.GRAM_SLOTS:fk.GRAM_SLOTS + self.depth], s[fk.GRAM_SLOTS + self.depth:])
        self.gamma.assign(gamma.astype(m.np_dtype))
        for k, x in enumerate(iterates):
            m.launch_cells(fk.anderson_update,
                           [Rows(self.residual[k]), FlatRows(self.residual_diff[k]), FlatRows(self.iterate_diff[k]),
                            self.gamma, self.depth, m.scalar(beta)],
                           [Rows(x.flatten())])
        return s


class BatchAndersonMixing:
    """``AndersonMixing`` of B fixed points at once, each case's vector a (components, B, cells)
    array's column (``iterate``, held by the caller), each case with its own history, coefficients
    and restarts (``MixingHistory``); the device's work of a step is three launches for every
    case, the host's one read and each case's small least-squares problem.

    Args:
        launches: the batch's launches (``numerics.launch.BatchLaunches``).
        shape: (components, B, cells) of the iterates.
        device, dtype: the batch's.
        beta: mixing of the residual.
        depth: history columns.
    """

    def __init__(self, launches, shape: tuple, device, dtype, beta: float = 0.5, depth: int = DEPTH):
        self.launches = launches
        self.beta, self.depth = dtype(beta), int(depth)
        self.np_dtype = np.float64 if dtype == wp.float64 else np.float32
        components, batch, cells = shape
        z = lambda *s: wp.zeros(s, dtype=dtype, device=device)  # noqa: E731
        #: G(x) of each case, filled by the caller before ``step``; then f = G(x) - x
        self.residual = z(*shape)
        self.previous_residual, self.previous_iterate = z(*shape), z(*shape)
        self.residual_diff, self.iterate_diff = z(self.depth, *shape), z(self.depth, *shape)
        self.sums = z(batch, fk.GRAM_SLOTS + 2 * self.depth)
        self.gamma = z(batch, self.depth)
        self.columns = wp.zeros(batch, dtype=wp.int32, device=device)
        self.used = wp.zeros((batch, self.depth), dtype=wp.int32, device=device)
        self.turning = wp.zeros(batch, dtype=wp.int32, device=device)
        self.histories = [MixingHistory(self.depth) for _ in range(batch)]

    def reset(self, rows):
        """Forget the history of the ``rows`` (booleans, one per case: a new load step)."""
        for history, on in zip(self.histories, rows):
            if on:
                history.reset()

    def step(self, iterate, rows) -> np.ndarray:
        """Each case of ``rows`` (booleans) x <- its next iterate, from ``residual`` = G(x); the
        other cases are left as they are. Returns each case's |G(x) - x| / |G(x)| before the step
        (0 where G(x) = 0 or not in ``rows``)."""
        rows = np.asarray(rows, dtype=bool)
        histories = self.histories
        columns = np.array([h.next if h.has_previous else -1 for h in histories], dtype=np.int32)
        for h, on in zip(histories, rows):
            if on:
                h.record()
        used = np.zeros((len(histories), self.depth), dtype=np.int32)
        for r, h in enumerate(histories):
            used[r, h.columns] = 1
        columns[~rows] = -1
        self.turning.assign(rows.astype(np.int32))
        self.columns.assign(columns)
        self.used.assign(used)
        self.sums.zero_()
        launches = self.launches
        launches.reduce(fk.batch_anderson_residual, [iterate, self.columns, self.turning],
                        [self.residual, self.previous_residual, self.previous_iterate, self.residual_diff,
                         self.iterate_diff, self.sums])
        launches.reduce(fk.batch_anderson_products, [self.residual, self.residual_diff, self.columns, self.used],
                        [self.sums])
        s = self.sums.numpy().astype(np.float64)
        gamma = np.zeros((len(histories), self.depth))
        residuals = np.zeros(len(histories))
        for r in np.flatnonzero(rows):
            h = histories[r]
            if columns[r] >= 0 and h.columns:
                pairs = s[r, fk.GRAM_SLOTS:].reshape(self.depth, 2)
                gamma[r] = h.coefficients(int(columns[r]), pairs[:, 0], pairs[:, 1])
            residuals[r] = math.sqrt(s[r, fk.S_RESIDUAL] / s[r, fk.S_IMAGE]) if s[r, fk.S_IMAGE] > 0 else 0.0
        self.gamma.assign(gamma.astype(self.np_dtype))
        launches.cells(fk.batch_anderson_update, [self.residual, self.residual_diff, self.iterate_diff, self.gamma,
                                                  self.beta, self.turning], [iterate])
        for r in np.flatnonzero(rows):
            histories[r].judged(residuals[r])
        return residuals


#: the local mixing's history columns (``local_anderson_update`` holds three) and the radius of
#: the patch of cells whose residuals set a cell's coefficients ((2 r + 1)^2 cells)
LOCAL_DEPTH = 3
LOCAL_RADIUS = 2


class LocalAndersonMixing(AndersonMixing):
    """Anderson mixing of a two-component (n, n) field whose coefficients are each cell's own:
    those that best cancel the residual over the patch of cells around it
    (``kernels/fixed_point.py``, ``local_anderson_update``).

    Where the turn map's error modes are many small clusters of cells far apart, each with its own
    gain (the lagged turns at the von Mises crossover: docs/model.md, "The turns' stall"), one set
    of coefficients for the whole field cannot cancel them all: a cluster of two cells whose
    gains make a rotation takes two coefficients of its own. Each cell's least-squares problem
    sees its neighbourhood alone, so each cluster gets its own; where the map is smooth the local
    coefficients vary slowly and act as the global ones would.
    """

    def __init__(self, model, radius: int = LOCAL_RADIUS):
        super().__init__(model, 2, beta=1.0, depth=LOCAL_DEPTH)
        self.radius = int(radius)
        self.use = wp.zeros(LOCAL_DEPTH, dtype=model.dtype, device=model.device)

    def step(self, iterates, beta: float | None = None) -> float:
        """As [`AndersonMixing.step`][warpcontact.solvers.fixed_point.AndersonMixing.step], with
        each cell's coefficients from its patch; ``beta`` must be 1 (the kernel's)."""
        if beta is not None and beta != 1.0:
            raise ValueError(f"LocalAndersonMixing mixes with beta = 1 only, got beta = {beta}")
        return super().step(iterates)

    def _combine(self, iterates, column: int, beta: float) -> np.ndarray:
        m = self.model
        use = np.zeros(self.depth)
        use[self.history.columns] = 1.0
        self.use.assign(use.astype(m.np_dtype))
        n = m.grid.n
        m.launch(fk.local_anderson_update, (n, n),
                 [self.residual[0], self.residual[1], self.residual_diff[0], self.residual_diff[1],
                  self.iterate_diff[0], self.iterate_diff[1], self.use, n, self.radius],
                 [iterates[0].flatten(), iterates[1].flatten()])
        return self.sums.numpy().astype(np.float64)

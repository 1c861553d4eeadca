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

from ..numerics.launch import products

#: history columns kept (5 reached the tolerance in the fewest turns on the Table 2 cases)
DEPTH = 5
#: columns whose Gram matrix is worse conditioned than this are dropped, oldest first
MAX_CONDITION = 1e10
#: a residual this many times the smallest of the load step so far restarts the mixing (history
#: forgotten). Without it, at Tabor parameter 5.7 the residual fell to 2e-5 and then climbed back
#: to 0.15 and stayed there for 1000 turns (n = 128, the first state of the pull-off curve); with
#: it the state converged in 605 turns after 2 restarts.
RESTART_GROWTH = 10.0


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
        self.reset()

    def reset(self):
        """Forget the history (a new load step)."""
        self._forget()
        self.best = math.inf  # smallest residual of this load step

    def _forget(self):
        self.columns: list[int] = []  # used history columns, oldest first
        self.gram = np.zeros((self.depth, self.depth))
        self._has_previous = False
        self._next = 0

    def step(self, iterates, beta: float | None = None) -> float:
        """x <- the next iterate, from ``self.residual`` = G(x) filled by the caller (its first
        ``len(iterates)`` components); returns the residual |G(x) - x| / |G(x)| before the step (0
        when G(x) = 0); ``norms`` then holds |G(x) - x|^2 and |G(x)|^2. ``beta``: this step's
        mixing of the residual (default: the mixing's own)."""
        beta = self.beta if beta is None else float(beta)
        column = self._record(iterates)
        sums = self._combine(iterates, column, beta)
        self._has_previous = True
        self.norms = (float(sums[fk.S_RESIDUAL]), float(sums[fk.S_IMAGE]))
        residual = math.sqrt(sums[fk.S_RESIDUAL] / sums[fk.S_IMAGE]) if sums[fk.S_IMAGE] > 0 else 0.0
        self.best = min(self.best, residual)
        if residual > RESTART_GROWTH * self.best:  # the mixing has gone astray: start it again from here
            self._forget()
            self.best = residual
        return residual

    def _record(self, iterates) -> int:
        """f = G(x) - x into ``residual``, the norms' sums, and (after a first step) the history
        column of dF and dX, made the newest used column; returns that column."""
        m = self.model
        column = self._next
        self.sums.zero_()
        for k, x in enumerate(iterates):
            m.launch_reduce(
                fk.anderson_residual, [x.flatten(), column, int(self._has_previous), self.depth],
                [self.residual[k], self.previous_residual[k], self.previous_iterate[k],
                 self.residual_diff[k], self.iterate_diff[k], self.sums],
            )
        if self._has_previous:
            if column in self.columns:
                self.columns.remove(column)
            self.columns.append(column)
            self._next = (column + 1) % self.depth
        return column

    def _combine(self, iterates, column: int, beta: float) -> np.ndarray:
        """x <- x + beta f - sum_j gamma_j (dX_j + beta dF_j), gamma the least-squares
        coefficients of the whole field; returns the sums read back."""
        m = self.model
        for j in self.columns:
            for k in range(len(iterates)):
                # dF_column . dF_j into the Gram matrix's slot j, dF_j . f into the right side's
                diff = self.residual_diff[k]
                m.launch_reduce(rk.sums_of_products,
                                products((diff[column], diff[j], fk.GRAM_SLOTS + j),
                                         (diff[j], self.residual[k], fk.GRAM_SLOTS + self.depth + j)),
                                [self.sums])
        s = self.sums.numpy().astype(np.float64)
        gamma = np.zeros(self.depth)
        if self.columns:
            for j in self.columns:
                self.gram[column, j] = self.gram[j, column] = s[fk.GRAM_SLOTS + j]
            rhs = s[fk.GRAM_SLOTS + self.depth:]
            gamma = self._least_squares(rhs)
        self.gamma.assign(gamma.astype(m.np_dtype))
        for k, x in enumerate(iterates):
            m.launch(fk.anderson_update, dim=m.n_cells,
                     inputs=[self.residual[k], self.residual_diff[k], self.iterate_diff[k], self.gamma, self.depth,
                             m.scalar(beta)],
                     outputs=[x.flatten()])
        return s

    def _least_squares(self, rhs):
        """gamma = argmin |f - dF gamma| over the used columns through the normal equations,
        dropping the oldest columns while the Gram matrix is ill-conditioned."""
        gamma = np.zeros(self.depth)
        while self.columns:
            idx = np.array(self.columns)
            g = self.gram[np.ix_(idx, idx)]
            if np.all(np.isfinite(g)) and np.linalg.cond(g) < MAX_CONDITION:
                gamma[idx] = np.linalg.solve(g, rhs[idx])
                return gamma
            self.columns.pop(0)
        return gamma


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
        use[self.columns] = 1.0
        self.use.assign(use.astype(m.np_dtype))
        n = m.grid.n
        m.launch(fk.local_anderson_update, (n, n),
                 [self.residual[0], self.residual[1], self.residual_diff[0], self.residual_diff[1],
                  self.iterate_diff[0], self.iterate_diff[1], self.use, n, self.radius],
                 [iterates[0].flatten(), iterates[1].flatten()])
        return self.sums.numpy().astype(np.float64)

"""Anderson acceleration of the adhesive fixed point t = law(h(t), s(t)) (MODEL.md section 6).

Each turn of ContactSolver evaluates the law at the last gap and slip (G(t)) and asks this class
for the next tractions. Plain relaxation t <- t + beta (G - t) converges slowly or not at all when
the law is stiff against the elastic compliance of the adhesive zone (large Tabor parameters):
the error modes of that zone have gains of both signs and many sizes, and no one beta damps them
all. Anderson mixing (Walker & Ni 2011, "Anderson acceleration for fixed-point iterations", SIAM J.
Numer. Anal. 49, 1715) combines the last ``depth`` residuals by least squares: for a linear map it
is equivalent to GMRES, and it keeps the cost to a few reductions per turn.

Device work per turn: one pass to form the residual and the new history column, ``depth`` passes
of dot products, one update pass. The host solves a depth x depth least-squares problem.
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
        m = self.model
        beta = self.beta if beta is None else float(beta)
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
        self._has_previous = True
        self.norms = (float(s[fk.S_RESIDUAL]), float(s[fk.S_IMAGE]))
        residual = math.sqrt(s[fk.S_RESIDUAL] / s[fk.S_IMAGE]) if s[fk.S_IMAGE] > 0 else 0.0
        self.best = min(self.best, residual)
        if residual > RESTART_GROWTH * self.best:  # the mixing has gone astray: start it again from here
            self._forget()
            self.best = residual
        return residual

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

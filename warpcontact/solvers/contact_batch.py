"""A load step with friction of B cases of one grid size, solved together: the lagged turns of
[`ContactSolver`][warpcontact.solvers.contact.ContactSolver] (MODEL.md 4) with a case axis.

Each turn is one batched normal solve
([`BatchNormalSolver`][warpcontact.solvers.normal_batch.BatchNormalSolver]) with each case's
shear's normal displacement K_zt q held fixed, each case's shear limit from its pressure (its own
law: ``kernels/laws.py``, ``batch_shear_limit``), and one batched tangential solve
([`BatchTangentialSolver`][warpcontact.solvers.tangential_batch.BatchTangentialSolver]) with its
pressure's tangential displacement K_tz p held fixed. A case's turns end as the single solver's
do: where its pressure and shear change by less than ``outer_tol`` (relative, 2-norm) in a turn
solved at full tolerance; early turns solve at 1/100 of the last turn's change, at most 1e-3
(``SolverSettings.turn_tolerance = "change"``). A case of identical materials (D = 0) decouples:
one turn at full tolerance. A case that has ended stops changing while the others turn on. The
step ends with a normal solve against each case's final shear (its gap and u_z) and its slip
s = delta - (K_tt q + K_tz p).

What the single solver adds for hard cases (the Anderson mixing of turns that stall, the
minimised turns of adhesion, the nested start and the window of large grids) is not here: a case
whose turns do not converge within ``max_turns`` is reported as not converged, and the caller
solves it on its own (``studies/batch_solve.py``).
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from warpcontact.kernels import coupling as ck
from warpcontact.kernels import laws as lk

from ..fft.batch import BatchElasticOperator
from ..numerics.state import SolveInfo
from .normal_batch import BatchNormalSolver
from .tangential_batch import BatchTangentialSolver
from .turns import TURN_TOL_RATIO, TURN_TOL_START, ratio


def law_parameters(friction, traction_scale: float) -> tuple:
    """A case's row of ``batch_shear_limit``'s law parameters (``kernels/laws.py``) from its
    shear-limit law (``physics/friction.py``: Coulomb or Tabor-von Mises), strengths scaled by
    ``traction_scale`` (E*)."""
    if hasattr(friction, "mu_b"):
        return (int(lk.LAW_TABOR), friction.mu_b, friction.k_vm, friction.yield_strength / traction_scale)
    return (int(lk.LAW_COULOMB), friction.mu, 0.0, 0.0)


class BatchContactSolver:
    """Steps with friction (no adhesion) of up to ``batch`` cases of an n x n grid, in scaled
    units (tractions / E*, lengths / dx, each case its own).

    Args:
        n: cells per side.
        batch: cases B the buffers hold.
        device: a Warp device.
        dtype: ``wp.float32`` or ``wp.float64``.

    ``set_cases`` gives each row its material pair, shear-limit law and pressure cap; the rows'
    ``normal.initial_gap`` are the caller's to fill. Each row's fields carry its path: the
    tractions of the last state start the next step, ``slip_x/y`` is its slip history.
    """

    def __init__(self, n: int, batch: int, device, dtype):
        self.normal = BatchNormalSolver(n, batch, device, dtype)
        self.operator = BatchElasticOperator(n, batch, device, dtype)
        self.tangential = BatchTangentialSolver(self.operator, np.ones(batch))
        self.n, self.batch, self.device, self.dtype = self.normal.n, self.normal.batch, self.normal.device, dtype
        self.n_cells = self.normal.n_cells
        np_dtype = self.normal.np_dtype

        def field():
            return wp.zeros((self.batch, self.n_cells), dtype=dtype, device=self.device)

        self.slip_x, self.slip_y = field(), field()
        self.previous = [field(), field(), field()]  # p, q_x, q_y of the last turn
        self.change = wp.zeros((self.batch, 4), dtype=dtype, device=self.device)
        self.laws = wp.zeros((self.batch, lk.N_LAW_PARAMETERS), dtype=dtype, device=self.device)
        self.shifts = wp.zeros((self.batch, 2), dtype=dtype, device=self.device)
        self.coupled = np.zeros(self.batch, dtype=bool)
        self.pressure_cap = np.full(self.batch, np.finfo(np_dtype).max)
        self._np_dtype = np_dtype

    def set_cases(self, pairs: list, laws: list, pressure_caps: list):
        """Rows 0 .. len(pairs) - 1: each case's material pair, its shear-limit law's parameters
        (``law_parameters``) and its pressure cap / E* (inf for none)."""
        stiffness, _, self.coupled = self.operator.set_pairs(pairs)
        self.tangential.set_stiffness(stiffness)
        rows = np.zeros((self.batch, lk.N_LAW_PARAMETERS))
        rows[: len(laws)] = laws
        self.laws.assign(rows.astype(self._np_dtype))
        big = float(np.finfo(self._np_dtype).max)
        self.pressure_cap[:] = big
        self.pressure_cap[: len(pressure_caps)] = np.minimum(pressure_caps, big)

    def clear(self):
        """Every row's tractions, statuses and slip history zeroed (a path's start)."""
        for a in (self.normal.pressure, self.tangential.shear, self.tangential.status, self.slip_x, self.slip_y):
            a.zero_()

    def _cells(self, kernel, inputs, outputs):
        self.normal.launches.launch(kernel, (self.batch, self.n_cells), inputs, outputs)

    def _change_sums(self) -> np.ndarray:
        """Each row's change sums of the pressure and the shear since the last call (the previous
        copies updated)."""
        t = self.tangential
        self.change.zero_()
        self.normal._reduce(ck.batch_change_sums, [self.normal.pressure, t.shear_x, t.shear_y],
                            [*self.previous, self.change])
        return self.change.numpy().astype(np.float64)

    def step(self, approach, tol, outer_tol, max_iter, max_turns: int, active) -> list:
        """Solve the rows where ``active`` at their rigid shifts ``approach`` ((rows, 3): delta_x,
        delta_y, delta_z, scaled), inner solves to ``tol`` (one per row), turns to ``outer_tol``,
        within ``max_iter`` inner iterations a solve and ``max_turns`` turns. Returns one
        ``SolveInfo`` per row (a row not solved: not converged, no iteration): converged where
        its turns converged and its last solves did; its inner iterations over every turn; its turns."""
        normal, tangential = self.normal, self.tangential
        active = np.asarray(active, dtype=bool)
        approach = np.asarray(approach, dtype=np.float64)
        tol = np.asarray(tol, dtype=np.float64)
        outer_tol = np.asarray(outer_tol, dtype=np.float64)
        shifts = np.zeros((self.batch, 2))
        shifts[: len(approach)] = approach[:, :2]
        self.shifts.assign(shifts.astype(self._np_dtype))
        self._cells(ck.batch_stick_target, [self.slip_x, self.slip_y, self.shifts],
                    [tangential.target_x, tangential.target_y])
        self._change_sums()  # the previous copies: the tractions the step starts from
        rows = self.batch
        turning = active.copy()
        turns = np.zeros(rows, dtype=np.int64)
        iterations = np.zeros(rows, dtype=np.int64)
        change = np.full(rows, math.inf)
        turns_converged = np.zeros(rows, dtype=bool)
        solves_converged = np.zeros(rows, dtype=bool)
        while turning.any():
            turns[turning] += 1
            turn_tol = np.where(self.coupled, np.maximum(tol, np.minimum(TURN_TOL_START, TURN_TOL_RATIO * change)), tol)
            self.operator.cross_normal(tangential.shear, normal.known)
            normal_infos = normal.solve(approach[:, 2], turn_tol, max_iter, pressure_cap=self.pressure_cap,
                                        active=turning)
            self._cells(lk.batch_shear_limit, [normal.pressure, self.laws], [tangential.shear_limit])
            self.operator.cross_tangential(normal.pressure, tangential.known)
            tangential_infos = tangential.solve(turn_tol, max_iter, turning)
            sums = self._change_sums()
            for row in np.flatnonzero(turning):
                ni, ti = normal_infos[row], tangential_infos[row]
                iterations[row] += ni.iterations + ti.iterations
                change[row] = max(ratio(sums[row, 0], sums[row, 1]), ratio(sums[row, 2], sums[row, 3]))
                solves_converged[row] = ni.converged and ti.converged
                if not self.coupled[row] or (change[row] < outer_tol[row] and turn_tol[row] == tol[row]):
                    turns_converged[row] = True
                    turning[row] = False
                elif turns[row] >= max_turns:
                    turning[row] = False
        # each row's gap and u_z against its final shear, then its slip and whole u_t
        self.operator.cross_normal(tangential.shear, normal.known)
        final = normal.solve(approach[:, 2], tol, max_iter, pressure_cap=self.pressure_cap, active=active)
        self.operator.tangential(tangential.shear, tangential.disp, pressure=normal.pressure)
        self._cells(ck.batch_accumulate_slip, [tangential.disp_x, tangential.disp_y, self.shifts],
                    [self.slip_x, self.slip_y])
        infos = []
        for row in range(rows):
            if not active[row]:
                infos.append(SolveInfo(converged=False, iterations=0, residual=math.nan))
                continue
            f = final[row]
            converged = bool(turns_converged[row] and solves_converged[row] and f.converged)
            infos.append(SolveInfo(converged=converged, iterations=int(iterations[row] + f.iterations),
                                   residual=f.residual, outer_iterations=int(turns[row]), history=[]))
        return infos

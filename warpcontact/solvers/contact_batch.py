"""A load step with friction of B cases of one grid size, solved together: the lagged turns of
[`ContactSolver`][warpcontact.solvers.contact.ContactSolver] (MODEL.md 4 and 6) with a case axis.

Each turn is one batched normal solve
([`BatchNormalSolver`][warpcontact.solvers.normal_batch.BatchNormalSolver]) with each case's
shear's normal displacement K_zt q held fixed, each case's shear limit from its pressure (its own
law: ``kernels/laws.py``, ``batch_shear_limit``), and one batched tangential solve
([`BatchTangentialSolver`][warpcontact.solvers.tangential_batch.BatchTangentialSolver]) with its
pressure's tangential displacement K_tz p held fixed. With adhesion (the SMC law, its contact
shear "bounded": ``set_cases``), each turn first moves the case's adhesive tractions towards the
law's of its last gap and slip (each case's own Anderson mixing, ``_AdhesiveRows``), and their
displacements are held fixed in both solves, as the single solver's lagged turns do. A case's
turns end as the single solver's do: where its pressure, shear and adhesive tractions change by
less than ``outer_tol`` (relative, 2-norm) in a turn solved at full tolerance; early turns solve
at 1/100 of the coupled residual, at most 1e-3 and never looser than the turn before
(``SolverSettings.turn_tolerance = "residual"``). A case of identical materials without
adhesion (D = 0) decouples: one turn at full tolerance. A case that has ended stops changing
while the others turn on. The step ends with a normal solve against each case's final shear (its
gap and u_z) and its slip s = delta - u_t.

The tangential solves run on a window of the grid that holds every turning case's contact (the
cells where its pressure is above zero, with ``WINDOW_ROOM`` cells around), each case's window
placed over its own contact: the shear is zero outside the contact, so the problem on the window
is the same problem (the single solver's ``SolverSettings.window``), and its transforms are of
(2 m)^2 entries instead of (2 n)^2 (a contact half the domain wide: a quarter). Without adhesion
the turns after a step's first stay on the window (``window_turns``): a step's first turn solves
the normal problem on the whole grid and places the window; the step's final normal solve, on
the whole grid, judges the turns: a case whose pressure it moves by ``outer_tol`` or more (a
contact that grew past the window) is reported as not converged. With adhesion the normal
solves stay on the whole grid (the adhesive tractions reach past the contact). A batch of many
cases is bound by the device's work, where the window pays (docs/performance.md, "Many cases
with friction solved together").

What the single solver adds for hard cases (the Anderson mixing of turns that stall, the
minimised turns of adhesion, the retry of adhesive turns from zero tractions, the nested start
and the window of large grids) is not here: a case whose turns do not converge within
``max_turns`` is reported as not converged, and the caller solves it on its own
(``studies/batch_solve.py``).
"""

from __future__ import annotations

import math
from collections import OrderedDict

import numpy as np
import warp as wp

from warpcontact.kernels import adhesion as ak
from warpcontact.kernels import coupling as ck
from warpcontact.kernels import grids as gk
from warpcontact.kernels import laws as lk

from ..fft.batch import BatchElasticOperator
from ..numerics.state import SolveInfo
from .fixed_point import BatchAndersonMixing
from .normal_batch import BatchNormalSolver
from .settings import SolverSettings
from .tangential import WINDOW_CACHE, window_cells, window_origin
from .tangential_batch import BatchTangentialSolver
from .turns import TURN_TOL_RATIO, TURN_TOL_START, ratio, starting_residual


#: cells of room the turns' window leaves on every side of the contacts it holds: the contact
#: of a later turn may pass the first turn's by a cell (the step's judgement on the whole grid
#: then finds it: the case is solved again on its own)
WINDOW_ROOM = 1


def law_parameters(friction, traction_scale: float) -> tuple:
    """A case's row of ``batch_shear_limit``'s law parameters (``kernels/laws.py``) from its
    shear-limit law (``physics/friction.py``: Coulomb or Tabor-von Mises), strengths scaled by
    ``traction_scale`` (E*)."""
    if hasattr(friction, "mu_b"):
        return (int(lk.LAW_TABOR), friction.mu_b, friction.k_vm, friction.yield_strength / traction_scale)
    return (int(lk.LAW_COULOMB), friction.mu, 0.0, 0.0)


def adhesion_parameters(adhesion, model) -> tuple | None:
    """A case's row of ``batch_smc_tractions``' law parameters (``kernels/adhesion.py``, slots
    SMC_*) from its SMC law, scaled by its ``model`` (tractions / E*, lengths / dx); None without
    adhesion."""
    from ..physics.adhesion import TOUCHING

    if adhesion is None:
        return None
    if adhesion.contact_shear != "bounded":
        raise ValueError("the batched turns carry the SMC law with its contact shear bounded only")
    E, L = model.traction_scale, model.length_scale
    return (adhesion.sigma_max / E, adhesion.tau_max / E, adhesion.delta_n / L, adhesion.delta_t / L,
            TOUCHING * adhesion.delta_n / L)


class _TurnWindow:
    """The turns' solvers on a window of ``m`` cells per side (``BatchContactSolver``): the
    tangential solver with its operator, and where the turns after a step's first stay on it
    (``stays``: a window smaller than the grid) a normal solver with the previous copies of the
    turns' change."""

    def __init__(self, m: int, batch: int, device, dtype, pairs: list, preconditioned: bool, stays: bool):
        self.m = m
        self.operator = BatchElasticOperator(m, batch, device, dtype)
        self.tangential = BatchTangentialSolver(self.operator, self.operator.set_pairs(pairs)[0], preconditioned)
        self.normal = self.previous = self.change = None
        if stays:
            self.normal = BatchNormalSolver(m, batch, device, dtype)
            self.previous = [wp.zeros((batch, m * m), dtype=dtype, device=self.normal.device) for _ in range(3)]
            self.change = wp.zeros((batch, 4), dtype=dtype, device=self.normal.device)

    def set_pairs(self, pairs: list):
        self.tangential.set_stiffness(self.operator.set_pairs(pairs)[0])


def change_sums(normal: BatchNormalSolver, shear, previous: list, change) -> np.ndarray:
    """Each row's change sums (``kernels/coupling.py``, ``batch_change_sums``) of ``normal``'s
    pressure and ``shear`` (a (2, B, cells) pair) since ``previous`` (its copies: p, q_x, q_y,
    updated)."""
    change.zero_()
    normal._reduce(ck.batch_change_sums, [normal.pressure, shear[0], shear[1]], [*previous, change])
    return change.numpy().astype(np.float64)


class BatchContactSolver:
    """Steps with friction (and the SMC law's adhesion where ``set_cases`` gives it) of up to
    ``batch`` cases of an n x n grid, in scaled units (tractions / E*, lengths / dx, each case
    its own).

    Args:
        n: cells per side.
        batch: cases B the buffers hold.
        device: a Warp device.
        dtype: ``wp.float32`` or ``wp.float64``.

    ``set_cases`` gives each row its material pair, shear-limit law and pressure cap; the rows'
    ``normal.initial_gap`` are the caller's to fill. Each row's fields carry its path: the
    tractions of the last state start the next step, ``slip`` is its slip history.
    """

    #: the tangential solves' iteration (``BatchTangentialSolver``'s ``preconditioned``): the
    #: circulant inverse on the stick cells; False: the plain one (``bench/throughput.py
    #: --plain-tangential`` compares them)
    tangential_preconditioned = True

    def __init__(self, n: int, batch: int, device, dtype):
        self.normal = BatchNormalSolver(n, batch, device, dtype)
        #: the whole grid's tangential and coupling blocks (the turns' known displacements, u_t)
        self.operator = BatchElasticOperator(n, batch, device, dtype)
        self.n, self.batch, self.device, self.dtype = self.normal.n, self.normal.batch, self.normal.device, dtype
        self.n_cells = self.normal.n_cells
        np_dtype = self.normal.np_dtype
        cells = (self.batch, self.n_cells)

        def field():
            return wp.zeros(cells, dtype=dtype, device=self.device)

        def pair():  # x and y of a vector field, (2, B, n^2)
            return wp.zeros((2, *cells), dtype=dtype, device=self.device)

        #: each case's shear q / E*, total tangential displacement u_t / dx, the pressure's K_tz p,
        #: stick target delta - s_prev and slip s / dx (x, y), its shear limit and cell statuses
        self.shear, self.disp, self.known, self.target, self.slip = (pair() for _ in range(5))
        self.shear_limit = field()
        self.status = wp.zeros(cells, dtype=wp.int32, device=self.device)
        self.previous = [field(), field(), field()]  # p, q_x, q_y of the last turn
        self.change = wp.zeros((self.batch, 4), dtype=dtype, device=self.device)
        self.laws = wp.zeros((self.batch, lk.N_LAW_PARAMETERS), dtype=dtype, device=self.device)
        self.shifts = wp.zeros((self.batch, 2), dtype=dtype, device=self.device)
        self.boxes = wp.zeros((self.batch, 4), dtype=wp.int32, device=self.device)
        self.origins = wp.zeros((self.batch, 2), dtype=wp.int32, device=self.device)
        self.turning = wp.zeros(self.batch, dtype=wp.int32, device=self.device)
        self.coupled = np.zeros(self.batch, dtype=bool)
        #: the rows whose case has adhesion (``set_cases``), and their buffers, made when first needed
        self.adhesive = np.zeros(self.batch, dtype=bool)
        self.adhesion = None
        self._adhesive_step = False  # a row of the step has adhesion: the turns carry the adhesive tractions
        self.pressure_cap = np.full(self.batch, np.finfo(np_dtype).max)
        self._np_dtype = np_dtype
        self._pairs: list = []
        self._windows: OrderedDict = OrderedDict()  # cells per side -> _TurnWindow
        self._kept = None  # the rows' path state kept by ``keep``, made when first needed

    def set_cases(self, pairs: list, laws: list, pressure_caps: list, adhesions: list | None = None):
        """Rows 0 .. len(pairs) - 1: each case's material pair, its shear-limit law's parameters
        (``law_parameters``), its pressure cap / E* (inf for none) and its SMC law's parameters
        (``adhesion_parameters``; None, or a list without, for none)."""
        self._pairs = list(pairs)
        _, self.coupled = self.operator.set_pairs(pairs)
        adhesions = list(adhesions or [])
        self.adhesive[:] = False
        self.adhesive[: len(adhesions)] = [a is not None for a in adhesions]
        if self.adhesive.any():
            if self.adhesion is None:
                self.adhesion = _AdhesiveRows(self)
            rows = np.zeros((self.batch, ak.N_SMC_PARAMETERS))
            for row, a in enumerate(adhesions):
                if a is not None:
                    rows[row] = a
            self.adhesion.laws.assign(rows.astype(self._np_dtype))
        elif self.adhesion is not None:
            self.adhesion.laws.zero_()
        for window in self._windows.values():
            window.set_pairs(pairs)
        rows = np.zeros((self.batch, lk.N_LAW_PARAMETERS))
        rows[: len(laws)] = laws
        self.laws.assign(rows.astype(self._np_dtype))
        big = float(np.finfo(self._np_dtype).max)
        self.pressure_cap[:] = big
        self.pressure_cap[: len(pressure_caps)] = np.minimum(pressure_caps, big)

    def clear(self):
        """Every row's tractions, statuses and slip history zeroed (a path's start)."""
        for a in self._state_fields():
            a.zero_()

    def _state_fields(self) -> list:
        """The arrays that carry a row's path from one step to the next: its pressure, shear,
        statuses and slip (2-D, one row a case); with adhesion its adhesive tractions and its gap
        too (the law's first turn of a step reads the last gap)."""
        fields = [self.normal.pressure, self.shear[0], self.shear[1], self.status, self.slip[0], self.slip[1]]
        if self.adhesion is not None:
            a = self.adhesion
            fields += [a.pressure, a.shear[0], a.shear[1], self.normal.gap]
        return fields

    def keep(self, rows):
        """Keep the path state of the ``rows`` (booleans, one per row) for a later ``restore``
        (a gross-slip search's last stick state)."""
        if self._kept is None or len(self._kept) != len(self._state_fields()):
            self._kept = [wp.zeros_like(a) for a in self._state_fields()]
        self._copy_rows(rows, self._state_fields(), self._kept)

    def restore(self, rows):
        """The ``rows``' path state as ``keep`` kept it."""
        self._copy_rows(rows, self._kept, self._state_fields())

    def _copy_rows(self, rows, sources, destinations):
        self.turning.assign(np.asarray(rows, dtype=np.int32))
        for src, dst in zip(sources, destinations):
            self.normal.launches.cells(gk.batch_copy_rows, [src, self.turning], [dst])

    def _window(self, turning: np.ndarray) -> _TurnWindow:
        """The window that holds the contact (p > 0) of every turning row with ``WINDOW_ROOM``
        cells of room on every side (of a ``WINDOW_STEPS`` size), each row's origin placed over
        its own contact (``origins``); the whole grid where the largest contact passes
        ``WINDOW_MAX_SHARE`` of it. One read of the device: the boxes."""
        n = self.n
        self.boxes.assign(np.tile(np.array([n, -1, n, -1], dtype=np.int32), (self.batch, 1)))
        self.normal.launches.launch(gk.batch_support_box, (self.batch, n), [self.normal.pressure, n], [self.boxes])
        boxes = self.boxes.numpy()
        rows = [r for r in np.flatnonzero(turning) if boxes[r, 1] >= 0]
        extent = max((max(boxes[r, 1] - boxes[r, 0], boxes[r, 3] - boxes[r, 2]) + 1 for r in rows), default=1)
        cells = window_cells(extent + 2 * WINDOW_ROOM, n) or n
        origins = np.zeros((self.batch, 2), dtype=np.int32)
        for r in rows if cells < n else ():
            origins[r] = (window_origin(boxes[r, 0], boxes[r, 1], cells, n), window_origin(boxes[r, 2], boxes[r, 3], cells, n))
        self.origins.assign(origins)
        return self._window_of(cells)

    def _window_of(self, cells: int) -> _TurnWindow:
        """The turns' window of ``cells`` per side (kept, ``WINDOW_CACHE`` sizes at most)."""
        window = self._windows.get(cells)
        if window is None:
            window = self._windows[cells] = _TurnWindow(cells, self.batch, self.device, self.dtype, self._pairs,
                                                        self.tangential_preconditioned, stays=cells < self.n)
            while len(self._windows) > WINDOW_CACHE:
                self._windows.popitem(last=False)
        self._windows.move_to_end(cells)
        return window

    def _crop(self, pairs, window: _TurnWindow):
        """Each row's window (at its origin) of the whole-grid fields into the window's: ``pairs``
        of (whole, part) (B, cells) arrays."""
        n, m = self.n, window.m
        for whole, part in pairs:
            self.normal.launches.launch(gk.batch_crop, (self.batch, m * m), [whole, n, self.origins, m], [part])

    def _put_back(self, pairs, window: _TurnWindow, rows: np.ndarray):
        """The ``rows``' (booleans) windows of ``pairs`` of (whole, part) put back into their whole
        grid, zero outside them."""
        self.turning.assign(rows.astype(np.int32))
        for whole, part in pairs:
            self.normal.launches.cells(gk.batch_put_back, [part, window.m, self.origins, self.turning, self.n], [whole])

    def _tangential_pairs(self, window: _TurnWindow) -> list:
        """(whole, window) pairs of the turn's shear and statuses."""
        t = window.tangential
        return [(self.shear[0], t.shear_x), (self.shear[1], t.shear_y), (self.status, t.status)]

    def _whole_turn(self, approach, turn_tol, max_iter, turning) -> tuple:
        """A turn of the ``turning`` rows whose normal solve runs on the whole grid, its tangential
        solve on the window that holds their contacts (``_window``; the whole grid where none
        does). Returns the rows' normal and tangential ``SolveInfo`` lists, their change sums and
        the window."""
        normal = self.normal
        self._normal_known()
        normal_infos = normal.solve(approach[:, 2], turn_tol, max_iter, pressure_cap=self.pressure_cap, active=turning)
        self._cells(lk.batch_shear_limit, [normal.pressure, self.laws], [self.shear_limit])
        self.operator.cross_tangential(normal.pressure, self.known)
        if self._adhesive_step:  # the adhesive tractions' tangential displacement, held fixed
            self.adhesion.add(self.adhesion.disp, self.known)
        window = self._window(turning)
        t = window.tangential
        self._crop([*self._tangential_pairs(window), (self.target[0], t.target_x), (self.target[1], t.target_y),
                    (self.known[0], t.known_x), (self.known[1], t.known_y), (self.shear_limit, t.shear_limit)], window)
        tangential_infos = t.solve(turn_tol, max_iter, turning)
        self._put_back(self._tangential_pairs(window), window, turning)
        if self._adhesive_step:  # the slip the next turn's adhesive shear follows
            self._slip(turn=True)
        return normal_infos, tangential_infos, self._change_sums(), window

    def _normal_known(self):
        """Each row's normal displacement held fixed in a normal solve: its shear's K_zt q (made
        with the turn's slip where the shear has not changed since: ``_slip``), plus its
        adhesive tractions' (with adhesion)."""
        a = self.adhesion if self._adhesive_step else None
        if a is not None and a.shear_normal_current:
            wp.copy(self.normal.known, a.shear_normal)
        else:
            self.operator.cross_normal(self.shear, self.normal.known)
        if a is not None:
            a.shear_normal_current = False  # (a tangential solve follows: the shear changes)
            a.add(a.disp_z, self.normal.known)

    def _slip(self, turn: bool = False):
        """Each row's slip s = delta - u_t of its current tractions (``disp``: u_t = K_tt q + K_tz
        p, plus the adhesive tractions' with adhesion). A ``turn``'s slip (with adhesion) makes
        the shear's K_zt q for the next normal solve from the same transforms."""
        a = self.adhesion if self._adhesive_step else None
        if turn:
            self.operator.coupled(self.normal.pressure, self.shear, a.shear_normal, self.disp, normal_block=False)
            a.shear_normal_current = True
        else:
            self.operator.tangential(self.shear, self.disp, pressure=self.normal.pressure)
        if a is not None:
            a.add(a.disp, self.disp)
        self._cells(ck.batch_accumulate_slip, [self.disp[0], self.disp[1], self.shifts], [self.slip[0], self.slip[1]])

    def _window_turn(self, window: _TurnWindow, approach, turn_tol, max_iter, turning) -> tuple:
        """A turn of the ``turning`` rows on the ``window`` alone: K_zt q, the normal solve, the
        shear limit, K_tz p and the tangential solve of the window's fields (the tractions lie
        in it, zero outside). Returns the rows' normal and tangential ``SolveInfo`` lists and
        their change sums."""
        t, normal = window.tangential, window.normal
        window.operator.cross_normal(t.shear, normal.known)
        normal_infos = normal.solve(approach[:, 2], turn_tol, max_iter, pressure_cap=self.pressure_cap, active=turning)
        normal.launches.cells(lk.batch_shear_limit, [normal.pressure, self.laws], [t.shear_limit])
        window.operator.cross_tangential(normal.pressure, t.known)
        tangential_infos = t.solve(turn_tol, max_iter, turning)
        return normal_infos, tangential_infos, change_sums(normal, t.shear, window.previous, window.change)

    def _cells(self, kernel, inputs, outputs):
        self.normal.launches.cells(kernel, inputs, outputs)

    def _change_sums(self) -> np.ndarray:
        """Each row's change sums of the pressure and the shear since the last call (the previous
        copies updated)."""
        return change_sums(self.normal, self.shear, self.previous, self.change)

    def step(self, approach, tol, outer_tol, max_iter, max_turns: int, active) -> list:
        """Solve the rows where ``active`` at their rigid shifts ``approach`` ((rows, 3): delta_x,
        delta_y, delta_z, scaled), inner solves to ``tol`` (one per row), turns to ``outer_tol``,
        within ``max_iter`` inner iterations a solve and ``max_turns`` turns. Returns one
        ``SolveInfo`` per row (a row not solved: not converged, no iteration): converged where
        its turns converged and its last solves did; its inner iterations over every turn; its turns."""
        normal = self.normal
        active = np.asarray(active, dtype=bool)
        approach = np.asarray(approach, dtype=np.float64)
        tol = np.asarray(tol, dtype=np.float64)
        outer_tol = np.asarray(outer_tol, dtype=np.float64)
        shifts = np.zeros((self.batch, 2))
        shifts[: len(approach)] = approach[:, :2]
        self.shifts.assign(shifts.astype(self._np_dtype))
        self._cells(ck.batch_stick_target, [self.slip[0], self.slip[1], self.shifts], [self.target[0], self.target[1]])
        self._change_sums()  # the previous copies: the tractions the step starts from
        rows = self.batch
        iterative = self.coupled | self.adhesive  # rows whose step needs turns
        adhesive = bool((self.adhesive & active).any())  # (the turns then stay on the whole grid)
        self._adhesive_step = adhesive
        if adhesive:
            self.adhesion.shear_normal_current = False  # (another step's shear, or restored rows')
        turning = active.copy()
        turns = np.zeros(rows, dtype=np.int64)
        iterations = np.zeros(rows, dtype=np.int64)
        change = np.full(rows, math.inf)
        coupled = np.full(rows, math.inf)  # each row's coupled residual (the turns' schedule, below)
        turn_tol = np.full(rows, math.inf)
        turns_converged = np.zeros(rows, dtype=bool)
        solves_converged = np.zeros(rows, dtype=bool)
        window, staying = None, False  # the turns' window; staying: the turns after the first stay on it
        while turning.any():
            turns[turning] += 1
            # 1/100 of the coupled residual, never looser than the last turn's (the single solver's
            # "residual" schedule, ``SolverSettings.turn_tolerance``)
            turn_tol = np.where(iterative, np.maximum(tol, np.minimum(np.minimum(TURN_TOL_START, turn_tol),
                                                                      TURN_TOL_RATIO * coupled)), tol)
            adhesive_change = (self.adhesion.update(turning & self.adhesive, first=turns.max() == 1) if adhesive
                               else np.zeros(rows))
            if staying:
                normal_infos, tangential_infos, sums = self._window_turn(window, approach, turn_tol, max_iter, turning)
            else:
                normal_infos, tangential_infos, sums, window = self._whole_turn(approach, turn_tol, max_iter, turning)
                staying = window.normal is not None and not adhesive
                if staying:  # the turns go on on the window: its normal solve's fields and the last turn's
                    self._crop([(normal.initial_gap, window.normal.initial_gap), (normal.pressure, window.normal.pressure),
                                *zip(self.previous, window.previous)], window)
            for row in np.flatnonzero(turning):
                ni, ti = normal_infos[row], tangential_infos[row]
                iterations[row] += ni.iterations + ti.iterations
                change[row] = max(ratio(sums[row, ck.CHANGE_PRESSURE], sums[row, ck.CHANGE_PRESSURE + 1]),
                                  ratio(sums[row, ck.CHANGE_SHEAR_X], sums[row, ck.CHANGE_SHEAR_X + 1]),
                                  adhesive_change[row])
                solves_converged[row] = ni.converged and ti.converged
                # where the normal solve started (how far the last tangential update moved its problem),
                # and where the tangential one did, as far as the turn's change confirms it
                coupled[row] = max(starting_residual(ni), min(change[row], starting_residual(ti)))
                if not iterative[row] or (change[row] < outer_tol[row] and turn_tol[row] == tol[row]):
                    turns_converged[row] = True
                    turning[row] = False
                elif turns[row] >= max_turns:
                    turning[row] = False
        if staying:  # the window's pressure, shear and statuses back into the whole grid, to be judged there
            self._put_back([(normal.pressure, window.normal.pressure), *self._tangential_pairs(window)], window, active)
            self._change_sums()  # the previous copies: the turns' answer
        # each row's gap and u_z against its final shear, then its whole u_t and its slip
        self._normal_known()
        final = normal.solve(approach[:, 2], tol, max_iter, pressure_cap=self.pressure_cap, active=active)
        if staying:  # a contact that grew past the window: its turns are not the whole grid's answer
            sums = self._change_sums()
            for row in np.flatnonzero(active):
                if ratio(sums[row, ck.CHANGE_PRESSURE], sums[row, ck.CHANGE_PRESSURE + 1]) >= outer_tol[row]:
                    turns_converged[row] = False
        self._slip()
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


class _AdhesiveRows:
    """The adhesive tractions of a ``BatchContactSolver``'s rows with adhesion (the SMC law, the
    contact shear "bounded"; ``set_cases``), a fixed point of their own in the lagged turns, as
    the single solver's (``ContactSolver.update_adhesion``): each turn takes the law's tractions
    of the last gap and slip as G(t) and moves t by each row's Anderson mixing
    (``BatchAndersonMixing``, beta ``SolverSettings.relax``); their displacements then enter both
    solves of the turn as known ones. A row's change is |G(t) - t| / |G(t)| before the move."""

    def __init__(self, solver: BatchContactSolver):
        self.solver = solver
        cells = (solver.batch, solver.n_cells)
        dtype, device = solver.dtype, solver.device
        #: the adhesive tractions / E*: p_adh, q_adh x, y, one (3, B, cells) array (the mixing's
        #: vector), and its views
        self.traction = wp.zeros((3, *cells), dtype=dtype, device=device)
        self.pressure, self.shear = self.traction[0], self.traction[1:3]
        #: their displacements / dx: normal, and the tangential pair
        self.disp_z = wp.zeros(cells, dtype=dtype, device=device)
        self.disp = wp.zeros((2, *cells), dtype=dtype, device=device)
        #: the contact shear's K_zt q made with a turn's slip (``BatchContactSolver._slip``), which
        #: the next normal solve holds fixed while ``shear_normal_current``
        self.shear_normal = wp.zeros(cells, dtype=dtype, device=device)
        self.shear_normal_current = False
        #: each row's law (``kernels/adhesion.py``, slots SMC_*; zeros: no adhesion)
        self.laws = wp.zeros((solver.batch, ak.N_SMC_PARAMETERS), dtype=dtype, device=device)
        self.mixing = BatchAndersonMixing(solver.normal.launches, self.traction.shape, device, dtype,
                                          beta=SolverSettings.relax)

    def add(self, source, target):
        """target += source (fields or pairs of the batch, each one contiguous array)."""
        self.solver.normal.launches.launch(ak.add_to, target.size, [source.flatten()], [target.flatten()])

    def update(self, rows: np.ndarray, first: bool) -> np.ndarray:
        """One mixed step of the ``rows``' (booleans) adhesive tractions (their mixing's history
        forgotten on the ``first`` turn of a step) and their displacements; returns each row's
        change |G(t) - t| / |G(t)| before the step (0 elsewhere)."""
        s = self.solver
        normal = s.normal
        law = self.mixing.residual
        if first:
            self.mixing.reset(rows)
        s._cells(ak.batch_smc_tractions, [normal.gap, s.slip[0], s.slip[1], normal.pressure, self.pressure,
                                          self.shear[0], self.shear[1], self.laws], [law[0], law[1], law[2]])
        change = self.mixing.step(self.traction, rows)
        # the displacements: K_zz p_adh + K_zt q_adh, and K_tt q_adh + K_tz p_adh
        s.operator.coupled(self.pressure, self.shear, self.disp_z, self.disp)
        return change

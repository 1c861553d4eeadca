"""Partial slip: bounded conjugate gradients for the shear traction (after Chen & Wang 2008)."""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import replace

import numpy as np
import warp as wp

from warpcontact.kernels import adhesion as ak
from warpcontact.kernels import grids as gk
from warpcontact.kernels import reduce
from warpcontact.kernels import tangential as tk

from ..numerics.launch import FirstRow, Rows, Sums
from ..numerics.state import SolveInfo
from .base import ProjectedCG, raise_non_finite
from .settings import SolverSettings

#: window sizes (cells per side): these numbers times a power of two, so that the window's padded
#: transforms (2m points) have no prime factor over 7
WINDOW_STEPS = (8, 9, 10, 12, 14, 15, 16)
#: the largest window, as a share of the grid's cells per side; a contact wider than its window
#: is solved on the whole grid (a window of 0.75 n transforms 56 % of the whole grid's entries)
WINDOW_MAX_SHARE = 0.75
#: window solvers kept (one per size), the least recently used let go
WINDOW_CACHE = 2
#: ``window = "auto"`` (the default): windows from these grids on (cells per side), by device
#: kind, where they were measured to cost less than they save (docs/performance.md, "The
#: tangential solves on the contact's window": ``bench/scaling.py``'s coupled problem, rows
#: coupled-window and coupled-whole)
WINDOW_AUTO_N = {"cpu": 128, "cuda": 1024}


def window_cells(extent: int, n: int) -> int | None:
    """The side of the window (cells) that holds a support ``extent`` cells wide on a grid of n
    cells per side: the smallest of WINDOW_STEPS times a power of two that is at least ``extent``
    (and at least 8); None where that is over WINDOW_MAX_SHARE x n."""
    extent = max(int(extent), WINDOW_STEPS[0])
    scale = 1
    while WINDOW_STEPS[-1] * scale < extent:
        scale *= 2
    cells = next(step * scale for step in WINDOW_STEPS if step * scale >= extent)
    return cells if cells <= WINDOW_MAX_SHARE * n else None


def window_enabled(choice, model, auto_n: dict | None = None) -> bool:
    """Whether a solver of ``model`` with ``SolverSettings.window`` = ``choice`` solves on windows:
    "auto", from ``auto_n`` cells per side (by the device's kind; default ``WINDOW_AUTO_N``) on."""
    if choice == "auto":
        auto_n = WINDOW_AUTO_N if auto_n is None else auto_n
        return model.grid.n >= auto_n["cuda" if model.device.is_cuda else "cpu"]
    return bool(choice)


def window_origin(first: int, last: int, cells: int, n: int) -> int:
    """First row (or column) of a window of ``cells`` that holds rows ``first`` .. ``last`` of a
    grid of n: the support centred in it, the window moved inside the grid where it would leave it."""
    start = first - (cells - (last - first + 1)) // 2
    return min(max(start, 0), n - cells)


class Windows:
    """A solver's windows of its model's grid (``SolverSettings.window``), kept per size
    (``WINDOW_CACHE``, the least recently used let go), on models of their own that a grid's
    solvers share (``ContactModel.window_model``)."""

    def __init__(self, model):
        self.model = model
        self._kept: OrderedDict = OrderedDict()  # cells -> window
        self._refused: set = set()  # window sizes that did not fit in the device's memory

    def kept(self):
        """The windows kept."""
        return self._kept.values()

    @staticmethod
    def transfer(window, kernel, pairs):
        """``kernel`` (``grids.crop``: whole grid to window, or ``grids.embed``: back) on each
        (source, destination) pair of fields, at the ``window``'s ``row0``, ``col0`` (on its
        solver's model; recorded launches, replayed while the window stays in place). On the CPU a
        row a thread, the window's rows split over the CPU's threads (``LaunchCache.launch_rows``):
        a window of 512-640 cells took 1.16 ms a field one cell a thread."""
        m = window.solver.model
        cropping = kernel is gk.crop
        for src, dst in pairs:
            m.launches.launch_rows(kernel, m.grid.shape, [src if cropping else Rows(src), window.row0, window.col0,
                                                          FirstRow()], [Rows(dst) if cropping else dst])

    def place(self, first_row: int, last_row: int, first_col: int, last_col: int, extent: int, make):
        """The window that holds rows ``first_row`` .. ``last_row`` and columns ``first_col`` ..
        ``last_col`` with room for ``extent`` cells (``window_cells``), placed over them (its
        ``row0``, ``col0``); ``make(model)`` makes one of a size first needed. None where that
        size is over ``WINDOW_MAX_SHARE`` of the grid or does not fit in the device's memory."""
        n = self.model.grid.n
        cells = window_cells(extent, n)
        if cells is None or cells in self._refused:
            return None
        window = self._kept.get(cells)
        if window is None:
            model = self.model.window_model(cells)
            if model is None:
                self._refused.add(cells)
                return None
            window = self._kept[cells] = make(model)
            while len(self._kept) > WINDOW_CACHE:
                self._kept.popitem(last=False)
        self._kept.move_to_end(cells)
        window.row0 = window_origin(first_row, last_row, cells, n)
        window.col0 = window_origin(first_col, last_col, cells, n)
        return window


class TangentialSolver(ProjectedCG):
    """Shear traction (q_x, q_y) under the disk bound |q| <= q_max at given rigid shifts.

    Chen, W. W. & Wang, Q. J. (2008), "A numerical model for the point contact of dissimilar
    materials considering tangential tractions", Mech. Mater. 40, 936-948; their correction of
    delta_x, delta_y is not used (the shifts are inputs). See kernels/tangential.py for the
    iteration. The relative residual is the norm of the violated stick/slip conditions (stick:
    the slip increment; slip: its part not along q and any reversal) over the norm of the
    right-hand side delta - s_prev - u_known on the contact.

    Preconditioned (``settings.tangential_preconditioner``, the default), an iteration makes one application of the
    tangential operator, K t of the conjugate direction, and carries g (g <- g - tau K t); g is
    made exact again (K q) after a released cell (a restart of the conjugacy), every
    ``exact_every`` iterations, and when the bound on what the projections changed since (slip
    cells' retraction onto their circle, stick cells projected onto it) exceeds ``deferral`` of
    the violation (``kernels/tangential.py``, ``tangential_advance``), as the normal solver
    carries its gap. The loop settles where the carried g meets the tolerance; the launch then
    makes g exact and the host judges the solve on it (going on where it does not agree). The
    direction is built from z = M g: on the stick cells M is the circulant inverse of K_tt (per
    wavenumber the inverse of the 2x2 block [[K_xx, K_xy], [K_xy, K_yy]] on the padded grid, its
    eigenvalues floored at ``eigen_floor``) applied to g on the stick cells and read there, the
    tangential analogue of the normal solver's preconditioner on its free set; on slip cells the
    Jacobi scaling of g's tangent part (1 / (self-influence + lambda / q_max)). An iteration makes
    two transform pairs (K t and M g), as the plain one does (K q and K t). Cells that slipped
    when the last solve ended start as slip cells on their new circle (``tangential_classify``'s
    ``keep_slip``). It takes half the iterations of the plain one and fewer as the grid grows
    (docs/model.md, "Partial slip"; ``tests/test_tangential_precond.py``).
    On slip cells the sums take g's tangent part (``kernels/tangential.py``, ``step_terms``): g's
    normal part, the slip increment, is up to 1e9 times it near a solution, and rounding let it
    into g . t, which held both iterations near a relative residual of 1e-10 for hundreds of
    iterations at a fretting reversal (``tests/test_fretting.py``). Related work: Zhao, Vollebregt & Oosterlee, "A fast
    nonlinear conjugate gradient based method for 3D frictional contact problems", J. Comput.
    Phys. (2015; TU Delft report 14-02): active set, slip tractions by their azimuth angle,
    diagonal scaling, FFT products; FFT-based (circulant inverse) preconditioners for the normal
    problem: Vollebregt (2014), J. Comput. Phys. 257, 333-351, and Zhao, Vollebregt & Oosterlee
    (2014), Numer. Linear Algebra Appl. 21, 256-274.

    ``tangential_preconditioner=False``: the iteration as Chen & Wang publish it, with Jacobi scaling: K q
    for the exact gradient and K t for the step at every iteration (two applications).

    The window (``settings.window``; by default from ``WINDOW_AUTO_N`` cells per side on, where it was
    measured to pay): the shear lives on the cells where q_max > 0 (the
    contact), and a solve is the same problem on any grid of the same cells that holds them all,
    the tractions outside it being zero. A solve therefore runs on the smallest square window of
    the grid that holds the contact (``window_cells``: 8, 9, 10, 12, 14, 15 or 16 times a power of
    two), with an operator of its own (the same cell size: the same influence coefficients, padded
    to 2m instead of 2n), where that window is at most ``WINDOW_MAX_SHARE`` of the grid per side;
    the shear and statuses are put back (zero outside it), and the whole grid's K_tt q (and K_tp p
    of the ``pressure``) is made at the end of the solve, or later by
    [`whole_displacement`][warpcontact.solvers.tangential.TangentialSolver.whole_displacement]
    where the caller defers it (``whole``). Only the preconditioner differs (the circulant inverse
    on the smaller padded grid), and with it the iterates' rounding and the iteration count by a
    few. A contact half the domain wide (domain 4 sqrt(R delta_z)) takes a window of n/2 (9n/16
    where it passes n/2 by a cell): each iteration's transforms have 25-32 % of the entries.
    Windows are kept per size (``WINDOW_CACHE``); on CUDA a window whose arrays would not fit in
    the free memory is not made (the solve runs on the whole grid).

    Args:
        model: the [`ContactModel`][warpcontact.numerics.model.ContactModel].
        settings: the solver's choices ([`SolverSettings`][warpcontact.solvers.settings.SolverSettings];
            this solver reads ``tol``, ``max_iter``, ``tangential_preconditioner``, ``exact_every``,
            ``deferral``, ``window``, ``iterations_per_launch``, ``use_graphs``); default: the
            defaults.
        **choices: settings replaced by name (``TangentialSolver(model, window=False)``).
    """

    restart_every = 100

    def __init__(self, model, settings: SolverSettings | None = None, **choices):
        settings = SolverSettings.of(settings, **choices)
        super().__init__(model, settings, tk.N_SUMS_PRECONDITIONED, tk.N_SCALARS)
        #: the iteration's fields on the whole grid (gradient, direction, response), made by the
        #: first solve that runs on the whole grid (solves on a window use the window's)
        self.grad_x = self.grad_y = self.dir_x = self.dir_y = self.resp_x = self.resp_y = None
        self._no_displacement = None
        # self-influence of the tangential kernel (scaled): the Jacobi preconditioner of stick
        # cells, and 1 / it the step of released cells when no conjugate step is defined
        k_self = 0.5 * (model.operator.self_coefficient("xx") + model.operator.self_coefficient("yy"))
        self.stiffness = model.scalar(k_self)
        self.slip_step = model.scalar(1.0 / k_self)
        #: floor of the eigenvalues of K_tt's 2x2 blocks in the preconditioner (scaled): a
        #: quarter of the self-influence. A few entries on the padded grid's axes near the highest
        #: frequency are below it (down to -0.04; the rest 0.7 and up); floors from 0.02 to 0.5
        #: times the self-influence gave the same iterations within 1 (NumPy replay, n = 64).
        self.eigen_floor = 0.25 * k_self
        self._column_norm = model.scalar(model.operator.tangential_column_norm())
        self.deferred = model.scalars(1)
        #: 1: the next iteration starts from an exact g (set by the device)
        self.recompute = wp.zeros(1, dtype=wp.int32, device=model.device)
        self._current_sums = self.sums[: tk.S_RHS + 1]  # slots S_G, S_VIOL, S_RHS
        #: launches of the last preconditioned solve that settled on a carried g whose exact
        #: value did not meet the tolerance (the loop then went on from the exact g)
        self.disagreements = 0
        #: the side of the last solve's window in cells, None where it ran on the whole grid
        self.last_window: int | None = None
        self._windows = Windows(model)
        self._box = wp.zeros(4, dtype=wp.int32, device=model.device)
        #: (state, pressure, known_x, known_y) of the last solve on a window whose whole-grid
        #: displacements are still to make (``whole_displacement``)
        self._pending = None

    def solve(self, state, target_x, target_y, shear_limit, known_x=None, known_y=None, tol=None, pressure=None,
              whole: bool = True) -> SolveInfo:
        """Solve for ``state.shear_x/y`` and ``state.status``.

        Args:
            state: holds the shear to start from (and the statuses the last solve left); its
                ``disp_x/y`` receive K_tt q.
            target_x, target_y: delta - s_prev [scaled]: where stick cells must stay.
            shear_limit: q_max per cell [scaled].
            known_x, known_y: tangential displacement from other tractions held fixed, scaled;
                zero if None.
            pressure: the contact pressure [scaled] whose tangential displacement K_tp p (the
                coupling of dissimilar materials) is held fixed beside ``known_x/y``, made by the
                solver on the grid it solves on (the window holds the pressure's cells too).
                ``known_x/y`` (then required) receive the sum on the whole grid: at once where
                the solve runs on it, else by
                [`whole_displacement`][warpcontact.solvers.tangential.TangentialSolver.whole_displacement].
            whole: make ``state.disp_x/y`` (and the sum above) on the whole grid at the end of a
                solve on a window; False: leave that to
                [`whole_displacement`][warpcontact.solvers.tangential.TangentialSolver.whole_displacement],
                which a caller that solves in turns calls only where it reads them (four or seven
                transforms of the whole padded grid saved per solve).
        """
        self._pending = None  # (a window's displacements left to make belong to the tractions this solve replaces)
        if pressure is not None and (known_x is None or known_y is None):
            raise ValueError("TangentialSolver.solve: pass known_x and known_y to receive K_tp p with pressure")
        known_x = known_x if known_x is not None else self.no_displacement
        known_y = known_y if known_y is not None else self.no_displacement
        window = self._window_for(shear_limit, pressure) if self.uses_window else None
        self.last_window = None if window is None else window.cells
        if window is not None:
            info = window.solve(self, state, target_x, target_y, shear_limit, known_x, known_y, tol, pressure)
            self._pending = (state, pressure, known_x, known_y)
            if whole:
                self.whole_displacement(state)
            return info
        self.make_whole_grid_fields()
        if pressure is not None:
            self._add_coupling(state, pressure, known_x, known_y)
        if self.settings.tangential_preconditioner:
            return self._solve_preconditioned(state, target_x, target_y, shear_limit, known_x, known_y, tol)
        return self._solve_plain(state, target_x, target_y, shear_limit, known_x, known_y, tol)

    def whole_displacement(self, state):
        """Where the last solve ran on a window for ``state`` with ``whole`` False: make
        ``state.disp_x/y`` = K_tt q on the whole grid, and add K_tp p of its ``pressure`` (as it is
        now) to its ``known_x/y``. Nothing otherwise (and nothing a second time)."""
        if self._pending is None or self._pending[0] is not state:
            return
        _, pressure, known_x, known_y = self._pending
        self._pending = None
        if pressure is not None:
            self._add_coupling(state, pressure, known_x, known_y)
        self.model.operator.tangential(state.shear_x, state.shear_y, state.disp_x, state.disp_y)

    def pending_pressure(self, state, take: bool = False):
        """The pressure whose K_tp p the last solve, on a window for ``state`` with ``whole``
        False, left to add on the whole grid (``whole_displacement``); None where there is none
        (nothing pending, or a solve without ``pressure``). ``take``: the caller makes the whole
        grid's displacements itself (K_tt q + K_tp p at once: ``ContactSolver.update_slip``), so
        nothing is left pending."""
        if self._pending is None or self._pending[0] is not state:
            return None
        pressure = self._pending[1]
        if take and pressure is not None:
            self._pending = None
        return pressure

    def _add_coupling(self, state, pressure, known_x, known_y):
        """known_x/y += K_tp p on the whole grid, made in ``state.disp_x/y`` (free: K_tt q is made
        there next)."""
        m = self.model
        m.operator.cross_tangential(pressure, state.disp_x, state.disp_y)
        for src, dst in ((state.disp_x, known_x), (state.disp_y, known_y)):
            m.launch(ak.add_to, dim=m.n_cells, inputs=[src.flatten()], outputs=[dst.flatten()])

    @property
    def no_displacement(self):
        """A zero field: the known displacement of a solve given none (made when first needed: a
        solver of coupled turns, or a window's, always gets one)."""
        if self._no_displacement is None:
            self._no_displacement = self.model.field()
        return self._no_displacement

    def make_whole_grid_fields(self):
        """Make the iteration's fields on the whole grid (gradient, direction, response) if they
        are not there: the first solve on the whole grid does. ``resources.breakdown`` counts them
        (the arrays a solve on the whole grid holds)."""
        if self.grad_x is None:
            f = self.model.field
            self.grad_x, self.grad_y, self.dir_x, self.dir_y, self.resp_x, self.resp_y = (f() for _ in range(6))

    @property
    def uses_window(self) -> bool:
        """Whether solves may run on a window (``settings.window``)."""
        return window_enabled(self.settings.window, self.model)

    @property
    def graph_count(self) -> int:
        """CUDA graphs captured and kept, its windows' included."""
        return super().graph_count + sum(w.solver.graph_count for w in self._windows.kept())

    def _window_for(self, shear_limit, pressure=None):
        """The window of the contact (cells where ``shear_limit`` > 0, or ``pressure`` > 0),
        placed over it; None where the solve runs on the whole grid (no contact, a contact wider
        than the largest window, a window that does not fit). One read of the device: the
        contact's bounding box."""
        m = self.model
        n = m.grid.n
        self._box.assign(np.array([n, -1, n, -1], dtype=np.int32))
        for field in (shear_limit, pressure):
            if field is None:
                continue
            if m.device.is_cpu:  # (a thread a row: the CPU runs the threads one after another)
                m.launch(gk.support_box_rows, n, [field], [self._box])
            else:
                m.launch(gk.support_box, (-(-n // int(gk.SUPPORT_ROWS)), n), [field], [self._box])
        first_row, last_row, first_col, last_col = (int(v) for v in self._box.numpy())
        if last_row < 0:
            return None
        return self._windows.place(first_row, last_row, first_col, last_col,
                                   max(last_row - first_row, last_col - first_col) + 1,
                                   lambda model: _Window(self, model))

    def _fields(self, state, target_x, target_y, shear_limit, known_x, known_y):
        """The fields flattened, marked as the CPU splits the reducing passes over its threads."""
        return tuple(Rows(a.flatten()) for a in (
            state.shear_x, state.shear_y, state.status, state.disp_x, state.disp_y, known_x, known_y, target_x,
            target_y, shear_limit, self.grad_x, self.grad_y, self.dir_x, self.dir_y, self.resp_x, self.resp_y))

    def _key(self, state, target_x, target_y, shear_limit, known_x, known_y):
        return (self.settings.tangential_preconditioner, self.float32_preconditioner, self.settings.preconditioner_grid,
                self.float32_response,
                *(a.ptr for a in (state.shear_x, state.shear_y, state.status, state.disp_x, state.disp_y, known_x,
                                  known_y, target_x, target_y, shear_limit)))

    def _on_non_finite(self, state):
        def on_non_finite(it):
            raise_non_finite("tangential solve", state, ("shear_x", "shear_y", "disp_x", "disp_y"), it)

        return on_non_finite

    def _solve_preconditioned(self, state, target_x, target_y, shear_limit, known_x, known_y, tol) -> SolveInfo:
        m = self.model
        inverse = self.preconditioner_transforms()
        fft = inverse.fft  # the preconditioner's transforms (float32 where settings.preconditioner_float32)
        # the response K t's transforms (float32 where settings.response_float32; else the operator's own)
        response = m.operator.response_transforms() if self.float32_response else None
        qx, qy, st, ux, uy, kx, ky, tgx, tgy, limit, gx, gy, tx, ty, rx, ry = self._fields(
            state, target_x, target_y, shear_limit, known_x, known_y)
        sums = Sums(self.sums)
        self._stage(tk.P_EXACT, 0.0)
        self._begin(tol)
        self.disagreements = 0
        output = [Rows(fft.padded_output), fft.output_scale]  # M g, as the preconditioner leaves it
        shape = m.grid.shape

        def start():
            self.dir_x.zero_()  # no leftover from an earlier (possibly failed) solve
            self.dir_y.zero_()
            m.launch_cells(tk.tangential_classify, [limit, 1], [qx, qy, st])

        def residual():  # g and slots S_G (slip part), S_VIOL, S_RHS from state.disp = K q
            m.launch_reduce(tk.tangential_residual,
                            [ux, uy, kx, ky, tgx, tgy, qx, qy, limit, st, self.stiffness, 0], [gx, gy, sums])

        def displacement():
            m.operator.tangential(state.shear_x, state.shear_y, state.disp_x, state.disp_y)

        def exact():
            displacement()
            residual()
            self.recompute.zero_()
            self.deferred.zero_()

        def recompute():  # the prelude of an iteration where the device asked for an exact g
            self._current_sums.zero_()
            displacement()
            residual()

        def stick_gradient(grad):  # one component of g on the stick cells into the padded input
            return lambda: m.launches.launch_rows(tk.tangential_stick_gradient, shape,
                                                  [Rows(grad.flatten()), st, m.grid.n], [Rows(fft.padded_input)])

        def direction_x():
            m.launches.launch_rows(tk.tangential_direction_stick, shape,
                                   [*output, st, self.sums, self.scalars, m.grid.n], [tx])

        def direction_rest():
            m.launches.launch_rows(tk.tangential_direction_rest, shape,
                                   [*output, gx, gy, qx, qy, limit, st, self.stiffness, self.sums, self.scalars,
                                    m.grid.n],
                                   [tx, ty])

        def body():  # after recompute() where self.recompute is set (the device decides: _run's prelude)
            m.operator.tangential_inverse_padded(stick_gradient(self.grad_x), stick_gradient(self.grad_y),
                                                 direction_x, direction_rest, self.sums, tk.S_G, self.eigen_floor,
                                                 inverse)
            m.operator.tangential(self.dir_x, self.dir_y, self.resp_x, self.resp_y, response)
            m.launch_reduce(tk.tangential_step_sums, [gx, gy, tx, ty, rx, ry, qx, qy, limit, st], [sums])
            m.launch_reduce(tk.tangential_carried_update,
                            [tx, ty, rx, ry, limit, self.slip_step, self.stiffness, self.parameters],
                            [qx, qy, st, gx, gy, sums])
            m.launch(tk.tangential_advance, 1,
                     [self.sums, self.parameters, self.restart_every, self.settings.exact_every, self._column_norm,
                      m.scalar(self.settings.deferral)],
                     [self.scalars, self.history, self.deferred, self.recompute, self.loop, self.refresh,
                      self.inner_loop])

        def on_disagreement():  # the carried g said "converged", the exact one does not: go on from it
            self.disagreements += 1

        key = self._key(state, target_x, target_y, shear_limit, known_x, known_y)
        return self._run(key, start, exact, body, self._on_non_finite(state), on_disagreement,
                         prelude=(self.recompute, recompute))

    def _solve_plain(self, state, target_x, target_y, shear_limit, known_x, known_y, tol) -> SolveInfo:
        m = self.model
        qx, qy, st, ux, uy, kx, ky, tgx, tgy, limit, gx, gy, tx, ty, rx, ry = self._fields(
            state, target_x, target_y, shear_limit, known_x, known_y)
        sums = Sums(self.sums)
        self._begin(tol)

        def start():
            self.dir_x.zero_()  # no leftover from an earlier (possibly failed) solve
            self.dir_y.zero_()
            m.launch_cells(tk.tangential_classify, [limit, 0], [qx, qy, st])

        def gradient():
            m.operator.tangential(state.shear_x, state.shear_y, state.disp_x, state.disp_y)
            m.launch_reduce(tk.tangential_residual,  # S_G with the stick cells' Jacobi part
                            [ux, uy, kx, ky, tgx, tgy, qx, qy, limit, st, self.stiffness, 1], [gx, gy, sums])

        def body():
            self.sums.zero_()
            gradient()
            m.launch_cells(tk.tangential_direction,
                           [gx, gy, qx, qy, limit, st, self.stiffness, self.sums, self.scalars], [tx, ty])
            m.operator.tangential(self.dir_x, self.dir_y, self.resp_x, self.resp_y)
            m.launch_reduce(tk.tangential_step_sums, [gx, gy, tx, ty, rx, ry, qx, qy, limit, st], [sums])
            m.launch_reduce(tk.tangential_update, [gx, gy, tx, ty, limit, self.slip_step, self.parameters],
                            [qx, qy, st, sums])
            m.launch(reduce.cg_advance, dim=1, inputs=[self.sums, self.parameters, self.restart_every],
                     outputs=[self.scalars, self.history, self.loop, self.refresh])

        key = self._key(state, target_x, target_y, shear_limit, known_x, known_y)
        return self._run(key, start, gradient, body, self._on_non_finite(state))


class _Window:
    """A square window of ``cells`` per side of a solver's grid (``SolverSettings.window``): a
    model of its own (the same materials and cell size), a tangential solver on it, and the
    fields of a solve, cut out of the whole grid's at ``(row0, col0)`` and put back."""

    #: the fields a solve reads, by the names of ``TangentialSolver.solve``'s arguments
    INPUTS = ("target_x", "target_y", "shear_limit", "known_x", "known_y")

    def __init__(self, parent: TangentialSolver, model):
        self.cells = model.grid.n
        self.row0 = self.col0 = 0
        self.solver = TangentialSolver(model, replace(parent.settings, tol=parent.tol, window=False))
        f = model.field
        # the state the window's solve works on (the attributes of ContactState it reads and writes)
        self.shear_x, self.shear_y, self.disp_x, self.disp_y = f(), f(), f(), f()
        self.status = wp.zeros(model.grid.shape, dtype=wp.int32, device=model.device)
        for name in self.INPUTS:
            setattr(self, name, f())
        self._pressure = None

    @property
    def pressure(self):
        """The pressure cut out for the coupling's known displacement (made when first needed)."""
        if self._pressure is None:
            self._pressure = self.solver.model.field()
        return self._pressure

    def solve(self, parent: TangentialSolver, state, target_x, target_y, shear_limit, known_x, known_y, tol,
              pressure) -> SolveInfo:
        """``parent.solve`` on the window: its fields cut out (with ``pressure``, K_tp p made on
        the window and added to the known displacement there), solved, the shear and statuses put
        back (zero and out of contact outside). The whole grid's displacements are the parent's
        to make (``whole_displacement``)."""
        solver = self.solver
        whole = (state.shear_x, state.shear_y, state.status, target_x, target_y, shear_limit, known_x, known_y)
        own = (self.shear_x, self.shear_y, self.status, *(getattr(self, name) for name in self.INPUTS))
        Windows.transfer(self, gk.crop, zip(whole, own))
        if pressure is not None:
            Windows.transfer(self, gk.crop, [(pressure, self.pressure)])
            solver._add_coupling(self, self.pressure, self.known_x, self.known_y)
        info = solver.solve(self, *own[3:], tol=tol)
        parent.disagreements = solver.disagreements
        for a in whole[:3]:
            a.zero_()
        Windows.transfer(self, gk.embed, zip(own[:3], whole[:3]))
        return info

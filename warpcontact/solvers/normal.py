"""Displacement-driven normal contact: Polonsky & Keer (1999) without the force constraint."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import warp as wp

from warpcontact.kernels import grids as gk
from warpcontact.kernels import normal as nk

from ..numerics.launch import ReductionLaunch, Rows, Sums
from ..numerics.state import SolveInfo
from .base import ProjectedCG, default_tolerance, raise_non_finite  # noqa: F401  (re-export)
from .settings import SolverSettings
from .tangential import Windows, window_enabled

#: ``window = "auto"``: the normal solves on windows from these grids on (cells per side), by device
#: kind, where they were measured to cost less than they save (docs/performance.md)
NORMAL_WINDOW_AUTO_N = {"cpu": 128, "cuda": 4096}
#: the normal solve's window holds the box of its starting contact and the cells its approach
#: closes, widened by this share of its extent on every side (where the contact grows past the
#: window, the solve on the whole grid that judges the window's answer goes on from it)
WINDOW_MARGIN = 0.03125


class NormalSolver(ProjectedCG):
    """Projected conjugate gradients for the contact pressure at a given rigid approach.

    Polonsky, I. A. & Keer, L. M. (1999), "A numerical method for solving rough contact problems
    based on the multi-level multi-summation and conjugate gradient techniques", Wear 231,
    206-219, in its displacement-driven form: delta_z is an input, no force constraint
    (MODEL.md section 4).

    The relative residual of a pressure p with gap g = h0 - delta_z + K p + u_known is
    ``sqrt(sum_{p>0} g^2 + sum_{p=0, g<0} g^2) / sqrt(sum_{p>0} (delta_z - h0 - u_known)^2)``:
    the misfit of the contact conditions relative to the rigid interference they absorb.

    One iteration makes one convolution, K t of the conjugate direction: the gap is carried
    (g <- g - tau K t) and made exact again (a second convolution, K p) only when what the
    projections changed since may matter (``deferral``), near convergence, and every
    ``exact_every`` iterations; the device decides (``kernels/normal.py``, ``normal_advance``).
    The solver's own work is four passes over the grid (``kernels/normal.py``), two of which
    write and read the FFT backend's padded buffers directly, so the convolution's padding and
    cropping passes are those passes. On CUDA (``fourier_step_sums``) three: the direction's pass
    sums g . t and the spectral product (K t) . t, in Fourier space.

    Preconditioned (``settings.normal_preconditioner``, the default): each iteration's direction is built from
    z = M g on the free set F (0 < p < cap) instead of g, with M the circulant inverse of K on
    the padded grid (1 / K(k) in Fourier space: the operator's spectrum inverted; restricted to F,
    M approximates the inverse of K restricted to F, most closely away from F's edge), and
    beta = delta (g . z) / (g_old . z_old): preconditioned conjugate gradients, with Polonsky and
    Keer's projections and re-entries unchanged. An iteration makes a second transform pair (of
    the free gap ``normal_free_gap``; g . M g summed in Fourier space by Parseval), and a Hertz solve
    from rest needs 4-8 times fewer: n = 256, 12 against 51; 512, 13 against 71-82; 1024, 11 against 86
    (the iterations of plain conjugate gradients grow with the contact's width in cells, as the
    square root of K's condition number on the contact; M removes that growth). The preconditioner
    is the continuous operator's inverse (|k| E* / 2) as the grid sees it; FFT-based
    preconditioners of the same kind for the contact integral equation: Zhao, Vollebregt &
    Oosterlee (2014), Numer. Linear Algebra Appl. 21, 256-274.

    Args:
        model: the [`ContactModel`][warpcontact.numerics.model.ContactModel].
        settings: the solver's choices ([`SolverSettings`][warpcontact.solvers.settings.SolverSettings];
            this solver reads ``tol``, ``max_iter``, ``normal_preconditioner``, ``one_convolution``,
            ``exact_every``, ``deferral``, ``fourier_step_sums``, ``iterations_per_launch``,
            ``use_graphs``); default: the defaults.
        pressure_cap: upper bound of the pressure [Pa] (hardness), inf for none.
        **choices: settings replaced by name (``NormalSolver(model, max_iter=500)``).
    """

    def __init__(self, model, settings: SolverSettings | None = None, *, pressure_cap: float = math.inf, **choices):
        settings = SolverSettings.of(settings, **choices)
        super().__init__(model, settings, nk.N_SUMS, nk.N_SCALARS)
        #: upper bound of the pressure [Pa] (the softer body's hardness: elastic-perfectly-plastic
        #: surface; MODEL.md section 5); inf for none
        self.pressure_cap = float(pressure_cap)
        big = np.finfo(model.np_dtype).max
        self._cap = model.scalar(min(self.pressure_cap / model.traction_scale, big))
        self.direction = model.field()
        self.response = model.field()
        #: the interference b = delta_z - h0 - u_known of the solve (scaled): g = K p - b
        self.interference = model.field()
        self.guess_sums = model.scalars(nk.N_GUESS_SUMS)
        #: 1: the solve starts from rest and makes the first guess (set by the device)
        self.guess_flag = wp.zeros(1, dtype=wp.int32, device=model.device)
        self.no_displacement = model.field()
        #: 1: the next iteration starts from an exact gap (set by the device)
        self.recompute = wp.zeros(1, dtype=wp.int32, device=model.device)
        self._column_norm = model.scalar(model.operator.column_norm("zz"))
        self.deferred = model.scalars(1)
        self._current_sums = self.sums[: nk.S_RHS + 1]  # slots S_G, S_VIOL, S_RHS
        self._preconditioned_g = self.sums[nk.S_G: nk.S_G + 1]
        #: sum g . t and (K t) . t in Fourier space (``settings.fourier_step_sums``; by default on
        #: CUDA, where it saves a pass over the grid; on the CPU the spectral sum costs more than
        #: the pass: docs/performance.md). Same iterates up to rounding.
        self.fourier_step_sums = (model.device.is_cuda if settings.fourier_step_sums is None
                                  else settings.fourier_step_sums)
        # the direction's pass (one sum) takes more blocks than the model's reductions: it is
        # faster so on CUDA (docs/performance.md)
        self._direction_launch = ReductionLaunch.for_cells(model.n_cells, model.device, blocks_per_sm=8)
        self._windows = Windows(model)
        self._box = wp.zeros(4, dtype=wp.int32, device=model.device)
        #: the side of the last solve's window in cells, None where it ran on the whole grid
        self.last_window: int | None = None
        #: the window of the last solve, placed where it was (None: the whole grid), which
        #: ``solve_on_window`` solves on again
        self._placed = None

    def solve(self, state, approach_z: float, known_displacement: wp.array | None = None, tol=None,
              displacement_current: bool = False) -> SolveInfo:
        """Solve for ``state.pressure`` at the rigid approach ``approach_z`` [m].

        Starts from the pressure already in ``state`` (warm start along a path) or, if it is zero,
        from a Hertz-shaped guess (`_guess`). ``known_displacement`` (scaled, (n, n)) is a
        normal displacement from other tractions (shear coupling, adhesion) held fixed during
        the solve. Fills ``state.pressure``, ``state.disp_z``, ``state.gap``. ``tol`` overrides
        the solver's tolerance for this solve. ``displacement_current``: ``state.disp_z`` is K p
        of ``state.pressure`` already (the pressure has not changed since a solve left it), so the
        start makes no convolution of its own (the later turns of a coupled or adhesive step).

        With ``settings.window`` (by default from ``NORMAL_WINDOW_AUTO_N`` cells per side on) the solve
        runs on a window of the grid around its contact (``_NormalWindow``), and is then judged,
        and finished where it must be, on the whole grid.
        """
        window = self._window_for(state, approach_z, known_displacement) if self.uses_window else None
        self.last_window = None
        self._placed = window
        if window is not None:
            return window.solve(self, state, approach_z, known_displacement, tol, displacement_current)
        return self._solve_whole(state, approach_z, known_displacement, tol, displacement_current)

    def solve_on_window(self, state, approach_z: float, shear_x, shear_y, tol=None) -> SolveInfo | None:
        """A coupled turn's solve on the window of the last ``solve`` alone, placed where it was:
        ``state.pressure`` at ``approach_z`` [m] with the normal displacement K_zt q of the shear
        (``shear_x``, ``shear_y``, scaled, zero outside the contact) held fixed, K_zt q made on the
        window (its transforms, not the whole grid's). The pressure is put back (zero outside the
        window) and not judged on the whole grid: ``state.disp_z`` and ``state.gap`` are left as
        they were, and the caller's next ``solve`` (displacement not current) judges the answer.
        Exact where the contact stays inside the window (the window holds the contact's box and
        a margin; the shear lies inside the contact). None where the last solve ran on the whole
        grid (then nothing is solved)."""
        window = self._placed
        if window is None:
            return None
        self.last_window = window.cells
        return window.solve_alone(self, state, approach_z, shear_x, shear_y, tol)

    @property
    def uses_window(self) -> bool:
        """Whether solves may run on a window (``settings.window``; "auto": from
        ``NORMAL_WINDOW_AUTO_N`` cells per side on)."""
        return window_enabled(self.settings.window, self.model, NORMAL_WINDOW_AUTO_N)

    def _window_for(self, state, approach_z: float, known):
        """The window of a solve from ``state.pressure`` at ``approach_z`` [m]: the bounding box of
        the cells where it is positive or that the approach closes with the displacements held
        (``state.disp_z`` and ``known``; ``kernels/grids.py``, ``closing_box``), widened by
        ``WINDOW_MARGIN`` of its extent (at least 4 cells) on every side,
        in the smallest window that holds it (``window_cells``); None where no cell is in contact
        or closed, or the window would be over ``WINDOW_MAX_SHARE`` of the grid or not fit. One
        read of the device."""
        m = self.model
        n = m.grid.n
        box = self._box
        box.assign(np.array([n, -1, n, -1], dtype=np.int32))
        known = self.no_displacement if known is None else known
        approach = m.scalar(m.np_dtype(approach_z / m.length_scale))  # as the kernels see it
        wp.launch(gk.closing_box, dim=(-(-n // int(gk.SUPPORT_ROWS)), n),
                  inputs=[state.pressure, m.initial_gap, state.disp_z, known, approach], outputs=[box], device=m.device)
        first_row, last_row, first_col, last_col = (int(v) for v in box.numpy())
        if last_row < 0:
            return None
        extent = max(last_row - first_row, last_col - first_col) + 1
        margin = max(4, int(math.ceil(WINDOW_MARGIN * extent)))
        return self._windows.place(first_row - margin, last_row + margin, first_col - margin, last_col + margin,
                                   extent + 2 * margin, lambda model: _NormalWindow(self, model))

    def _solve_whole(self, state, approach_z: float, known_displacement: wp.array | None = None, tol=None,
                     displacement_current: bool = False) -> SolveInfo:
        """``solve`` on the whole grid."""
        m = self.model
        fft = m.operator.fft
        known = self.no_displacement if known_displacement is None else known_displacement
        self._stage(nk.P_APPROACH, float(m.np_dtype(approach_z / m.length_scale)))  # as the kernels see it
        self._stage(nk.P_EXACT, 0.0 if self.settings.one_convolution else 1.0)
        self._begin(tol)
        p, g, t, b = (a.flatten() for a in (state.pressure, state.gap, self.direction, self.interference))
        # the passes of an iteration, as the CPU splits them over its threads (by rows)
        p_rows, g_rows, t_rows, b_rows = (Rows(a) for a in (p, g, t, b))
        output = [Rows(fft.padded_output), fft.output_scale, m.grid.n]
        preconditioned = self.settings.normal_preconditioner
        # the preconditioner's transforms (float32 where settings.preconditioner_float32; none made
        # when the solve is not preconditioned)
        inverse = self.preconditioner_transforms(preconditioned)
        inverse_output = [Rows(inverse.fft.padded_output), inverse.fft.output_scale]

        def displacement():  # state.disp_z <- K p
            m.operator.normal(state.pressure, state.disp_z)

        def start():  # the interference; the first guess when no cell has p > 0 (the device decides); K p
            m.launch(nk.normal_interference, m.n_cells, [m.initial_gap.flatten(), known.flatten(), self.parameters], [b])
            self.guess_sums.zero_()
            m.launch_reduce(nk.count_positive, [p], [self.guess_sums])
            m.launch(nk.guess_needed, 1, [self.guess_sums], [self.guess_flag])
            wp.capture_if(self.guess_flag, on_true=lambda: self._guess(state),
                          on_false=None if displacement_current else displacement)
            self.direction.zero_()  # no leftover from an earlier (possibly failed) solve

        def gap_sums():  # state.gap and the residual sums of p, from state.disp_z = K p
            m.launch_reduce(nk.normal_gap, [Rows(state.disp_z.flatten()), Rows(b), Rows(p), self._cap],
                            [Rows(g), Sums(self.sums)])

        def exact_from_displacement():
            gap_sums()
            self.recompute.zero_()  # state.gap is exact now
            self.deferred.zero_()

        def exact():
            displacement()
            exact_from_displacement()

        def recompute():
            self._current_sums.zero_()
            displacement()
            gap_sums()

        def precondition():  # M g on the free set into the padded output; its G = g . M g into slot S_G
            m.launches.launch_rows(nk.normal_free_gap, m.grid.shape, [g_rows, p_rows, self._cap, m.grid.n],
                                   [Rows(inverse.fft.padded_input)])
            self._preconditioned_g.zero_()
            m.operator.normal_padded(self.sums, nk.S_G, inverse=True, transforms=inverse)

        def body():  # after recompute() where self.recompute is set (the device decides: _run's prelude)
            if preconditioned:
                precondition()
            direction_in = [g_rows, p_rows, self._cap, self.sums, self.scalars,
                            *(inverse_output if preconditioned else output[:2]), int(preconditioned), m.grid.n]
            if self.fourier_step_sums:  # g . t with t, (K t) . t in the spectral product
                m.launches.launch_reduce(nk.normal_direction_sum, self._direction_launch, m.n_cells, direction_in,
                                         [t, fft.padded_input])
                m.operator.normal_padded(self.sums, nk.S_RT)
            else:
                m.launches.launch_rows(nk.normal_direction, m.grid.shape, direction_in, [t_rows, Rows(fft.padded_input)])
                m.operator.normal_padded()
                m.launch_reduce(nk.normal_step_sums, [g_rows, t_rows, *output], [Sums(self.sums)])
            m.launch_reduce(nk.normal_update, [t_rows, *output, b_rows, self._cap, self.parameters],
                            [p_rows, g_rows, Sums(self.sums)])
            m.launch(nk.normal_advance, 1,
                     [self.sums, self.parameters, self.settings.exact_every, self._column_norm,
                      m.scalar(self.settings.deferral)],
                     [self.scalars, self.history, self.deferred, self.recompute, self.loop, self.refresh,
                      self.inner_loop])

        def on_disagreement():  # the carried gap said "converged", the exact one does not
            if self._parameters[nk.P_EXACT] == 0:
                self._stage(nk.P_EXACT, 1.0)  # recompute the gap at every iteration from now on
                self._upload()

        def on_non_finite(it):
            raise_non_finite("normal solve", state, ("pressure", "gap", "disp_z"), it)

        key = (state.pressure.ptr, state.gap.ptr, state.disp_z.ptr, known.ptr, preconditioned, displacement_current,
               self.float32_preconditioner, self.settings.preconditioner_grid)
        return self._run(key, start, exact, body, on_non_finite, on_disagreement, start_exact=exact_from_displacement,
                         prelude=(self.recompute, recompute))

    def _guess(self, state):
        """The first guess of a solve from rest: p = c s, with s = sqrt(max(b - b_max / 2, 0)),
        b = max(delta_z - h0 - u_known, 0) the rigid interference, and c the least-squares fit
        of K p to b on the support of s, capped at the hardness. For a paraboloid s is the Hertz
        pressure's shape on the Hertz contact area (an elastic contact closes half the rigid
        interference), so a Hertz solve starts near its answer: 52 iterations at n = 256, 74 at
        512, 87 at 1024 (CPU), against 125, 127 and 153 from the guess c b, whose support is
        twice the contact area. On the device (``guess_sums`` zeroed before).

        Leaves K p in ``state.disp_z``: c K s, from the convolution the fit made, so a solve from
        rest makes its first exact gap without a convolution of its own; with a finite cap, which
        c s may reach, a convolution of p."""
        m = self.model
        p, b = state.pressure.flatten(), self.interference.flatten()
        m.launch_reduce(nk.guess_max_interference, [b], [self.guess_sums])
        m.launch(nk.guess_shape, m.n_cells, [b, self.guess_sums], [p])
        m.operator.normal(state.pressure, self.response)
        m.launch_reduce(nk.guess_fit_sums, [b, p, self.response.flatten()], [self.guess_sums])
        m.launch(nk.guess_scale, m.n_cells, [self.guess_sums, self._cap, self.response.flatten()],
                 [p, state.disp_z.flatten()])
        if math.isfinite(self.pressure_cap):
            m.operator.normal(state.pressure, state.disp_z)


class _NormalWindow:
    """A square window of a normal solver's grid (``SolverSettings.window``): a solver on the
    window's model (``ContactModel.window_model``) and the fields of a solve, cut out of the whole
    grid's at ``(row0, col0)``.

    A solve there is the whole grid's problem restricted to the window, the pressure outside it
    held at zero: exact where the contact stays inside the window. Its pressure is put back
    (zero outside) and the whole grid's solve goes on from it: K p on the whole grid (one
    convolution of it), the gap and the residual over every cell, and iterations only where they
    miss the tolerance (a contact grown past the window, or rounding at the tolerance's edge).
    A step's solves then make one transform pair of the whole grid each instead of their every
    iteration's two and their exact gaps'."""

    def __init__(self, parent: NormalSolver, model):
        self.cells = model.grid.n
        self.row0 = self.col0 = 0
        self.solver = NormalSolver(model, replace(parent.settings, tol=parent.tol, window=False),
                                   pressure_cap=parent.pressure_cap)
        f = model.field
        # the state the window's solve works on (the attributes of ContactState it reads and writes)
        self.pressure, self.disp_z, self.gap, self.known = f(), f(), f(), f()
        self._shear = None
        #: the window's ``disp_z`` is K p of its pressure, which is the state's pressure cut out:
        #: its last solve was ``solve_alone`` (a judged solve may move the pressure on the whole grid)
        self.current = False

    @property
    def shear(self):
        """The shear cut out for its normal displacement (``solve_alone``; made when first needed)."""
        if self._shear is None:
            self._shear = (self.solver.model.field(), self.solver.model.field())
        return self._shear

    def solve(self, parent: NormalSolver, state, approach_z, known, tol, displacement_current) -> SolveInfo:
        """``parent.solve`` on the window, then on the whole grid from its pressure."""
        pairs = [(state.pressure, self.pressure), (parent.model.initial_gap, self.solver.model.initial_gap)]
        if known is not None:
            pairs.append((known, self.known))
        if displacement_current:  # K p cut out is the window's K p: the pressure is inside it
            pairs.append((state.disp_z, self.disp_z))
        Windows.transfer(self, gk.crop, pairs)
        inner = self.solver.solve(self, approach_z, None if known is None else self.known, tol, displacement_current)
        state.pressure.zero_()
        Windows.transfer(self, gk.embed, [(self.pressure, state.pressure)])
        whole = parent._solve_whole(state, approach_z, known, tol)
        parent.last_window = self.cells
        self.current = False
        # the residual the solve started from first (``turns.starting_residual``), the whole grid's last
        history = (inner.history if inner.iterations else []) + (whole.history if whole.iterations else [])
        return SolveInfo(converged=whole.converged, iterations=inner.iterations + whole.iterations,
                         residual=whole.residual, history=history)

    def solve_alone(self, parent: NormalSolver, state, approach_z, shear_x, shear_y, tol) -> SolveInfo:
        """``NormalSolver.solve_on_window`` on this window as it is placed: the pressure, the
        gap before deformation and the shear cut out, K_zt q of the shear made here as the known
        displacement, solved, the pressure put back. K p on the window is the last solve's where
        that was this one's (``current``): the turns after the second make no convolution of it."""
        solver = self.solver
        shear = self.shear
        Windows.transfer(self, gk.crop, [(state.pressure, self.pressure),
                                         (parent.model.initial_gap, solver.model.initial_gap),
                                         (shear_x, shear[0]), (shear_y, shear[1])])
        solver.model.operator.cross_normal(shear[0], shear[1], self.known)
        info = solver.solve(self, approach_z, self.known, tol, displacement_current=self.current)
        self.current = True
        state.pressure.zero_()
        Windows.transfer(self, gk.embed, [(self.pressure, state.pressure)])
        return info

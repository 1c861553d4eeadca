"""The adhesive normal problem solved as one problem: energy minimisation over the displacement.

The adhesive tractions are not lagged: elastic energy and the law's potential are minimised
together, with non-penetration as a bound (kernels/adhesive.py states the problem).
"""

from __future__ import annotations

import contextlib
import math

import numpy as np
import warp as wp

from warpcontact.kernels import adhesive as ak
from warpcontact.kernels import reduce as rk

from .. import interrupts
from ..numerics.launch import ReductionLaunch, products
from ..numerics.state import SolveInfo

#: L-BFGS pairs kept: the fewest FFT pairs per state on the Maugis-Dugdale curves (docs/model.md)
MEMORY = 5
#: sufficient decrease of the line search (Armijo)
ARMIJO = 1e-4
#: halvings of a trial step before the iteration gives up on its direction
MAX_HALVINGS = 40
#: Hager & Zhang's approximate Wolfe conditions (CG_DESCENT, SIAM J. Optim. 2005), used where the
#: energy can no longer tell a decrease (a change within APPROX_ENERGY of |E|: near the solution an
#: energy change ~ |g|^2 falls below the energy's round-off at a relative gradient of ~sqrt(eps)):
#: the slope at the trial point decides, sigma phi'(0) <= phi'(a) <= (2 delta - 1) phi'(0).
APPROX_ENERGY = 1e-6
WOLFE_DELTA = 0.1
WOLFE_SIGMA = 0.9
#: fields of the padded grid besides the L-BFGS pairs: displacement, traction, gradient,
#: direction, its traction, work, and the trial point's three
PADDED_FIELDS = 9
#: iterations between exact recomputations of p = C^-1 u (the carried p gathers rounding)
EXACT_EVERY = 50


def default_adhesive_tolerance(dtype) -> float:
    """Relative projected gradient to reach: 1e-8 in float64, 1e-4 in float32 (float32's sums of
    the gradient over 4 n^2 entries round at about 1e-6 of the traction's norm)."""
    return 1e-8 if dtype == wp.float64 else 1e-4


class PaddedConvolution:
    """The circulant C of the DC-FFT operator K_zz on the padded (2 n, 2 n) grid, and its inverse,
    applied to whole padded fields (no zero padding assumed): real-to-complex transforms from the
    FFT library of the device (scipy.fft with worker threads on the CPU, cuFFT through CuPy on
    CUDA), the product with K_zz's spectrum between them. K_zz's spectrum is the operator's own
    where its backend keeps the (2 n, n + 1) real-to-complex layout (scipy, fftw, cupy), else it
    is made once here."""

    def __init__(self, model):
        self.model = model
        n = model.grid.n
        self.shape = (2 * n, 2 * n)
        op = model.operator
        device = model.device
        if device.is_cuda:
            try:
                import cupy
            except ImportError as e:  # pragma: no cover - CUDA without CuPy
                from ..errors import InputError

                raise InputError("adhesion", "the adhesive solver on CUDA needs CuPy: pip install "
                                             "'warpcontact[gpu]'") from e
            self._xp = cupy
            self._fft = cupy.fft
            self._kwargs = {}
            # CuPy works on its current device, which need not be the model's on a host of several
            # GPUs: its arrays would be made on another GPU and read by Warp's kernels on this one
            # (seen on two H200s: CUDA error 700, an illegal address, at the next launch)
            self._on_device = lambda: cupy.cuda.Device(device.ordinal)
        else:
            import scipy.fft

            from ..fft.base import cpu_threads
            from ..fft.scipy_backend import ScipyFFT

            self._xp = np
            self._fft = scipy.fft
            self._on_device = contextlib.nullcontext
            # the (2n, 2n) transforms are a ScipyFFT pair's work: threads from the same size on
            self._kwargs = {"workers": cpu_threads(n * n, ScipyFFT.THREADS_FROM_CELLS)}
        fft = op.fft
        with self._on_device():
            if fft.spectral_shape == (2 * n, n + 1) and fft.half_axis == 1:
                spectrum = self._view(op.influence[0])  # K_zz's (real) spectrum
            else:  # the warp backend's layout: made once on the host
                from ..physics.influence import influence_coefficients

                coeffs = influence_coefficients(model.pair, n, n, model.grid.dx, model.grid.dy)["zz"]
                coeffs *= model.pair.E_star / model.grid.dx
                spectrum = self._xp.asarray(np.fft.rfft2(coeffs).real.astype(model.np_dtype))
            self._spectrum = spectrum
            self._inverse_spectrum = 1.0 / spectrum

    def _view(self, a: wp.array):
        """A zero-copy view of a Warp array in the library's array type."""
        if self.model.device.is_cuda:
            return self._xp.from_dlpack(wp.to_dlpack(a))
        return a.numpy()

    def apply(self, source: wp.array, out: wp.array, inverse: bool = False):
        """out <- C source (or C^-1 source), both flat padded fields of 4 n^2 entries."""
        with self._on_device():
            x = self._view(source).reshape(self.shape)
            spectrum = self._fft.rfft2(x, **self._kwargs)
            spectrum *= self._inverse_spectrum if inverse else self._spectrum
            y = self._fft.irfft2(spectrum, s=self.shape, **self._kwargs)
            self._view(out).reshape(self.shape)[...] = y


class AdhesiveNormalSolver:
    """Normal contact with an adhesion law as one energy minimisation.

    The unknown is the normal displacement u on the padded grid of the DC-FFT operator; the
    energy E(u) = 1/2 u . C^-1 u + sum phi(h) (elastic energy on the padded circulant, whose
    stationarity on the padding is the DC-FFT's zero traction there, plus the law's potential on
    the physical cells) is minimised under the bound h = h0 - delta_z + u_known + u >= 0, as the
    Adhesion package minimises its energy with a bounded quasi-Newton method (Pastewka & Robbins,
    PNAS 111 (2014) 3298; L-BFGS-B: Byrd, Lu, Nocedal & Zhu, SIAM J. Sci. Comput. 16 (1995) 1190).
    Every law with a potential fits: SMC at the cell's fixed tangential opening, Dugdale with
    ramps, exponential, Lennard-Jones 9-3 (``warpcontact.physics.adhesion``). A local minimum is a stable
    equilibrium: along a path each state continues the last one's branch, and where that branch
    ends (jump into or out of contact) the minimisation moves to the next stable one, as the
    physical system does under displacement control.

    The iteration: projected L-BFGS (``MEMORY`` pairs) whose initial inverse Hessian is the
    compliance C (the preconditioner: it maps the gradient, a traction, to a displacement;
    the normal solver's circulant preconditioner, inverted) scaled on both sides by
    J^-1/2, J = 1 + max(k, 0) c0 on each physical cell (k: the law's stiffness at the cell's gap,
    c0: a cell's self-compliance; a law much stiffer than the elastic half-space there otherwise
    dominates the curvature; J^-1/2 C J^-1/2 is symmetric positive definite), restricted to the
    free cells: those not held at the bound (touching, h <= eps, with the gradient pushing
    into the contact; eps = min(5e-3 l, 10 r l) with l the law's length and r the current
    residual: an epsilon-active set). A backtracking line search on the energy (Armijo) along the
    projected path; C^-1 d is made once per iteration (one transform pair), so that the trial
    tractions are p + step C^-1 d without another transform unless a trial step meets the bound.

    Convergence: the projected gradient's 2-norm (the traction misfit p + t(h) on free cells)
    relative to the 2-norm of the traction on the physical cells falls under ``tol``; that norm
    counts as at least one cell at the law's peak tension, so that a state out of contact (a
    traction far below the law's, whose relative misfit the energy's round-off stops near 1e-7)
    is held to a misfit of ``tol`` times one cell's peak tension, not ``tol`` of its own
    vanishing traction.

    Args:
        model: the contact model.
        law: an adhesion law with ``normal_law(model)`` (``warpcontact.physics.adhesion``).
        tol: relative projected gradient (default :func:`default_adhesive_tolerance`).
        max_iter: iteration limit of a solve.
        memory: L-BFGS pairs.
    """

    def __init__(self, model, law, tol=None, max_iter: int = 5000, memory: int = MEMORY):
        self.model = model
        self.law = law
        self.tol = default_adhesive_tolerance(model.dtype) if tol is None else float(tol)
        self.max_iter = int(max_iter)
        self.memory = int(memory)
        n = model.grid.n
        self.n_padded = 4 * n * n
        self.convolution = PaddedConvolution(model)
        z = lambda: wp.zeros(self.n_padded, dtype=model.dtype, device=model.device)  # noqa: E731
        #: displacement u, its traction p = C^-1 u, the gradient of the energy (padded grid)
        self.displacement, self.traction, self.gradient = z(), z(), z()
        self.direction, self.direction_traction, self.work = z(), z(), z()
        self.trial_displacement, self.trial_traction, self.trial_gradient = z(), z(), z()
        self.steps = [z() for _ in range(self.memory)]
        self.gradient_changes = [z() for _ in range(self.memory)]
        self.offset = model.field()
        self.opening_t = model.field()
        self.no_displacement = model.field()
        self.sums = model.scalars(ak.N_SUMS)
        #: the two-loop recursion's dot products (s_k . q in slot k, y_k . d in slot memory + k)
        #: and each stored pair's 1 / (s . y) (by storage slot): on the device, so that a direction
        #: costs no read on the host (on a GPU each read is a synchronisation; docs/performance.md
        #: gives the reads per iteration)
        self.two_loop_dots = model.scalars(2 * self.memory)
        self.rho = model.scalars(self.memory)
        self._reduction = ReductionLaunch.for_cells(self.n_padded, model.device)
        self._self_compliance = model.scalar(model.operator.self_coefficient("zz"))
        self.law_id, params, self.law_length = law.normal_law(model)
        #: the residual's smallest traction scale: one cell at the law's peak tension (scaled)
        self.traction_floor = law.peak_tension / model.traction_scale
        self._params = [model.scalar(v) for v in params]

    # -- device work -------------------------------------------------------------------------

    def _reduce(self, kernel, inputs, outputs):
        self.model.launches.launch_reduce(kernel, self._reduction, self.n_padded, inputs, outputs)

    def _launch(self, kernel, dim, inputs, outputs=()):
        self.model.launch(kernel, dim, inputs, outputs)

    def _sums(self) -> np.ndarray:
        return self.sums.numpy().astype(np.float64)

    def _evaluate(self, displacement, traction, gradient, eps: float) -> np.ndarray:
        """The gradient and sums (energy, projected gradient, traction, force) at a point."""
        self.sums.zero_()
        self._add_evaluation(displacement, traction, gradient, eps)
        return self._sums()

    def _add_evaluation(self, displacement, traction, gradient, eps: float):
        """The gradient at a point, its sums added into ``self.sums`` (not read)."""
        m = self.model
        self._reduce(ak.adhesive_evaluate,
                     [displacement, traction, self.offset.flatten(), self.opening_t.flatten(), self.law_id,
                      *self._params, m.scalar(eps), m.grid.n], [gradient, self.sums])

    def _add_trial(self, step: float) -> np.ndarray:
        """The trial point at ``step`` along the direction, its sums added into ``self.sums``;
        returns them (read)."""
        m = self.model
        self._reduce(ak.adhesive_trial,
                     [self.displacement, self.traction, self.gradient, self.direction, self.direction_traction,
                      self.offset.flatten(), self.opening_t.flatten(), self.law_id, *self._params,
                      m.scalar(step), m.grid.n],
                     [self.trial_displacement, self.trial_traction, self.sums])
        return self._sums()

    def _dot(self, x, y) -> float:
        self.sums.zero_()
        self._reduce(rk.sums_of_products, products((x, y, ak.S_DOT)), [self.sums])
        return float(self._sums()[ak.S_DOT])

    def _direction(self, pairs, eps: float):
        """self.direction <- -H g: the two-loop recursion over the kept (s, y) pairs (``pairs``:
        their storage slots, oldest first) with the preconditioner as initial inverse Hessian, on
        the free cells. The recursion's scalars stay on the device (``two_loop_dots``, ``rho``)."""
        m = self.model
        q = self.work
        wp.copy(q, self.gradient)
        dots = self.two_loop_dots
        newest_first = list(reversed(pairs))
        if pairs:
            dots.zero_()
        for k, slot in enumerate(newest_first):  # alpha_k = rho_k s_k . q; q <- q - alpha_k y_k
            self._reduce(rk.sums_of_products, products((self.steps[slot], q, k)), [dots])
            self._launch(ak.two_loop_first, self.n_padded, [dots, k, self.rho, slot, self.gradient_changes[slot]], [q])
        free_in = [self.displacement, self.gradient, self.offset.flatten(), m.scalar(eps), m.grid.n]
        scale_in = [self.displacement, self.gradient, self.offset.flatten(), self.opening_t.flatten(), self.law_id,
                    *self._params, m.scalar(eps), self._self_compliance, m.grid.n]
        self._launch(ak.adhesive_scale, self.n_padded, scale_in, [q])  # J^-1/2, 0 on bound cells
        self.convolution.apply(q, self.direction)
        self._launch(ak.adhesive_scale, self.n_padded, scale_in, [self.direction])
        for k in reversed(range(len(newest_first))):  # oldest first: d <- d + (alpha_k - rho_k y_k . d) s_k
            slot = newest_first[k]
            self._reduce(rk.sums_of_products, products((self.gradient_changes[slot], self.direction, self.memory + k)),
                         [dots])
            self._launch(ak.two_loop_second, self.n_padded,
                         [dots, k, self.memory, self.rho, slot, self.steps[slot]], [self.direction])
        self._launch(ak.adhesive_free, self.n_padded, free_in, [self.direction])
        self._launch(ak.scaled_copy, self.n_padded, [m.scalar(-1.0), self.direction], [self.direction])

    # -- the solve ---------------------------------------------------------------------------

    def solve(self, state, approach_z: float, known_displacement: wp.array | None = None, tol=None,
              warm: bool = False) -> SolveInfo:
        """Solve for the total normal traction of ``state`` at the rigid approach ``approach_z`` [m].

        Starts from the state's tractions (pressure + adhesive_pressure: their displacement C p)
        and fills ``state.pressure`` (contact part, >= 0 where h = 0), ``state.adhesive_pressure``
        (-t(h)), ``state.gap`` and ``state.disp_z`` (the displacement of the total normal
        traction). ``known_displacement`` (scaled) is a normal displacement of other tractions
        held fixed (the shear's coupling). The SMC law's tangential opening comes from the state's
        slip. ``warm``: start from this solver's last displacement instead (the state's tractions
        are the ones its last solve wrote: the turns of a coupled step), which saves a transform
        pair."""
        m = self.model
        n = m.grid.n
        tol = self.tol if tol is None else float(tol)
        known = self.no_displacement if known_displacement is None else known_displacement
        self._launch(ak.adhesive_offset, m.n_cells,
                     [m.initial_gap.flatten(), known.flatten(), m.scalar(approach_z / m.length_scale)],
                     [self.offset.flatten()])
        self.law.tangential_opening(m, state, self.opening_t)
        # start: u = C (p_c + p_adh) of the state (or the last solve's u), projected onto the bound
        if not warm:
            self.work.zero_()
            self._launch(ak.adhesive_start, m.n_cells,
                         [state.pressure.flatten(), state.adhesive_pressure.flatten(), n], [self.work])
            self.convolution.apply(self.work, self.displacement)
        self._launch(ak.project_to_bound, m.n_cells, [self.displacement, self.offset.flatten(),
                                                       state.pressure.flatten(), n])
        self.convolution.apply(self.displacement, self.traction, inverse=True)
        eps_max = 5e-3 * self.law_length
        eps = eps_max
        sums = self._evaluate(self.displacement, self.traction, self.gradient, eps)
        pairs = []  # storage slots of the kept (s, y) pairs, oldest first (self.steps, self.gradient_changes)
        history = []
        residual = math.inf
        converged = False
        it = 0
        transforms = 3
        while True:
            scale = max(math.sqrt(sums[ak.S_TRACTION]), self.traction_floor)
            residual = math.sqrt(sums[ak.S_PG]) / scale
            if not math.isfinite(residual):
                from ..errors import NonFiniteError

                raise NonFiniteError(f"adhesive solve: non-finite residual at iteration {it}")
            history.append(residual)
            if residual < tol:
                converged = True
                break
            if it >= self.max_iter:
                break
            if it % 16 == 0:
                interrupts.check()
            it += 1
            new_eps = min(eps_max, 10.0 * residual * self.law_length)
            if new_eps != eps:  # the free set with the new epsilon
                eps = new_eps
                sums = self._evaluate(self.displacement, self.traction, self.gradient, eps)
            descent = False
            for _ in range(2):  # the direction, and the first trial (step 1) read with its slope g . d
                self._direction(pairs, eps)
                self.convolution.apply(self.direction, self.direction_traction, inverse=True)
                transforms += 2
                self.sums.zero_()
                self._reduce(rk.sums_of_products, products((self.gradient, self.direction, ak.S_DOT)), [self.sums])
                t = self._add_trial(1.0)
                descent = t[ak.S_DOT] < 0
                if descent or not pairs:
                    break
                pairs.clear()  # not a descent direction: forget the pairs, precondition alone
            if not descent:
                break
            step = 1.0
            accepted = False
            trial_sums = None
            energy_noise = APPROX_ENERGY * abs(sums[ak.S_ENERGY])
            for halving in range(MAX_HALVINGS):
                if halving > 0:
                    self.sums.zero_()
                    t = self._add_trial(step)
                if t[ak.S_CLIPPED] > 0:  # the bound bent the path: the trial traction made exactly
                    self.convolution.apply(self.trial_displacement, self.trial_traction, inverse=True)
                    transforms += 1
                    change = self._energy_change()
                else:
                    change = t[ak.S_ENERGY]
                if change <= ARMIJO * t[ak.S_SLOPE] or (change <= 0 and step < 1e-6):
                    accepted = True
                    break
                if abs(change) <= energy_noise and t[ak.S_SLOPE] < 0:  # the energy cannot tell: the slope
                    trial_sums = self._evaluate(self.trial_displacement, self.trial_traction, self.trial_gradient, eps)
                    self._launch(ak.difference, self.n_padded, [self.trial_displacement, self.displacement],
                                 [self.work])
                    trial_slope = self._dot(self.trial_gradient, self.work)
                    if WOLFE_SIGMA * t[ak.S_SLOPE] <= trial_slope <= (2.0 * WOLFE_DELTA - 1.0) * t[ak.S_SLOPE]:
                        accepted = True
                        break
                    trial_sums = None
                step *= 0.5
            if not accepted:
                pairs.clear()
                if len(history) > 1 and step < 1e-9:
                    break
                continue
            # the new pair (s, y) in the oldest slot, its sums read with the trial point's
            evaluate = trial_sums is None
            self.sums.zero_()
            if evaluate:
                self._add_evaluation(self.trial_displacement, self.trial_traction, self.trial_gradient, eps)
            slot = it % self.memory
            self._launch(ak.difference, self.n_padded, [self.trial_displacement, self.displacement], [self.steps[slot]])
            self._launch(ak.difference, self.n_padded, [self.trial_gradient, self.gradient],
                         [self.gradient_changes[slot]])
            s, y = self.steps[slot], self.gradient_changes[slot]
            self._reduce(rk.sums_of_products, products((s, y, ak.S_SY), (s, s, ak.S_SS), (y, y, ak.S_YY)), [self.sums])
            read = self._sums()
            if evaluate:
                trial_sums = read
            pairs = [k for k in pairs if k != slot]
            if read[ak.S_SY] > 1e-12 * math.sqrt(read[ak.S_SS] * read[ak.S_YY]):
                self._launch(ak.pair_curvature, 1, [self.sums, m.scalar(1.0), slot], [self.rho])
                pairs.append(slot)
                pairs = pairs[-self.memory:]
            self.displacement, self.trial_displacement = self.trial_displacement, self.displacement
            self.traction, self.trial_traction = self.trial_traction, self.traction
            self.gradient, self.trial_gradient = self.trial_gradient, self.gradient
            sums = trial_sums
            if it % EXACT_EVERY == 0:  # the carried traction made exact again
                self.convolution.apply(self.displacement, self.traction, inverse=True)
                transforms += 1
                sums = self._evaluate(self.displacement, self.traction, self.gradient, eps)
        self._launch(ak.adhesive_state, m.n_cells,
                     [self.displacement, self.traction, self.offset.flatten(), self.opening_t.flatten(), self.law_id,
                      *self._params, n],
                     [state.pressure.flatten(), state.adhesive_pressure.flatten(), state.gap.flatten(),
                      state.disp_z.flatten()])
        self.transforms = transforms
        return SolveInfo(converged=converged, iterations=it, residual=float(residual), history=history)

    def _energy_change(self) -> float:
        """The energy change from the current point to the trial one (after an exact trial
        traction)."""
        m = self.model
        self.sums.zero_()
        self._reduce(ak.adhesive_change,
                     [self.displacement, self.traction, self.trial_displacement, self.trial_traction,
                      self.offset.flatten(), self.opening_t.flatten(), self.law_id, *self._params, m.grid.n],
                     [self.sums])
        return float(self._sums()[ak.S_ENERGY])

"""The DC-FFT convolutions of B cases of one grid size at once: batched transforms.

Each case's field is an (n, n) slice of a (B, n, n) Warp array the batched kernels write
(``kernels/normal_batch.py``), zero-padded to (2 n, 2 n): transformed, one spectral product, and
back, keeping the n rows and n columns of the result, into a second (B, n, n) array the kernels
read. The library does the batching. On the CPU ``scipy.fft`` (its ``workers`` threads) transforms
the rows of the n data rows, then the columns, so the zero padding is never transformed (as the
single-case backends prune it: ``warpcontact.fft``). On CUDA cuFFT's batched 2-D plans of the
padded grids are called directly (``cupy_backend.BatchedPlans``) on Warp's stream
(``cupy.cuda.ExternalStream``), CuPy arrays sharing the buffers without a copy (DLPack) for the
padding, the products and the cropping: on a batch of small grids the host's time per call is what
a batched step spends, and CuPy's own FFT functions (plan look-up, padded copies) took the most of
it (docs/performance.md, "Many cases with friction solved together").

In the model's scaled units (tractions / E*, lengths / the cell size) the normal influence
coefficients of a square grid depend on n alone (K_zz = (1 - nu_1^2) / E_1 + (1 - nu_2^2) / E_2
is 1 / E*), so one spectrum serves cases of any materials and cell sizes
(``BatchConvolution``); the tangential and coupling blocks depend on the pair (its A E*, B E*,
D E*), so each case has its pair's (``BatchElasticOperator``, one spectrum for the rows that
share a pair).
"""

from __future__ import annotations

import contextlib
import functools

import numpy as np
import warp as wp

from ..errors import InputError


@functools.lru_cache(maxsize=8)
def normal_influence(n: int) -> tuple[np.ndarray, float]:
    """The scaled normal influence coefficients of an n x n grid of square cells: their real
    spectrum (2 n, n + 1) on the (2 n, 2 n) padded grid, ``numpy.fft.rfft2``'s layout, float64
    (K_zz is even: its spectrum is real), and the 2-norm of one column of K (the bound
    ||K c||_2 <= norm ||c||_1 of ``ElasticOperator.column_norm``)."""
    from ..physics.influence import influence_coefficients
    from ..physics.materials import Material, MaterialPair

    unit = Material(E=2.0, nu=0.0)  # two of them: E* = 1, so with dx = 1 the coefficients are scaled ones
    coefficients = influence_coefficients(MaterialPair(unit, unit), n, n, 1.0, 1.0)["zz"]
    return np.fft.rfft2(coefficients).real, float(np.linalg.norm(coefficients))


class BatchLibrary:
    """The FFT library of batched transforms on one Warp device: ``scipy.fft`` with all its
    ``workers`` threads on the CPU, CuPy's cuFFT on CUDA (run on Warp's stream there); ``xp`` the
    array module (numpy or CuPy), ``view`` a Warp array as an ``xp`` array without a copy."""

    def __init__(self, device):
        self.device = wp.get_device(device)
        if self.device.is_cpu:
            import scipy.fft

            self.fft, self.xp, self.workers = scipy.fft, np, {"workers": -1}
            self._stream = self._plans = None
            return
        from . import OPTIONAL, cupy_backend

        if not cupy_backend.available():
            raise InputError("solver.fft", "batched solves on CUDA transform through CuPy's cuFFT: "
                             + OPTIONAL["cupy"])
        import cupy
        import cupy.fft

        self.fft, self.xp, self.workers = cupy.fft, cupy, {}
        self._cuda_device = cupy.cuda.Device(self.device.ordinal)
        stream = wp.get_stream(self.device).cuda_stream
        self._stream = cupy.cuda.ExternalStream(stream, self.device.ordinal)
        #: the solves' transforms: cuFFT's 2-D plans of the padded grids, called directly
        self._plans = cupy_backend.BatchedPlans(stream)

    def forward(self, fields):
        """The spectra (B, 2 n, n + 1) of (B, n, n) ``fields``, each zero-padded to (2 n, 2 n). On
        the CPU the rows' real transforms of the n data rows, then the columns' (the padding never
        transformed); on CUDA one batched 2-D transform of the padded grids
        (``cupy_backend.BatchedPlans``: on a batch of small grids the host's time per call is
        what counts, and CuPy's functions take about ten times as much)."""
        n = fields.shape[-1]
        if self._plans is None:
            fft, w = self.fft, self.workers
            rows = fft.rfft(fields, n=2 * n, axis=-1, **w)
            return fft.fft(rows, n=2 * n, axis=-2, **w)
        xp = self.xp
        padded = xp.zeros((fields.shape[0], 2 * n, 2 * n), dtype=fields.dtype)
        padded[:, :n, :n] = fields
        spectrum = xp.empty((fields.shape[0], 2 * n, n + 1), dtype=np.result_type(fields.dtype, np.complex64))
        self._plans.execute(True, padded, spectrum)
        return spectrum

    def inverse(self, spectrum, out):
        """``out`` (B, n, n) <- the first n rows and columns of the inverse of ``spectrum``
        (B, 2 n, n + 1), which it may overwrite."""
        n = out.shape[-1]
        if self._plans is None:
            fft, w = self.fft, self.workers
            rows = fft.ifft(spectrum, axis=-2, **w)[:, :n]  # the n rows kept
            out[...] = fft.irfft(rows, n=2 * n, axis=-1, **w)[:, :, :n]
            return
        xp = self.xp
        padded = xp.empty((spectrum.shape[0], 2 * n, 2 * n), dtype=out.dtype)
        self._plans.execute(False, xp.ascontiguousarray(spectrum), padded)
        xp.multiply(padded[:, :n, :n], out.dtype.type(1.0 / (4 * n * n)), out=out)

    def view(self, a: wp.array):
        """``a`` (on this device) as a numpy or CuPy array sharing its memory."""
        if self._stream is None:
            return a.numpy()
        with self._cuda_device:
            return self.xp.from_dlpack(wp.to_dlpack(a))

    def release(self):
        """On CUDA: hand the blocks CuPy's memory pool keeps after a batched pass (the transforms'
        work arrays, up to a chunk's worth: ``stress_batch.CHUNK_BYTES``) back to the device, so
        that Warp's next allocations (a larger grid's fields) can use them; on the CPU nothing."""
        if self._stream is not None:
            with self._cuda_device:
                self.xp.get_default_memory_pool().free_all_blocks()

    def on_device(self):
        """On CUDA: CuPy's current device and stream made this device and Warp's stream there (a
        GPU other than the first, the work ordered with Warp's kernels); on the CPU nothing."""
        if self._stream is None:
            return contextlib.nullcontext()
        stack = contextlib.ExitStack()
        stack.enter_context(self._cuda_device)
        stack.enter_context(self._stream)
        return stack


class BatchConvolution:
    """K_zz (or its circulant inverse, the preconditioner) on the fields of B cases at once.

    Args:
        n: cells per side of each case's grid.
        batch: cases B.
        device: a Warp device (CPU: scipy.fft; CUDA: CuPy's cuFFT, which must be installed).
        dtype: ``wp.float32`` or ``wp.float64``.
    """

    def __init__(self, n: int, batch: int, device, dtype):
        self.n, self.batch = int(n), int(batch)
        self.device = wp.get_device(device)
        self.dtype = dtype
        shape = (self.batch, self.n, self.n)
        #: each case's field (its zero padding is the transforms')
        self.source = wp.zeros(shape, dtype=dtype, device=self.device)
        #: each case's normalised result
        self.result = wp.zeros(shape, dtype=dtype, device=self.device)
        np_real = np.float64 if dtype == wp.float64 else np.float32
        spectrum, norm = normal_influence(self.n)
        #: the 2-norm of one column of K (scaled units)
        self.column_norm = norm
        inverse = np.where(spectrum > 0.0, 1.0 / np.where(spectrum > 0.0, spectrum, 1.0), 0.0)
        self.library = BatchLibrary(self.device)
        self._input, self._output = self.library.view(self.source), self.library.view(self.result)
        with self.library.on_device():  # the multipliers on the cases' device
            xp = self.library.xp
            self._multipliers = {False: xp.asarray(spectrum.astype(np_real)),
                                 True: xp.asarray(inverse.astype(np_real))}

    def apply(self, inverse: bool = False):
        """``result`` <- K_zz (``inverse``: its circulant inverse M, 0 where K_zz(k) <= 0) applied
        to every case's ``source``, each zero-padded to (2 n, 2 n) and the result cropped to (n, n)."""
        with self.library.on_device():
            self._apply(inverse)

    def _apply(self, inverse: bool):
        spectrum = self.library.forward(self._input)
        spectrum *= self._multipliers[inverse]
        self.library.inverse(spectrum, self._output)


@functools.lru_cache(maxsize=8)
def tangential_influence(pair, n: int) -> tuple[dict, float]:
    """The scaled tangential and coupling influence spectra of a material pair on an n x n grid
    of square cells, ``numpy.fft.rfft2``'s layout (2 n, n + 1) on the (2 n, 2 n) padded grid:
    "xx", "yy", "xy" real (even kernels), "xz", "yz" complex (i times the imaginary part: kernels
    odd in one axis); with the self-influence 1/2 (K_xx + K_yy)(0). In scaled units
    (tractions / E*, lengths / dx) they depend on the pair's A E*, B E* and D E* alone, not on
    the cell size: they are computed with dx = 1."""
    from ..physics.influence import influence_coefficients

    coefficients = influence_coefficients(pair, n, n, 1.0, 1.0)
    spectra = {}
    for k in ("xx", "yy", "xy", "xz", "yz"):
        a = coefficients[k] * pair.E_star
        spectrum = np.fft.rfft2(a)
        spectra[k] = spectrum.real.copy() if k in ("xx", "yy", "xy") else 1j * spectrum.imag
    stiffness = 0.5 * (coefficients["xx"][0, 0] + coefficients["yy"][0, 0]) * pair.E_star
    return spectra, float(stiffness)


@functools.lru_cache(maxsize=8)
def tangential_inverse_blocks(pair, n: int) -> dict:
    """The tangential solver's preconditioner of a material pair on an n x n grid: per wavenumber
    of the padded grid the inverse of K_tt's 2x2 block [[xx, xy], [xy, yy]]
    (``tangential_influence``'s spectra) with its eigenvalues raised to at least a quarter of
    the self-influence, as ``spectral.tangential_inverse_block`` makes it for one case: "xx",
    "yy", "xy", real, ``numpy.fft.rfft2``'s layout."""
    spectra, stiffness = tangential_influence(pair, n)
    xx, yy, xy = spectra["xx"], spectra["yy"], spectra["xy"]
    floor = 0.25 * stiffness
    mean, diff = 0.5 * (xx + yy), 0.5 * (xx - yy)
    spread = np.sqrt(diff * diff + xy * xy)
    inv_high, inv_low = 1.0 / np.maximum(mean + spread, floor), 1.0 / np.maximum(mean - spread, floor)
    safe = np.where(spread > 0.0, spread, 1.0)
    cos2, sin2 = np.where(spread > 0.0, diff / safe, 1.0), np.where(spread > 0.0, xy / safe, 0.0)
    average, half_gap = 0.5 * (inv_high + inv_low), 0.5 * (inv_high - inv_low)
    return {"xx": average + half_gap * cos2, "yy": average - half_gap * cos2, "xy": half_gap * sin2}


class BatchElasticOperator:
    """The tangential block K_tt and the coupling blocks K_tz, K_zt of B cases at once, each case
    with its own material pair, on (B, n^2) Warp fields (one row a case, row-major cells) viewed
    as (B, n, n) arrays of the batched transforms (``BatchLibrary``).

    Args:
        n: cells per side.
        batch: cases B.
        device: a Warp device.
        dtype: ``wp.float32`` or ``wp.float64``.

    ``set_pairs`` gives each row its pair; rows of one pair share one spectrum (a batch of one
    pair holds one, broadcast over the rows).
    """

    def __init__(self, n: int, batch: int, device, dtype):
        self.n, self.batch = int(n), int(batch)
        self.device = wp.get_device(device)
        self.dtype = dtype
        self.library = BatchLibrary(self.device)
        self._real = np.float64 if dtype == wp.float64 else np.float32
        self._complex = np.complex128 if dtype == wp.float64 else np.complex64
        self._views: dict = {}
        self._spectra: dict = {}
        self._inverse: dict = {}
        self._pairs: tuple = ()

    def set_pairs(self, pairs: list) -> tuple[np.ndarray, np.ndarray]:
        """Give rows 0 .. len(pairs) - 1 the pairs ``pairs`` (the rows after them the last one).
        Returns per row the self-influence of K_tt and whether the pair couples (D != 0)."""
        pairs = list(pairs) + [pairs[-1]] * (self.batch - len(pairs))
        if tuple(pairs) != self._pairs:
            self._pairs = tuple(pairs)
            distinct = list(dict.fromkeys(pairs))
            rows = pairs[:1] if len(distinct) == 1 else pairs
            spectra = [tangential_influence(p, self.n)[0] for p in rows]
            inverses = [tangential_inverse_blocks(p, self.n) for p in rows]
            with self.library.on_device():
                xp = self.library.xp
                self._spectra = {k: xp.asarray(np.stack([s[k] for s in spectra]).astype(
                    self._real if k in ("xx", "yy", "xy") else self._complex)) for k in spectra[0]}
                self._inverse = {k: xp.asarray(np.stack([s[k] for s in inverses]).astype(self._real))
                                 for k in inverses[0]}
        return (np.array([tangential_influence(p, self.n)[1] for p in pairs]),
                np.array([p.D != 0.0 for p in pairs]))

    def _view(self, a: wp.array):
        """A (B, n^2) Warp field, or a (2, B, n^2) pair of them (x and y), as a (B, n, n) or
        (2 B, n, n) numpy or CuPy array sharing its memory (kept)."""
        key = (a.ptr, a.shape)
        view = self._views.get(key)
        if view is None:
            view = self._views[key] = self.library.view(a).reshape(-1, self.n, self.n)
        return view

    def _pair_spectra(self, vector):
        """The spectra (2, B, 2 n, n + 1) of a (2, B, n^2) pair of fields: one batched transform."""
        return self.library.forward(self._view(vector)).reshape(2, self.batch, 2 * self.n, self.n + 1)

    def _to_pair(self, spectra, vector):
        """``vector`` (2, B, n^2) <- the inverse of ``spectra`` (2, B, 2 n, n + 1): one batched transform."""
        self.library.inverse(spectra.reshape(2 * self.batch, 2 * self.n, self.n + 1), self._view(vector))

    def _block_product(self, blocks, vector):
        """The spectra (2, B, 2 n, n + 1) of the symmetric 2x2 ``blocks`` ("xx", "xy", "yy" per
        wavenumber: K_tt or its inverse) applied to the (2, B, n^2) pair ``vector`` (on the
        library's device)."""
        q = self._pair_spectra(vector)
        u = self.library.xp.empty_like(q)
        u[0] = blocks["xx"] * q[0] + blocks["xy"] * q[1]
        u[1] = blocks["xy"] * q[0] + blocks["yy"] * q[1]
        return u

    def tangential(self, shear, disp, pressure=None):
        """``disp`` <- K_tt ``shear`` (each a (2, B, n^2) pair: x, y), plus K_tz ``pressure`` where given."""
        s, lib = self._spectra, self.library
        with lib.on_device():
            u = self._block_product(s, shear)
            if pressure is not None:
                p = lib.forward(self._view(pressure))
                u[0] += s["xz"] * p
                u[1] += s["yz"] * p
            self._to_pair(u, disp)

    def tangential_inverse(self, gradient, out):
        """``out`` <- M ``gradient`` (each a (2, B, n^2) pair: x, y), M each row's circulant
        inverse of K_tt on the padded grid (``tangential_inverse_blocks``): the batched
        tangential solver's preconditioner, applied to g on the stick cells."""
        with self.library.on_device():
            self._to_pair(self._block_product(self._inverse, gradient), out)

    def cross_tangential(self, pressure, disp):
        """``disp`` (a (2, B, n^2) pair) <- K_tz p: the pressure's tangential displacement."""
        s, lib = self._spectra, self.library
        with lib.on_device():
            p = lib.forward(self._view(pressure))
            u = lib.xp.empty((2, *p.shape), dtype=p.dtype)
            u[0] = s["xz"] * p
            u[1] = s["yz"] * p
            self._to_pair(u, disp)

    def cross_normal(self, shear, disp_z):
        """disp_z <- K_zt q of ``shear`` (a (2, B, n^2) pair): the shear's normal displacement
        (K_zt = -K_tz in Fourier space: the kernels are odd)."""
        s, lib = self._spectra, self.library
        with lib.on_device():
            q = self._pair_spectra(shear)
            lib.inverse(-(s["xz"] * q[0] + s["yz"] * q[1]), self._view(disp_z))

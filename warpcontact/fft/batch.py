"""The DC-FFT convolutions of B cases of one grid size at once: batched transforms.

Each case's field is written into the (n, n) corner of its zero-padded (2 n, 2 n) grid (by the
solvers' kernels, or ``kernels/spectral_batch.py``'s ``batch_pad``), transformed, multiplied by its
influence spectrum and transformed back, and the result is read from the corner of a second grid:
buffers made once, kernels launched once for all B cases, nothing allocated in an iteration (one
pass over the spectra a product, where array expressions make a temporary per operation). The
library does the batching. On the CPU ``scipy.fft`` (its ``workers`` threads) transforms the rows
of the n data rows, then the columns, so the zero padding is never transformed (as the single-case
backends prune it: ``warpcontact.fft``). On CUDA cuFFT's batched 2-D plans of the padded grids are
called directly (``cupy_backend.BatchedPlans``) on Warp's stream (``cupy_backend.cupy_stream``), on
the Warp buffers seen as CuPy arrays without a copy (DLPack): on a batch of small grids the host's
time per call is what a batched step spends, and CuPy's own FFT functions (plan look-up, padded
copies) took the most of it (docs/performance.md, "Many cases with friction solved together").

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
import sys

import numpy as np
import warp as wp

from warpcontact.kernels import spectral_batch as sbk

from ..errors import InputError
from ..numerics.launch import LaunchCache


def scaled_influence(pair, n: int, device: str, names: tuple, circulants: tuple = (), scale: float = 1.0) -> dict:
    """Each kernel of ``names`` (``physics.influence.KERNELS``) of ``pair`` on an n x n grid of unit
    cells, times ``scale``: (its spectrum (2 n, n + 1) on the (2 n, 2 n) padded grid,
    ``numpy.fft.rfft2``'s layout, complex; the 2-norm of its coefficients; its coefficient at
    offset (0, 0); for the kernels of ``circulants`` the real spectrum (n, n // 2 + 1) of T. Chan's
    circulant on the grid itself, ``chan_circulant``, else None), as numpy float64 arrays.

    On a CUDA ``device`` (its alias) the coefficients are Warp's (``device_coefficients``) and the
    transforms cuFFT's (CuPy, on Warp's stream), one kernel's arrays on the device at a time and
    only the results read back: the host's numpy path took 0.25 s for the normal spectra and 0.48 s
    for the tangential ones at n = 588 on 2 CPU cores (the largest of Table 2's adhesive grids at
    n = 256), and the batched Table 2 makes them for five grids. On the CPU numpy's."""
    from ..physics.influence import chan_circulant, device_coefficients, influence_coefficients

    device = wp.get_device(device)
    out = {}
    if not device.is_cuda:
        coefficients = influence_coefficients(pair, n, n, 1.0, 1.0)
        for name in names:
            a = coefficients[name] * scale
            circulant = np.fft.rfft2(chan_circulant(a)).real if name in circulants else None
            out[name] = (np.fft.rfft2(a), float(np.linalg.norm(a)), float(a[0, 0]), circulant)
        return out
    import cupy

    from .cupy_backend import cupy_stream

    with cupy.cuda.Device(device.ordinal):
        stream = cupy_stream(wp.get_stream(device))
    with cupy.cuda.Device(device.ordinal), stream:
        # CuPy's plan cache left as it was (its plans' work areas would stay in the memory pool, and an
        # eviction later would leave a free block there)
        cache = cupy.fft.config.get_plan_cache()
        size = cache.get_size()
        cache.set_size(0)
        try:
            for name, a in device_coefficients(pair, n, n, 1.0, 1.0, device, scale=scale):
                if name in names:
                    v = cupy.from_dlpack(wp.to_dlpack(a))
                    circulant = None
                    if name in circulants:
                        circulant = cupy.fft.rfft2(cupy.from_dlpack(wp.to_dlpack(chan_circulant(a)))).real.get()
                    out[name] = (cupy.fft.rfft2(v).get(), float(cupy.linalg.norm(v)), float(v[0, 0]), circulant)
                if len(out) == len(names):
                    break  # the kernels after the last one asked for are not made
        finally:
            cache.set_size(size)
    release_transforms(device)  # the transforms' arrays and work areas back to the device
    return out


@functools.lru_cache(maxsize=8)
def normal_influence(n: int, device: str = "cpu") -> tuple[np.ndarray, float, np.ndarray]:
    """The scaled normal influence coefficients of an n x n grid of square cells: their real
    spectrum (2 n, n + 1) on the (2 n, 2 n) padded grid, ``numpy.fft.rfft2``'s layout, float64
    (K_zz is even: its spectrum is real), the 2-norm of one column of K (the bound
    ||K c||_2 <= norm ||c||_1 of ``ElasticOperator.column_norm``), and the real spectrum (n,
    n // 2 + 1) of T. Chan's circulant of K_zz on the grid itself (``chan_circulant``: the
    preconditioner's, periodic); made on ``device`` (``scaled_influence``)."""
    from ..physics.materials import Material, MaterialPair

    unit = Material(E=2.0, nu=0.0)  # two of them: E* = 1, so with dx = 1 the coefficients are scaled ones
    spectrum, norm, _, circulant = scaled_influence(MaterialPair(unit, unit), n, device, ("zz",), ("zz",))["zz"]
    return spectrum.real.copy(), norm, circulant


class BatchLibrary:
    """The FFT library of batched transforms on one Warp device: on the CPU FFTW's plans through
    pyFFTW where it is installed (half scipy.fft's time on a batch: it transforms in place, where
    scipy.fft returns new arrays), else ``scipy.fft``, with all the CPU's threads; cuFFT's
    batched plans on CUDA (``cupy_backend.BatchedPlans``, run on Warp's stream there); ``xp`` the array module (numpy or CuPy), ``view`` a Warp array as
    an ``xp`` array without a copy.

    The solves' transforms (``forward``, ``inverse``) go between Warp arrays the caller keeps: a
    stack of zero-padded (2 n, 2 n) grids, whose (n, n) corner alone is data, and a stack of their
    (2 n, n + 1) spectra (complex numbers as 2-vectors), so an iteration allocates nothing and its
    products and padding are Warp kernels (``kernels/spectral_batch.py``) launched through
    ``launches``. ``max_plans``: the cuFFT plans kept (``BatchedPlans``; None: every one)."""

    def __init__(self, device, max_plans: int | None = None):
        self.device = wp.get_device(device)
        #: the products', padding's and cropping's launches, recorded once and replayed
        self.launches = LaunchCache(self.device)
        self._views: dict = {}
        if self.device.is_cpu:
            import scipy.fft

            from . import fftw_backend

            self.fft, self.xp, self.workers = scipy.fft, np, {"workers": -1}
            self._stream = self._plans = None
            #: FFTW's plans of the kept buffers (``keep``), by direction and arrays (None: no pyFFTW)
            self._fftw = {} if fftw_backend.available() else None
            return
        from . import OPTIONAL, cupy_backend

        if not cupy_backend.available():
            raise InputError("solver.fft", "batched solves on CUDA transform through CuPy's cuFFT: "
                             + OPTIONAL["cupy"])
        import cupy
        import cupy.fft

        self.fft, self.xp, self.workers = cupy.fft, cupy, {}
        self._cuda_device = cupy.cuda.Device(self.device.ordinal)
        stream = wp.get_stream(self.device)
        with self._cuda_device:
            self._stream = cupy_backend.cupy_stream(stream)
        #: the solves' transforms: cuFFT's 2-D plans of the padded grids, called directly
        self._plans = cupy_backend.BatchedPlans(stream.cuda_stream, max_plans)

    def forward(self, padded: wp.array, spectra: wp.array):
        """``spectra`` (rows, 2 n, n + 1) <- the transforms of the zero-padded grids ``padded``
        (rows, 2 n, 2 n). On the CPU the rows' real transforms of the n data rows, then the
        columns' (the padding never transformed); on CUDA one batched 2-D transform (on a batch
        of small grids the host's time per call is what counts, and CuPy's own functions take
        about ten times as much)."""
        n = padded.shape[-1] // 2
        if self._plans is None:
            plans = self._fftw_plans(padded, spectra, forward=True)
            if plans is not None:
                plans.forward()
                return
            fft, w = self.fft, self.workers
            rows = fft.rfft(self.view(padded)[:, :n, :n], n=2 * n, axis=-1, **w)
            self.complex_view(spectra)[...] = fft.fft(rows, n=2 * n, axis=-2, **w)
            return
        self._plans.execute(True, self.view(padded), self.complex_view(spectra))

    def inverse(self, spectra: wp.array, padded: wp.array):
        """The (n, n) corner of each grid of ``padded`` (rows, 2 n, 2 n) <- the unnormalised inverse
        transform of ``spectra`` (rows, 2 n, n + 1), which it may overwrite (the 1 / (4 n^2) is the
        influence spectra's); the rest of ``padded`` is left undefined."""
        n = padded.shape[-1] // 2
        if self._plans is None:
            plans = self._fftw_plans(padded, spectra, forward=False)
            if plans is not None:
                plans.inverse()
                return
            fft, w = self.fft, self.workers
            columns = fft.ifft(self.complex_view(spectra), axis=-2, norm="forward", **w)[:, :n]  # the n rows kept
            self.view(padded)[:, :n, :n] = fft.irfft(columns, n=2 * n, axis=-1, norm="forward", **w)[:, :, :n]
            return
        self._plans.execute(False, self.complex_view(spectra), self.view(padded))

    def periodic_forward(self, fields: wp.array, n: int, spectra: wp.array):
        """``spectra`` (..., n, n // 2 + 1) <- the transforms of the (n, n) grids themselves,
        periodic, no padding (the preconditioners' circulants: ``fft.make_periodic_fft``), of
        ``fields`` (a contiguous stack of rows of n^2 row-major cells, or of (n, n) grids)."""
        if self._plans is None:
            plans = self._periodic_fftw(fields, n, spectra, forward=True)
            if plans is not None:
                plans.forward()
                return
            self.complex_view(spectra)[...] = self.fft.rfft2(self._grids(fields, n), axes=(-2, -1), **self.workers)
            return
        self._plans.execute(True, self._grids(fields, n), self.complex_view(spectra))

    def periodic_inverse(self, spectra: wp.array, n: int, fields: wp.array):
        """``fields`` (as :meth:`periodic_forward` takes them) <- the unnormalised inverse transforms
        of ``spectra`` (..., n, n // 2 + 1), which it may overwrite."""
        if self._plans is None:
            plans = self._periodic_fftw(fields, n, spectra, forward=False)
            if plans is not None:
                plans.inverse()
                return
            self._grids(fields, n)[...] = self.fft.irfft2(self.complex_view(spectra), s=(n, n), axes=(-2, -1),
                                                          norm="forward", **self.workers)
            return
        self._plans.execute(False, self.complex_view(spectra), self._grids(fields, n))

    def _grids(self, fields: wp.array, n: int):
        """A contiguous stack of fields as an ``xp`` array of (n, n) grids sharing its memory."""
        return self.view(fields).reshape(-1, n, n)

    def _periodic_fftw(self, fields: wp.array, n: int, spectra: wp.array, forward: bool):
        """On the CPU with pyFFTW, FFTW's plans of a periodic pass between ``fields`` and ``spectra``
        (the solvers' buffers: made once, measured or from wisdom,
        ``fftw_backend.PeriodicFFTWPlans.measured``); None without pyFFTW (then ``scipy.fft``)."""
        if self._fftw is None:
            return None
        key = ("periodic", forward, fields.ptr, fields.shape, spectra.ptr, spectra.shape)
        plans = self._fftw.get(key)
        if plans is None:
            from .base import cpu_threads
            from .fftw_backend import FFTWBackend, PeriodicFFTWPlans

            grids, spectrum = self._grids(fields, n), self.complex_view(spectra)
            threads = cpu_threads(grids.shape[0] * n * n // 4, FFTWBackend.THREADS_FROM_CELLS)
            plans = self._fftw[key] = PeriodicFFTWPlans.measured(grids if forward else None, spectrum,
                                                                 None if forward else grids, threads)
        return plans

    def pad(self, fields: wp.array, padded: wp.array):
        """The (n, n) corner of each grid of ``padded`` (rows, 2 n, 2 n) <- the row of ``fields``
        (rows, n^2, row-major cells); the rest of ``padded`` as it was. On the CPU a NumPy copy
        (about five times faster there than a Warp kernel of one thread a cell), on CUDA
        ``batch_pad``."""
        n = padded.shape[-1] // 2
        if self._stream is None:
            self.view(padded)[:, :n, :n] = self.view(fields).reshape(-1, n, n)
            return
        self.launches.launch(sbk.batch_pad, fields.shape, [fields, n], [padded])

    def crop(self, padded: wp.array, fields: wp.array):
        """Each row of ``fields`` (rows, n^2) <- the (n, n) corner of its grid of ``padded``
        (rows, 2 n, 2 n), as :meth:`pad` copies."""
        n = padded.shape[-1] // 2
        if self._stream is None:
            self.view(fields).reshape(-1, n, n)[...] = self.view(padded)[:, :n, :n]
            return
        self.launches.launch(sbk.batch_crop, fields.shape, [padded, n], [fields])

    def _fftw_plans(self, padded: wp.array, spectra: wp.array, forward: bool):
        """On the CPU with pyFFTW, FFTW's plans of a forward (or inverse) pass between two kept
        buffers (``keep``), made on first use (measured, their wisdom kept on disk:
        ``fftw_backend.FFTWPlans.measured``); None for arrays not kept (a temporary's plan would
        cost more than it saves) or without pyFFTW (then ``scipy.fft``)."""
        if self._fftw is None:
            return None
        key = (forward, padded.ptr, padded.shape, spectra.ptr, spectra.shape)
        plans = self._fftw.get(key)
        if plans is None:
            kept = [self._views.get((a.ptr, a.shape, a.dtype)) for a in (padded, spectra)]
            if any(v is None for v in kept):
                return None
            from .base import cpu_threads
            from .fftw_backend import FFTWBackend, FFTWPlans

            n = padded.shape[-1] // 2
            grids = kept[0].reshape(-1, 2 * n, 2 * n)[:, :n, :]  # the data rows of each padded grid
            spectrum = self.complex_view(spectra)
            threads = cpu_threads(grids.shape[0] * n * n, FFTWBackend.THREADS_FROM_CELLS)
            plans = self._fftw[key] = FFTWPlans.measured(grids if forward else None, spectrum,
                                                         None if forward else grids, threads)
        return plans

    def view(self, a: wp.array):
        """``a`` (on this device) as a numpy or CuPy array sharing its memory: the view ``keep``
        made, or a new one."""
        view = self._views.get((a.ptr, a.shape, a.dtype))
        if view is not None:
            return view
        if self._stream is None:
            return a.numpy()
        with self._cuda_device:
            return self.xp.from_dlpack(wp.to_dlpack(a))

    def keep(self, *arrays: wp.array):
        """Make the views of buffers that live as long as the library once (a view holds its
        array: temporaries are viewed at each call, not kept)."""
        for a in arrays:
            self._views[(a.ptr, a.shape, a.dtype)] = self.view(a)

    def complex_view(self, spectra: wp.array):
        """A Warp stack of spectra (..., 2 n, n + 1) of 2-vectors as a complex (rows, 2 n, n + 1)
        ``xp`` array sharing its memory."""
        rows, columns = spectra.shape[-2:]
        v = self.view(spectra)
        return v.view(np.complex128 if v.dtype == np.float64 else np.complex64).reshape(-1, rows, columns)

    def spectral_launch(self, kernel, rows: int, spectra_shape, inputs, outputs=()):
        """A product kernel of ``kernels/spectral_batch.py`` over ``rows`` cases' spectra of
        ``spectra_shape`` (2 n, n + 1): on CUDA one entry a thread, on the CPU a row of spectra a
        thread (``per``, passed after ``inputs``)."""
        length, columns = spectra_shape
        if self.device.is_cpu:
            self.launches.launch(kernel, (rows, length, 1), [*inputs, columns], outputs)
        else:
            self.launches.launch(kernel, (rows, length, columns), [*inputs, 1], outputs)

    def release(self, work: bool = False):
        """On CUDA: hand the blocks CuPy's memory pool keeps after a batched pass back to the
        device, so that Warp's next allocations (a larger grid's fields) can use them; ``work``:
        the transforms' work area too (a library whose transforms no captured graph replays: the
        yield check's); on the CPU nothing."""
        if self._stream is not None:
            if work:
                self._plans.release_work()
            release_transforms(self.device)

    def on_device(self):
        """On CUDA: CuPy's current device and stream made this device and Warp's stream there (a
        GPU other than the first, the work ordered with Warp's kernels); on the CPU nothing."""
        if self._stream is None:
            return contextlib.nullcontext()
        stack = contextlib.ExitStack()
        stack.enter_context(self._cuda_device)
        stack.enter_context(self._stream)
        return stack


def release_transforms(device):
    """On a CUDA ``device``: hand the blocks CuPy's memory pool keeps there (the work areas and
    arrays of batched transforms no longer used) back to the device, so that Warp's next
    allocations can use them; elsewhere nothing."""
    device = wp.get_device(device)
    if device.is_cuda and "cupy" in sys.modules:
        import cupy

        with cupy.cuda.Device(device.ordinal):
            cupy.get_default_memory_pool().free_all_blocks()


def spectra_vector(dtype):
    """The 2-vector type of a stack of spectra of float type ``dtype``."""
    return wp.vec2d if dtype == wp.float64 else wp.vec2f


def _positive_inverse(spectrum: np.ndarray) -> np.ndarray:
    """1 / spectrum where it is positive, 0 elsewhere (a circulant inverse's multipliers)."""
    return np.where(spectrum > 0.0, 1.0 / np.where(spectrum > 0.0, spectrum, 1.0), 0.0)


class BatchConvolution:
    """K_zz (or its circulant inverse, the preconditioner) on the fields of B cases at once.

    Args:
        n: cells per side of each case's grid.
        batch: cases B.
        device: a Warp device (CPU: scipy.fft; CUDA: cuFFT through CuPy, which must be installed).
        dtype: ``wp.float32`` or ``wp.float64``.

    The caller writes each case's field into the (n, n) corner of its zero-padded grid in
    ``source`` (B, 2 n, 2 n) (``kernels/normal_batch.py``'s ``corner``) and reads the result from
    the corner of ``result``; the rest of ``source`` stays zero. The preconditioner runs, where
    ``periodic_preconditioner``, on the (n, n) grids themselves (``inverse_source`` and
    ``inverse_result``, (B, n, n)): T. Chan's circulant of K_zz, transforms of a quarter of the
    entries (``SolverSettings.preconditioner_grid``); else on the padded ones.
    """

    #: the preconditioner on the grids themselves (T. Chan's circulant), else on the padded grids
    periodic_preconditioner = True

    def __init__(self, n: int, batch: int, device, dtype):
        self.n, self.batch = int(n), int(batch)
        self.device = wp.get_device(device)
        self.dtype = dtype
        padded = (self.batch, 2 * self.n, 2 * self.n)
        #: each case's field in the corner of its zero-padded grid
        self.source = wp.zeros(padded, dtype=dtype, device=self.device)
        #: each case's result in the corner of its grid
        self.result = wp.zeros(padded, dtype=dtype, device=self.device)
        self.spectra = wp.zeros((self.batch, 2 * self.n, self.n + 1), dtype=spectra_vector(dtype), device=self.device)
        np_real = np.float64 if dtype == wp.float64 else np.float32
        spectrum, norm, circulant = normal_influence(self.n, self.device.alias)
        #: the 2-norm of one column of K (scaled units)
        self.column_norm = norm
        self.periodic = bool(self.periodic_preconditioner)
        if self.periodic:  # the preconditioner's grids and spectra: (B, n, n), (B, n, n // 2 + 1)
            grids = (self.batch, self.n, self.n)
            self.inverse_source = wp.zeros(grids, dtype=dtype, device=self.device)
            self.inverse_result = wp.zeros(grids, dtype=dtype, device=self.device)
            self._inverse_spectra = wp.zeros((self.batch, self.n, self.n // 2 + 1), dtype=spectra_vector(dtype),
                                             device=self.device)
            inverse = _positive_inverse(circulant)
            inverse_scale = 1.0 / (self.n * self.n)
        else:
            self.inverse_source, self.inverse_result, self._inverse_spectra = self.source, self.result, self.spectra
            inverse = _positive_inverse(spectrum)
            inverse_scale = 1.0 / (4 * self.n * self.n)
        scale = 1.0 / (4 * self.n * self.n)  # the inverse transform's
        self.library = BatchLibrary(self.device)
        self.library.keep(self.source, self.result, self.spectra)
        if self.periodic:
            self.library.keep(self.inverse_source, self.inverse_result, self._inverse_spectra)
        self._multipliers = {False: wp.array((spectrum * scale).astype(np_real)[None], dtype=dtype, device=self.device),
                             True: wp.array((inverse * inverse_scale).astype(np_real)[None], dtype=dtype,
                                            device=self.device)}

    def apply(self, inverse: bool = False):
        """``result`` <- K_zz applied to every case's ``source``, each zero-padded to (2 n, 2 n),
        in the corner of each grid; ``inverse``: ``inverse_result`` <- the preconditioner M (the
        circulant inverse, of T. Chan's circulant on the grid itself where ``periodic``, else of
        the padded grid's, 0 where K_zz(k) <= 0) applied to ``inverse_source``."""
        lib = self.library
        with lib.on_device():
            if inverse and self.periodic:
                lib.periodic_forward(self.inverse_source, self.n, self._inverse_spectra)
            else:
                lib.forward(self.source, self.spectra)
            spectra = self._inverse_spectra if inverse else self.spectra
            lib.spectral_launch(sbk.batch_spectral_scale, self.batch, spectra.shape[1:],
                                [self._multipliers[inverse], spectra])
            if inverse and self.periodic:
                lib.periodic_inverse(self._inverse_spectra, self.n, self.inverse_result)
            else:
                lib.inverse(self.spectra, self.result)


@functools.lru_cache(maxsize=8)
def tangential_influence(pair, n: int, device: str = "cpu") -> tuple[dict, float, float, dict]:
    """The scaled tangential and coupling influence spectra of a material pair on an n x n grid
    of square cells, ``numpy.fft.rfft2``'s layout (2 n, n + 1) on the (2 n, 2 n) padded grid:
    "xx", "yy", "xy" real (even kernels), "xz", "yz" complex (i times the imaginary part: kernels
    odd in one axis); with the self-influence 1/2 (K_xx + K_yy)(0) and the column norm, a bound on
    the 2-norm of the tangential displacements one cell's unit shear (any direction) causes,
    sqrt(|K_xx|^2 + 2 |K_xy|^2 + |K_yy|^2) (``ElasticOperator.tangential_column_norm``); and the
    real spectra (n, n // 2 + 1) of T. Chan's circulants of K_xx, K_yy and K_xy on the grid itself
    (``chan_circulant``: the periodic preconditioner's), from the same coefficients, made on
    ``device`` (``scaled_influence``). In scaled units (tractions / E*, lengths / dx) they depend
    on the pair's A E*, B E* and D E* alone, not on the cell size: they are computed with dx = 1."""
    even = ("xx", "yy", "xy")
    parts = scaled_influence(pair, n, device, even + ("xz", "yz"), even, pair.E_star)
    spectra = {k: parts[k][0].real.copy() if k in even else 1j * parts[k][0].imag for k in parts}
    stiffness = 0.5 * (parts["xx"][2] + parts["yy"][2])
    norms = {k: parts[k][1] for k in even}
    column_norm = np.sqrt(norms["xx"] ** 2 + 2.0 * norms["xy"] ** 2 + norms["yy"] ** 2)
    circulants = {k: parts[k][3] for k in even}
    return spectra, float(stiffness), float(column_norm), circulants


@functools.lru_cache(maxsize=8)
def tangential_inverse_blocks(pair, n: int, periodic: bool = False, device: str = "cpu") -> dict:
    """The tangential solver's preconditioner of a material pair on an n x n grid: per wavenumber
    of the padded grid (``periodic``: of the grid itself, T. Chan's circulants of K_xx, K_yy and
    K_xy, ``chan_circulant``) the inverse of K_tt's 2x2 block [[xx, xy], [xy, yy]] with its
    eigenvalues raised to at least a quarter of the self-influence, as
    ``spectral.tangential_inverse_block`` makes it for one case: "xx", "yy", "xy", real,
    ``numpy.fft.rfft2``'s layout, from ``tangential_influence`` made on ``device``."""
    spectra, stiffness, _, circulants = tangential_influence(pair, n, device)
    if periodic:
        spectra = circulants
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
    with its own material pair, on (B, n^2) Warp fields (one row a case, row-major cells),
    transformed in batches (``BatchLibrary``).

    Args:
        n: cells per side.
        batch: cases B.
        device: a Warp device.
        dtype: ``wp.float32`` or ``wp.float64``.

    ``set_pairs`` gives each row its pair; rows of one pair share one spectrum (a batch of one
    pair holds one, read by every row). A pair (x, y) of fields is one (2, B, n^2) array,
    transformed in one call: padded into ``padded`` (2 B grids), its spectra in ``pair_spectra``
    (2, B, 2 n, n + 1); a pressure's in ``pressure_spectra`` (B, 2 n, n + 1). The preconditioner
    (``tangential_inverse``) runs, where ``periodic_preconditioner``, on the (n, n) grids
    themselves (T. Chan's circulants, spectra (2, B, n, n // 2 + 1)), else on the padded ones.
    """

    #: the preconditioner on the grids themselves (T. Chan's circulants), else on the padded grids
    periodic_preconditioner = True

    def __init__(self, n: int, batch: int, device, dtype):
        self.n, self.batch = int(n), int(batch)
        self.device = wp.get_device(device)
        self.dtype = dtype
        self.library = BatchLibrary(self.device)
        self._real = np.float64 if dtype == wp.float64 else np.float32
        rows, length, columns = 2 * self.batch, 2 * self.n, self.n + 1
        vector = spectra_vector(dtype)
        #: the fields' zero-padded grids (a pair's 2 B; a pressure's the first B), and the inverse
        #: transforms' grids
        self.padded = wp.zeros((rows, length, length), dtype=dtype, device=self.device)
        self.result = wp.zeros((rows, length, length), dtype=dtype, device=self.device)
        self.pair_spectra = wp.zeros((2, self.batch, length, columns), dtype=vector, device=self.device)
        self.pressure_spectra = wp.zeros((self.batch, length, columns), dtype=vector, device=self.device)
        self._padded_pressure, self._result_pressure = self.padded[: self.batch], self.result[: self.batch]
        self.library.keep(self.padded, self.result, self.pair_spectra, self.pressure_spectra, self._padded_pressure,
                          self._result_pressure)
        self.periodic = bool(self.periodic_preconditioner)
        if self.periodic:  # the preconditioner's spectra of the grids themselves
            self.inverse_spectra = wp.zeros((2, self.batch, self.n, self.n // 2 + 1), dtype=vector, device=self.device)
            self.library.keep(self.inverse_spectra)
        self._inverse_fields: set = set()  # the fields tangential_inverse was given (their views kept)
        self._rows: dict = {}  # a (2, B, n^2) pair of fields as (2 B, n^2) rows, by its address
        self._spectra: dict = {}
        self._inverse: dict = {}
        self._pairs: tuple = ()
        self._normal = None  # K_zz's spectrum (``coupled``), made when first needed
        self.column_norms = np.zeros(self.batch)

    def set_pairs(self, pairs: list) -> tuple[np.ndarray, np.ndarray]:
        """Give rows 0 .. len(pairs) - 1 the pairs ``pairs`` (the rows after them the last one).
        Returns per row the self-influence of K_tt and whether the pair couples (D != 0)."""
        pairs = list(pairs) + [pairs[-1]] * (self.batch - len(pairs))
        device = self.device.alias
        influence = [tangential_influence(p, self.n, device) for p in pairs]  # (spectra, stiffness, norm, circulants)
        if tuple(pairs) != self._pairs:
            self._pairs = tuple(pairs)
            distinct = list(dict.fromkeys(pairs))
            rows = pairs[:1] if len(distinct) == 1 else pairs
            scale = 1.0 / (4 * self.n * self.n)  # the inverse transform's
            spectra = [i[0] for i in influence[:len(rows)]]
            inverses = [tangential_inverse_blocks(p, self.n, self.periodic, device) for p in rows]

            def stack(values, part, scale=scale):
                return wp.array((part(np.stack(values)) * scale).astype(self._real), dtype=self.dtype,
                                device=self.device)

            # the coupling blocks are imaginary: their imaginary parts (``kernels/spectral_batch.py``)
            self._spectra = {k: stack([s[k] for s in spectra], np.imag if k in ("xz", "yz") else np.real)
                             for k in spectra[0]}
            inverse_scale = 1.0 / (self.n * self.n) if self.periodic else scale
            self._inverse = {k: stack([s[k] for s in inverses], np.real, inverse_scale) for k in inverses[0]}
            #: each row's bound on ||K_tt c||_2 / ||c||_1 (``tangential_influence``'s column norm)
            self.column_norms = np.array([i[2] for i in influence])
        return (np.array([i[1] for i in influence]),
                np.array([p.D != 0.0 for p in pairs]))

    def _as_rows(self, vector: wp.array) -> wp.array:
        """A (2, B, n^2) pair of fields as (2 B, n^2) rows (kept), or a (B, n^2) field as it is."""
        if vector.ndim == 2:
            return vector
        rows = self._rows.get(vector.ptr)
        if rows is None:
            rows = self._rows[vector.ptr] = vector.reshape((2 * self.batch, self.n * self.n))
        return rows

    def _forward(self, field, pair: bool):
        """The spectra of a (2, B, n^2) pair of fields (``pair``) or a pressure (B, n^2): padded
        and transformed in one batched call."""
        field = self._as_rows(field)
        padded = self.padded if pair else self._padded_pressure
        lib = self.library
        lib.pad(field, padded)
        lib.forward(padded, self.pair_spectra if pair else self.pressure_spectra)

    def _inverse_into(self, field, pair: bool):
        """``field`` (a (2, B, n^2) pair, or (B, n^2)) <- the inverse of the pair's (or the
        pressure's) spectra, cropped."""
        field = self._as_rows(field)
        result = self.result if pair else self._result_pressure
        lib = self.library
        lib.inverse(self.pair_spectra if pair else self.pressure_spectra, result)
        lib.crop(result, field)

    def _apply(self, sources, kernel, inputs, outputs, out, out_pair: bool):
        """The spectra of ``sources`` ((field, pair) each: a (2, B, n^2) pair of fields or a
        pressure (B, n^2)), the product ``kernel`` on them (``inputs``, ``outputs``: the
        influence and spectra arrays it takes), and ``out`` (a pair, ``out_pair``, or a field) <-
        the inverse of the pair's (or the pressure's) spectra."""
        lib = self.library
        with lib.on_device():
            for field, pair in sources:
                self._forward(field, pair)
            lib.spectral_launch(kernel, self.batch, self.pressure_spectra.shape[1:], inputs, outputs)
            self._inverse_into(out, out_pair)

    def _block_product(self, blocks, vector, out):
        """``out`` <- the symmetric 2x2 ``blocks`` ("xx", "xy", "yy" per wavenumber: K_tt or its
        inverse) applied to the pair ``vector`` (each a (2, B, n^2) pair)."""
        self._apply([(vector, True)], sbk.batch_spectral_tangential,
                    [blocks["xx"], blocks["xy"], blocks["yy"], self.pair_spectra], [], out, True)

    def tangential(self, shear, disp, pressure=None):
        """``disp`` <- K_tt ``shear`` (each a (2, B, n^2) pair: x, y), plus K_tz ``pressure`` where given."""
        if pressure is None:
            self._block_product(self._spectra, shear, disp)
            return
        s = self._spectra
        self._apply([(shear, True), (pressure, False)], sbk.batch_spectral_tangential_coupled,
                    [s["xx"], s["xy"], s["yy"], s["xz"], s["yz"], self.pressure_spectra, self.pair_spectra], [],
                    disp, True)

    def tangential_inverse(self, gradient, out):
        """``out`` <- M ``gradient`` (each a (2, B, n^2) pair: x, y), M each row's circulant
        inverse of K_tt (``tangential_inverse_blocks``: of T. Chan's circulants on the grid itself
        where ``periodic``, else on the padded grid): the batched tangential solver's
        preconditioner, applied to g on the stick cells."""
        if not self.periodic:
            self._block_product(self._inverse, gradient, out)
            return
        lib = self.library
        for field in (gradient, out):  # the solver's own buffers: their views made once
            if field.ptr not in self._inverse_fields:
                self._inverse_fields.add(field.ptr)
                lib.keep(field)
        b = self._inverse
        with lib.on_device():
            lib.periodic_forward(gradient, self.n, self.inverse_spectra)
            lib.spectral_launch(sbk.batch_spectral_tangential, self.batch, self.inverse_spectra.shape[2:],
                                [b["xx"], b["xy"], b["yy"], self.inverse_spectra])
            lib.periodic_inverse(self.inverse_spectra, self.n, out)

    def cross_tangential(self, pressure, disp):
        """``disp`` (a (2, B, n^2) pair) <- K_tz p: the pressure's tangential displacement."""
        s = self._spectra
        self._apply([(pressure, False)], sbk.batch_spectral_cross_tangential,
                    [s["xz"], s["yz"], self.pressure_spectra], [self.pair_spectra], disp, True)

    def coupled(self, pressure, shear, disp_z, disp, normal_block: bool = True):
        """``disp`` (a (2, B, n^2) pair) <- K_tt ``shear`` + K_tz ``pressure``, and ``disp_z`` <-
        K_zt ``shear`` (+ K_zz ``pressure`` where ``normal_block``): every block of the operator
        from one forward transform of each traction (three transform pairs where the separate
        products make five)."""
        s = self._spectra
        lib = self.library
        if self._normal is None:  # K_zz's spectrum, the same for every pair in scaled units
            spectrum = normal_influence(self.n, self.device.alias)[0] / (4 * self.n * self.n)
            self._normal = wp.array(spectrum[None].astype(self._real), dtype=self.dtype, device=self.device)
        with lib.on_device():
            self._forward(shear, True)
            self._forward(pressure, False)
            lib.spectral_launch(sbk.batch_spectral_coupled, self.batch, self.pressure_spectra.shape[1:],
                                [s["xx"], s["xy"], s["yy"], s["xz"], s["yz"], self._normal, int(normal_block),
                                 self.pressure_spectra, self.pair_spectra])
            self._inverse_into(disp, True)
            self._inverse_into(disp_z, False)

    def cross_normal(self, shear, disp_z):
        """disp_z <- K_zt q of ``shear`` (a (2, B, n^2) pair): the shear's normal displacement
        (K_zt = -K_tz in Fourier space: the kernels are odd)."""
        s = self._spectra
        self._apply([(shear, True)], sbk.batch_spectral_cross_normal,
                    [s["xz"], s["yz"], self.pair_spectra], [self.pressure_spectra], disp_z, False)

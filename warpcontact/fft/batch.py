"""The normal DC-FFT convolution of B cases of one grid size at once: batched transforms.

Each case's field is an (n, n) slice of a (B, n, n) Warp array the batched kernels write
(``kernels/normal_batch.py``), zero-padded to (2 n, 2 n) by the transforms themselves: the rows'
real transforms of length 2 n of the n data rows, then the columns' of length 2 n, one spectral
product, and back, keeping the n rows and n columns of the result, into a second (B, n, n) array
the kernels read. The zero padding is never transformed (as the single-case backends prune it:
``warpcontact.fft``), and the library does the batching: ``scipy.fft`` (its ``workers``
threads) on the CPU, cuFFT through CuPy on CUDA, on Warp's stream (``cupy.cuda.ExternalStream``),
the buffers shared without a copy (DLPack).

In the model's scaled units (tractions / E*, lengths / the cell size) the normal influence
coefficients of a square grid depend on n alone (K_zz = (1 - nu_1^2) / E_1 + (1 - nu_2^2) / E_2
is 1 / E*), so one spectrum serves cases of any materials and cell sizes.
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
            self._stream = None
            return
        from . import OPTIONAL, cupy_backend

        if not cupy_backend.available():
            raise InputError("solver.fft", "batched solves on CUDA transform through CuPy's cuFFT: "
                             + OPTIONAL["cupy"])
        import cupy
        import cupy.fft

        self.fft, self.xp, self.workers = cupy.fft, cupy, {}
        self._cuda_device = cupy.cuda.Device(self.device.ordinal)
        self._stream = cupy.cuda.ExternalStream(wp.get_stream(self.device).cuda_stream, self.device.ordinal)

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
        fft, n, w = self.library.fft, self.n, self.library.workers
        rows = fft.rfft(self._input, n=2 * n, axis=-1, **w)  # the n data rows, padded to 2 n
        spectrum = fft.fft(rows, n=2 * n, axis=-2, **w)  # the columns, padded to 2 n
        spectrum *= self._multipliers[inverse]
        rows = fft.ifft(spectrum, axis=-2, **w)[:, :n]  # the n rows kept
        self._output[...] = fft.irfft(rows, n=2 * n, axis=-1, **w)[:, :, :n]

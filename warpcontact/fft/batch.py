"""The normal DC-FFT convolution of B cases of one grid size at once: batched transforms.

Each case's field sits in the top-left (n, n) corner of its (2 n, 2 n) zero-padded buffer (a
(B, 2 n, 2 n) Warp array the batched kernels write: ``kernels/normal_batch.py``); one real
forward transform over the last two axes of all B buffers, one spectral product, one inverse
into a second (B, 2 n, 2 n) buffer whose corners the kernels read. The library does the
batching: ``scipy.fft`` (its ``workers`` threads) on the CPU, cuFFT through CuPy on CUDA, on
Warp's stream (``cupy.cuda.ExternalStream``), the buffers shared without a copy (DLPack). A
library's batched plan is what makes one launch serve every case; the single-case backends of
this package (``warpcontact.fft``) prune the zero padding by hand, which a batched 2-D plan does
not need to pay off.

In the model's scaled units (tractions / E*, lengths / the cell size) the normal influence
coefficients of a square grid depend on n alone (K_zz = (1 - nu_1^2) / E_1 + (1 - nu_2^2) / E_2
is 1 / E*), so one spectrum serves cases of any materials and cell sizes.
"""

from __future__ import annotations

import functools

import numpy as np
import warp as wp

from ..errors import InputError


@functools.lru_cache(maxsize=8)
def normal_spectrum(n: int) -> np.ndarray:
    """The real spectrum (2 n, n + 1) of the scaled normal influence coefficients of an n x n
    grid of square cells on its (2 n, 2 n) padded grid, ``numpy.fft.rfft2``'s layout, float64
    (K_zz is even: its spectrum is real)."""
    from ..physics.influence import influence_coefficients
    from ..physics.materials import Material, MaterialPair

    unit = Material(E=2.0, nu=0.0)  # two of them: E* = 1, so with dx = 1 the coefficients are scaled ones
    coefficients = influence_coefficients(MaterialPair(unit, unit), n, n, 1.0, 1.0)["zz"]
    return np.fft.rfft2(coefficients).real


class BatchConvolution:
    """K_zz (or its circulant inverse, the preconditioner) on B padded buffers at once.

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
        shape = (self.batch, 2 * self.n, 2 * self.n)
        #: each case's field in its (n, n) corner; the padding stays zero (nothing writes there)
        self.padded_input = wp.zeros(shape, dtype=dtype, device=self.device)
        #: the normalised result, each case's in its (n, n) corner
        self.padded_output = wp.zeros(shape, dtype=dtype, device=self.device)
        np_real = np.float64 if dtype == wp.float64 else np.float32
        spectrum = normal_spectrum(self.n)
        inverse = np.where(spectrum > 0.0, 1.0 / np.where(spectrum > 0.0, spectrum, 1.0), 0.0)
        if self.device.is_cpu:
            import scipy.fft

            self._fft = scipy.fft
            self._xp = np
            self._input, self._output = self.padded_input.numpy(), self.padded_output.numpy()
            self._stream = None
            self._workers = {"workers": -1}
        else:
            from . import OPTIONAL, cupy_backend

            if not cupy_backend.available():
                raise InputError("solver.fft", "batched solves on CUDA transform through CuPy's cuFFT: "
                                 + OPTIONAL["cupy"])
            import cupy
            import cupy.fft

            self._fft = cupy.fft
            self._xp = cupy
            self._stream = cupy.cuda.ExternalStream(wp.get_stream(self.device).cuda_stream, self.device.ordinal)
            with cupy.cuda.Device(self.device.ordinal):
                self._input = cupy.from_dlpack(wp.to_dlpack(self.padded_input))
                self._output = cupy.from_dlpack(wp.to_dlpack(self.padded_output))
            self._workers = {}
        xp = self._xp
        self._multipliers = {False: xp.asarray(spectrum.astype(np_real)), True: xp.asarray(inverse.astype(np_real))}

    def apply(self, inverse: bool = False):
        """``padded_output`` <- K_zz (``inverse``: its circulant inverse M, 0 where K_zz(k) <= 0)
        applied to every case's ``padded_input``."""
        if self._stream is None:
            self._apply(inverse)
        else:
            with self._stream:
                self._apply(inverse)

    def _apply(self, inverse: bool):
        fft = self._fft
        size = (2 * self.n, 2 * self.n)
        spectrum = fft.rfft2(self._input, axes=(-2, -1), **self._workers)
        spectrum *= self._multipliers[inverse]
        self._output[...] = fft.irfft2(spectrum, s=size, axes=(-2, -1), **self._workers)

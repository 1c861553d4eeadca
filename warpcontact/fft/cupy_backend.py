"""cuFFT through CuPy on CUDA devices: the default backend there when CuPy is installed.

Warp arrays pass to CuPy through DLPack without a copy, on Warp's stream. Same layout and the same
zero-padding economy as the scipy backend: spectral layout (2 ny, nx + 1).
"""

from __future__ import annotations

import numpy as np
import warp as wp

from .base import FFTBackend


def available() -> bool:
    try:
        import cupy  # noqa: F401

        return cupy.cuda.runtime.getDeviceCount() > 0
    except Exception:
        return False


class CupyFFT(FFTBackend):
    name = "cupy"

    def __init__(self, ny, nx, device, dtype):
        super().__init__(ny, nx, device, dtype)
        if not self.device.is_cuda:
            raise ValueError(f"fft: the cupy backend runs on CUDA devices only, not on {self.device}")
        import cupy

        self.cp = cupy
        self._cp_device = cupy.cuda.Device(self.device.ordinal)
        self._stream = cupy.cuda.ExternalStream(int(wp.get_stream(self.device).cuda_stream), self.device.ordinal)

    @property
    def spectral_shape(self):
        return (2 * self.ny, self.nx + 1)

    def spectrum_of_padded(self, padded):
        return np.fft.rfft2(np.asarray(padded, dtype=np.float64))

    def _views(self, spectrum):
        cp = self.cp
        return cp.from_dlpack(wp.to_dlpack(spectrum)).view(self.np_complex).reshape(spectrum.shape)

    def forward(self, field, spectrum):
        cp = self.cp
        with self._cp_device, self._stream:
            x = cp.from_dlpack(wp.to_dlpack(field))
            rows = cp.fft.rfft(x, n=2 * self.nx, axis=1)
            self._views(spectrum)[...] = cp.fft.fft(rows, n=2 * self.ny, axis=0)

    def inverse(self, spectrum, field):
        cp = self.cp
        with self._cp_device, self._stream:
            s = self._views(spectrum)
            cols = cp.fft.ifft(s, axis=0)[: self.ny]
            out = cp.from_dlpack(wp.to_dlpack(field))
            out[...] = cp.fft.irfft(cols, n=2 * self.nx, axis=1)[:, : self.nx]

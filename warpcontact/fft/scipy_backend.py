"""scipy.fft on the CPU, with worker threads: the default backend on CPU.

Real-to-complex transforms; the zero padding is never transformed: the forward pass does the
row transforms on the ny data rows only (``n = 2 nx`` pads them), and the inverse keeps only the
ny output rows before the last pass. Spectral layout: (2 ny, nx + 1).
"""

from __future__ import annotations

import os

import numpy as np
import scipy.fft as sfft
import warp as wp

from .base import FFTBackend


class ScipyFFT(FFTBackend):
    name = "scipy"

    def __init__(self, ny, nx, device, dtype, workers: int | None = None):
        super().__init__(ny, nx, device, dtype)
        if not self.device.is_cpu:
            raise ValueError(f"fft: the scipy backend runs on the CPU only, not on {self.device}")
        self.workers = workers or os.cpu_count() or 1

    @property
    def spectral_shape(self):
        return (2 * self.ny, self.nx + 1)

    def spectrum_of_padded(self, padded):
        return sfft.rfft2(np.asarray(padded, dtype=np.float64), workers=self.workers)

    def _complex_view(self, spectrum: wp.array2d) -> np.ndarray:
        return spectrum.numpy().view(self.np_complex).reshape(spectrum.shape)

    def forward(self, field, spectrum):
        x = field.numpy()  # zero-copy on the CPU
        rows = sfft.rfft(x, n=2 * self.nx, axis=1, workers=self.workers)
        self._complex_view(spectrum)[...] = sfft.fft(rows, n=2 * self.ny, axis=0, workers=self.workers)

    def inverse(self, spectrum, field):
        s = self._complex_view(spectrum)
        cols = sfft.ifft(s, axis=0, workers=self.workers, overwrite_x=True)[: self.ny]
        field.numpy()[...] = sfft.irfft(cols, n=2 * self.nx, axis=1, workers=self.workers)[:, : self.nx]

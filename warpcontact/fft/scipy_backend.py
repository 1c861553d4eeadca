"""scipy.fft on the CPU, with worker threads: the default backend on CPU.

Real-to-complex transforms; the zero padding is never transformed: the forward pass does the
row transforms on the ny data rows only (of a kept (ny, 2 nx) buffer whose right half stays zero:
``padded_input``), and the inverse keeps only the ny output rows before the last pass (into the
field, or into the kept (ny, nx) ``padded_output``). Spectral layout: (2 ny, nx + 1). The column
passes run in place on the spectrum (the forward pass writes its rows into the top half and zeros the bottom
half first): letting scipy pad the columns allocated and copied a second spectrum, and made the
forward pass 2-3x slower than the inverse (measured: 17 against 6-9 ms at n = 512, 2 cores).

``PeriodicScipyFFT``: the transforms of the (ny, nx) grid itself, no padding, for the
preconditioners' circulants (``make_periodic_fft``).

scipy.fft is imported where a transform is first made, not with this module: the FFTW backend
shares this one's layout and buffers (it subclasses it) but not its transforms, and the import
costs about 0.2 s of every process's start (2 cores).
"""

from __future__ import annotations

import numpy as np
import warp as wp

from .base import FFTBackend, cpu_threads


class ScipyFFT(FFTBackend):
    name = "scipy"
    #: worker threads from this many cells on (``base.cpu_threads``): below it a transform is
    #: faster on one thread than on two (docs/performance.md, "Many cases: the batch engine")
    THREADS_FROM_CELLS = 1024 * 1024

    def __init__(self, ny, nx, device, dtype, workers: int | None = None):
        super().__init__(ny, nx, device, dtype)
        if not self.device.is_cpu:
            raise ValueError(f"fft: the scipy backend runs on the CPU only, not on {self.device}")
        self.workers = workers or cpu_threads(ny * nx, self.THREADS_FROM_CELLS)
        # the forward pass's rows, padded: the field goes into the left half, the right half stays
        # zero. Letting scipy pad (``rfft(x, n=2 nx)``) allocated and zeroed a fresh (ny, 2 nx)
        # array per transform: 5.7-6.5 against 3.0-3.6 ms per forward pass at n = 512, 2 cores.
        self._rows_buffer = wp.zeros((ny, 2 * nx), dtype=dtype, device=self.device)
        self._rows = self._rows_buffer.numpy()  # zero-copy view
        self.padded_input = self._rows_buffer
        #: the kept (ny, nx) result of the inverse (scipy normalises it): what solver kernels read
        self.padded_output = wp.zeros((ny, nx), dtype=dtype, device=self.device)
        self._output = self.padded_output.numpy()
        self.output_scale = dtype(1.0)
        self._set_parseval(1, 2 * nx, 4 * nx * ny)

    @property
    def spectral_shape(self):
        return (2 * self.ny, self.nx + 1)

    def spectrum_of_padded(self, padded):
        import scipy.fft as sfft

        return sfft.rfft2(np.asarray(padded, dtype=np.float64), workers=self.workers)

    def transform_input(self, spectrum):
        import scipy.fft as sfft

        s = self._complex_view(spectrum)
        s[: self.ny] = sfft.rfft(self._rows, axis=1, workers=self.workers)
        s[self.ny :] = 0
        out = sfft.fft(s, axis=0, workers=self.workers, overwrite_x=True)
        if not np.shares_memory(out, s):  # scipy may return a new array even when allowed to overwrite
            s[...] = out

    def _inverse_rows(self, spectrum) -> np.ndarray:
        """The (ny, 2 nx) rows of the normalised inverse transform (a new array from scipy)."""
        import scipy.fft as sfft

        s = self._complex_view(spectrum)
        cols = sfft.ifft(s, axis=0, workers=self.workers, overwrite_x=True)[: self.ny]
        return sfft.irfft(cols, n=2 * self.nx, axis=1, workers=self.workers)

    def transform_to_output(self, spectrum):
        self._output[...] = self._inverse_rows(spectrum)[:, : self.nx]

    def forward(self, field, spectrum):
        self._rows[:, : self.nx] = field.numpy()  # a numpy copy (numpy(): zero-copy on the CPU)
        self.transform_input(spectrum)

    def inverse(self, spectrum, field):
        field.numpy()[...] = self._inverse_rows(spectrum)[:, : self.nx]


class PeriodicScipyFFT(FFTBackend):
    """scipy.fft's real-to-complex transforms of the (ny, nx) grid itself, periodic, with no zero
    padding (``FFTBackend.periodic``): the preconditioners' circulants (``make_periodic_fft``).
    ``padded_input`` and ``padded_output`` are (ny, nx) (scipy normalises the inverse); the
    spectrum (ny, nx // 2 + 1), the layout of ``numpy.fft.rfft2``."""

    name = "scipy"
    periodic = True

    def __init__(self, ny, nx, device, dtype, workers: int | None = None):
        super().__init__(ny, nx, device, dtype)
        if not self.device.is_cpu:
            raise ValueError(f"fft: the scipy backend runs on the CPU only, not on {self.device}")
        # threads as the padded backend's of the same number of transformed entries
        self.workers = workers or cpu_threads(ny * nx // 4, ScipyFFT.THREADS_FROM_CELLS)
        self.padded_input = wp.zeros((ny, nx), dtype=dtype, device=self.device)
        self.padded_output = wp.zeros((ny, nx), dtype=dtype, device=self.device)
        self._input, self._output = self.padded_input.numpy(), self.padded_output.numpy()  # zero-copy views
        self.output_scale = dtype(1.0)
        self._set_parseval(1, nx, ny * nx)

    @property
    def spectral_shape(self):
        return (self.ny, self.nx // 2 + 1)

    def spectrum_of_padded(self, padded):
        """The spectrum of a real (ny, nx) array (the grid's own: nothing is padded here)."""
        import scipy.fft as sfft

        return sfft.rfft2(np.asarray(padded, dtype=np.float64), workers=self.workers)

    def transform_input(self, spectrum):
        import scipy.fft as sfft

        self._complex_view(spectrum)[...] = sfft.rfft2(self._input, workers=self.workers)

    def transform_to_output(self, spectrum):
        import scipy.fft as sfft

        self._output[...] = sfft.irfft2(self._complex_view(spectrum), s=(self.ny, self.nx), workers=self.workers,
                                        overwrite_x=True)

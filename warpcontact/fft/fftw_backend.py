"""FFTW through pyFFTW on the CPU: the scipy backend's transforms, planned once and run in place.

The same pruned pair and spectral layout as :mod:`.scipy_backend` ((2 ny, nx + 1), real-to-complex
along x): the forward pass transforms the ny data rows of the kept (ny, 2 nx) ``padded_input``
straight into the top half of the spectrum and the columns in place; the inverse transforms the
columns in place and the ny kept rows straight into the (ny, 2 nx) ``padded_output``, whose left
half the solver kernels read, unnormalised (``output_scale`` = 1 / (4 nx ny)). No temporary
arrays and no copies between the passes, which scipy.fft makes (it returns new arrays).

Plans (``FFTW_ESTIMATE``: planning costs milliseconds, and ``FFTW_MEASURE`` would overwrite the
arrays it plans on) are made on first use for each spectrum array the backend meets (an operator
has three) and kept. Optional: ``pip install warpcontact[fftw]``. pyFFTW is BSD-licensed, but its
wheels bundle FFTW, which is GPL-2.0-or-later: see the README.
"""

from __future__ import annotations

import os

# pyFFTW's wheels run FFTW's threads under GNU OpenMP, whose idle threads spin for a while after
# each transform (OMP_WAIT_POLICY unset): on 2 cores they took a core from the solver's passes
# that follow (n = 512: normal_update 1.5 -> 2.7 ms, a Hertz solve 0.68 -> 0.90 s). Passive
# waiting, unless the user chose otherwise; read once, when OpenMP starts (at pyFFTW's import).
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

import numpy as np  # noqa: E402
import warp as wp  # noqa: E402

from .base import FFTBackend  # noqa: E402
from .scipy_backend import ScipyFFT  # noqa: E402


def available() -> bool:
    """True when pyFFTW can be imported."""
    try:
        import pyfftw  # noqa: F401
    except ImportError:
        return False
    return True


class FFTWPlans:
    """The four transforms of one spectrum: rows and columns, forward and inverse."""

    def __init__(self, rows_in: np.ndarray, spectrum: np.ndarray, rows_out: np.ndarray, threads: int):
        import pyfftw

        ny = rows_in.shape[0]
        common = dict(flags=("FFTW_ESTIMATE",), threads=threads)
        self.spectrum = spectrum
        self.rows_forward = pyfftw.FFTW(rows_in, spectrum[:ny], axes=(1,), direction="FFTW_FORWARD", **common)
        self.columns_forward = pyfftw.FFTW(spectrum, spectrum, axes=(0,), direction="FFTW_FORWARD", **common)
        self.columns_inverse = pyfftw.FFTW(spectrum, spectrum, axes=(0,), direction="FFTW_BACKWARD",
                                           normalise_idft=False, **common)
        # complex-to-real overwrites its input (the spectrum's top half), which inverse transforms may
        self.rows_inverse = pyfftw.FFTW(spectrum[:ny], rows_out, axes=(1,), direction="FFTW_BACKWARD",
                                        normalise_idft=False, **common)


class FFTWBackend(ScipyFFT):
    name = "fftw"

    def __init__(self, ny, nx, device, dtype, workers: int | None = None):
        super().__init__(ny, nx, device, dtype, workers)
        #: the (ny, 2 nx) unnormalised inverse rows; the solver kernels read the left half
        self.padded_output = wp.zeros((ny, 2 * nx), dtype=dtype, device=self.device)
        self._output = self.padded_output.numpy()
        self.output_scale = dtype(1.0 / (4 * nx * ny))
        self._plans: dict[int, FFTWPlans] = {}

    def _plans_for(self, spectrum: wp.array2d) -> FFTWPlans:
        plans = self._plans.get(spectrum.ptr)
        if plans is None or plans.spectrum.shape != spectrum.shape:
            plans = FFTWPlans(self._rows, self._complex_view(spectrum), self._output, self.workers)
            self._plans[spectrum.ptr] = plans
        return plans

    def transform_input(self, spectrum):
        plans = self._plans_for(spectrum)
        plans.rows_forward.execute()
        plans.spectrum[self.ny :] = 0
        plans.columns_forward.execute()

    def transform_to_output(self, spectrum):
        plans = self._plans_for(spectrum)
        plans.columns_inverse.execute()
        plans.rows_inverse.execute()

    # padding and cropping kernels around the transforms (scipy's numpy copies assume its layout)
    forward = FFTBackend.forward
    inverse = FFTBackend.inverse

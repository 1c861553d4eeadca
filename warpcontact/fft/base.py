"""The interface every FFT backend implements for the DC-FFT convolution.

Liu, Wang & Liu (2000), "A versatile method of discrete convolution and FFT (DC-FFT) for contact
analyses", Wear 243: the tractions on an (ny, nx) grid are zero-padded to (2 ny, 2 nx), multiplied
in Fourier space by the spectra of the influence coefficients (held in wrap-around order on the
padded grid), transformed back, and the first (ny, nx) outputs kept. No periodic images.

A backend owns the layout of its spectra (``spectral_shape``): the spectral products are
elementwise Warp kernels that do not care about it. Complex numbers are 2-vectors of the
backend's float type (``wp.vec2f`` or ``wp.vec2d``).
"""

from __future__ import annotations

import os

import numpy as np
import warp as wp

from ..kernels.fft import crop_field, pad_field
from ..numerics.launch import LaunchCache, Rows


def cpu_threads(cells: int, threads_from_cells: int) -> int:
    """Threads for the CPU transforms of a grid of ``cells`` cells (n x n; the padded transform is
    of 4 n^2 entries): one per CPU from ``threads_from_cells`` on, one below it, where starting
    and joining the threads costs more than they save (each backend's ``THREADS_FROM_CELLS``,
    measured on 2 cores)."""
    return (os.cpu_count() or 1) if cells >= threads_from_cells else 1


class FFTBackend:
    """Zero-padded forward and truncated inverse 2-D transforms on one device, in one float type.

    Args:
        ny, nx: grid cells along y (rows) and x (columns).
        device: Warp device the arrays live on.
        dtype: ``wp.float32`` or ``wp.float64``.
    """

    #: Name used in case files and on the command line.
    name = "base"

    def __init__(self, ny: int, nx: int, device, dtype):
        self.ny, self.nx = int(ny), int(nx)
        self.device = wp.get_device(device)
        self.dtype = dtype
        self.complex_dtype = wp.vec2d if dtype == wp.float64 else wp.vec2f
        self.np_real = np.float64 if dtype == wp.float64 else np.float32
        self.np_complex = np.complex128 if dtype == wp.float64 else np.complex64
        self.launches = LaunchCache(self.device)

    #: whether the transforms are of the (ny, nx) grid itself, periodic, with no zero padding (the
    #: preconditioners' circulants: ``make_periodic_fft``); False: of the DC-FFT's padded grid
    periodic = False

    @property
    def padded_shape(self) -> tuple[int, int]:
        """The grid transformed: (2 ny, 2 nx), or (ny, nx) where ``periodic``."""
        return (self.ny, self.nx) if self.periodic else (2 * self.ny, 2 * self.nx)

    @property
    def spectral_shape(self) -> tuple[int, int]:
        """Shape of one spectrum (complex entries)."""
        raise NotImplementedError

    def _complex_view(self, spectrum: wp.array2d) -> np.ndarray:
        """A CPU spectrum as a complex numpy view (no copy)."""
        return spectrum.numpy().view(self.np_complex).reshape(spectrum.shape)

    def alloc_spectra(self, count: int) -> wp.array:
        """``count`` spectra in one array of shape (count, *spectral_shape), zero-filled."""
        return wp.zeros((count, *self.spectral_shape), dtype=self.complex_dtype, device=self.device)

    def spectrum_of_padded(self, padded: np.ndarray) -> np.ndarray:
        """Host spectrum, in this backend's layout, of a real (2 ny, 2 nx) float64 array.

        Used once per grid for the influence coefficients; returns complex128 numpy.
        """
        raise NotImplementedError

    def alloc_influence(self, count: int) -> wp.array:
        """``count`` influence spectra, each real or imaginary (only that part is kept), in one
        real array of shape (count, *spectral_shape), zero-filled."""
        return wp.zeros((count, *self.spectral_shape), dtype=self.dtype, device=self.device)

    def influence_spectra(self, padded_arrays, parts, out: wp.array, scratch: wp.array):
        """``out[k]`` <- the real or imaginary part (``parts[k]``: "real" or "imag") of the
        spectrum of ``padded_arrays[k]``, in this backend's layout and float type.

        ``padded_arrays``: an iterable of real (2 ny, 2 nx) float64 host arrays (the influence
        coefficients in wrap-around order), consumed one at a time; ``out``: from
        [`alloc_influence`][warpcontact.fft.base.FFTBackend.alloc_influence]; ``scratch``: one
        spectrum ([`alloc_spectra`][warpcontact.fft.base.FFTBackend.alloc_spectra]) the backend
        may overwrite. Once per grid. Here: each spectrum on the host in float64
        ([`spectrum_of_padded`][warpcontact.fft.base.FFTBackend.spectrum_of_padded]), its part cast
        and copied into ``out``; a backend with a faster device path overrides this.
        """
        for k, (padded, part) in enumerate(zip(padded_arrays, parts)):
            spectrum = self.spectrum_of_padded(padded)
            del padded
            values = spectrum.real if part == "real" else spectrum.imag
            out[k].assign(np.ascontiguousarray(values, dtype=self.np_real))

    # The padded buffers. Each backend transforms from a real buffer whose top-left (ny, nx)
    # corner holds the field (the rest is the zero padding, which stays zero: nothing writes
    # there) and leaves the inverse in a real buffer whose corner holds the result, unnormalised.
    # Solver kernels may write the corner of ``padded_input`` and read that of ``padded_output``
    # themselves (``ElasticOperator.normal_padded``), saving the padding and cropping passes.
    #: the real buffer the forward transforms read; the field goes into its (ny, nx) corner
    padded_input: wp.array2d
    #: the real buffer the inverse transforms write; the result is its (ny, nx) corner times ``output_scale``
    padded_output: wp.array2d
    #: the normalisation of ``padded_output`` (a scalar of the backend's float type)
    output_scale = None
    # Parseval's identity in this layout, for sums over the padded grid taken in Fourier space
    # (``kernels/spectral.py``, ``spectral_normal_energy``): sum_x a(x) b(x) = energy_scale *
    # sum_k w_k Re(A(k) conj(B(k))), w = 1 where the index along ``half_axis`` is 0 or
    # half_length / 2, 2 elsewhere
    #: the spectrum's axis that holds only the non-negative frequencies of the real transform
    half_axis: int = 1
    #: the length of the real transform along that axis (the padded grid's, in points)
    half_length: int = 0
    #: 1 / (points of the padded grid) (a scalar of the backend's float type)
    energy_scale = None

    def _set_parseval(self, half_axis: int, half_length: int, padded_points: int):
        self.half_axis, self.half_length = int(half_axis), int(half_length)
        self.energy_scale = self.dtype(1.0 / padded_points)

    def transform_input(self, spectrum: wp.array2d):
        """``spectrum`` <- transform of ``padded_input``."""
        raise NotImplementedError

    def transform_to_output(self, spectrum: wp.array2d):
        """``padded_output`` <- unnormalised inverse transform of ``spectrum`` (which it may
        overwrite)."""
        raise NotImplementedError

    def forward(self, field: wp.array2d, spectrum: wp.array2d):
        """``spectrum`` <- transform of the real (ny, nx) ``field`` zero-padded to (2 ny, 2 nx)."""
        self.launches.launch_rows(pad_field, (self.ny, self.nx), [Rows(field)], [Rows(self.padded_input)])
        self.transform_input(spectrum)

    def inverse(self, spectrum: wp.array2d, field: wp.array2d):
        """``field`` <- the first (ny, nx) values of the normalised inverse transform of ``spectrum``.

        May overwrite ``spectrum``.
        """
        self.transform_to_output(spectrum)
        self.launches.launch_rows(crop_field, (self.ny, self.nx), [Rows(self.padded_output), self.output_scale],
                                  [Rows(field)])

    def library_transforms(self, field: wp.array2d, spectrum: wp.array2d):
        """The FFT library's own forward and inverse transforms of the padded grid, without this
        backend's padding and cropping passes (``field`` unused): what benchmarks compare an
        iteration with (the floor)."""
        self.transform_input(spectrum)
        self.transform_to_output(spectrum)

    #: set by :meth:`transient`: this backend's grid serves only a few solves
    is_transient = False

    def transient(self):
        """Say that this backend's grid serves only a few solves (a tangential solve's window):
        a backend whose plans cost time to make may make cheaper ones. Here: only noted
        (``is_transient``, which a backend made beside it for the same grid follows)."""
        self.is_transient = True

    def check_field(self, name: str, a: wp.array):
        """Raise ValueError naming ``name`` unless ``a`` is an (ny, nx) array of this dtype and device."""
        if a.shape != (self.ny, self.nx) or a.dtype != self.dtype or a.device != self.device:
            raise ValueError(
                f"{name}: expected shape {(self.ny, self.nx)} {self.dtype.__name__} on {self.device}, "
                f"got {a.shape} {a.dtype.__name__} on {a.device}"
            )

"""Warp's ``tile_fft`` on CPU and CUDA: the FFT backend with no dependency beyond Warp.

Padding. DC-FFT (Liu, Wang & Liu 2000, see :mod:`.base`) needs the field zero-padded to at least
2n - 1 points per axis so that the circular convolution equals the linear one on the n kept outputs.
This backend pads each axis to the smallest power of two L >= 2n (L = 2n when n is a power of two):
on CPU ``tile_fft`` runs radix-2 for powers of two only and otherwise a direct DFT with a sine and
a cosine per term (measured, float64, per row: 0.71 ms at L = 200 against 0.005 ms at 256, 81 ms at
2000 against 0.04 ms at 2048; float32 also loses the phase of large k n), and powers of two are the
lengths cuFFTDx handles best on CUDA. :meth:`spectrum_of_padded` moves the influence coefficients
from the (2 ny, 2 nx) wrap-around grid onto the (Ly, Lx) one; the only coefficient dropped is the
one at offset +-n (index n), which never meets a kept output, so the convolution results are those
of the (2 ny, 2 nx) grid.

Layout. Real-to-complex and transposed: a spectrum has shape (Lx // 2 + 1, Ly), entry [kx, ky] of
the 2-D DFT X[ky, kx] of the padded field, i.e. ``numpy.fft.rfft2(padded).T``. Sign convention
X_k = sum_n x_n exp(-2 pi i k n / L).

Passes (kernels in ``warpcontact.kernels.fft``; one tile row per block):

- forward: rows of the field (ny of them, zero-padded to Lx) -> their first Lx/2 + 1 frequencies,
  stored as columns of a (Lx/2 + 1, Ly) buffer whose columns ny..Ly-1 stay zero; then the Lx/2 + 1
  rows of that buffer -> the spectrum.
- inverse: the Lx/2 + 1 rows of the spectrum -> inverse DFT, first ny values kept, scaled by
  w_kx / (Lx Ly) with w = 1 at kx = 0 and Lx/2 and 2 in between, stored as columns of an
  (ny, Lx/2 + 1) buffer; then its ny rows (zero-padded to Lx) -> real part of the inverse DFT, first
  nx values. Doubling the inner frequencies and taking the real part is the Hermitian completion of
  the half spectrum, the same result as ``numpy.fft.irfft``.

On CPU tile kernels run with ``block_dim`` 1, serially, one row after another; on CUDA cuFFTDx
(bundled libmathdx) transforms each row with max(1, L / 16) threads. Size limits: ``MAX_LENGTH``.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from ..kernels.fft import row_fft_kernels
from .base import FFTBackend

#: Largest padded length L per axis, by device kind and dtype. CPU: checked up to L = 8192
#: (n = 4096) in both precisions; the row tiles live on the stack of the launching thread. CUDA
#: (H100, 16 elements per thread): float32 runs at L = 8192; float64 at L = 8192 compiles but the
#: launch asks for more registers than a block has. Larger grids: the scipy or cupy backend.
MAX_LENGTH = {
    ("cpu", wp.float32): 8192,
    ("cpu", wp.float64): 8192,
    ("cuda", wp.float32): 8192,
    ("cuda", wp.float64): 4096,
}

#: Elements per thread of a CUDA row transform (cuFFTDx needs 2..16 for complex128).
CUDA_ELEMENTS_PER_THREAD = 16


def padded_length(n: int) -> int:
    """The smallest power of two L >= 2 n: the padded length of an axis of n cells."""
    length = 2
    while length < 2 * int(n):
        length *= 2
    return length


def embed_wraparound(padded: np.ndarray, ly: int, lx: int) -> np.ndarray:
    """Coefficients in wrap-around order on a (2 ny, 2 nx) grid moved onto an (ly, lx) grid.

    Per axis (L >= 2 n): offsets 0..n-1 stay at indices 0..n-1 and offsets -(n-1)..-1 (indices
    n+1..2n-1) go to L-n+1..L-1; offset +-n (index n) is dropped unless L = 2 n, where the grids
    coincide.
    """
    my, mx = padded.shape
    out = np.zeros((ly, lx), dtype=np.float64)
    ny, nx = my // 2, mx // 2
    rows_src = np.arange(my) if ly == my else np.r_[0:ny, ny + 1 : my]
    rows_dst = np.where(rows_src < ny, rows_src, rows_src - my + ly)
    cols_src = np.arange(mx) if lx == mx else np.r_[0:nx, nx + 1 : mx]
    cols_dst = np.where(cols_src < nx, cols_src, cols_src - mx + lx)
    out[np.ix_(rows_dst, cols_dst)] = padded[np.ix_(rows_src, cols_src)]
    return out


class WarpTileFFT(FFTBackend):
    """DC-FFT transforms on Warp's ``tile_fft``, on CPU or CUDA, float32 or float64.

    Spectra have shape (Lx // 2 + 1, Ly): see the module docstring for the padding to powers of two
    and the transposed real-to-complex layout.
    """

    name = "warp"

    def __init__(self, ny, nx, device, dtype):
        super().__init__(ny, nx, device, dtype)
        if dtype not in (wp.float32, wp.float64):
            raise ValueError(f"fft: the warp backend needs dtype wp.float32 or wp.float64, got {dtype!r}")
        if self.ny < 1 or self.nx < 1:
            raise ValueError(f"fft: grid must have at least one cell per axis, got ny={self.ny}, nx={self.nx}")

        #: Padded lengths along y and x (smallest powers of two >= 2 ny, 2 nx).
        self.ly, self.lx = padded_length(self.ny), padded_length(self.nx)
        kind = "cpu" if self.device.is_cpu else "cuda"
        max_length = MAX_LENGTH[(kind, dtype)]
        if max(self.ly, self.lx) > max_length:
            n_max = max_length // 2
            raise ValueError(
                f"fft: the warp backend handles at most {n_max} cells per axis in {dtype.__name__} on {kind} "
                f"(padded length {max_length}); got ny={self.ny}, nx={self.nx} "
                f"(padded {self.ly} x {self.lx})"
                + ("; use the cupy backend on CUDA" if kind == "cuda" else "; use the scipy backend")
            )
        self.hx = self.lx // 2 + 1

        self._kx = row_fft_kernels(self.lx, dtype)  # transforms along x (length Lx)
        self._ky = row_fft_kernels(self.ly, dtype)  # transforms along y (length Ly)
        self._block_x = self._block_dim(self.lx)
        self._block_y = self._block_dim(self.ly)

        with wp.ScopedDevice(self.device):
            #: Forward: x-transformed rows, stored transposed; shape (Lx/2 + 1, Ly), columns >= ny stay 0.
            self._rows_q = wp.zeros((self.hx, self.ly), dtype=self.complex_dtype, device=self.device)
            #: Inverse: y-inverted, Hermitian-weighted half rows; shape (ny, Lx/2 + 1).
            self._half_r = wp.zeros((self.ny, self.hx), dtype=self.complex_dtype, device=self.device)
            # Transposed views: the x passes write and read these buffers column by column.
            self._rows_q_t = self._rows_q.transpose()
            self._half_r_t = self._half_r.transpose()
            weights = np.full(self.hx, 2.0)
            weights[0] = weights[-1] = 1.0
            #: w_kx / (Lx Ly): Hermitian weight and normalisation of the inverse, per kx.
            self._row_scale = wp.array(weights / (self.lx * self.ly), dtype=self.dtype, device=self.device)
            # the padded buffers of solver kernels (``FFTBackend``): the row transforms pad and
            # truncate by themselves, so both are (ny, nx); the inverse is normalised
            self.padded_input = wp.zeros((self.ny, self.nx), dtype=self.dtype, device=self.device)
            self.padded_output = wp.zeros((self.ny, self.nx), dtype=self.dtype, device=self.device)
            self.output_scale = self.dtype(1.0)
            self._set_parseval(0, self.lx, self.lx * self.ly)  # spectra are transposed: (Lx/2 + 1, Ly)
            self._load_kernels()

    def _block_dim(self, length: int) -> int:
        if self.device.is_cpu:
            return 1
        return max(1, length // CUDA_ELEMENTS_PER_THREAD)

    def _load_kernels(self):
        """Compile the row transforms now; a length the device rejects becomes a ValueError.

        On CUDA a zero round trip through the work buffers also runs every kernel once: a block
        that asks for more registers than the device has fails at launch, not at compile time.
        """
        for kernels, length, block_dim in ((self._kx, self.lx, self._block_x), (self._ky, self.ly, self._block_y)):
            try:
                wp.load_module(kernels["forward"].module, device=self.device, block_dim=block_dim)
            except Exception as exc:  # a failed build raises RuntimeError or a bare Exception
                raise ValueError(
                    f"fft: Warp's tile_fft could not build {length}-point {self.dtype.__name__} row transforms "
                    f"on {self.device} (grid {self.ny} x {self.nx}): {exc}"
                ) from exc
        if self.device.is_cuda:
            field = wp.zeros((self.ny, self.nx), dtype=self.dtype, device=self.device)
            try:
                self._launch_forward(field, self._rows_q)  # zeros in, zeros out: the buffers stay clean
                self._launch_inverse(self._rows_q, field)
                wp.synchronize_device(self.device)
            except Exception as exc:
                raise ValueError(
                    f"fft: Warp's tile_fft row transforms ({self.ly} x {self.lx} points, {self.dtype.__name__}) "
                    f"failed to run on {self.device} (grid {self.ny} x {self.nx}): {exc}"
                ) from exc

    @property
    def spectral_shape(self) -> tuple[int, int]:
        return (self.hx, self.ly)

    def spectrum_of_padded(self, padded):
        padded = np.asarray(padded, dtype=np.float64)
        if padded.shape != self.padded_shape:
            raise ValueError(f"fft: padded coefficients must have shape {self.padded_shape}, got {padded.shape}")
        embedded = embed_wraparound(padded, self.ly, self.lx)
        return np.ascontiguousarray(np.fft.rfft2(embedded).T)

    def check_spectrum(self, name: str, a: wp.array):
        """Raise ValueError naming ``name`` unless ``a`` is one spectrum of this backend."""
        if a.shape != self.spectral_shape or a.dtype != self.complex_dtype or a.device != self.device:
            raise ValueError(
                f"{name}: expected shape {self.spectral_shape} {self.complex_dtype.__name__} on {self.device}, "
                f"got {a.shape} {a.dtype.__name__} on {a.device}"
            )

    def transform_input(self, spectrum):
        self._launch_forward(self.padded_input, spectrum)

    def transform_to_output(self, spectrum):
        self._launch_inverse(spectrum, self.padded_output)

    def forward(self, field, spectrum):  # straight from the field: the row loads pad it
        self.check_field("field", field)
        self.check_spectrum("spectrum", spectrum)
        self._launch_forward(field, spectrum)

    def inverse(self, spectrum, field):  # straight into the field: the row stores truncate
        self.check_spectrum("spectrum", spectrum)
        self.check_field("field", field)
        self._launch_inverse(spectrum, field)

    def _launch_forward(self, field, spectrum):
        # x: ny rows of the field (zero-padded to Lx) -> first Lx/2 + 1 frequencies, as columns
        self._row_pass("x", "forward_real", [field], self._rows_q_t)
        # y: Lx/2 + 1 rows of Ly (zero beyond ny) -> spectrum rows
        self._row_pass("y", "forward", [self._rows_q], spectrum)

    def _launch_inverse(self, spectrum, field):
        # y: inverse of each spectrum row, first ny values, weighted and normalised, as columns
        self._row_pass("y", "inverse_scaled", [spectrum, self._row_scale], self._half_r_t)
        # x: ny half rows (zero-padded to Lx) -> real part of the inverse, first nx values
        self._row_pass("x", "inverse_real", [self._half_r], field)

    def _row_pass(self, axis: str, name: str, inputs: list, output):
        """One tiled launch of the row transform ``name`` (of ``row_fft_kernels``) along ``axis``:
        "x" over the ny rows of Lx points, "y" over the Lx/2 + 1 rows of Ly points; one row a block."""
        kernels, rows, block_dim = ((self._kx, self.ny, self._block_x) if axis == "x"
                                    else (self._ky, self.hx, self._block_y))
        wp.launch_tiled(kernels[name], dim=(rows,), inputs=inputs, outputs=[output], block_dim=block_dim,
                        device=self.device)

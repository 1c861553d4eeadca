"""The Warp tile_fft backend against numpy's DC-FFT and the scipy backend, on every device present.

The convolution results are compared, not the spectra: the backends lay their spectra out
differently (warp: transposed half spectrum on power-of-two padded grids; scipy: (2 ny, nx + 1)).
"""

import numpy as np
import pytest
import warp as wp

from warpcontact.fft.scipy_backend import ScipyFFT
from warpcontact.fft.warp_backend import WarpTileFFT

wp.config.quiet = True

DEVICES = ["cpu"] + ([pytest.param("cuda:0", marks=pytest.mark.gpu)] if wp.get_cuda_device_count() > 0 else [])
SIZES = [8, 9, 16, 25, 64]

# Error relative to max |result|. float64: a few ulps times the O(log2 M) butterfly stages.
# float32: rounding (eps ~ 6e-8) accumulates over the log2(M) butterfly stages of the forward and
# inverse transforms, and Warp's CPU radix-2 builds its twiddles by repeated multiplication, so
# errors of 1e-7..1e-6 are normal at these sizes; 1e-5 leaves a margin.
TOL_F64 = 1.0e-12
TOL_F32 = 1.0e-5


def _tol(dtype):
    return TOL_F64 if dtype == wp.float64 else TOL_F32


def _inputs(ny, nx, seed=0):
    """A positive field on (ny, nx) and random influence coefficients on (2 ny, 2 nx), wrap-around."""
    rng = np.random.default_rng(seed)
    return rng.random((ny, nx)), rng.standard_normal((2 * ny, 2 * nx))


def _numpy_dc_fft(field, kernel):
    """Zero-pad to (2 ny, 2 nx), multiply the spectra, transform back, keep the first (ny, nx)."""
    ny, nx = field.shape
    spectrum = np.fft.fft2(field, s=(2 * ny, 2 * nx)) * np.fft.fft2(kernel)
    return np.fft.ifft2(spectrum)[:ny, :nx].real


def _backend_convolution(fft, field, kernel):
    """forward, multiply by the spectrum of ``kernel`` (on the host), inverse, with backend ``fft``."""
    device = fft.device
    x = wp.array(np.asarray(field, dtype=fft.np_real), dtype=fft.dtype, device=device)
    spectrum = fft.alloc_spectra(1)[0]
    fft.forward(x, spectrum)

    s = spectrum.numpy().view(fft.np_complex).reshape(spectrum.shape)
    product = (s * fft.spectrum_of_padded(kernel)).astype(fft.np_complex)
    spectrum = wp.array(product.view(fft.np_real).reshape(*spectrum.shape, 2), dtype=fft.complex_dtype, device=device)

    out = wp.zeros((fft.ny, fft.nx), dtype=fft.dtype, device=device)
    fft.inverse(spectrum, out)
    return out.numpy().astype(np.float64)


def _rel_err(got, want):
    return np.abs(got - want).max() / np.abs(want).max()


@pytest.mark.parametrize("n", SIZES)
@pytest.mark.parametrize("dtype", [wp.float64, wp.float32], ids=["f64", "f32"])
@pytest.mark.parametrize("device", DEVICES)
def test_convolution_matches_numpy(device, dtype, n):
    field, kernel = _inputs(n, n)
    fft = WarpTileFFT(n, n, device, dtype)
    got = _backend_convolution(fft, field, kernel)
    # the reference sees the same rounded input as the backend
    want = _numpy_dc_fft(field.astype(fft.np_real).astype(np.float64), kernel)
    err = _rel_err(got, want)
    assert err < _tol(dtype), f"DC-FFT convolution n={n} {dtype.__name__} on {device}: relative error {err:.2e}"


@pytest.mark.parametrize("n", SIZES)
@pytest.mark.parametrize("device", DEVICES)
def test_convolution_matches_scipy_backend_f64(device, n):
    field, kernel = _inputs(n, n, seed=1)
    got = _backend_convolution(WarpTileFFT(n, n, device, wp.float64), field, kernel)
    want = _backend_convolution(ScipyFFT(n, n, "cpu", wp.float64), field, kernel)
    err = _rel_err(got, want)
    assert err < TOL_F64, f"warp vs scipy backend n={n} on {device}: relative error {err:.2e}"


@pytest.mark.parametrize("dtype", [wp.float64, wp.float32], ids=["f64", "f32"])
@pytest.mark.parametrize("device", DEVICES)
def test_rectangular_grid(device, dtype):
    ny, nx = 5, 12  # padded to 16 x 32
    field, kernel = _inputs(ny, nx, seed=2)
    got = _backend_convolution(WarpTileFFT(ny, nx, device, dtype), field, kernel)
    want = _numpy_dc_fft(field.astype(np.float32 if dtype == wp.float32 else np.float64).astype(np.float64), kernel)
    err = _rel_err(got, want)
    assert err < _tol(dtype), f"DC-FFT convolution {ny}x{nx} {dtype.__name__} on {device}: relative error {err:.2e}"


@pytest.mark.parametrize("device", DEVICES)
def test_forward_layout_matches_spectrum_of_padded(device):
    """forward(field) and spectrum_of_padded(field zero-padded to (2 ny, 2 nx)) share one layout."""
    ny, nx = 9, 7
    field, _ = _inputs(ny, nx, seed=3)
    fft = WarpTileFFT(ny, nx, device, wp.float64)
    spectrum = fft.alloc_spectra(1)[0]
    fft.forward(wp.array(field, dtype=wp.float64, device=device), spectrum)
    got = spectrum.numpy().view(np.complex128).reshape(fft.spectral_shape)

    padded = np.zeros(fft.padded_shape)
    padded[:ny, :nx] = field
    want = fft.spectrum_of_padded(padded)
    assert want.shape == fft.spectral_shape
    assert _rel_err(got, want) < TOL_F64


@pytest.mark.parametrize("device", DEVICES)
def test_rejects_bad_operands(device):
    fft = WarpTileFFT(8, 8, device, wp.float64)
    spectrum = fft.alloc_spectra(1)[0]
    with pytest.raises(ValueError, match="field"):
        fft.forward(wp.zeros((8, 9), dtype=wp.float64, device=device), spectrum)
    with pytest.raises(ValueError, match="field"):
        fft.forward(wp.zeros((8, 8), dtype=wp.float32, device=device), spectrum)
    with pytest.raises(ValueError, match="spectrum"):
        fft.inverse(wp.zeros((3, 3), dtype=wp.vec2d, device=device), wp.zeros((8, 8), dtype=wp.float64, device=device))
    with pytest.raises(ValueError, match="padded"):
        fft.spectrum_of_padded(np.zeros((8, 8)))


@pytest.mark.parametrize("device", DEVICES)
def test_rejects_grids_beyond_the_limit(device):
    with pytest.raises(ValueError, match="cells per axis"):
        WarpTileFFT(16, 8193, device, wp.float64)

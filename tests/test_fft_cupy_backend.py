"""The cupy backend (cuFFT plans) against numpy's DC-FFT, in both of its layouts: the pruned row
and column plans (the default, which skip the transforms of the zero padding) and the 2-D plans of
the whole padded grid. CUDA only: one skip where there is no CUDA device with CuPy."""

import numpy as np
import pytest
import warp as wp

from warpcontact.fft import cupy_backend

wp.config.quiet = True

if wp.get_cuda_device_count() == 0 or not cupy_backend.available():
    pytest.skip("no CUDA device with CuPy here", allow_module_level=True)

pytestmark = pytest.mark.gpu

from test_fft_warp_backend import _backend_convolution, _inputs, _numpy_dc_fft, _rel_err, _tol  # noqa: E402

SHAPES = [(8, 8), (9, 9), (25, 25), (64, 64), (12, 20), (33, 16)]


@pytest.mark.parametrize("shape", SHAPES, ids=lambda s: f"{s[0]}x{s[1]}")
@pytest.mark.parametrize("dtype", [wp.float64, wp.float32], ids=["f64", "f32"])
@pytest.mark.parametrize("pruned", [True, False], ids=["pruned", "2d"])
def test_convolution_matches_numpy(pruned, dtype, shape):
    ny, nx = shape
    field, kernel = _inputs(ny, nx, seed=ny + nx)
    fft = cupy_backend.CupyFFT(ny, nx, "cuda:0", dtype, pruned=pruned)
    got = _backend_convolution(fft, field, kernel)
    want = _numpy_dc_fft(field.astype(fft.np_real).astype(np.float64), kernel)
    err = _rel_err(got, want)
    assert err < _tol(dtype), f"cupy {'pruned' if pruned else '2-D'} {shape} {dtype.__name__}: relative error {err:.2e}"


def test_forward_spectra_of_both_layouts_agree():
    """The two layouts give the same spectrum of the padded field, (2 ny, nx + 1), numpy's rfft2
    layout, to float64 rounding: the operator's influence spectra serve either."""
    ny, nx = 24, 40
    field, _ = _inputs(ny, nx, seed=3)
    x = wp.array(field, dtype=wp.float64, device="cuda:0")
    spectra = []
    for pruned in (True, False):
        fft = cupy_backend.CupyFFT(ny, nx, "cuda:0", wp.float64, pruned=pruned)
        s = fft.alloc_spectra(1)[0]
        fft.forward(x, s)
        spectra.append(s.numpy().view(np.complex128).reshape(s.shape))
    want = np.fft.rfft2(field, s=(2 * ny, 2 * nx))
    for s in spectra:
        assert np.abs(s - want).max() < 1e-12 * np.abs(want).max()


@pytest.mark.parametrize("n", [127, 131, 1000, 2039, 3001, 4097])
def test_work_area_within_the_memory_estimate(n):
    """cuFFT's work area (the plans' shared buffer) stays within ``resources.cufft_work_spectra``,
    the allowance the memory estimate counts: sizes with and without large prime factors, where
    cuFFT uses Bluestein's algorithm or not (measured 0 to 6.46 spectra)."""
    from warpcontact.numerics.resources import cufft_work_spectra

    for dtype in (wp.float64, wp.float32):
        for pruned in (True, False):
            fft = cupy_backend.CupyFFT(n, n, "cuda:0", dtype, pruned=pruned)
            spectrum = 2 * n * (n + 1) * 2 * np.dtype(fft.np_real).itemsize
            assert fft.work_bytes <= cufft_work_spectra(n) * spectrum, (dtype, pruned, fft.work_bytes / spectrum)
            del fft


@pytest.mark.parametrize("shape", [(8, 8), (25, 25), (64, 64), (12, 20)], ids=lambda s: f"{s[0]}x{s[1]}")
@pytest.mark.parametrize("dtype", [wp.float64, wp.float32], ids=["f64", "f32"])
@pytest.mark.parametrize("pruned", [True, False], ids=["pruned", "2d"])
def test_influence_spectra_on_the_device(pruned, dtype, shape):
    """``influence_spectra`` (the operator's set-up: cuFFT on the device, in the backend's float
    type) gives the real and imaginary parts of the host's float64 spectra (numpy's rfft2 of the
    padded arrays) to the rounding of that type, for three arrays in a row; the forward pass's
    zero padding is intact afterwards (a convolution right after it is still numpy's)."""
    ny, nx = shape
    rng = np.random.default_rng(ny * nx)
    arrays = [rng.standard_normal((2 * ny, 2 * nx)) for _ in range(3)]
    parts = ["real", "imag", "real"]
    fft = cupy_backend.CupyFFT(ny, nx, "cuda:0", dtype, pruned=pruned)
    out = fft.alloc_influence(3)
    fft.influence_spectra(iter(arrays), parts, out, fft.alloc_spectra(1)[0])
    got = out.numpy()
    for k, (a, part) in enumerate(zip(arrays, parts)):
        spectrum = np.fft.rfft2(a.astype(fft.np_real).astype(np.float64))
        want = spectrum.real if part == "real" else spectrum.imag
        err = np.abs(got[k] - want).max() / np.abs(spectrum).max()
        assert err < _tol(dtype), (k, err)
    field, kernel = _inputs(ny, nx, seed=ny + nx)
    err = _rel_err(_backend_convolution(fft, field, kernel),
                   _numpy_dc_fft(field.astype(fft.np_real).astype(np.float64), kernel))
    assert err < _tol(dtype), err


def test_batched_plans_past_their_limit_keep_the_latest_and_transform_alike():
    """BatchedPlans with ``max_plans`` (the yield checks' library): past the limit the least
    recently used plan is destroyed, and transforms through re-made plans equal numpy's rfft2 to
    round-off (1e-12 relative in float64: the same transform, another order of sums)."""
    import cupy

    plans = cupy_backend.BatchedPlans(wp.get_stream("cuda:0").cuda_stream, max_plans=2)
    rng = np.random.default_rng(3)
    for m in (1, 2, 3, 1, 2):
        real = rng.standard_normal((m, 16, 16))
        spectra = cupy.empty((m, 16, 9), dtype=np.complex128)
        with cupy_backend.cupy_stream(wp.get_stream("cuda:0")):
            plans.execute(True, cupy.asarray(real), spectra)
        wp.synchronize_device("cuda:0")
        want = np.fft.rfft2(real)
        assert np.abs(spectra.get() - want).max() <= 1e-12 * np.abs(want).max()
        assert len(plans._plans) <= 2
    assert [key[1] for key in plans._plans] == [1, 2]


def test_cupy_views_warps_stream_without_a_warning():
    """CuPy's view of Warp's stream is the same CUDA stream, made without a warning (CuPy 14
    deprecates ``ExternalStream``: its warning was a line in every batched command's output)."""
    import warnings

    import cupy

    stream = wp.get_stream("cuda:0")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with cupy.cuda.Device(0):
            view = cupy_backend.cupy_stream(stream)
    assert view.ptr == stream.cuda_stream

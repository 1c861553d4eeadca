"""The FFTW backend (pyFFTW, an optional extra) against the scipy backend it shares a layout with.

Both hold their spectra as (2 ny, nx + 1) with the real transform along x, so spectra and
convolutions are compared entry by entry. Without pyFFTW these tests are skipped, with the reason
in pytest's summary (the test extra installs it: CI runs them).
"""

import json
import os
import subprocess
import sys
import tracemalloc

import numpy as np
import pytest
import warp as wp
from conftest import NEEDS_FFTW

from warpcontact.errors import InputError
from warpcontact.fft import fftw_backend, make_fft
from warpcontact.fft.scipy_backend import ScipyFFT

pytestmark = NEEDS_FFTW

# Both backends compute the same exact DFTs with different algorithms: they differ by rounding,
# a few ulps times the log2 of the transform length (2 n <= 256 here): float64 1e-13, float32 1e-5
# relative to the largest entry (as in test_fft_warp_backend.py).
TOL = {wp.float64: 1e-13, wp.float32: 1e-5}
SHAPES = [(8, 8), (17, 17), (25, 40), (100, 100), (127, 64)]


def _field(ny, nx, seed=0):
    return np.random.default_rng(seed).random((ny, nx))


@pytest.mark.parametrize("shape", SHAPES, ids=lambda s: f"{s[0]}x{s[1]}")
@pytest.mark.parametrize("dtype", [wp.float64, wp.float32], ids=["f64", "f32"])
def test_spectra_and_inverse_match_scipy(shape, dtype):
    """forward and inverse (with the padding and cropping passes), and the padded-buffer path the
    solvers use (transform_input / transform_to_output, scaled by output_scale), on square,
    rectangular, odd and prime sizes."""
    ny, nx = shape
    ref, fftw = ScipyFFT(ny, nx, "cpu", dtype), make_fft("fftw", ny, nx, "cpu", dtype)
    assert fftw.spectral_shape == ref.spectral_shape and fftw.half_axis == ref.half_axis
    field = wp.array(_field(ny, nx).astype(ref.np_real), dtype=dtype, device="cpu")
    spectra = {}
    for name, backend in (("scipy", ref), ("fftw", fftw)):
        s = backend.alloc_spectra(1)[0]
        backend.forward(field, s)
        spectra[name] = s.numpy().copy()
        out = wp.zeros((ny, nx), dtype=dtype, device="cpu")
        backend.inverse(s, out)  # the inverse of the forward: the field itself
        assert np.abs(out.numpy() - field.numpy()).max() < TOL[dtype], name
    scale = np.abs(spectra["scipy"]).max()
    assert np.abs(spectra["fftw"] - spectra["scipy"]).max() < TOL[dtype] * scale

    # the padded buffers: a field written into the corner of padded_input, the result read from the
    # corner of padded_output times output_scale
    corners = {}
    for name, backend in (("scipy", ref), ("fftw", fftw)):
        backend.padded_input.numpy()[:ny, :nx] = 2.0 * field.numpy()
        s = backend.alloc_spectra(1)[0]
        backend.transform_input(s)
        backend.transform_to_output(s)
        corners[name] = backend.padded_output.numpy()[:ny, :nx] * float(backend.output_scale)
    assert np.abs(corners["fftw"] - corners["scipy"]).max() < TOL[dtype] * 2.0
    assert np.abs(corners["fftw"] - 2.0 * field.numpy()).max() < TOL[dtype] * 2.0


def test_plans_are_made_once_per_spectrum_and_transforms_allocate_nothing():
    """Each spectrum array gets its four plans on first use and keeps them; a transform pair
    then allocates no numpy temporaries (tracemalloc: under 64 KiB, against 1.6 MiB for one
    spectrum at n = 128; scipy's pair allocates about two spectra)."""
    n = 128
    fftw = make_fft("fftw", n, n, "cpu", wp.float64)
    spectra = [fftw.alloc_spectra(1)[0] for _ in range(3)]
    fftw.padded_input.numpy()[:n, :n] = _field(n, n)
    for s in spectra + spectra:
        fftw.transform_input(s)
        fftw.transform_to_output(s)
    assert len(fftw._plans) == 3
    tracemalloc.start()
    try:
        base = tracemalloc.get_traced_memory()[0]
        for s in spectra:
            fftw.transform_input(s)
            fftw.transform_to_output(s)
        peak = tracemalloc.get_traced_memory()[1] - base
    finally:
        tracemalloc.stop()
    assert peak < 64 * 1024, peak


@pytest.mark.parametrize("preset", [None, "ACTIVE"])
def test_openmp_threads_wait_passively_unless_the_user_chose(preset):
    """Importing the backend sets OMP_WAIT_POLICY=PASSIVE before pyFFTW starts OpenMP (spinning
    idle threads took a core from the solver's passes), and keeps a value the user set."""
    env = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
    if preset:
        env["OMP_WAIT_POLICY"] = preset
    code = "import os, warpcontact.fft.fftw_backend as f; f.available(); print(os.environ['OMP_WAIT_POLICY'])"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.strip().splitlines()[-1] == (preset or "PASSIVE")


@NEEDS_FFTW
def test_small_grids_transform_on_one_thread(monkeypatch):
    """Threads cost more than they save on small grids (a transform pair on 2 cores: FFTW 0.217
    against 0.028 ms at n = 32, scipy 0.377 against 0.105 ms at 64): each backend starts them from
    its THREADS_FROM_CELLS on; an explicit count is kept."""
    from warpcontact.fft.fftw_backend import FFTWBackend

    monkeypatch.setattr(os, "cpu_count", lambda: 8)
    assert FFTWBackend(64, 64, "cpu", wp.float64).workers == 1
    assert FFTWBackend(128, 128, "cpu", wp.float64).workers == 1
    assert FFTWBackend(256, 256, "cpu", wp.float64).workers == 8
    assert ScipyFFT(512, 512, "cpu", wp.float64).workers == 1
    assert ScipyFFT(64, 64, "cpu", wp.float64, workers=3).workers == 3
    assert FFTWBackend.THREADS_FROM_CELLS < ScipyFFT.THREADS_FROM_CELLS


def test_auto_picks_fftw_on_the_cpu():
    from warpcontact.fft import available_backends

    assert available_backends("cpu")[0] == "fftw"
    assert make_fft("auto", 8, 8, "cpu", wp.float64).name == "fftw"


def test_asking_for_fftw_without_pyfftw_says_how_to_install(monkeypatch):
    monkeypatch.setattr(fftw_backend, "available", lambda: False)
    with pytest.raises(InputError) as e:
        make_fft("fftw", 8, 8, "cpu", wp.float64)
    assert e.value.key == "solver.fft" and "pip install 'warpcontact[fftw]'" in str(e.value), str(e.value)
    assert make_fft("auto", 8, 8, "cpu", wp.float64).name == "scipy"


def _measured_backend(n, monkeypatch, wisdom_file):
    """A backend with measured plans and ``wisdom_file`` as the kept wisdom, this process's wisdom
    forgotten first (earlier tests' grids from 48 cells on have measured plans already, and the
    wisdom they left would be used instead of measuring)."""
    import pyfftw

    pyfftw.forget_wisdom()
    monkeypatch.setenv("WARPCONTACT_FFTW_WISDOM", str(wisdom_file))
    monkeypatch.setattr(fftw_backend, "_wisdom_loaded", False)
    return fftw_backend.FFTWBackend(n, n, "cpu", wp.float64, measure=True)


def test_measured_plans_leave_the_arrays_alone_and_keep_their_wisdom(monkeypatch, tmp_path):
    """FFTW_MEASURE runs transforms on the arrays it plans for: the backend measures on scratch
    arrays, so a field already in the padded input and a spectrum already computed survive the
    planning, and the results equal the estimated plans' to rounding. The wisdom goes to the kept
    file, which a new process loads: it then plans from wisdom alone (FFTW_WISDOM_ONLY fails
    without it)."""
    n, wisdom = 48, tmp_path / "wisdom.json"
    measured = _measured_backend(n, monkeypatch, wisdom)
    estimated = fftw_backend.FFTWBackend(n, n, "cpu", wp.float64, measure=False)
    field = _field(n, n, seed=3)
    results = []
    for backend in (measured, estimated):
        s = backend.alloc_spectra(1)[0]
        view = backend._complex_view(s)
        view[...] = 1.0 + 2.0j  # what planning on this array would overwrite
        backend.padded_input.numpy()[:n, :n] = field
        before = backend.padded_input.numpy().copy()
        backend._plans_for(s)
        assert np.array_equal(backend.padded_input.numpy(), before) and np.all(view == 1.0 + 2.0j)
        backend.transform_input(s)
        spectrum = view.copy()
        backend.transform_to_output(s)
        results.append((spectrum, backend.padded_output.numpy()[:n, :n] * float(backend.output_scale)))
    assert np.abs(results[0][0] - results[1][0]).max() < TOL[wp.float64] * np.abs(results[1][0]).max()
    assert np.abs(results[0][1] - field).max() < TOL[wp.float64]
    assert wisdom.exists()

    code = f"""
import pyfftw, warp as wp
from warpcontact.fft import fftw_backend
b = fftw_backend.FFTWBackend({n}, {n}, "cpu", wp.float64)
arrays = (b._rows, b._complex_view(b.alloc_spectra(1)[0]), b._output, b.workers)
try:
    fftw_backend.FFTWPlans(*arrays, ("FFTW_MEASURE", "FFTW_WISDOM_ONLY"))
    print("without wisdom: planned")
except RuntimeError:
    print("without wisdom: refused")
fftw_backend._load_wisdom()
fftw_backend.FFTWPlans(*arrays, ("FFTW_MEASURE", "FFTW_WISDOM_ONLY"))
print("with the kept wisdom: planned")
"""
    env = {**os.environ, "WARPCONTACT_FFTW_WISDOM": str(wisdom)}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.split("\n")[-3:-1] == ["without wisdom: refused", "with the kept wisdom: planned"], out.stdout


def test_a_damaged_wisdom_file_is_measured_again(monkeypatch, tmp_path):
    wisdom = tmp_path / "wisdom.json"
    wisdom.write_text("{not json")
    backend = _measured_backend(40, monkeypatch, wisdom)
    backend._plans_for(backend.alloc_spectra(1)[0])
    assert isinstance(json.loads(wisdom.read_text()), list)


def test_a_transient_grid_plans_from_wisdom_or_estimates(monkeypatch, tmp_path):
    """A backend marked transient (a tangential solve's window) measures nothing: without wisdom
    for its layout its plans are estimated and no wisdom is written; with wisdom for it (a grid
    of that size measured before) its plans come from the wisdom."""
    n, wisdom = 56, tmp_path / "wisdom.json"
    window = _measured_backend(n, monkeypatch, wisdom)
    window.transient()
    plans = window._plans_for(window.alloc_spectra(1)[0])
    assert "FFTW_ESTIMATE" in plans.rows_forward.flags and not wisdom.exists()
    _measured_backend(n, monkeypatch, wisdom)._plans_for(window.alloc_spectra(1)[0])  # a grid of this size measured
    assert wisdom.exists()
    later = fftw_backend.FFTWBackend(n, n, "cpu", wp.float64, measure=True)
    later.transient()
    plans = later._plans_for(later.alloc_spectra(1)[0])
    assert "FFTW_WISDOM_ONLY" in plans.rows_forward.flags


def test_no_wisdom_file_when_switched_off(monkeypatch, tmp_path):
    monkeypatch.setenv("WARPCONTACT_FFTW_WISDOM", "")
    monkeypatch.setattr(fftw_backend, "_wisdom_loaded", False)
    monkeypatch.setattr(fftw_backend, "WISDOM_FOLDER", tmp_path)
    assert fftw_backend.wisdom_path() is None
    backend = fftw_backend.FFTWBackend(40, 40, "cpu", wp.float64, measure=True)
    backend._plans_for(backend.alloc_spectra(1)[0])
    assert list(tmp_path.iterdir()) == []


def test_grids_from_48_cells_per_side_get_measured_plans():
    assert not fftw_backend.FFTWBackend(47, 48, "cpu", wp.float64).measure
    assert fftw_backend.FFTWBackend(48, 48, "cpu", wp.float64).measure


def test_the_wisdom_file_is_per_machine_in_the_cache_folder(monkeypatch, tmp_path):
    monkeypatch.delenv("WARPCONTACT_FFTW_WISDOM", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    path = fftw_backend.wisdom_path()
    assert path.parent == tmp_path / "warpcontact" and path.name.startswith("fftw-wisdom-")
    monkeypatch.setattr(fftw_backend, "WISDOM_FOLDER", tmp_path / "elsewhere")
    assert fftw_backend.wisdom_path().parent == tmp_path / "elsewhere"

"""Shared test set-up: one test per available device, opt-in slow studies."""

import signal

import pytest
import warp as wp

from warpcontact.fft import fftw_backend

wp.config.quiet = True
wp.config.log_level = wp.LOG_WARNING
wp.init()

DEVICES = ["cpu"] + [f"cuda:{i}" for i in range(wp.get_cuda_device_count())]

#: for the FFTW backend's cases: skipped, with the reason in the summary, where pyFFTW is missing
#: (the test extra installs it)
NEEDS_FFTW = pytest.mark.skipif(
    not fftw_backend.available(),
    reason="pyFFTW is not installed (pip install 'warpcontact[fftw]'): fftw backend untested")


def pytest_addoption(parser):
    parser.addoption("--runslow", action="store_true", help="run the slow validation studies (minutes)")


def pytest_configure(config):
    config.addinivalue_line("markers", "slow: long validation studies; opt in with --runslow")
    config.addinivalue_line("markers", "gpu: the CUDA-device half of a device test (pytest -m gpu runs only those)")


def pytest_collection_modifyitems(config, items):
    if config.getoption("--runslow"):
        return
    skip = pytest.mark.skip(reason="slow study: opt in with --runslow")
    for item in items:
        if "slow" in item.keywords:
            item.add_marker(skip)


def pytest_report_header(config):
    return f"warpcontact test devices: {', '.join(DEVICES)}"


@pytest.fixture(params=[pytest.param(d, marks=pytest.mark.gpu) if d.startswith("cuda") else d for d in DEVICES])
def device(request):
    """Every device present: the CPU always, each CUDA device when there is one."""
    return request.param


@pytest.fixture
def handlers():
    """interrupts.install() in this process (SIGTERM and SIGHUP from their defaults), pytest's
    handlers put back afterwards: the stop-signal tests of the commands."""
    from warpcontact import interrupts

    saved = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.signal(signal.SIGHUP, signal.SIG_DFL)
    interrupts.reset()
    interrupts.install()
    yield interrupts
    for s, h in saved.items():
        signal.signal(s, h)
    interrupts.reset()


@pytest.fixture
def small_normal_windows(monkeypatch):
    """Normal solves' windows placed as if the approach were a sixth of the solve's, with no
    margin, so that the contact outgrows them; returns the windows chosen ((row0, col0, cells), or
    None for the whole grid), and undoes the change where a test calls ``monkeypatch.undo()``."""
    from warpcontact.solvers import normal as normal_module
    from warpcontact.solvers.normal import NormalSolver

    monkeypatch.setattr(normal_module, "WINDOW_MARGIN", 0.0)
    original = NormalSolver._window_for
    chosen = []

    def small(self, state, approach_z, known):
        window = original(self, state, approach_z / 6, known)
        chosen.append(None if window is None else (window.row0, window.col0, window.cells))
        return window

    monkeypatch.setattr(NormalSolver, "_window_for", small)
    return chosen

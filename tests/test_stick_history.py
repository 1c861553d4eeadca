"""The stick shear of a dissimilar pair depends on when each cell entered the contact: a normal
leg in N steps leaves a staircase in the stick zone's q_x that shrinks about as 1/N towards the
profile of a continuous loading (validation/stick_history.py, docs/limits.md). Not the solver's
tolerance: the same steps at tol 1e-13 give the same q_x."""

import importlib.util
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
spec = importlib.util.spec_from_file_location("stick_history", ROOT / "validation" / "stick_history.py")
stick_history = importlib.util.module_from_spec(spec)
spec.loader.exec_module(stick_history)


@pytest.fixture(scope="module")
def rows():
    return {steps: stick_history.centre_row(32, steps) for steps in (4, 16, 64)}


def test_the_staircase_shrinks_with_the_normal_steps(rows):
    """Against 64 steps, q_x of the stick zone lies 3-5 times closer after 16 steps than after 4
    (1/N: 4 times; measured at n = 64: 63, 22, 7 MPa RMS after 1, 8, 32 steps against 128)."""
    _, ref_qx, ref_stick, _, _ = rows[64]
    rms = {}
    for steps in (4, 16):
        _, qx, stick, _, converged = rows[steps]
        assert converged
        rms[steps], _ = stick_history.deviation(qx, stick, ref_qx, ref_stick)
    assert rms[16] > 0.0
    assert 2.5 < rms[4] / rms[16] < 6.0, rms


def test_the_staircase_is_not_the_tolerance(monkeypatch):
    """The same path solved to 1e-13 instead of 1e-10: q_x of the stick cells the same to 1e-6 of
    its largest value (the staircase is 10 % of it)."""
    base = stick_history.case(32, 4)
    tight = stick_history.case(32, 4)
    tight["solver"]["tol"] = 1e-13
    import warnings

    import numpy as np

    import warpcontact as wc

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        a = wc.solve(base, fields="last").fields[-1]
        b = wc.solve(tight, fields="last").fields[-1]
    stick = (a["status"] == 1) & (b["status"] == 1)
    scale = np.abs(a["shear_x"][stick]).max()
    assert np.max(np.abs(a["shear_x"][stick] - b["shear_x"][stick])) < 1e-6 * scale

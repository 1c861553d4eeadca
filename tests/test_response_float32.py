"""The tangential solves' response K t in float32 beside float64 fields (``response_float32``):
the operator's product rounded to float32, and the same answers as the float64 product's."""

import sys
from pathlib import Path

import numpy as np
import pytest

from warpcontact.physics.geometry import Grid, Sphere
from warpcontact.physics.materials import PAPER_PAIR
from warpcontact.numerics.model import ContactModel
from warpcontact.solvers.settings import RESPONSE_FLOAT32_AUTO, float32_chosen

from test_tangential_precond import A, R, assert_same_shear, coupled_step, mindlin_step


@pytest.mark.parametrize("fft", ["auto", "warp"])
def test_the_float32_response_is_the_operator_rounded_to_float32(device, fft):
    """``ElasticOperator.tangential`` on its float32 transforms (``response_transforms``) against
    the float64 product on a random shear: within 1e-5 of the largest displacement (float32's
    rounding through two transforms of 2n points per side, about 1e-7 a pass times the sum's
    growth; measured 1.8e-7 at n = 40 with FFTW and scipy, 1.6e-6 with the warp backend's own
    transforms), and not equal to it (the float32 path ran: the float64 one differs from itself
    by nothing)."""
    n = 40
    model = ContactModel(PAPER_PAIR, Sphere(R), Grid(n, 4 * A), device=device, dtype="float64", fft=fft)
    rng = np.random.default_rng(7)
    qx, qy = (model.field(a) for a in rng.standard_normal((2, n, n)))
    exact = [model.field() for _ in range(2)]
    rounded = [model.field() for _ in range(2)]
    model.operator.tangential(qx, qy, *exact)
    model.operator.tangential(qx, qy, *rounded, model.operator.response_transforms())
    u0 = np.stack([a.numpy() for a in exact])
    u1 = np.stack([a.numpy() for a in rounded])
    error = np.abs(u1 - u0).max() / np.abs(u0).max()
    assert 0 < error < 1e-5, error


@pytest.mark.parametrize("case", ["mindlin", "coupled"])
def test_a_float32_response_reaches_the_same_shear(case, device):
    """The response rounded to float32 changes the step lengths and the carried gradient, not the
    problem: the gradient is made exact in float64 where the loop settles and the solve is judged
    on it, so the solves meet 1e-10 and the shear, forces and statuses agree with the float64
    response's as any two iterations that meet it do (``assert_same_shear``: 1000 tolerances of the
    largest shear, 10 of the forces; measured 2.6e-9 and 5.5e-11 on the Mindlin step at n = 64).
    Iterations: at most a fifth more plus two (measured 26 against 26)."""
    tol = 1e-10
    if case == "mindlin":
        (a, info_a, _), (b, info_b, _) = (mindlin_step(64, device, "float64", True, response_float32=f)
                                          for f in (False, True))
        assert info_b.converged and info_b.residual < tol
        assert info_b.iterations <= 1.2 * info_a.iterations + 2, (info_a, info_b)
    else:
        a, b = (coupled_step(device, "float64", True, response_float32=f) for f in (False, True))
    assert_same_shear(a, b, tol)


@pytest.mark.parametrize("path", ["figure2c", "figure2d"])
def test_a_whole_path_with_a_float32_response(path):
    """Figure 2c and 2d (with SMC adhesion) at n = 64 on the CPU, 16 states, windows on: every
    state converged either way, the forces of every state within 1e-7 of the largest (the turns
    end at a change of 100 tolerances, 1e-8; measured 1.8e-10 and 4.5e-11) and the path's inner
    iterations within a tenth plus 20 of the float64 response's (measured 636 against 629, 798
    against 793)."""
    import warpcontact as wc

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bench"))
    import paths

    results = {}
    for float32 in (False, True):
        case = paths.case_dict(path)
        case["grid"]["n"] = 64
        case["solver"].update(device="cpu", window=True, response_float32=float32)
        states = wc.solve(case, fields="none").states
        assert all(s["converged"] for s in states), float32
        forces = np.array([[s["force"][k] for k in ("x", "y", "z")] for s in states])
        results[float32] = forces, sum(int(s["iterations"]) for s in states)
    (f0, it0), (f1, it1) = results[False], results[True]
    assert np.abs(f1 - f0).max() <= 1e-7 * np.abs(f0).max(), np.abs(f1 - f0).max() / np.abs(f0).max()
    assert it1 <= 1.1 * it0 + 20, (it0, it1)


def test_auto_chooses_by_grid_and_device():
    """"auto" follows ``RESPONSE_FLOAT32_AUTO``: off on the small grids of either device, on on
    the large ones, never beside float32 fields."""
    for cuda in (True, False):
        assert not float32_chosen("auto", RESPONSE_FLOAT32_AUTO, 256, cuda, True)
        assert float32_chosen("auto", RESPONSE_FLOAT32_AUTO, 4096, cuda, True)
        assert not float32_chosen("auto", RESPONSE_FLOAT32_AUTO, 4096, cuda, False)  # (float32 fields)

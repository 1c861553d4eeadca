"""The preconditioners' circulants on the grid itself (``SolverSettings.preconditioner_grid =
"periodic"``): T. Chan's optimal circulants of K_zz and K_tt, their transforms of n^2 entries, and
solves and paths that reach the answers of the padded circulant's (the DC-FFT's own)."""

import math
import sys
from pathlib import Path

import numpy as np
import pytest
import warp as wp

from warpcontact.fft import available_backends, make_periodic_fft
from warpcontact.numerics.model import ContactModel
from warpcontact.numerics.state import ContactState
from warpcontact.physics.geometry import Grid, Sphere
from warpcontact.physics.influence import chan_circulant, influence_coefficients
from warpcontact.physics.materials import PAPER_PAIR
from warpcontact.records.results import state_summary
from warpcontact.solvers.normal import NormalSolver
from warpcontact.solvers.tangential import TangentialSolver

from test_tangential_precond import assert_same_shear, coupled_step, mindlin_step

R, DZ = 10e-6, 1.0e-10
A = math.sqrt(R * DZ)


def chan_reference(padded: np.ndarray) -> np.ndarray:
    """T. Chan's circulant from the (2 ny, 2 nx) wrap-around coefficients, written out: the offset
    j (0 <= j < n) weighted (n - j) / n and its image j - n weighted j / n, along each axis."""
    ny, nx = padded.shape[0] // 2, padded.shape[1] // 2
    wy, wx = (np.arange(ny) / ny), (np.arange(nx) / nx)
    out = np.zeros((ny, nx))
    for image_y, weight_y in ((0, 1 - wy), (ny, wy)):
        for image_x, weight_x in ((0, 1 - wx), (nx, wx)):
            out += np.outer(weight_y, weight_x) * padded[image_y:image_y + ny, image_x:image_x + nx]
    return out


@pytest.mark.parametrize("ny, nx", [(8, 8), (9, 9), (6, 11)])
def test_chan_circulant_weights_the_two_images_of_each_offset(ny, nx):
    """The kernel (``kernels/influence.py``) against the formula written out in NumPy, on each
    kernel's coefficients: equal to the rounding of four products (4 eps of the largest)."""
    coeffs = influence_coefficients(PAPER_PAIR, ny, nx, 1e-9, 1.3e-9)
    for name, padded in coeffs.items():
        want = chan_reference(padded)
        got = chan_circulant(padded)
        assert got.shape == (ny, nx)
        assert np.abs(got - want).max() <= 4 * np.finfo(np.float64).eps * np.abs(padded).max(), name


def periodic_backends(device: str) -> list[str]:
    return [b for b in available_backends(device) if b != "warp"]


@pytest.mark.parametrize("dtype", ["float64", "float32"])
@pytest.mark.parametrize("n", [16, 15])
def test_periodic_transforms_are_numpys_rfft2(device, dtype, n):
    """Each backend's periodic transforms (``make_periodic_fft``) of a random field: the spectrum
    is ``numpy.fft.rfft2``'s and the inverse times ``output_scale`` gives the field back, within
    the transforms' rounding (1e-12 in float64, 1e-5 in float32, of the largest entry: measured
    at the level of eps); the Parseval constants are those of the (n, n) grid."""
    wdtype = getattr(wp, dtype)
    rng = np.random.default_rng(3)
    field = rng.standard_normal((n, n))
    rel = 1e-12 if dtype == "float64" else 1e-5
    for name in periodic_backends(device):
        fft = make_periodic_fft(name, n, n, device, wdtype)
        assert fft.periodic and fft.padded_shape == (n, n) and fft.spectral_shape == (n, n // 2 + 1)
        assert fft.half_length == n and float(fft.energy_scale) == pytest.approx(1.0 / (n * n), rel=1e-7)
        spectrum = fft.alloc_spectra(1)[0]
        fft.padded_input.assign(field.astype(fft.np_real))
        fft.transform_input(spectrum)
        got = spectrum.numpy().astype(np.float64)
        want = np.fft.rfft2(field)
        assert np.abs(got[..., 0] + 1j * got[..., 1] - want).max() <= rel * np.abs(want).max(), name
        fft.transform_to_output(spectrum)
        back = fft.padded_output.numpy().astype(np.float64) * float(fft.output_scale)
        assert np.abs(back - field).max() <= rel * np.abs(field).max(), name


def test_the_warp_backend_keeps_the_padded_circulant():
    """The ``warp`` backend has no periodic transforms: its operator offers none, and a solver set
    to "periodic" runs on the padded grid (the same transforms as "padded")."""
    model = ContactModel(PAPER_PAIR, Sphere(R), Grid(16, 4 * A), fft="warp")
    assert not model.operator.has_periodic_preconditioner
    assert make_periodic_fft("warp", 16, 16, "cpu", wp.float64) is None
    solver = NormalSolver(model, preconditioner_grid="periodic")
    assert solver.preconditioner_transforms().fft is model.operator.fft


@pytest.mark.parametrize("dtype", ["float64", "float32"])
@pytest.mark.parametrize("n", [32, 33])
def test_periodic_tangential_preconditioner_is_chans_floored_inverse(device, dtype, n):
    """M g on the grid itself (``tangential_inverse_padded`` on the periodic transforms) against a
    NumPy reference: the 2x2 blocks of the Chan circulants' spectra (``chan_reference``)
    diagonalised by ``np.linalg.eigh``, eigenvalues floored at the solver's floor, inverted; and
    its sum g . M g against the sum over the cells. Within 1e-12 (float64) and 1e-5 (float32) of
    the largest entry, 1e-11 and 1e-4 of the sum (the bounds of the padded preconditioner's
    test in test_tangential_precond.py: the transforms' rounding)."""
    model = ContactModel(PAPER_PAIR, Sphere(R), Grid(n, 4 * A), device=device, dtype=dtype)
    solver = TangentialSolver(model)
    inverse = model.operator.inverse_transforms(periodic=True)
    assert inverse.fft.periodic
    rng = np.random.default_rng(1)
    gx, gy = rng.standard_normal((2, n, n))
    scale = PAPER_PAIR.E_star / model.grid.dx
    coeffs = influence_coefficients(PAPER_PAIR, n, n, model.grid.dx, model.grid.dx)
    kxx, kyy, kxy = (np.fft.rfft2(chan_reference(coeffs[k] * scale)).real for k in ("xx", "yy", "xy"))
    blocks = np.stack([np.stack([kxx, kxy], -1), np.stack([kxy, kyy], -1)], -2)
    values, vectors = np.linalg.eigh(blocks)
    m = np.einsum("...ik,...k,...jk->...ij", vectors, 1.0 / np.maximum(values, solver.eigen_floor), vectors)
    fx, fy = np.fft.rfft2(gx), np.fft.rfft2(gy)
    zx = np.fft.irfft2(m[..., 0, 0] * fx + m[..., 0, 1] * fy, s=(n, n))
    zy = np.fft.irfft2(m[..., 1, 0] * fx + m[..., 1, 1] * fy, s=(n, n))
    out = []

    def fill(g):
        return lambda: inverse.fft.padded_input.assign(g.astype(inverse.fft.np_real))

    def use():
        out.append(inverse.fft.padded_output.numpy().astype(np.float64) * float(inverse.fft.output_scale))

    energy = model.scalars(2)
    model.operator.tangential_inverse_padded(fill(gx), fill(gy), use, use, energy, 1, solver.eigen_floor, inverse)
    rel = 1e-12 if dtype == "float64" else 1e-5
    for got, want in zip(out, (zx, zy)):
        assert np.abs(got - want).max() <= rel * np.abs(want).max()
    total = float((gx * zx + gy * zy).sum())
    assert float(energy.numpy()[1]) == pytest.approx(total, rel=100 * rel)


def hertz_solve(device, grid: str):
    model = ContactModel(PAPER_PAIR, Sphere(R, "paraboloid"), Grid(96, 4 * A), device=device)
    state = ContactState(model)
    info = NormalSolver(model, preconditioner_grid=grid).solve(state, DZ)
    assert info.converged and info.residual < 1e-10, info
    return state.pressure.numpy(), info.iterations


def test_the_normal_solve_reaches_the_padded_circulants_pressure(device):
    """Hertz at n = 96: the solve preconditioned on the grid itself meets 1e-10, its pressure
    within 100 tolerances of the peak of the padded circulant's (two solves that meet 1e-10:
    test_hertz.py's bound), in at most a fifth more iterations plus two (Chan's circulant is as
    near K_zz as the padded one: measured the same counts)."""
    (p0, it0), (p1, it1) = (hertz_solve(device, grid) for grid in ("padded", "periodic"))
    assert np.abs(p1 - p0).max() < 100 * 1e-10 * p0.max()
    assert it1 <= 1.2 * it0 + 2, (it0, it1)


@pytest.mark.parametrize("case", ["mindlin", "coupled"])
def test_the_tangential_solve_reaches_the_padded_circulants_shear(case, device):
    """The Mindlin step (n = 64) and the coupled step (n = 48) with both preconditioners on the grid
    itself: the shear within 1000 tolerances of its largest cell, F_x and F_z within 10, the same
    stick and slip cells (test_tangential_precond.py's bounds for two iterations that meet
    1e-10); the Mindlin solve in at most a fifth more iterations plus two."""
    tol = 1e-10
    if case == "mindlin":
        (a, info_a, _), (b, info_b, _) = (mindlin_step(64, device, "float64", True, preconditioner_grid=g)
                                          for g in ("padded", "periodic"))
        assert info_b.converged and info_b.iterations <= 1.2 * info_a.iterations + 2, (info_a, info_b)
    else:
        a, b = (coupled_step(device, "float64", True, preconditioner_grid=g) for g in ("padded", "periodic"))
    assert_same_shear(a, b, tol)


@pytest.mark.parametrize("path", ["figure2c", "figure2d"])
def test_a_whole_path_reaches_the_padded_circulants_forces(path):
    """Figure 2c and 2d (with SMC adhesion) at n = 64 on the CPU, 16 states, with the windows and
    the float32 preconditioners forced on (the choices of large grids): every state converged
    either way, the forces of every state within 1e-7 of the largest (the turns end at a change
    of 100 tolerances, 1e-8; measured here 1.3e-10 and 4.8e-9, and 1.2e-10-2.5e-7 at n = 512-4096),
    and the path's inner iterations within a tenth plus 20 of the padded circulant's (measured
    here 639 against 650 and 803 against 799; -7 % to +3 % at n = 64-4096)."""
    import warpcontact as wc

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bench"))
    import paths

    results = {}
    for grid in ("padded", "periodic"):
        case = paths.case_dict(path)
        case["grid"]["n"] = 64
        case["solver"].update(device="cpu", window=True, preconditioner_float32=True, preconditioner_grid=grid)
        states = wc.solve(case, fields="none").states
        assert all(s["converged"] for s in states), grid
        forces = np.array([[s["force"][k] for k in ("x", "y", "z")] for s in states])
        results[grid] = forces, sum(int(s["iterations"]) for s in states)
    (f0, it0), (f1, it1) = results["padded"], results["periodic"]
    assert np.abs(f1 - f0).max() <= 1e-7 * np.abs(f0).max(), np.abs(f1 - f0).max() / np.abs(f0).max()
    assert it1 <= 1.1 * it0 + 20, (it0, it1)


def test_adhesive_turns_end_within_their_path_dependence():
    """An adhesive Table 2 cell (SMC, k_tau 0.8, delta_z 1e-4 um, n = 48: the grid of 60 cells of
    test_tangential_window.py), delta_z then delta_x = 2e-11 m, the lagged turns. Without adhesion
    the two circulants' solves converge to one answer as the tolerance falls (measured 1.8e-12 of
    the largest pressure at tol 1e-13); with adhesion they end 2.0e-7 apart at every tolerance from
    1e-10 to 1e-13 (the adhesive pressure 2.2e-4 apart at one cell just outside the contact, where
    the law is steepest): the lagged fixed point's edge cells keep the path the iterates took (the
    padded circulant's solves on a window and on the whole grid also end 3e-6 apart there at 1e-12).
    Held here: the same stick and slip cells, the forces within 1e-8 (measured 2.4e-9) and the
    contact pressure within 1e-6 of its largest (measured 2.0e-7), the bound on a method change's
    answer; both converged."""
    from warpcontact.physics.friction import TaborVonMises
    from warpcontact.solvers.contact import ContactSolver
    from warpcontact.studies import table2 as t2

    settings = t2.Table2Settings(n=48)
    law = settings.adhesion_law()
    dz = 1e-4 * t2.UM
    out = {}
    for grid in ("padded", "periodic"):
        model = ContactModel(PAPER_PAIR, Sphere(t2.RADIUS), t2.cell_grid(dz, settings, law))
        solver = ContactSolver(model, TaborVonMises(0.8, PAPER_PAIR.softer.yield_strength), adhesion=law,
                               turns="lagged", preconditioner_grid=grid)
        state = ContactState(model)
        for approach in ((0.0, 0.0, dz), (2.0e-11, 0.0, dz)):
            assert solver.step(state, approach).converged, grid
        out[grid] = state.to_numpy_si(), state.status.numpy().copy(), state_summary(state)["force"]
    (a, status_a, f_a), (b, status_b, f_b) = out["padded"], out["periodic"]
    assert np.array_equal(status_a, status_b)
    for c in ("x", "z"):
        assert abs(f_b[c] / f_a[c] - 1) < 1e-8, (c, f_a, f_b)
    assert np.abs(b["pressure"] - a["pressure"]).max() < 1e-6 * np.abs(a["pressure"]).max()


def block_inverse_reference(pair, n: int, gx: np.ndarray, gy: np.ndarray):
    """M g of the batched solves' scaled units (dx = 1, kernels times E*): the Chan circulants'
    2x2 blocks inverted with their eigenvalues floored at a quarter of the self-influence."""
    coeffs = influence_coefficients(pair, n, n, 1.0, 1.0)
    kxx, kyy, kxy = (np.fft.rfft2(chan_reference(coeffs[k] * pair.E_star)).real for k in ("xx", "yy", "xy"))
    floor = 0.25 * 0.5 * (coeffs["xx"][0, 0] + coeffs["yy"][0, 0]) * pair.E_star
    values, vectors = np.linalg.eigh(np.stack([np.stack([kxx, kxy], -1), np.stack([kxy, kyy], -1)], -2))
    m = np.einsum("...ik,...k,...jk->...ij", vectors, 1.0 / np.maximum(values, floor), vectors)
    fx, fy = np.fft.rfft2(gx), np.fft.rfft2(gy)
    return (np.fft.irfft2(m[..., 0, 0] * fx + m[..., 0, 1] * fy, s=(n, n)),
            np.fft.irfft2(m[..., 1, 0] * fx + m[..., 1, 1] * fy, s=(n, n)))


def test_batched_preconditioners_are_chans_circulant_inverses():
    """The batched solves' preconditioners on the grids themselves (``fft/batch.py``) against the
    NumPy references, a batch of two cases of two pairs: the tangential block inverse of each
    case's own pair (``BatchElasticOperator.tangential_inverse``) and 1 / K_zz's (``BatchConvolution``,
    the unit pair), within 1e-12 of the largest entry (the transforms' rounding)."""
    from warpcontact.fft.batch import BatchConvolution, BatchElasticOperator
    from warpcontact.physics.materials import COPPER, Material, MaterialPair

    n, pairs = 24, [PAPER_PAIR, MaterialPair(COPPER, COPPER)]
    rng = np.random.default_rng(2)
    operator = BatchElasticOperator(n, 2, "cpu", wp.float64)
    assert operator.periodic
    operator.set_pairs(pairs)
    g = rng.standard_normal((2, 2, n * n))
    out = wp.zeros((2, 2, n * n), dtype=wp.float64, device="cpu")
    operator.tangential_inverse(wp.array(g, dtype=wp.float64, device="cpu"), out)
    for case, pair in enumerate(pairs):
        want = block_inverse_reference(pair, n, g[0, case].reshape(n, n), g[1, case].reshape(n, n))
        for component in range(2):
            got = out.numpy()[component, case].reshape(n, n)
            assert np.abs(got - want[component]).max() <= 1e-12 * np.abs(want[component]).max(), (case, component)
    convolution = BatchConvolution(n, 2, "cpu", wp.float64)
    assert convolution.periodic
    field = rng.standard_normal((2, n, n))
    convolution.inverse_source.assign(field)
    convolution.apply(inverse=True)
    unit = influence_coefficients(MaterialPair(Material(E=2.0, nu=0.0), Material(E=2.0, nu=0.0)), n, n, 1.0, 1.0)["zz"]
    spectrum = np.fft.rfft2(chan_reference(unit)).real
    for case in range(2):
        want = np.fft.irfft2(np.fft.rfft2(field[case]) / spectrum, s=(n, n))
        got = convolution.inverse_result.numpy()[case]
        assert np.abs(got - want).max() <= 1e-12 * np.abs(want).max(), case

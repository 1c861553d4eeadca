"""Reliability: repeatable results, float32 against float64, CPU against CUDA, properties of the
operator and the shear laws (hypothesis), and non-finite values named where they appear."""

import functools
import math

import numpy as np
import pytest
import warp as wp
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from conftest import NEEDS_FFTW

from warpcontact.errors import NonFiniteError
from warpcontact.physics.friction import TaborVonMises
from warpcontact.physics.geometry import Grid, Sphere
from warpcontact.studies.slip_search import estimate_delta_x_max
from warpcontact.kernels import laws
from warpcontact.kernels.tangential import STICK
from warpcontact.physics.materials import PAPER_PAIR
from warpcontact.numerics.model import ContactModel
from warpcontact.records.results import state_summary
from warpcontact.solvers import NormalSolver
from warpcontact.solvers.contact import ContactSolver
from warpcontact.solvers.tangential import TangentialSolver
from warpcontact.numerics.state import ContactState
from warpcontact.studies.table2 import Table2Settings, table2_cell

R = 10e-6
HERTZ_DZ = 1.0e-10  # m, the paper's 1e-4 um
COUPLED_DZ = 5.0e-11  # m, the paper's 5e-5 um (Table 2: below the crossover pressure at k_tau 0.8)
K_TAU, S_Y = 0.8, 200e6
CUDA = [f"cuda:{i}" for i in range(wp.get_cuda_device_count())] or ["cuda:0"]
no_cuda = pytest.mark.skipif(wp.get_cuda_device_count() == 0, reason="no CUDA device here")


def rel(a, b) -> float:
    return abs(a / b - 1.0)


def hertz(n=64, device="cpu", dtype="float64", fft="auto", use_graphs=None, one_convolution=True) -> dict:
    """Frictionless normal solve of the paper pair at 1e-4 um, domain 4a (as tests/test_hertz.py)."""
    a = math.sqrt(R * HERTZ_DZ)
    model = ContactModel(PAPER_PAIR, Sphere(R, "paraboloid"), Grid(n, 4 * a), device=device, dtype=dtype, fft=fft)
    state = ContactState(model)
    info = NormalSolver(model, use_graphs=use_graphs, one_convolution=one_convolution).solve(state, HERTZ_DZ)
    assert info.converged, info
    p = state.to_numpy_si()["pressure"]
    return {"F_z": float(p.sum() * model.grid.cell_area), "p0": float(p.max()), "pressure": p,
            "iterations": info.iterations}


def coupled_path(n=48, device="cpu", dtype="float64", fft="auto", use_graphs=None) -> dict:
    """Copper on steel, Tabor + von Mises (k_tau 0.8): delta_z in 2 steps, then delta_x at 1/4 and
    1/2 of Mindlin's gross-slip estimate, every state by ContactSolver.step from fresh objects.
    Partial slip throughout: the last state still has stick cells."""
    a = math.sqrt(R * COUPLED_DZ)
    model = ContactModel(PAPER_PAIR, Sphere(R), Grid(n, 3 * a), device=device, dtype=dtype, fft=fft)
    law = TaborVonMises(K_TAU, S_Y)
    solver, state = ContactSolver(model, law, use_graphs=use_graphs), ContactState(model)
    est = estimate_delta_x_max(PAPER_PAIR, R, COUPLED_DZ, law)
    for approach in ((0.0, 0.0, 0.5 * COUPLED_DZ), (0.0, 0.0, COUPLED_DZ), (0.25 * est, 0.0, COUPLED_DZ),
                     (0.5 * est, 0.0, COUPLED_DZ)):
        info = solver.step(state, approach)
        assert info.converged, (approach, info)
    out = state.to_numpy_si()
    out["status"] = state.status.numpy().copy()
    out["summary"] = state_summary(state)
    out["graphs"] = solver.normal.graph_count + solver.tangential.graph_count
    assert np.count_nonzero(out["status"] == STICK) > 0, "the path reached gross slip"
    return out


# ---------------------------------------------------------------------------------------------
# a. the same case twice in one process gives the same bits


def test_repeated_cpu_runs_are_bit_identical():
    """CPU kernels sum in one fixed order (a launch split over the CPU's threads adds its parts'
    sums in part order); scipy.fft's and FFTW's threads split whole lines: nothing depends on
    timing, so two runs agree to the last bit."""
    first, second = coupled_path(), coupled_path()
    for name in ("pressure", "shear_x", "shear_y", "slip_x", "slip_y", "gap", "status"):
        assert np.array_equal(first[name], second[name]), f"{name} differs between two identical runs"
    assert first["summary"]["force"] == second["summary"]["force"]


# ---------------------------------------------------------------------------------------------
# b. float32 against float64


def test_float32_against_float64_hertz():
    """Hertz at n = 64. float32 stops at a relative residual of 1e-5 (solvers/base.py), float64 at
    1e-10. F_z sums the pressure over the contact, so the residual's misfit averages out: allowed
    5e-5 (5 x the float32 floor). p0 is one cell's value, where the misfit is amplified by the
    conditioning of the contact operator (about sqrt of the ~200 contact cells, ~15): allowed 5e-4.
    Measured here: F_z 1.7e-6, p0 1.9e-5 (n = 48: 1.8e-6, 8.2e-5; n = 128: 5.8e-6, 1.3e-4)."""
    r64, r32 = hertz(dtype="float64"), hertz(dtype="float32")
    d_fz, d_p0 = rel(r32["F_z"], r64["F_z"]), rel(r32["p0"], r64["p0"])
    print(f"\nfloat32 vs float64, Hertz n=64: F_z {d_fz:.2e}, p0 {d_p0:.2e}")
    assert d_fz < 5e-5, d_fz
    assert d_p0 < 5e-4, d_p0


def test_float32_against_float64_table2_cell():
    """Table 2, k_tau 0.80, delta_z 5e-5 um, n = 48. delta_x_max: each search ends with a 1 %
    bracket around its own gross-slip threshold, so the two may land in neighbouring brackets
    (1 %), and float32's coupling turns stop at a relative change of 1e-3 (outer_tol = 100 tol),
    which moves the threshold by about 0.1 %: allowed 1.5 %. mu = F_x / F_z at delta_x_max: near
    gross slip F_x flattens (Mindlin: Q / mu P = 1 - (1 - delta / delta_max)^(3/2)), so a 1 %
    shift in delta_x changes mu by under 0.1 %, plus float32's 1e-3 shear accuracy: allowed 0.2 %.
    Measured here: delta_x_max 0 (same bracket), mu 2.1e-6."""
    c64 = table2_cell(0.8, 5e-5, Table2Settings(n=48, dtype="float64"))
    c32 = table2_cell(0.8, 5e-5, Table2Settings(n=48, dtype="float32"))
    assert c64["converged"] and c32["converged"], (c64["converged"], c32["converged"])
    d_dx = rel(c32["delta_x_max_um"], c64["delta_x_max_um"])
    d_mu = rel(c32["mu"], c64["mu"])
    print(f"\nfloat32 vs float64, Table 2 (0.80, 5e-5 um) n=48: delta_x_max {d_dx:.2e} "
          f"({c32['delta_x_max_um']:.4e} vs {c64['delta_x_max_um']:.4e} um), mu {d_mu:.2e} "
          f"({c32['mu']:.6f} vs {c64['mu']:.6f})")
    assert d_dx < 0.015, d_dx
    assert d_mu < 2e-3, d_mu


# ---------------------------------------------------------------------------------------------
# c. CPU against CUDA, and the CPU's two FFT libraries against each other


def _compare(a, b, label):
    """Integral quantities within 1e-9 relative (both sides reach a relative residual of 1e-10;
    a force sums it away); fields within 5e-8 of the largest value of their kind (|p|, |q|, |s|):
    pointwise the residual is amplified by the conditioning of the contact operator (measured
    between scipy.fft and Warp's tile_fft on the CPU: forces 1.3e-10, fields 4.4e-9)."""
    diffs = {}
    if "summary" in a:
        for k in ("x", "z"):
            diffs[f"F_{k}"] = rel(b["summary"]["force"][k], a["summary"]["force"][k])
        scales = {"pressure": np.abs(a["pressure"]).max(),
                  "shear_x": np.hypot(a["shear_x"], a["shear_y"]).max(),
                  "slip_x": np.hypot(a["slip_x"], a["slip_y"]).max()}
        scales["shear_y"], scales["slip_y"] = scales["shear_x"], scales["slip_x"]
    else:
        diffs["F_z"], diffs["p0"] = rel(b["F_z"], a["F_z"]), rel(b["p0"], a["p0"])
        scales = {"pressure": np.abs(a["pressure"]).max()}
    for name, s in scales.items():
        diffs[name] = float(np.abs(b[name] - a[name]).max() / s)
    print(f"\n{label}: " + ", ".join(f"{k} {v:.1e}" for k, v in diffs.items()))
    for k, v in diffs.items():
        assert v < (5e-8 if k in scales else 1e-9), (k, v)


@pytest.mark.parametrize("other", [pytest.param("fftw", marks=NEEDS_FFTW), "warp"])
def test_fft_libraries_agree_on_cpu(other):
    """scipy.fft, FFTW and Warp's tile_fft round differently, as the CPU and a GPU do: the
    solutions still agree to the solvers' tolerance (the bounds of _compare)."""
    _compare(hertz(fft="scipy"), hertz(fft=other), f"Hertz, scipy vs {other} FFT")
    _compare(coupled_path(fft="scipy"), coupled_path(fft=other), f"coupled partial slip, scipy vs {other} FFT")


@no_cuda
@pytest.mark.gpu
@pytest.mark.parametrize("cuda", CUDA)
def test_cpu_and_cuda_agree_float64(cuda):
    _compare(hertz(), hertz(device=cuda), f"Hertz, cpu vs {cuda}")
    _compare(coupled_path(), coupled_path(device=cuda), f"coupled partial slip, cpu vs {cuda}")


@no_cuda
@pytest.mark.gpu
@pytest.mark.parametrize("cuda", CUDA)
def test_cuda_graphs_match_eager_launches(cuda):
    """Iterations replayed from captured CUDA graphs give the solution of the same launches made
    one by one (bounds of _compare: the block sums' atomics may add in another order), and the
    graphs are captured once per set of arrays and kind of start, not per solve: the coupled
    path's 4 steps, dozens of solves, keep three graphs: the normal solver's for a turn's first
    solve and for the later ones (which start from the state's K p: ``displacement_current``),
    and the tangential solver's (on the whole grid: n = 48 is under ``WINDOW_AUTO_N`` on CUDA;
    a solve on a window keeps its graph in the window's solver, ``graph_count`` counts both)."""
    _compare(hertz(device=cuda, use_graphs=False), hertz(device=cuda), f"Hertz on {cuda}, eager vs graphs")
    eager, graphs = coupled_path(device=cuda, use_graphs=False), coupled_path(device=cuda)
    _compare(eager, graphs, f"coupled partial slip on {cuda}, eager vs graphs")
    assert eager["graphs"] == 0 and graphs["graphs"] == 3, (eager["graphs"], graphs["graphs"])


@no_cuda
@pytest.mark.gpu
@pytest.mark.parametrize("cuda", CUDA)
def test_one_convolution_graphs_match_two_convolutions(cuda):
    """The default CUDA iteration carries K p and lets a conditional node of its graph decide on
    the device when to recompute it (after a projection, every 50 iterations). It gives the
    solution of the iteration that recomputes K p every time (bounds of _compare), and takes the
    iterations of the same one-convolution iteration launched eagerly, where the host reads the
    decision: the conditional node follows the flag (the count may differ by the iteration or
    two that block sums added in another order can shift)."""
    graphs = hertz(device=cuda)
    _compare(hertz(device=cuda, one_convolution=False), graphs, f"Hertz on {cuda}, two vs one convolution (graphs)")
    eager = hertz(device=cuda, use_graphs=False, one_convolution=True)
    _compare(eager, graphs, f"Hertz on {cuda}, one convolution, eager vs graphs")
    assert abs(eager["iterations"] - graphs["iterations"]) <= 2, (eager["iterations"], graphs["iterations"])


def test_device_loop_stops_at_the_converged_iteration_whatever_the_launch_length():
    """The iterations run in a device loop that stops itself at the update whose iterate meets the
    tolerance; the host reads only between launches (``iterations_per_launch``). A warm-started
    solve (a coupled step's turn: 1-4 iterations) and a solve from rest take the same iterations
    and give the same pressure, bit for bit, whether the loop is launched for every iteration
    (1), for launches that do not divide the count (3), or once (64)."""
    model = ContactModel(PAPER_PAIR, Sphere(R, "paraboloid"), Grid(32, 4 * math.sqrt(R * HERTZ_DZ)), device="cpu",
                         dtype="float64")
    start = ContactState(model)
    NormalSolver(model).solve(start, HERTZ_DZ)
    for warm in (True, False):
        counts, pressures = [], []
        for per_launch in (1, 3, 64):
            solver = NormalSolver(model, iterations_per_launch=per_launch)
            state = ContactState(model)
            if warm:  # 0.1 % deeper, to 1e-4 (a coupled step's early turns solve to 1e-3 ... 1e-8)
                state.copy_from(start)
                info = solver.solve(state, 1.001 * HERTZ_DZ, tol=1e-4)
            else:
                info = solver.solve(state, HERTZ_DZ)
            assert info.converged and info.residual < solver.active_tol
            # history: the residual each iteration started from; none started from a converged
            # iterate (the loop stops at the update that converged)
            assert len(info.history) == info.iterations, (len(info.history), info.iterations)
            assert all(h >= solver.active_tol for h in info.history), f"an iteration past convergence: {info.history}"
            counts.append(info.iterations)
            pressures.append(state.pressure.numpy())
        if warm:
            assert 1 <= counts[0] <= 4, f"the warm start should need 1-4 iterations here, took {counts[0]}"
        else:
            assert counts[0] > 3, counts  # from rest: several launches of 3
        assert counts[1] == counts[0] and counts[2] == counts[0], (warm, counts)
        np.testing.assert_array_equal(pressures[1], pressures[0])
        np.testing.assert_array_equal(pressures[2], pressures[0])


def test_iteration_limit_stops_the_device_loop():
    """A solve capped at max_iter iterations stops there, unconverged, for any launch length (the
    uncapped solve takes 6 iterations here: capped at 3)."""
    model = ContactModel(PAPER_PAIR, Sphere(R, "paraboloid"), Grid(32, 4 * math.sqrt(R * HERTZ_DZ)), device="cpu",
                         dtype="float64")
    assert NormalSolver(model).solve(ContactState(model), HERTZ_DZ).iterations > 3
    for per_launch in (1, 2, 64):
        solver = NormalSolver(model, max_iter=3, iterations_per_launch=per_launch)
        info = solver.solve(ContactState(model), HERTZ_DZ)
        assert not info.converged and info.iterations == 3 and len(info.history) == 3, (per_launch, info)


def test_cufft_layout_rule_follows_the_measurements():
    """prune_by_default picks the layout that takes less time on an H100 (pruned / 2-D;
    bench/iteration_parts.py times both): float64 pruned only at powers of two; float32 pruned
    below 1000 and at powers of two below 4096."""
    from warpcontact.fft.cupy_backend import prune_by_default

    for n in (256, 512, 1024, 2048, 4096):
        assert prune_by_default(n, n, wp.float64), n
    for n in (300, 315, 360, 588, 600, 700, 768, 1000, 1500, 2000, 3000, 4000, 8191):
        assert not prune_by_default(n, n, wp.float64), n
    for n in (256, 300, 315, 360, 512, 588, 600, 1024, 2048):
        assert prune_by_default(n, n, wp.float32), n
    for n in (1000, 3000, 4096, 11584):
        assert not prune_by_default(n, n, wp.float32), n
    assert not prune_by_default(256, 300, wp.float64)  # both lengths must be powers of two


# ---------------------------------------------------------------------------------------------
# d. properties (hypothesis): the operator on a 12 x 12 grid, the shear laws, the disk bound

N_SMALL = 12


@functools.lru_cache(maxsize=None)
def small_model():
    return ContactModel(PAPER_PAIR, Sphere(R, "paraboloid"), Grid(N_SMALL, 1e-7), device="cpu", dtype="float64")


def apply_coupled(x: np.ndarray) -> np.ndarray:
    """The coupled 3x3 operator on a (3, n, n) traction array, as a (3, n, n) displacement array."""
    m = small_model()
    src = [m.field(x[i]) for i in range(3)]
    dst = [m.field() for _ in range(3)]
    m.operator.coupled_apply(*src, *dst)
    return np.stack([d.numpy() for d in dst])


def apply_normal(p: np.ndarray) -> np.ndarray:
    m = small_model()
    out = m.field()
    m.operator.normal(m.field(p), out)
    return out.numpy()


@functools.lru_cache(maxsize=None)
def dense_operators():
    """The coupled operator and its normal block as dense matrices (one apply per unit vector)."""
    size = 3 * N_SMALL * N_SMALL
    eye = np.eye(size)
    full = np.stack([apply_coupled(eye[k].reshape(3, N_SMALL, N_SMALL)).ravel() for k in range(size)], axis=1)
    nn = N_SMALL * N_SMALL
    return full, full[:nn, :nn]


unit = st.floats(-1.0, 1.0, allow_nan=False, allow_subnormal=False)
tractions = hnp.arrays(np.float64, (3, N_SMALL, N_SMALL), elements=unit)
scale = st.floats(-1e3, 1e3, allow_nan=False, allow_subnormal=False)


@settings(max_examples=25, deadline=None)
@given(x=tractions, y=tractions, a=scale, b=scale)
def test_operator_is_linear(x, y, a, b):
    """K(a x + b y) = a K x + b K y to 1e-12 of |a| |Kx| + |b| |Ky| (the FFT round trip is exact
    to ~1e-15 of the norms it transforms)."""
    lhs = apply_coupled(a * x + b * y)
    rhs = a * apply_coupled(x) + b * apply_coupled(y)
    bound = 1e-12 * (abs(a) * np.linalg.norm(apply_coupled(x)) + abs(b) * np.linalg.norm(apply_coupled(y)))
    assert np.linalg.norm(lhs - rhs) <= bound + 1e-300


@settings(max_examples=25, deadline=None)
@given(x=tractions, y=tractions)
def test_coupled_operator_is_symmetric(x, y):
    """<x, K y> = <K x, y> to 1e-12 of |x| |K| |y| (reciprocity, MODEL.md section 2; the scale of
    either side, which can cancel to near zero)."""
    full, _ = dense_operators()
    k_norm = np.linalg.norm(full, 2)
    lhs = float(np.sum(x * apply_coupled(y)))
    rhs = float(np.sum(apply_coupled(x) * y))
    assert abs(lhs - rhs) <= 1e-12 * _norm_bound(x) * _norm_bound(y) * k_norm


@settings(max_examples=25, deadline=None)
@given(p=hnp.arrays(np.float64, (N_SMALL, N_SMALL), elements=unit))
def test_normal_block_is_positive_definite(p):
    """<p, K_zz p> > 0 for p != 0, and at least the smallest eigenvalue of K_zz times |p|^2 (less
    1e-12 of the largest, the rounding of the FFT apply)."""
    assume(np.abs(p).max() > 1e-6)
    _, kzz = dense_operators()
    eig = np.linalg.eigvalsh(0.5 * (kzz + kzz.T))
    energy = float(np.sum(p * apply_normal(p)))
    assert energy > 0
    assert energy >= (eig[0] - 1e-12 * eig[-1]) * float(np.sum(p * p))


def _launch_law(kernel, pressure: np.ndarray, *scalars) -> np.ndarray:
    p = wp.array(pressure, dtype=wp.float64, device="cpu")
    out = wp.zeros(len(pressure), dtype=wp.float64, device="cpu")
    wp.launch(kernel, dim=len(pressure), inputs=[p, *(wp.float64(s) for s in scalars)], outputs=[out], device="cpu")
    return out.numpy()


def _pressures(s_y):
    """Pressures around the yield strength: negative, zero, below, at and above S_Y."""
    specials = st.sampled_from([0.0, -0.0, s_y, -s_y, s_y * (1 - 1e-15), s_y * (1 + 1e-15), 2 * s_y, -1e-300])
    return st.lists(st.one_of(st.floats(-3 * s_y, 3 * s_y, allow_nan=False), specials), min_size=1, max_size=64)


@settings(max_examples=25, deadline=None)
@given(data=st.data(), k_tau=st.floats(0.05, 0.99), k_vm=st.floats(0.1, 1.0), s_y=st.floats(1e-5, 1e-1))
def test_tabor_limit_matches_closed_form(data, k_tau, k_vm, s_y):
    """q_max = min(mu_b p, k_VM sqrt(max(S_Y^2 - p^2, 0))) for p > 0, 0 otherwise (MODEL.md 5),
    to 1e-12 relative in float64, and q_max >= 0. (Scaled units: S_Y / E* ~ 2.6e-3 here.)"""
    p = np.array(data.draw(_pressures(s_y)), dtype=np.float64)
    mu_b = k_vm / math.sqrt(k_tau**-2 - 1.0)
    got = _launch_law(laws.tabor_limit, p, mu_b, k_vm, s_y)
    want = np.where(p > 0, np.minimum(mu_b * p, k_vm * np.sqrt(np.maximum(s_y * s_y - p * p, 0.0))), 0.0)
    assert np.all(got >= 0)
    bad = np.abs(got - want) > 1e-12 * np.abs(want)
    assert not bad.any(), np.c_[p, got, want][bad]


@settings(max_examples=25, deadline=None)
@given(data=st.data(), mu=st.floats(0.0, 2.0))
def test_coulomb_limit_matches_closed_form(data, mu):
    """q_max = mu p for p > 0, 0 otherwise, to 1e-12 relative, and q_max >= 0."""
    p = np.array(data.draw(_pressures(1e-2)), dtype=np.float64)
    got = _launch_law(laws.coulomb_limit, p, mu)
    want = np.where(p > 0, mu * p, 0.0)
    assert np.all(got >= 0)
    assert np.all(np.abs(got - want) <= 1e-12 * np.abs(want))


@functools.lru_cache(maxsize=None)
def small_tangential():
    m = small_model()
    return TangentialSolver(m, max_iter=300), ContactState(m)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), out_fraction=st.floats(0.0, 0.9), load=st.floats(1e-3, 1e2))
def test_tangential_solve_keeps_the_disk_bound(seed, out_fraction, load):
    """After a tangential solve on a random problem (random q_max with cells out of contact,
    random stick targets, a random starting shear partly outside the disks): |q| <= q_max (1 +
    1e-12) on every cell (the projection and the retraction onto the circle round to a few ulp),
    and q = 0 where q_max = 0, whether or not the solve converged."""
    rng = np.random.default_rng(seed)
    solver, state = small_tangential()
    m = small_model()
    shape = (N_SMALL, N_SMALL)
    q_max = rng.uniform(0.0, 1e-2, shape) * (rng.uniform(size=shape) >= out_fraction)
    target = [m.field(load * 1e-2 * rng.standard_normal(shape)) for _ in range(2)]
    state.shear_x.assign(rng.uniform(-2e-2, 2e-2, shape))
    state.shear_y.assign(rng.uniform(-2e-2, 2e-2, shape))
    solver.solve(state, target[0], target[1], m.field(q_max))
    q = np.hypot(state.shear_x.numpy(), state.shear_y.numpy())
    assert np.all(q <= q_max * (1 + 1e-12)), float(np.max(q - q_max))
    assert np.all(q[q_max == 0] == 0)


# ---------------------------------------------------------------------------------------------
# e. non-finite values are named


def _hertz_model(n=32):
    a = math.sqrt(R * HERTZ_DZ)
    return ContactModel(PAPER_PAIR, Sphere(R, "paraboloid"), Grid(n, 4 * a))


def _norm_bound(a):
    """max|a| sqrt(a.size) >= the 2-norm, without the underflow of squaring tiny entries
    (hypothesis tries values near 1e-260, whose squares vanish)."""
    return float(np.abs(a).max()) * math.sqrt(a.size)


def _poison(array, cell):
    values = array.numpy().copy()
    values[cell] = np.nan
    array.assign(values)


def test_nan_in_initial_gap_names_the_cell():
    model = _hertz_model()
    _poison(model.initial_gap, (15, 17))  # inside the contact
    with pytest.raises(NonFiniteError, match=r"row 15, column 17"):
        NormalSolver(model).solve(ContactState(model), HERTZ_DZ)


@pytest.mark.parametrize("name, field_of, cell", [
    ("gap", lambda model, state: model.initial_gap, (15, 17)),
    ("pressure", lambda model, state: state.pressure, (14, 16)),
], ids=["initial gap at a contact cell", "starting pressure"])
def test_nan_on_a_warm_start_names_the_field_and_the_cell(name, field_of, cell):
    """From a solved state (pressure > 0 at the cell), a NaN gap enters the residual sums, and a NaN
    in the pressure a solve starts from spreads through the FFT to every displacement: either way
    the solve stops with NonFiniteError naming the field and the cell it came from, not the first
    cell it reached."""
    model = _hertz_model()
    state, solver = ContactState(model), NormalSolver(model)
    assert solver.solve(state, HERTZ_DZ).converged
    _poison(field_of(model, state), cell)
    with pytest.raises(NonFiniteError, match=rf"{name} .*row {cell[0]}, column {cell[1]}"):
        solver.solve(state, HERTZ_DZ)


def test_solver_recovers_after_a_non_finite_error():
    """A solver that raised NonFiniteError solves clean inputs afterwards as a fresh one does."""
    model = _hertz_model()
    state, solver = ContactState(model), NormalSolver(model)
    assert solver.solve(state, HERTZ_DZ).converged
    clean = model.initial_gap.numpy().copy()
    _poison(model.initial_gap, (15, 17))
    with pytest.raises(NonFiniteError):
        solver.solve(state, HERTZ_DZ)
    model.initial_gap.assign(clean)
    info = solver.solve(ContactState(model), HERTZ_DZ)
    assert info.converged, info.residual


# ---------------------------------------------------------------------------------------------
# f. an adhesive law still pulling on the domain's edge: one warning, naming grid.size


def _smc_case(size, n, delta_n=5e-10, sigma_max=3.6788e7, delta_z=HERTZ_DZ):
    """The paper pair, R = 10 um (paraboloid), frictionless, one normal state at ``delta_z`` [m],
    SMC law (w = e sigma_max delta_n = 0.05 J/m^2 by default) on an ``n`` x ``n`` grid of side
    ``size`` [m]."""
    from warpcontact.records.case import case_from_dict

    return case_from_dict({
        "sphere": {"radius": R, "E": 106e9, "nu": 0.33, "profile": "paraboloid"},
        "flat": {"E": 205e9, "nu": 0.31},
        "grid": {"n": n, "size": size},
        "load": {"delta_z": delta_z},
        "adhesion": {"law": "smc", "sigma_max": sigma_max, "tau_max": sigma_max, "delta_n": delta_n,
                     "delta_t": delta_n},
    })


def _edge_warnings(run, case, **kw):
    """(result of run(case), the AdhesionAtEdgeWarnings it gave)."""
    import warnings

    from warpcontact.records.guards import AdhesionAtEdgeWarning

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = run(case, **kw)
    return result, [w for w in caught if issubclass(w.category, AdhesionAtEdgeWarning)]


def _edge_fraction(tension) -> float:
    return max(tension[0].max(), tension[-1].max(), tension[:, 0].max(), tension[:, -1].max()) / tension.max()


def test_adhesion_at_the_edge_warns_and_the_suggested_domain_holds_the_tail():
    """delta_n = 5e-10 m on 4 contact radii (126 nm): the gap at the edge is 0.2 delta_n, the law
    pulls there at its full strength. The suggested side (616 nm, 2.2 sqrt(2 R (delta_z + 7.64
    delta_n))) holds the tail; a side 5 % under the tail's own reach (without the 1.1 margin)
    still warns, so the check is not idle. The force the small domain misses is most of it."""
    import re

    from warpcontact.physics.adhesion import SMC
    from warpcontact.api import solve
    from warpcontact.records.guards import suggested_adhesive_size

    a = math.sqrt(R * HERTZ_DZ)
    small, warned = _edge_warnings(solve, _smc_case(4 * a, 32))
    assert len(warned) == 1, [str(w.message) for w in warned]
    message = str(warned[0].message)
    suggested = float(re.search(r"grid\.size >= (\S+) m", message).group(1))
    law = SMC(3.6788e7, 3.6788e7, 5e-10, 5e-10)
    assert suggested == pytest.approx(suggested_adhesive_size(R, HERTZ_DZ, law), rel=1e-3)
    assert suggested == pytest.approx(2.2 * math.sqrt(2 * R * (HERTZ_DZ + 7.64 * 5e-10)), rel=1e-3)
    assert "100 % of its peak" in message and "tail" in message

    wide, warned = _edge_warnings(solve, _smc_case(suggested, 64))
    assert not warned and wide.converged
    assert _edge_fraction(-wide.fields[-1]["adhesive_pressure"]) < 0.01
    assert wide.states[-1]["force"]["z"] < -2e-6 < 0 < small.states[-1]["force"]["z"]  # the tail's pull is lost

    _, warned = _edge_warnings(solve, _smc_case(0.95 * suggested / 1.1, 64))
    assert len(warned) == 1


def test_short_ranged_law_on_a_wide_domain_does_not_warn():
    """delta_n = 2e-12 m at delta_z = 5e-11 m on 4 contact radii: the law pulls at its peak near
    the contact, while the gap at the edge (about 25 delta_n) leaves it no tension there."""
    from warpcontact.api import solve

    a = math.sqrt(R * COUPLED_DZ)
    result, warned = _edge_warnings(solve, _smc_case(4 * a, 32, delta_n=2e-12, sigma_max=3e7, delta_z=COUPLED_DZ))
    assert not warned and result.converged
    tension = -result.fields[-1]["adhesive_pressure"]
    assert tension.max() > 0.5 * 3e7 and _edge_fraction(tension) < 1e-3  # the law acts, not at the edge


def test_adhesion_at_the_edge_warns_once_per_curve():
    """An approach-retract curve with the tail cut at several states warns once."""
    from warpcontact.api import pull_off

    a = math.sqrt(R * HERTZ_DZ)
    curve, warned = _edge_warnings(pull_off, _smc_case(4 * a, 32), steps=2)
    assert len(curve["curve"]) == 5 and len(warned) == 1


def test_adhesive_tail_lengths():
    """SMC: x e^(1 - x) falls to 1 % of its peak at x = 7.64; Dugdale: no tension past its range."""
    from warpcontact.physics.adhesion import SMC, Dugdale
    from warpcontact.records.guards import SMC_TAIL_IN_DELTA_N, adhesion_tail, suggested_adhesive_size

    x = SMC_TAIL_IN_DELTA_N
    assert x * math.exp(1 - x) == pytest.approx(0.01, rel=0.01)
    assert adhesion_tail(SMC(1e8, 1e8, 1e-9, 2e-9)) == pytest.approx(7.64e-9)
    law = Dugdale(1e8, 1e-9)  # the centred ramp (default) ends at h_0 (1 + smoothing / 2)
    assert adhesion_tail(law) == law.range == pytest.approx(1.025e-9)
    assert suggested_adhesive_size(R, 1e-10, law) == pytest.approx(2.2 * math.sqrt(2 * R * (1e-10 + 1.025e-9)))
    law = Dugdale(1e8, 1e-9, ramps="both")  # the ramps at both ends: the falling one ends at h_0 (1 + smoothing)
    assert adhesion_tail(law) == law.range == pytest.approx(1.05e-9)


@pytest.mark.parametrize("key, value", [("rel_tol", 0.0), ("rel_tol", -0.1), ("rel_tol", 1.0), ("rel_tol", float("nan")),
                                        ("normal_steps", 0), ("tangential_steps", 2.5)])
def test_gross_slip_search_settings_are_checked(key, value):
    """A bisection tolerance outside (0, 1) would never end (or end at once); step counts must be
    whole and positive. Refused before any solve, naming the argument."""
    from warpcontact.errors import InputError
    from warpcontact.physics.friction import Coulomb
    from warpcontact.studies.slip_search import find_gross_slip

    model = ContactModel(PAPER_PAIR, Sphere(10e-6), Grid(16, 1e-7))
    with pytest.raises(InputError, match=key):
        find_gross_slip(model, ContactSolver(model, Coulomb(0.3)), 1e-10, **{key: value})

"""The adhesive normal problem as one energy minimisation (warpcontact/solvers/adhesive.py)."""

import math

import numpy as np
import pytest
import warp as wp

from warpcontact.physics.adhesion import SMC, Dugdale, Exponential, LennardJones93
from warpcontact.studies.approach_retract import approach_retract
from warpcontact.errors import InputError
from warpcontact.physics.geometry import Grid, Sphere
from warpcontact.kernels import adhesive as ak
from warpcontact.physics.materials import PAPER_PAIR
from warpcontact.numerics.model import ContactModel
from warpcontact.physics.reference import maugis_dugdale_pull_off
from warpcontact.solvers.adhesive import AdhesiveNormalSolver
from warpcontact.solvers.contact import ContactSolver
from warpcontact.numerics.state import ContactState

R, W = 1e-6, 0.5
A0 = (9 * math.pi * W * R**2 / (2 * PAPER_PAIR.E_star)) ** (1 / 3)  # JKR contact radius at zero load


def dugdale_at(lam: float, smoothing: float = 0.05, ramps: str = "both") -> Dugdale:
    """The Dugdale law at Maugis parameter ``lam``; the measured cases below (n = 64 / 96 / 192)
    were measured with the ramps at both ends (their docstrings' numbers), the centred ones ask."""
    sigma_0 = lam / (9 * R / (2 * math.pi * W * PAPER_PAIR.E_star**2)) ** (1 / 3)
    return Dugdale(sigma_0=sigma_0, h_0=W / sigma_0, smoothing=smoothing, ramps=ramps)


LAWS = {
    "smc": SMC(sigma_max=2e8, tau_max=2e8, delta_n=5e-10, delta_t=5e-10),
    "dugdale": Dugdale(sigma_0=2e8, h_0=1e-9, smoothing=0.1, ramps="both"),
    "dugdale_centred": Dugdale(sigma_0=2e8, h_0=1e-9, smoothing=0.1, ramps="centred"),
    "exponential": Exponential(work_of_adhesion=0.3, rho=4e-10),
    "lj93": LennardJones93(work_of_adhesion=0.3, z0=3e-10),
}


@wp.kernel
def _law_table(h: wp.array(dtype=wp.float64), opening: wp.float64, law: int, a: wp.float64, b: wp.float64,
               c: wp.float64, out: wp.array2d(dtype=wp.float64)):
    i = wp.tid()
    phi, t, k = ak.law_values(law, h[i], opening, a, b, c)
    out[i, 0] = phi
    out[i, 1] = t
    out[i, 2] = k


@pytest.mark.parametrize("name", sorted(LAWS))
def test_law_potential_tension_and_stiffness_agree(name):
    """Each law's tension is the derivative of its potential and its stiffness that of the
    tension (central differences, step 1e-6 of the law's length: error O(step^2) ~ 1e-12 of the
    values, allowed 1e-6 relative to the largest tension; the ramps' kinks of the Dugdale law are
    skipped), the potential tends to 0 far away (as its tail says) and its depth at h = 0 is the work of adhesion
    (SMC at zero opening, exponential, LJ 9-3: exact; Dugdale: sigma_0 h_0)."""
    law = LAWS[name]
    model = ContactModel(PAPER_PAIR, Sphere(R), Grid(16, 1e-8))
    law_id, params, length = law.normal_law(model)
    h = np.linspace(0.0, 6.0 * length, 601)[1:]
    step = 1e-6 * length
    kinks = np.zeros_like(h, dtype=bool)
    if name == "dugdale":
        for x in (params[2], params[1], params[1] + params[2]):
            kinks |= np.abs(h - x) < 3 * step
    if name == "dugdale_centred":
        for x in (params[1] - params[2] / 2, params[1] + params[2] / 2):
            kinks |= np.abs(h - x) < 3 * step
    grid = np.concatenate([h - step, h, h + step, [0.0, 200.0 * length]])
    out = wp.zeros((grid.size, 3), dtype=wp.float64)
    wp.launch(_law_table, grid.size, [wp.array(grid, dtype=wp.float64), 0.0, law_id, *params], [out])
    v = out.numpy()
    n = h.size
    lo, mid, hi = v[:n], v[n:2 * n], v[2 * n:3 * n]
    t_scale = np.abs(mid[:, 1]).max()
    d_phi = (hi[:, 0] - lo[:, 0]) / (2 * step)
    d_t = (hi[:, 1] - lo[:, 1]) / (2 * step)
    ok = ~kinks
    assert np.abs(d_phi - mid[:, 1])[ok].max() < 1e-6 * t_scale, name
    assert np.abs(d_t - mid[:, 2])[ok].max() < 1e-6 * t_scale / length, name
    w_scaled = law.work_of_adhesion / (model.traction_scale * model.length_scale)
    assert v[-2, 0] == pytest.approx(-w_scaled, rel=1e-12), "depth at contact"
    # far away (200 lengths): LJ 9-3's tail (4/3) (z0/z)^2 w = 3.3e-5 w is the slowest; the others ~e^-200
    assert abs(v[-1, 0]) < (4.0 / 3.0) / 200.0**2 * w_scaled, "potential far away"
    peak = max(mid[:, 1].max(), v[-2, 1]) * model.traction_scale  # sampled every 1e-2 length, and at h = 0
    assert peak == pytest.approx(law.peak_tension, rel=2e-3)


def _solve_at(law, n, dz, dtype="float64", device="cpu"):
    model = ContactModel(PAPER_PAIR, Sphere(R), Grid(n, 5 * A0), dtype=dtype, device=device)
    solver = AdhesiveNormalSolver(model, law)
    state = ContactState(model)
    info = solver.solve(state, dz)
    return model, solver, state, info


@pytest.mark.parametrize("name", sorted(LAWS))
def test_solution_meets_the_contact_and_law_conditions(name, device):
    """At the minimiser (every law, in contact at delta_z = 1 nm, n = 48): the gap is >= 0, the
    contact pressure sits only where the gap is 0, out of contact the total traction equals the
    law's -t(h) (the projected gradient, to the solve's tolerance 1e-8 of the traction's norm;
    checked at 1e-6), and the traction on the padding (not returned) vanishes likewise: the
    non-periodic DC-FFT solution. The displacement is the operator's K p of the total traction
    (1e-6 of its norm: the carried traction is exact to the tolerance)."""
    law = LAWS[name]
    model, solver, state, info = _solve_at(law, 48, 1e-9, device=device)
    assert info.converged, info
    f = state.to_numpy_si()
    p_c, p_a, h = f["pressure"], f["adhesive_pressure"], f["gap"]
    assert h.min() >= 0.0
    assert np.all(h[p_c > 0] == 0.0)
    assert (p_c > 0).sum() > 10
    traction = solver.traction.numpy().reshape(2 * 48, 2 * 48)
    norm = np.linalg.norm(traction[:48, :48])
    assert np.abs(traction[48:, :]).max() < 1e-6 * norm and np.abs(traction[:, 48:]).max() < 1e-6 * norm
    disp = model.field()
    total = model.field((p_c + p_a) / model.traction_scale)
    model.operator.normal(total, disp)
    u = disp.numpy() * model.length_scale
    assert np.linalg.norm(u - f["disp_z"]) < 1e-6 * np.linalg.norm(u)


@pytest.mark.gpu
@pytest.mark.skipif(wp.get_cuda_device_count() < 2, reason="needs two CUDA devices")
def test_the_solve_runs_on_its_models_gpu_whatever_cupys_current_device():
    """On a host of several GPUs, CuPy's current device need not be the model's: the solve on
    cuda:0 with CuPy's current device 1 gives the answer it gives with 0, to 1e-6 of the largest
    pressure (the solve's tolerance is 1e-8 of the traction's norm; two runs on a GPU differ in
    their last bits, whose block sums add in no fixed order). Before, CuPy made the inverse
    spectrum on device 1 and Warp's kernels on cuda:0 read it: CUDA error 700."""
    cupy = pytest.importorskip("cupy")
    law = LAWS["exponential"]
    answers = []
    for current in (0, 1):
        with cupy.cuda.Device(current):
            _, _, state, info = _solve_at(law, 48, 1e-9, device="cuda:0")
        assert info.converged, info
        answers.append(state.to_numpy_si()["pressure"])
    assert np.abs(answers[1] - answers[0]).max() <= 1e-6 * np.abs(answers[0]).max()


def test_an_iteration_reads_the_device_at_most_three_times(monkeypatch):
    """The two-loop recursion keeps its scalars on the device: an iteration reads the device's
    sums only for its trial step (once per halving of it) and for the accepted point with its new
    pair, plus a new free set's evaluation (each read is a synchronisation on a GPU; there were
    about 15 an iteration when the dot products were read one by one). Exponential law, n = 48."""
    reads = []
    original = AdhesiveNormalSolver._sums
    monkeypatch.setattr(AdhesiveNormalSolver, "_sums", lambda self: reads.append(1) or original(self))
    _, _, _, info = _solve_at(LAWS["exponential"], 48, 1e-9)
    assert info.converged and info.iterations > 10
    assert len(reads) <= 3 * info.iterations + 2, (len(reads), info.iterations)


def test_minimiser_is_a_local_minimum_of_the_energy():
    """Perturbations of the solution's displacement that keep the bound raise the energy (the
    solver returns a stable equilibrium, not a saddle): 20 random perturbations of 1e-3 of the
    law's length, energy from the same kernels."""
    law = LAWS["exponential"]
    model, solver, state, info = _solve_at(law, 32, 5e-10)
    assert info.converged
    rng = np.random.default_rng(0)
    u0 = solver.displacement.numpy().copy()
    p0 = solver.traction.numpy().copy()
    e0 = solver._evaluate(solver.displacement, solver.traction, solver.gradient, 0.0)[ak.S_ENERGY]
    offset = solver.offset.numpy().ravel()
    lo = np.full(u0.shape, -np.inf)
    lo.reshape(64, 64)[:32, :32] = -offset.reshape(32, 32)
    for _ in range(20):
        du = rng.normal(0.0, 1e-3 * solver.law_length, u0.shape)
        u = np.maximum(u0 + du, lo)
        solver.displacement.assign(u)
        solver.convolution.apply(solver.displacement, solver.traction, inverse=True)
        e = solver._evaluate(solver.displacement, solver.traction, solver.gradient, 0.0)[ak.S_ENERGY]
        assert e > e0, (e, e0)
    solver.displacement.assign(u0)
    solver.traction.assign(p0)


def maugis_dugdale_path(n: int) -> dict:
    """The Dugdale law at Maugis parameter lambda = 1 (R = 1 um, w = 0.5 J/m^2, ramps of 0.05
    h_0, domain 5 a0, 12 steps each way) on n cells, the pull-off refined."""
    law = dugdale_at(1.0)
    model = ContactModel(PAPER_PAIR, Sphere(R), Grid(n, 5 * A0))
    return approach_retract(model, ContactSolver(model, None, adhesion=law), -law.h_0, 2 * law.h_0, -3 * law.h_0, 12)


def test_maugis_dugdale_at_lambda_1_on_a_coarse_grid_says_it_is_jagged():
    """n = 64 (a0 over 13 cells): every state converges, and the retraction's force is jagged (the
    contact edge leaves one ring of cells at a time): the substeps around the pull-off lie 4 % of
    it off a smooth curve (measured 0.068 pi R w), the pull-off -1.708 pi R w (+6.7 % from
    Maugis-Dugdale's -1.6007; the parabola's -1.678, +4.8 %). The run reports the jaggedness (the
    warning's threshold is 1 %), which is larger than the equal steps' scatter alone suggested: 12
    steps gave -1.6078 (+0.44 %) by where they fell on the sawtooth."""
    r = maugis_dugdale_path(64)
    assert r["converged"], [c.get("iterations") for c in r["curve"]]
    assert r["pull_off_scatter"] > 0.01 * abs(r["pull_off_force"])
    reference = maugis_dugdale_pull_off(1.0) * math.pi * R * W
    # the pull-off and the smooth curve's lie on the tensile side of Maugis-Dugdale, by less than
    # the sawtooth's amplitude twice (what the grid's snapping can add)
    for value in (r["pull_off_force"], r["pull_off_fit"]):
        assert 0.0 < reference - value < 2 * r["pull_off_scatter"], (value, reference, r["pull_off_scatter"])


@pytest.mark.slow
def test_maugis_dugdale_pull_off_at_lambda_1():
    """n = 192 (a0 over 38 cells; 2 CPU cores, about 2 minutes): every state converges and the
    refined pull-off lies within 1.5 % of Maugis-Dugdale's -1.6007 pi R w (measured -1.6240,
    +1.46 %; the smooth curve's -1.6275, the substeps' scatter 0.6 %)."""
    r = maugis_dugdale_path(192)
    assert r["converged"], [c.get("iterations") for c in r["curve"]]
    ratio = r["pull_off_force"] / (math.pi * R * W)
    reference = maugis_dugdale_pull_off(1.0)
    assert abs(ratio / reference - 1) < 0.015, (ratio, reference)


def _tension_table(law, h_si: np.ndarray) -> np.ndarray:
    """The law's tension t(h) [Pa] from the minimiser's kernel (law_values) at gaps h [m]."""
    model = ContactModel(PAPER_PAIR, Sphere(R), Grid(16, 1e-8))
    law_id, params, _ = law.normal_law(model)
    out = wp.zeros((h_si.size, 3), dtype=wp.float64)
    wp.launch(_law_table, h_si.size, [wp.array(h_si / model.length_scale, dtype=wp.float64), 0.0, law_id, *params],
              [out])
    return out.numpy()[:, 1] * model.traction_scale


def test_centred_ramp_keeps_the_work_and_the_centroid_of_the_sharp_law():
    """Dugdale's ramps of width c = smoothing h_0 (0.3): both kinds keep w = sigma_0 h_0. The law's
    centroid int h t dh / w (the sharp law's h_0 / 2) moves out by c / 2 with the ramps at both
    ends, first order in c, and by c^2 / (24 h_0) with the centred ramp, second order (closed
    forms of the piecewise-linear laws). The centred law's tension is sigma_0 at contact
    (Maugis's), the other's 0. Trapezoid rule on 2e5 intervals: exact but at the kinks (allowed
    1e-6 relative; a first-order shift would be 0.3 of the centroid)."""
    sigma_0, h_0, s = 2e8, 1e-9, 0.3
    h = np.linspace(0.0, 2.0 * h_0, 200001)
    c = s * h_0
    for ramps, centroid in (("centred", 0.5 * h_0 + c * c / (24 * h_0)), ("both", 0.5 * h_0 + 0.5 * c)):
        law = Dugdale(sigma_0=sigma_0, h_0=h_0, smoothing=s, ramps=ramps)
        t = _tension_table(law, h)
        w = np.trapezoid(t, h)
        assert w == pytest.approx(sigma_0 * h_0, rel=1e-6), ramps
        assert np.trapezoid(h * t, h) / w == pytest.approx(centroid, rel=1e-6), ramps
        assert t[0] == pytest.approx(sigma_0 if ramps == "centred" else 0.0, abs=1e-9 * sigma_0), ramps
        assert law.range == pytest.approx(h[np.flatnonzero(t > 0)[-1]], abs=2 * (h[1] - h[0])), ramps
    with pytest.raises(InputError, match="adhesion.ramps"):
        Dugdale(sigma_0=sigma_0, h_0=h_0, ramps="middle")
    from warpcontact.physics.adhesion import RAMPS
    from warpcontact.records.case import DUGDALE_RAMPS

    assert RAMPS == DUGDALE_RAMPS  # the case file's choices are the law's


def test_centred_ramp_in_the_fixed_point_kernel():
    """The fixed-point turns' tension (Dugdale.tractions, kernels/adhesion.py, used with friction)
    is the minimiser's law (law_values) for the centred ramp too, on cells out of contact past the
    touching band (TOUCHING h_0); 1e-12 of sigma_0."""
    from warpcontact.physics.adhesion import TOUCHING

    law = Dugdale(sigma_0=2e8, h_0=1e-9, smoothing=0.4, ramps="centred")
    model = ContactModel(PAPER_PAIR, Sphere(R), Grid(16, 1e-8))
    state = ContactState(model)
    h = np.linspace(0.0, 1.5 * law.h_0, 256)
    state.gap.assign((h / model.length_scale).reshape(16, 16))
    out = [model.field() for _ in range(3)]
    law.tractions(model, state, *out)
    got = out[0].numpy().ravel() * model.traction_scale
    expected = np.where(h > TOUCHING * law.h_0, -_tension_table(law, h), 0.0)
    assert np.allclose(got, expected, rtol=0.0, atol=1e-12 * law.sigma_0)


def lambda_path(lam: float, n: int, smoothing: float, ramps: str) -> dict:
    """``warpcontact pull-off``'s default path (20 steps each way from -2 ranges to 2 h_0 and back
    to -4 ranges, extended until the contact breaks) for the Dugdale law at Maugis parameter
    ``lam`` (R = 1 um, w = 0.5 J/m^2, domain 5 a0) on n cells, the pull-off refined."""
    law = dugdale_at(lam, smoothing)
    law = Dugdale(sigma_0=law.sigma_0, h_0=law.h_0, smoothing=smoothing, ramps=ramps)
    model = ContactModel(PAPER_PAIR, Sphere(R), Grid(n, 5 * A0))
    return approach_retract(model, ContactSolver(model, None, adhesion=law), -2.0 * law.range, 2.0 * law.h_0,
                            -4.0 * law.range, 20, extend=True)


def test_centred_ramp_reaches_maugis_dugdale_on_a_coarse_grid():
    """lambda = 1 on n = 96 (the Dugdale zone 4.5 cells wide; about 10 s), one ramp centred on h_0,
    smoothing 0.3 (cell_softening 0.37): every state converges and the refined pull-off lies within
    1 % of Maugis-Dugdale's -1.6007 pi R w (measured -1.6111, +0.65 %; the substeps' scatter 1.2 %).
    The ramps' own change of the pull-off, measured in the continuum (axisymmetric rings,
    validation/md_convergence.py --continuum), is +0.04 %. With the ramps at both ends the same grid
    gives +5.1 % (smoothing 0.05, cell_softening 2.2) and their own change in the continuum is
    +0.6 % at smoothing 0.05, +3.2 % at 0.3 (first order in the smoothing)."""
    r = lambda_path(1.0, 96, 0.3, "centred")
    assert r["converged"], [c.get("iterations") for c in r["curve"]]
    ratio = r["pull_off_force"] / (math.pi * R * W)
    reference = maugis_dugdale_pull_off(1.0)
    assert abs(ratio / reference - 1) < 0.01, (ratio, reference)


def test_float32_agrees_with_float64():
    """The same state in float32: the total normal traction within 5e-3 of its 2-norm and the
    net force within 5e-3 of the gross force sum |p| (the net force is a small difference of
    compressive and tensile parts) (float32 stops at 1e-4 of the gradient; the solution's error is that times
    the preconditioned Hessian's spread, about 10: measured 1.5e-3 and force 2e-4). The split into contact and
    adhesive parts may differ on a cell at the contact's edge (touching in one precision, 1e-7
    of the law's length open in the other: measured 4e-3 of the peak on one cell)."""
    law = LAWS["lj93"]
    out = {}
    for dtype in ("float64", "float32"):
        model, solver, state, info = _solve_at(law, 32, 5e-10, dtype)
        assert info.converged, (dtype, info)
        out[dtype] = state.to_numpy_si()
    a, b = out["float64"], out["float32"]
    ta, tb = a["pressure"] + a["adhesive_pressure"], b["pressure"] + b["adhesive_pressure"]
    assert np.linalg.norm(ta - tb) < 5e-3 * np.linalg.norm(ta)
    fa = (a["pressure"] + a["adhesive_pressure"]).sum()
    fb = (b["pressure"] + b["adhesive_pressure"]).sum()
    assert abs(fb - fa) < 5e-3 * np.abs(ta).sum()


def test_devices_agree(device):
    """The same state on each device (CUDA: cuFFT through CuPy) against the CPU: fields within
    1e-6 of the peak (the solves stop at 1e-8 of the traction's norm; their iterates differ in
    rounding). On the CPU alone this checks that a solve repeats."""
    law = LAWS["smc"]
    out = {}
    for dev in ("cpu", device):
        model, solver, state, info = _solve_at(law, 48, 1e-9, device=dev)
        assert info.converged
        out[dev] = state.to_numpy_si()
    for name in ("pressure", "adhesive_pressure", "gap"):
        a, b = out["cpu"][name], out[device][name]
        assert np.abs(a - b).max() <= 1e-6 * np.abs(a).max(), name


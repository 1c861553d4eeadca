"""Partial slip against Cattaneo-Mindlin; coupling of dissimilar materials; hysteresis."""

import math

import numpy as np
import pytest

from warpcontact.physics.friction import Coulomb, TaborVonMises
from warpcontact.physics.geometry import Grid, Sphere
from warpcontact.studies.slip_search import find_gross_slip
from warpcontact.physics.materials import COPPER, PAPER_PAIR, MaterialPair
from warpcontact.numerics.model import ContactModel
from warpcontact.physics.reference import hertz, mindlin
from warpcontact.records.results import state_summary
from warpcontact.solvers.contact import ContactSolver
from warpcontact.numerics.state import ContactState

R, DZ, MU = 10e-6, 1.0e-10, 0.3
A = math.sqrt(R * DZ)
SAME = MaterialPair(COPPER, COPPER)


def loaded(pair, friction, n=64, device="cpu", dtype="float64", size=3 * A, preconditioned=True):
    model = ContactModel(pair, Sphere(R, "paraboloid"), Grid(n, size), device=device, dtype=dtype)
    solver = ContactSolver(model, friction, tangential_preconditioner=preconditioned)
    state = ContactState(model)
    for k in (1, 2):
        info = solver.step(state, (0.0, 0.0, DZ * k / 2))
        assert info.converged, info
    return model, solver, state


@pytest.mark.parametrize("preconditioned", [True, False])
@pytest.mark.parametrize("ratio", [0.25, 0.5, 0.75])
def test_cattaneo_mindlin_stick_radius_and_displacement(ratio, preconditioned, device):
    """Identical materials, Coulomb: stick radius within two cells of a (1 - Q/muP)^(1/3) and
    delta_x(Q) within 2 % of Mindlin's, Q the computed tangential force; with the preconditioned
    tangential solver (the default) and with Chen & Wang's plain iteration."""
    model, solver, state = loaded(SAME, Coulomb(MU), device=device, preconditioned=preconditioned)
    ref = mindlin(SAME, R, DZ, MU, ratio)
    info = solver.step(state, (ref["delta_x"], 0.0, DZ))
    assert info.converged, info
    s = state_summary(state)
    q_ratio = s["force"]["x"] / (MU * s["force"]["z"])
    # Mindlin's delta_x at the computed Q: the displacement error, relative
    dx_mindlin = mindlin(SAME, R, DZ, MU, q_ratio)["delta_x"]
    assert abs(ref["delta_x"] / dx_mindlin - 1) < 0.02, (
        f"delta_x {ref['delta_x']:.4e} vs Mindlin {dx_mindlin:.4e} at Q/muP {q_ratio:.4f}")
    c = math.sqrt(s["stick_area"] / math.pi)
    c_ref = A * (1 - q_ratio) ** (1 / 3)
    assert abs(c - c_ref) < 2 * model.grid.dx, f"stick radius {c:.3e} vs {c_ref:.3e} (cell {model.grid.dx:.2e})"


def test_cattaneo_mindlin_gross_slip():
    """delta_x_max within 3 % of Mindlin's 3 mu P / (16 a) ((2-nu1)/G1 + (2-nu2)/G2); mu = F_x/F_z."""
    model = ContactModel(SAME, Sphere(R, "paraboloid"), Grid(64, 3 * A))
    r = find_gross_slip(model, ContactSolver(model, Coulomb(MU)), DZ, normal_steps=2)
    ref = mindlin(SAME, R, DZ, MU, 0.5)["delta_x_max"]
    assert r["converged"]
    assert abs(r["delta_x_max"] / ref - 1) < 0.03, f"delta_x_max {r['delta_x_max']:.4e} vs Mindlin {ref:.4e}"
    assert (r["delta_x_gross"] - r["delta_x_max"]) <= 0.01 * r["delta_x_max"] * 1.0001
    assert abs(r["mu"] / MU - 1) < 0.01


def test_dissimilar_normal_loading_makes_shear_and_slip(device):
    """Copper on steel under pure normal approach: coupling produces shear and a slip annulus;
    identical materials produce none (MODEL.md section 3)."""
    fr = TaborVonMises(0.8, COPPER.yield_strength)
    _, _, state = loaded(PAPER_PAIR, fr, device=device)
    q = np.hypot(state.shear_x.numpy(), state.shear_y.numpy()).max() * PAPER_PAIR.E_star
    status = state.status.numpy()
    assert q > 1e5, f"max shear {q:.3e} Pa"  # of order beta p0, ~1e7 Pa here
    assert (status == 2).sum() > 0 and (status == 1).sum() > 0
    # the shear points radially: the sphere (copper) is pulled outwards by the flat on the +x side
    X, _ = np.meshgrid(np.arange(64), np.arange(64))
    assert np.sum(state.shear_x.numpy() * (X - 31.5)) != 0
    _, _, same = loaded(SAME, fr, device=device)
    assert np.abs(same.shear_x.numpy()).max() == 0 and (same.status.numpy() == 2).sum() == 0


def test_hysteresis_loop_closes():
    """A tangential load-unload-reload cycle (Mindlin-Deresiewicz): F_x(delta_x) at the same
    delta_x differs between loading and unloading (dissipation), and the loop closes: the
    force at the turning points is recovered within the solver's accuracy."""
    model, solver, state = loaded(SAME, Coulomb(MU))
    dmax = mindlin(SAME, R, DZ, MU, 0.5)["delta_x_max"]
    amp = 0.6 * dmax
    xs = list(np.linspace(0, amp, 5)[1:]) + list(np.linspace(amp, -amp, 9)[1:]) + list(np.linspace(-amp, amp, 9)[1:])
    forces = []
    for x in xs:
        info = solver.step(state, (float(x), 0.0, DZ))
        assert info.converged, info
        forces.append(state_summary(state)["force"]["x"])
    P = hertz(SAME, R, DZ)["force"]
    f_top_first, f_top_again = forces[3], forces[-1]
    assert abs(f_top_again - f_top_first) < 1e-3 * MU * P, "loop does not close at +amp"
    # Mindlin-Deresiewicz: unloading from Q* follows delta = delta* - 2 delta_load((Q* - Q)/2), so at
    # delta_x = 0 on the way down the force is already negative, and positive on the way up
    down_zero = forces[3 + 4]
    up_zero = forces[3 + 8 + 4]
    assert down_zero < -0.05 * MU * P and up_zero > 0.05 * MU * P
    assert abs(down_zero + up_zero) < 1e-3 * MU * P  # symmetric loop
    # quantitatively: Q(delta) = mu P (1 - (1 - delta/delta_max)^(3/2)) on loading, so the
    # unloading branch crosses delta_x = 0 at Q = Q* - 2 Q(amp / 2)
    q_load = lambda d: MU * P * (1 - (1 - d / dmax) ** 1.5)  # noqa: E731
    expected = q_load(amp) - 2 * q_load(amp / 2)
    assert abs(down_zero - expected) < 0.02 * MU * P, (
        f"F_x at delta_x = 0 on unloading {down_zero:.4e} vs M-D {expected:.4e}")


@pytest.mark.parametrize("adhesive", [False, True])
def test_stick_cells_do_not_slip(adhesive):
    """The stick condition itself, on the coupled pair: over a load step the slip of every stick
    cell is unchanged (to the solver tolerance times the shift), and slip cells' shear is at its
    limit and along their slip increment."""
    from warpcontact.physics.adhesion import SMC

    law = SMC(2e7, 2e7, 2e-11, 2e-11) if adhesive else None
    model = ContactModel(PAPER_PAIR, Sphere(R, "paraboloid"), Grid(48, 3 * A))
    solver = ContactSolver(model, TaborVonMises(0.8, COPPER.yield_strength), adhesion=law)
    state = ContactState(model)
    for k in (1, 2):
        assert solver.step(state, (0.0, 0.0, DZ * k / 2)).converged
    shift = 2.0e-11
    before = state.to_numpy_si()
    assert solver.step(state, (shift, 0.0, DZ)).converged
    after = state.to_numpy_si()
    status = state.status.numpy()
    ds = np.hypot(after["slip_x"] - before["slip_x"], after["slip_y"] - before["slip_y"])
    assert (status == 1).sum() > 10 and (status == 2).sum() > 10
    assert ds[status == 1].max() < 1e-6 * shift, f"stick cells slipped by up to {ds[status == 1].max():.2e} m"
    slipping = (status == 2) & (ds > 1e-3 * shift)
    cos = (after["shear_x"] * (after["slip_x"] - before["slip_x"])
           + after["shear_y"] * (after["slip_y"] - before["slip_y"]))
    cos = cos[slipping] / (np.hypot(after["shear_x"], after["shear_y"])[slipping] * ds[slipping])
    assert cos.min() > 0.999, "slip cells' shear is not along their slip increment"


@pytest.mark.parametrize("adhesive", [False, True])
def test_turns_keep_the_normal_displacement_of_the_pressure(adhesive, device):
    """The later turns of a coupled step start their normal solves from the state's
    displacement instead of convolving the unchanged pressure again (``displacement_current``):
    after the step, disp_z is K p of the final pressure, as a fresh convolution makes it (to
    float64 rounding: the first guess's K p is c K s, not K (c s)). With adhesion the turns'
    normal solves are the adhesive minimisation, warm-started from its own displacement: disp_z
    is K of the total normal traction (contact + adhesive) to 1e-6 (the test of
    test_adhesive_solver: the traction is the displacement's, carried between exact products,
    and the split into contact and adhesive parts meets the law to the solve's tolerance)."""
    from warpcontact.physics.adhesion import SMC

    law = SMC(2e7, 2e7, 2e-11, 2e-11) if adhesive else None
    model = ContactModel(PAPER_PAIR, Sphere(R, "paraboloid"), Grid(48, 3 * A), device=device)
    solver = ContactSolver(model, TaborVonMises(0.8, COPPER.yield_strength), adhesion=law)
    state = ContactState(model)
    for approach in ((0.0, 0.0, DZ), (2.0e-11, 0.0, DZ)):
        info = solver.step(state, approach)
        assert info.converged and info.outer_iterations > 2, info
        fresh = model.field()
        total = model.field()
        total.assign(state.pressure.numpy() + (state.adhesive_pressure.numpy() if adhesive else 0.0))
        model.operator.normal(total, fresh)
        u, ref = state.disp_z.numpy(), fresh.numpy()
        tol = 1e-6 if adhesive else 1e-13
        assert np.abs(u - ref).max() < tol * np.abs(ref).max(), np.abs(u - ref).max() / np.abs(ref).max()


def test_normal_solves_preconditioned_by_default():
    """ContactSolver preconditions every normal solve by default, in the turns of a coupled or
    adhesive step too (its docstring gives the measurements); an explicit choice wins.
    Frictionless, both choices reach the same pressure (to 100 tolerances of its peak: both meet
    the 1e-10 residual), the preconditioned one in fewer iterations."""
    from warpcontact.physics.adhesion import SMC

    law = TaborVonMises(0.8, PAPER_PAIR.softer.yield_strength)
    model = ContactModel(PAPER_PAIR, Sphere(R), Grid(48, 4 * A))
    same = ContactModel(SAME, Sphere(R), Grid(48, 4 * A))
    assert ContactSolver(model).normal.settings.normal_preconditioner
    assert ContactSolver(same, law).normal.settings.normal_preconditioner
    assert ContactSolver(model, law).normal.settings.normal_preconditioner
    assert ContactSolver(model, adhesion=SMC(2e7, 2e7, 5e-12, 5e-12)).normal.settings.normal_preconditioner
    assert not ContactSolver(model, law, normal_preconditioner=False).normal.settings.normal_preconditioner
    results = {}
    for preconditioned in (True, False):
        state = ContactState(model)
        info = ContactSolver(model, normal_preconditioner=preconditioned).step(state, (0.0, 0.0, DZ))
        assert info.converged
        results[preconditioned] = (state.pressure.numpy(), info.iterations)
    (p1, it1), (p2, it2) = results[True], results[False]
    assert np.abs(p1 - p2).max() < 100 * 1e-10 * p2.max()
    assert it1 < it2, (it1, it2)


@pytest.mark.parametrize("tangential_preconditioned", [True, False])
def test_turn_tolerance_schedules_reach_the_same_state(tangential_preconditioned):
    """The coupled step (copper on steel, Tabor k_tau 0.8, delta_z then delta_x, n = 48) with the
    turns' tolerance from the coupled residual (the default) and from the last turn's change (the
    schedule before, plain normal solves in the turns): both end at a change under 100 tol in a
    turn at full tolerance, so their forces agree to about that (1e-8 relative; measured 1e-10),
    and the default takes fewer inner iterations (measured at n = 48 with scipy.fft: 88 against 259
    with the preconditioned tangential solver). The counts move with the transforms' rounding
    (fftw: 87 / 231, warp: 93 / 193; a clean-clone CI with freshly measured FFTW plans once gave
    201 / 193), so the test pins scipy.fft, whose transforms do not depend on measured plans."""
    results = {}
    for schedule in ("residual", "change"):
        model = ContactModel(PAPER_PAIR, Sphere(R), Grid(48, 4 * A), fft="scipy")
        solver = ContactSolver(model, TaborVonMises(0.8, PAPER_PAIR.softer.yield_strength),
                               normal_preconditioner=schedule == "residual", turn_tolerance=schedule,
                               tangential_preconditioner=tangential_preconditioned)
        state = ContactState(model)
        iterations = 0
        for approach in ((0.0, 0.0, DZ), (2.0e-11, 0.0, DZ)):
            info = solver.step(state, approach)
            assert info.converged, (schedule, approach, info.outer_iterations)
            iterations += info.iterations
        s = state_summary(state, None)
        results[schedule] = (s["force"]["x"], s["force"]["z"], iterations)
    (fx1, fz1, it1), (fx2, fz2, it2) = results["residual"], results["change"]
    assert fx1 == pytest.approx(fx2, rel=1e-8) and fz1 == pytest.approx(fz2, rel=1e-8)
    if tangential_preconditioned:
        assert it1 < it2, (it1, it2)


def test_exact_turns_reach_the_same_state_in_fewer_turns():
    """``turn_tolerance = "exact"``: every turn's solves at the full tolerance. The same coupled
    step as above (n = 48, scipy.fft): the forces agree with the default's loose early turns to
    1e-8 relative (both end at a change under 100 tol in a turn at full tolerance; measured 1e-10),
    in fewer turns (each turn does its solves' whole work: 6-8 against 11-12 at n = 128-512,
    bench/scaling.py's row coupled-exact) but more inner iterations in all (1.6-2.2x there)."""
    results = {}
    for schedule in ("residual", "exact"):
        model = ContactModel(PAPER_PAIR, Sphere(R), Grid(48, 4 * A), fft="scipy")
        solver = ContactSolver(model, TaborVonMises(0.8, PAPER_PAIR.softer.yield_strength), turn_tolerance=schedule)
        state = ContactState(model)
        turns = iterations = 0
        for approach in ((0.0, 0.0, DZ), (2.0e-11, 0.0, DZ)):
            info = solver.step(state, approach)
            assert info.converged, (schedule, approach, info.outer_iterations)
            turns += info.outer_iterations
            iterations += info.iterations
        s = state_summary(state, None)
        results[schedule] = (s["force"]["x"], s["force"]["z"], turns, iterations)
    (fx1, fz1, t1, it1), (fx2, fz2, t2, it2) = results["residual"], results["exact"]
    assert fx1 == pytest.approx(fx2, rel=1e-8) and fz1 == pytest.approx(fz2, rel=1e-8)
    assert t2 < t1 and it2 > it1, results

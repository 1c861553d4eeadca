"""Adhesion: the laws against their closed forms, the DMT pull-off limit, adhesion in a case."""

import math

import numpy as np
import pytest
from scipy import integrate

from warpcontact.physics.adhesion import SMC, TOUCHING, Dugdale
from warpcontact.physics.geometry import Grid, Sphere
from warpcontact.physics.materials import PAPER_PAIR
from warpcontact.numerics.model import ContactModel
from warpcontact.studies.approach_retract import approach_retract, tabor_parameter
from warpcontact.physics.reference import maugis_dugdale_pull_off
from warpcontact.solvers.contact import ContactSolver
from warpcontact.solvers.turns import LaggedTurns, MinimisedTurns
from warpcontact.numerics.state import ContactState


def test_smc_and_dugdale_kernels_match_closed_forms(device):
    """The law kernels' tractions equal MODEL.md section 6 evaluated in numpy (1e-12)."""
    n = 16
    model = ContactModel(PAPER_PAIR, Sphere(1e-6), Grid(n, 1e-7), device=device)
    state = ContactState(model)
    rng = np.random.default_rng(3)
    law = SMC(sigma_max=2e8, tau_max=1e8, delta_n=5e-10, delta_t=8e-10)
    L, E = model.length_scale, model.traction_scale
    h = rng.uniform(-1e-10, 3e-9, (n, n))
    sx, sy = rng.normal(0, 1e-9, (2, n, n))
    sx[0, 0] = sy[0, 0] = 0.0
    p_c = np.where(rng.random((n, n)) < 0.2, 1e-3, 0.0)  # some cells in contact: no adhesive traction
    for name, v in (("gap", h / L), ("slip_x", sx / L), ("slip_y", sy / L), ("pressure", p_c)):
        getattr(state, name).assign(v)
    h[1, :4] = np.array([0.0, 0.2, 0.5, 0.9]) * TOUCHING * law.delta_n  # touching cells (out of contact)
    p_c[1, :4] = 0.0
    for name, v in (("gap", h / L), ("pressure", p_c)):
        getattr(state, name).assign(v)
    out_fields = (state.adhesive_pressure, state.adhesive_shear_x, state.adhesive_shear_y)
    law.tractions(model, state, *out_fields)  # the current adhesive tractions are zero
    xn = np.maximum(h, 0) / law.delta_n
    s = np.hypot(sx, sy)
    xt = s / law.delta_t
    e = np.exp(1 - np.sqrt(xn**2 + xt**2))
    out = (p_c <= 0) & (h > TOUCHING * law.delta_n)  # touching cells keep their traction (0) on [0, law]
    p_ref = np.where(out, -law.sigma_max * xn * e, 0.0)
    q = np.where(out, law.tau_max * xt * e, 0.0)
    qx_ref = np.where(s > 0, q * sx / np.where(s > 0, s, 1), 0.0)
    f = state.to_numpy_si()
    assert np.allclose(f["adhesive_pressure"], p_ref, rtol=1e-12, atol=1e-12 * law.sigma_max)
    assert np.allclose(f["adhesive_shear_x"], qx_ref, rtol=1e-12, atol=1e-12 * law.tau_max)
    # a touching cell keeps a traction that lies on the segment [0, law] and is projected onto it
    # otherwise (the law's jump to the contact side, see warpcontact.physics.adhesion.TOUCHING)
    law_p = -law.sigma_max * np.maximum(h, 0) / law.delta_n * e
    start = np.zeros((n, n))
    start[1, 1] = 0.5 * law_p[1, 1]  # on the segment: kept
    start[1, 2] = 2.0 * law_p[1, 2]  # beyond the law's value: projected to it
    start[1, 3] = -law_p[1, 3]  # the wrong sign: projected to 0
    state.adhesive_pressure.assign(start / E)
    state.adhesive_shear_x.zero_()
    state.adhesive_shear_y.zero_()
    law.tractions(model, state, *out_fields)
    got = state.to_numpy_si()["adhesive_pressure"][1, 1:4]
    assert np.allclose(got, [0.5 * law_p[1, 1], law_p[1, 2], 0.0], rtol=1e-12, atol=1e-12 * law.sigma_max)
    # the work of pure opening is e sigma_max delta_n
    w = law.sigma_max * law.delta_n * integrate.quad(lambda x: x * math.exp(1 - x), 0, np.inf)[0]
    assert w == pytest.approx(law.work_of_adhesion, rel=1e-9)
    dug = Dugdale(sigma_0=1e8, h_0=4e-10, smoothing=0.0)  # the sharp law
    for a in out_fields:
        a.zero_()
    dug.tractions(model, state, *out_fields)
    ref = np.where((p_c <= 0) & (h > TOUCHING * dug.h_0) & (h <= dug.h_0), -dug.sigma_0, 0.0)
    assert np.allclose(state.to_numpy_si()["adhesive_pressure"], ref, rtol=1e-12, atol=1e-6)
    smooth = Dugdale(sigma_0=1e8, h_0=4e-10, smoothing=0.1, ramps="both")  # ramps of width 0.1 h_0 at both ends
    state.adhesive_pressure.zero_()
    smooth.tractions(model, state, *out_fields)
    ramp = 0.1 * smooth.h_0
    shape = np.clip(np.minimum(h / ramp, (smooth.h_0 + ramp - h) / ramp), 0.0, 1.0)
    ref = np.where((p_c <= 0) & (h > TOUCHING * smooth.h_0), -smooth.sigma_0 * shape, 0.0)
    assert np.allclose(state.to_numpy_si()["adhesive_pressure"], ref, rtol=1e-9, atol=1e-6)
    # the ramps keep the work of adhesion: integral of the law over h is sigma_0 h_0
    hh = np.linspace(0, 2 * smooth.h_0, 200001)
    law = np.clip(np.minimum(hh / ramp, (smooth.h_0 + ramp - hh) / ramp), 0, 1) * smooth.sigma_0
    assert integrate.trapezoid(law, hh) == pytest.approx(smooth.work_of_adhesion, rel=1e-6)


def test_pull_off_dmt_limit():
    """Small Tabor parameter (0.074): the pull-off force approaches 2 pi R w (Derjaguin-Muller-
    Toporov). Expected here: Maugis-Dugdale at lambda = 1.16 mu gives 0.98 of it; allowed 3 %
    (the delta_z sampling of the retraction curve, 0.25 nm, and the domain's truncated tail)."""
    R, w, dn = 1e-6, 0.05, 1e-9
    law = SMC(w / (math.e * dn), w / (math.e * dn), dn, dn)
    mu = tabor_parameter(PAPER_PAIR, R, w, dn)
    assert 0.05 < mu < 0.1
    model = ContactModel(PAPER_PAIR, Sphere(R), Grid(64, 3.2e-7))
    r = approach_retract(model, ContactSolver(model, None, adhesion=law), -dn, 1e-9, -1e-9, 8)
    assert r["converged"]
    ratio = r["pull_off_force"] / (-2 * math.pi * R * w)
    expected = -maugis_dugdale_pull_off(1.16 * mu) / 2
    assert abs(ratio - 1) < 0.03, f"pull-off / (2 pi R w) = {ratio:.4f} (Maugis-Dugdale at lambda = 1.16 mu: {expected:.4f})"


def jkr_side_pull_off(w: float) -> tuple[float, float, float, float]:
    """The SMC law's pull-off on the JKR side (R = 1 um, delta_n = 0.2 nm, work of adhesion ``w``
    [J/m^2]; n = 128 on a domain of 4 JKR radii at zero load, approach to 2 nm and back to -1.5 nm
    in 16 steps each way): (Tabor parameter, pull-off / (pi R w), Maugis-Dugdale's at the law's
    peak stress and work, Maugis-Dugdale's at Johnson-Greenwood's lambda = 1.16 mu)."""
    R, dn = 1e-6, 2e-10
    mu = tabor_parameter(PAPER_PAIR, R, w, dn)
    a0 = (9 * math.pi * w * R**2 / (2 * PAPER_PAIR.E_star)) ** (1 / 3)  # JKR contact radius, zero load
    law = SMC(w / (math.e * dn), w / (math.e * dn), dn, dn)
    model = ContactModel(PAPER_PAIR, Sphere(R), Grid(128, 4 * a0))
    r = approach_retract(model, ContactSolver(model, None, adhesion=law), -dn, 2e-9, -1.5e-9, 16)
    assert r["converged"], (f"Tabor {mu:.2f}", [c["outer_iterations"] for c in r["curve"]])
    ratio = -r["pull_off_force"] / (math.pi * R * w)
    lam = law.sigma_max * (9 * R / (2 * math.pi * w * PAPER_PAIR.E_star**2)) ** (1 / 3)
    peak, jg = -maugis_dugdale_pull_off(lam), -maugis_dugdale_pull_off(1.16 * mu)
    print(f"\npull-off at Tabor {mu:.2f}: {ratio:.4f} pi R w; Maugis-Dugdale {peak:.4f} (peak stress), {jg:.4f} (1.16 mu)")
    return mu, ratio, peak, jg


@pytest.mark.slow
def test_pull_off_leaves_dmt_for_the_jkr_side_at_tabor_parameter_2_74():
    """Tabor parameter 2.74 (w = 1 J/m^2): the pull-off leaves the DMT value 2 pi R w for the JKR
    side (1.5 pi R w at the limit). The reference is Maugis-Dugdale, but an exponential law maps
    onto Dugdale's only approximately: matching the peak stress and the work (sigma_0 =
    sigma_max, lambda = 1.14) gives 1.585 pi R w, Johnson-Greenwood's lambda = 1.16 mu 1.515. The
    allowed difference from the first is the spread between the two mappings. Measured: 1.631
    pi R w (+2.9 %) at n = 128 (cells 1.8 nm across a contact radius a0 = 57 nm); n = 256 gives
    1.631 again. Tabor 4.35 and 5.7, and the fall between them: the slow study below. A slow
    study itself (21 s on 2 CPU cores): the pull-off on the JKR side in every run is
    tests/test_adhesion_laws_case.py's (exponential law, Tabor 3) and tests/test_pull_off_path.py's
    jump in and out."""
    mu, ratio, peak, jg = jkr_side_pull_off(1.0)
    assert 2.7 < mu < 2.8
    assert 1.5 < ratio < 1.75, f"pull-off = {ratio:.4f} pi R w (JKR 1.5, DMT 2)"
    assert abs(ratio - peak) < abs(peak - jg), (ratio, peak, jg)


@pytest.mark.slow
def test_pull_off_at_tabor_parameters_4_35_and_5_7_falls_towards_jkr():
    """Tabor parameters 4.35 and 5.7 (w = 2 and 3 J/m^2, as the test above; about 6 minutes on 2
    CPU cores). At 4.35 the measured pull-off is 1.570 pi R w (+1.9 % from Maugis-Dugdale at the
    same peak stress and work, lambda = 1.80: 1.541; Johnson-Greenwood's mapping gives 1.506): the
    same bounds as at 2.74. At 5.7 the curve needs the mixing's restarts (RESTART_GROWTH) and the
    cold-start retry of a step: without them, every state stopped unconverged at 200 turns, and
    with 1000 turns alone 20 of 33 still did. Measured there: every state converged in 421-807
    turns (the last, past pull-off, in 19 more from zero tractions after 1000 from the previous
    state's), and the pull-off is 1.548 pi R w, +1.4 % from Maugis-Dugdale at the same peak
    stress and work (lambda = 2.36: 1.526). Checked: the pull-off falls from 4.35 to 5.7 and stays
    above JKR (1.5), and at 5.7 it is within 3 % of the peak-stress Maugis-Dugdale value, the
    largest difference measured at the lower parameters (+2.9 % at 2.74)."""
    mu, at_4_35, peak, jg = jkr_side_pull_off(2.0)
    assert 4.3 < mu < 4.4
    assert 1.5 < at_4_35 < 1.75 and abs(at_4_35 - peak) < abs(peak - jg), (at_4_35, peak, jg)
    mu, at_5_7, peak, _ = jkr_side_pull_off(3.0)
    assert 5.6 < mu < 5.8
    assert 1.5 < at_5_7 < at_4_35, (at_5_7, at_4_35)
    assert abs(at_5_7 / peak - 1) < 0.03, (at_5_7, peak)


def dugdale_pull_off_difference(n: int) -> float:
    """The Dugdale law at Maugis parameter lambda = 0.5 (R = 1 um, w = 0.5 J/m^2, sigma_0 = 643 MPa,
    h_0 = 0.78 nm, the default ramp of 0.05 h_0 centred on h_0; domain 5 a0; 12 steps each way) on
    an n-cell grid: every state converges; returns the pull-off's relative difference from
    Maugis-Dugdale's -1.718 pi R w."""
    R, w, lam = 1e-6, 0.5, 0.5
    sigma_0 = lam / (9 * R / (2 * math.pi * w * PAPER_PAIR.E_star**2)) ** (1 / 3)
    law = Dugdale(sigma_0=sigma_0, h_0=w / sigma_0, smoothing=0.05)
    a0 = (9 * math.pi * w * R**2 / (2 * PAPER_PAIR.E_star)) ** (1 / 3)
    model = ContactModel(PAPER_PAIR, Sphere(R), Grid(n, 5 * a0))
    r = approach_retract(model, ContactSolver(model, None, adhesion=law), -law.h_0, 2 * law.h_0, -3 * law.h_0, 12)
    assert r["converged"], n
    return r["pull_off_force"] / (math.pi * R * w) / maugis_dugdale_pull_off(lam) - 1


def test_dugdale_pull_off_matches_maugis_dugdale():
    """``dugdale_pull_off_difference`` at n = 96: measured -0.20 % (+0.8 % with the ramps at both
    ends of h_0); allowed 2 %, the grid's error at 96 cells (the refinement to 192 is the slow
    study below)."""
    difference = dugdale_pull_off_difference(96)
    assert abs(difference) < 0.02, difference


@pytest.mark.slow
def test_dugdale_pull_off_closer_to_maugis_dugdale_on_a_finer_grid():
    """Refined from n = 96 to 192 the pull-off comes closer to Maugis-Dugdale's: measured -0.20 % at
    96, +0.17 % at 192 (with the ramps at both ends: +0.8 %, +0.3 %); the remaining difference is
    the grid's and the 0.19 nm sampling of the curve. About 30 s on 2 CPU cores."""
    differences = [dugdale_pull_off_difference(n) for n in (96, 192)]
    print(f"\nDugdale pull-off vs Maugis-Dugdale at lambda 0.5: {differences[0]:+.2%} (n 96), {differences[1]:+.2%} (n 192)")
    assert abs(differences[0]) < 0.02 and abs(differences[1]) < abs(differences[0]), differences


def test_maugis_dugdale_reference_limits():
    """The Maugis-Dugdale transcription reproduces its limits: DMT -2, JKR -1.5 (in pi w R)."""
    assert maugis_dugdale_pull_off(1e-3) == pytest.approx(-2.0, abs=2e-3)
    assert maugis_dugdale_pull_off(20.0) == pytest.approx(-1.5, abs=2e-3)
    vals = [maugis_dugdale_pull_off(x) for x in (0.1, 0.5, 1.0, 2.0)]
    assert all(a < b for a, b in zip(vals, vals[1:]))  # monotone between the limits


def test_adhesion_enlarges_contact_and_stick_area():
    """The paper's observation (Figure 1): with adhesion the contact and the stick areas grow."""
    from warpcontact.physics.friction import TaborVonMises
    from warpcontact.records.results import state_summary

    R, dz = 10e-6, 5e-11
    a = math.sqrt(R * dz)
    areas = {}
    for label, law in (("none", None), ("smc", SMC(2e7, 2e7, 2e-11, 2e-11))):
        model = ContactModel(PAPER_PAIR, Sphere(R), Grid(48, 4 * a))
        solver = ContactSolver(model, TaborVonMises(0.8, 200e6), adhesion=law)
        state = ContactState(model)
        for k in (1, 2):
            assert solver.step(state, (0.0, 0.0, dz * k / 2)).converged
        assert solver.step(state, (3.0e-11, 0.0, dz)).converged
        areas[label] = state_summary(state, law)
    assert areas["smc"]["contact_area"] > areas["none"]["contact_area"]
    assert areas["smc"]["stick_area"] > areas["none"]["stick_area"]
    assert areas["smc"]["adhesive_area"] > 0 and areas["none"]["adhesive_area"] == 0


def test_maugis_parameter_of_the_laws():
    """lambda = sigma_peak (9 R / (2 pi w E*^2))^(1/3): exactly Maugis's for the Dugdale law (sharp,
    sigma_0 chosen for lambda = 2), 0.0557 for Table 2's SMC law (DMT side)."""
    from warpcontact.physics.adhesion import maugis_parameter

    R, W, E = 1e-6, 0.5, PAPER_PAIR.E_star
    sigma_0 = 2.0 / (9 * R / (2 * math.pi * W * E**2)) ** (1 / 3)
    assert maugis_parameter(Dugdale(sigma_0=sigma_0, h_0=W / sigma_0, smoothing=0.0), R, E) == pytest.approx(2.0)
    assert maugis_parameter(SMC(1e6, 1e6, 5e-12, 5e-12), 10e-6, E) == pytest.approx(0.05573, rel=1e-4)


def test_the_turns_are_lagged_on_the_dmt_side_and_minimised_towards_jkr():
    """With adhesion and friction the solver picks the turns by the law's Maugis parameter: lagged
    under LAGGED_TURNS_MAX_MAUGIS (Table 2's SMC law, 0.056), minimised above it (the same law
    with a 200x peak tension and a 200x shorter length, the same work: 11), lagged with a hardness
    cap whatever the law."""
    from warpcontact.physics.friction import TaborVonMises
    from warpcontact.solvers import contact

    model = ContactModel(PAPER_PAIR, Sphere(10e-6), Grid(32, 1e-7))
    friction = TaborVonMises(0.8, PAPER_PAIR.softer.yield_strength)
    dmt, towards_jkr = SMC(1e6, 1e6, 5e-12, 5e-12), SMC(2e8, 2e8, 2.5e-14, 2.5e-14)
    assert ContactSolver(model, friction, adhesion=dmt).turns == "lagged"
    assert ContactSolver(model, friction, adhesion=towards_jkr).turns == "minimised"
    assert ContactSolver(model, friction, adhesion=towards_jkr, pressure_cap=1e9).turns == "lagged"
    assert contact.LAGGED_TURNS_MAX_MAUGIS == pytest.approx(0.1)


def test_lagged_and_minimised_turns_give_the_same_table2_cell(monkeypatch):
    """One adhesive Table 2 cell (k_tau 0.8, delta_z 1e-4 um, n = 32) by the lagged turns (the
    default there) and by the minimised turns: the same delta_x_max (its 1 % bracket lands in the
    same place) and mu within 1e-4 relative (the two stop on different criteria; 3e-5 at most over
    the 12 cells at n = 48 and 256, docs/performance.md). Then a lagged
    step made to fail is solved by the minimised turns from its iterate (turn_fallbacks)."""
    from warpcontact.studies import table2 as t2
    from warpcontact.solvers import contact

    settings = t2.Table2Settings(n=32)
    lagged = t2.table2_cell(0.8, 1e-4, settings, adhesion=True)
    original = contact.ContactSolver.__init__

    def minimised(self, *a, **k):
        original(self, *a, turns="minimised", **k)

    monkeypatch.setattr(contact.ContactSolver, "__init__", minimised)
    other = t2.table2_cell(0.8, 1e-4, settings, adhesion=True)
    assert lagged["converged"] and other["converged"]
    assert lagged["delta_x_max_um"] == other["delta_x_max_um"]
    assert lagged["mu"] == pytest.approx(other["mu"], rel=1e-4)

    monkeypatch.setattr(contact.ContactSolver, "__init__", original)
    from warpcontact.physics.friction import TaborVonMises

    model = ContactModel(PAPER_PAIR, Sphere(t2.RADIUS), t2.cell_grid(1e-4 * t2.UM, settings, settings.adhesion_law()))
    solver = ContactSolver(model, TaborVonMises(0.8, PAPER_PAIR.softer.yield_strength), adhesion=settings.adhesion_law())
    assert solver.turns == "lagged"
    lagged = solver.strategies[0]
    assert isinstance(lagged, LaggedTurns)
    turns = lagged._turns

    def failing_turns(*args):  # the lagged turns as they are, reported as not converged
        r = turns(*args)
        return (*r[:3], False, *r[4:])

    monkeypatch.setattr(lagged, "_turns", failing_turns)
    info = solver.step(ContactState(model), (0.0, 0.0, 1e-4 * t2.UM))
    assert info.converged and solver.turn_fallbacks == 1


def _minimised_solver(n: int, mixing: bool, sigma: float = 2e7):
    """bench/scaling.py --adhesion's problem: the paper's pair, Tabor k_tau 0.8, SMC law sigma_max
    = tau_max = ``sigma`` [Pa], delta_n = delta_t = 5 pm (2e7 Pa: Maugis parameter 0.41; 1e8 Pa:
    1.2), the minimised turns."""
    from warpcontact.physics.friction import TaborVonMises

    model = ContactModel(PAPER_PAIR, Sphere(10e-6), Grid(n, 4 * math.sqrt(10e-6 * 1e-10)))
    solver = ContactSolver(model, TaborVonMises(0.8, PAPER_PAIR.softer.yield_strength),
                           adhesion=SMC(sigma, sigma, 5e-12, 5e-12), turn_mixing=mixing)
    assert solver.turns == "minimised"
    return solver, ContactState(model)


def _minimised_steps(n: int, mixing: bool, sigma: float = 2e7):
    """The solver's steps delta_z = 1e-10 m, then delta_x = 2e-11 m: (infos, SI fields)."""
    solver, state = _minimised_solver(n, mixing, sigma)
    infos = [solver.step(state, approach) for approach in ((0.0, 0.0, 1e-10), (2e-11, 0.0, 1e-10))]
    assert solver.turn_fallbacks == 0
    return infos, state.to_numpy_si()


def test_anderson_mixed_minimised_turns_reach_the_plain_fixed_point_in_fewer_turns():
    """The minimised turns' shear Anderson-mixed (the default) against the plain fixed point
    x <- G(x), which contracts by about 0.62 per turn here: at most half the turns (measured 12 and
    13 against 34 and 28 at n = 64) and the same state: every traction within 1e-6 of its largest
    (the turns stop at a relative change of 1e-8, 100 x the inner tolerance; measured 1.5e-7).
    On finer grids a cell touching within the law's threshold may carry a different adhesive
    shear (its traction is any point of a segment there; docs/performance.md)."""
    plain_infos, plain = _minimised_steps(64, mixing=False)
    mixed_infos, mixed = _minimised_steps(64, mixing=True)
    assert all(i.converged for i in plain_infos + mixed_infos)
    for p, m in zip(plain_infos, mixed_infos):
        assert 2 * m.outer_iterations <= p.outer_iterations, (m.outer_iterations, p.outer_iterations)
    for name in ("pressure", "adhesive_pressure", "shear_x", "adhesive_shear_x", "gap"):
        scale = np.abs(plain[name]).max()
        assert np.abs(mixed[name] - plain[name]).max() < 1e-6 * scale, name


def test_anderson_mixed_minimised_turns_converge_where_the_plain_fixed_point_stalls():
    """Maugis parameter 1.2 (SMC 1e8 Pa, 5 pm), n = 64: the plain fixed point of the minimised turns
    stalls at a change of 0.73 per turn and falls back to the lagged turns after 1000 turns (20110
    inner iterations, 29 s on 2 cores); mixed, both steps converge in the minimised turns (44 and
    50 turns, 448 and 661 inner iterations, 1.3 and 1.7 s)."""
    infos, _ = _minimised_steps(64, mixing=True, sigma=1e8)
    assert all(i.converged for i in infos)
    assert all(i.outer_iterations < 100 for i in infos), [i.outer_iterations for i in infos]


def test_a_step_counts_the_work_of_turns_that_fell_back(monkeypatch):
    """Minimised turns that do not converge hand the step to the lagged turns from their iterate;
    the step's iterations and turns include the attempt's (a stalled attempt must not look cheap)."""
    from warpcontact.numerics.state import SolveInfo

    solver, state = _minimised_solver(32, mixing=True)
    minimised = solver.strategies[0]
    assert isinstance(minimised, MinimisedTurns)
    monkeypatch.setattr(minimised, "solve", lambda *a: SolveInfo(converged=False, iterations=1234, residual=1.0,
                                                                 outer_iterations=77))
    info = solver.step(state, (0.0, 0.0, 1e-10))
    assert info.converged and solver.turn_fallbacks == 1
    assert info.iterations > 1234 and info.outer_iterations > 77, info

"""The Maugis-Dugdale reference (warpcontact.physics.reference) against an independent solution, its limits and
published values.

Units are Johnson & Greenwood's (1997), J. Colloid Interface Sci. 192, 326: K = 4 E* / 3,
A = a / (pi w R^2 / K)^(1/3), P = F / (pi w R), Delta = delta / (pi^2 w^2 R / K^2)^(1/3),
lambda = sigma_0 (9 R / (2 pi w E*^2))^(1/3).
"""

import math
from types import SimpleNamespace

import numpy as np
import pytest
from scipy import integrate, special

from warpcontact.physics.reference import (
    LAMBDA_JUMP_IN_ON_NONCONTACT_BRANCH,
    LAMBDA_JUMP_OUT_ON_CONTACT_BRANCH,
    maugis_dugdale_critical_points,
    maugis_dugdale_curve,
    maugis_dugdale_force_at,
    maugis_dugdale_noncontact_curve,
    maugis_dugdale_pull_off,
    maugis_dugdale_si,
    maugis_dugdale_state_at,
    maugis_parameter,
)

LAMBDAS = (0.1, 0.3, 0.5, 1.0, 2.0, 3.0, 5.0)


# --- an independent solution: Maugis's tractions, displacements by the Boussinesq integral ----------------
# Units with K = 1 (E* = 3/4), R = 1, w = 1/pi make A = a, P = F, Delta = delta, sigma_0 = lambda / 2 and
# h_0 = 2 / (pi lambda).
E_STAR = 0.75


def _traction(t, a, c, sigma_0):
    """Maugis's pressure (compressive > 0): Hertz's for radius a plus the Dugdale zone's, at radius t."""
    t = np.asarray(t, dtype=float)
    inside = t < a
    a2_t2 = np.clip(a * a - t * t, 1e-300, None)
    hertz = np.where(inside, 2.0 * E_STAR / math.pi * np.sqrt(a2_t2), 0.0)
    dugdale = np.where(inside, -2.0 * sigma_0 / math.pi * np.arctan(np.sqrt((c * c - a * a) / a2_t2)),
                       np.where(t < c, -sigma_0, 0.0))
    return hertz + dugdale


def _surface_displacement(r, a, c, sigma_0):
    """Both surfaces' normal displacement (apart > 0) at radius r under _traction (Johnson 1985, eq. 3.5
    with Landen's transformation: u = 4 / (pi E*) [int_0^r p (t/r) K(t/r) dt + int_r^c p K(r/t) dt])."""
    K = lambda k: special.ellipk(k * k)  # noqa: E731  (complete elliptic integral of modulus k)
    p = lambda t: _traction(t, a, c, sigma_0)  # noqa: E731
    opts = {"epsabs": 1e-14, "epsrel": 1e-12, "limit": 400}
    if r == 0.0:
        return 2.0 / E_STAR * integrate.quad(p, 0.0, c, points=[a], **opts)[0]
    inner_pts = [x for x in (a, c) if 0.0 < x < r] or None
    outer_pts = [x for x in (a, c) if r < x < c] or None
    inner = integrate.quad(lambda t: p(t) * (t / r) * K(t / r), 0.0, r, points=inner_pts, **opts)[0]
    outer = integrate.quad(lambda t: p(t) * K(r / t), r, c, points=outer_pts, **opts)[0] if r < c else 0.0
    return 4.0 / (math.pi * E_STAR) * (inner + outer)


@pytest.mark.parametrize("lam, m", [(0.1, 20.0), (0.3, 3.0), (1.0, 1.5), (3.0, 1.05)])
def test_contact_branch_matches_boussinesq_integration(lam, m):
    """Maugis's closed forms against the tractions integrated numerically: at the curve's (A, m) the
    force is 2 pi int p r dr = P, the centre displacement is Delta, the gap is zero inside the contact
    (r = a/2, 0.9 a) and h_0 at the Dugdale zone's edge. Measured to 1e-14; quad's error bound 1e-12;
    allowed 1e-9 (a wrong constant in any of the three equations moves these by > 1e-3)."""
    curve = maugis_dugdale_curve(lam, [m])
    a, P, Delta = curve["A"][0], curve["P"][0], curve["Delta"][0]
    c, sigma_0, h_0 = m * a, lam / 2.0, 2.0 / (math.pi * lam)
    force = 2.0 * math.pi * integrate.quad(lambda t: _traction(t, a, c, sigma_0) * t, 0.0, c, points=[a],
                                           epsabs=1e-14, epsrel=1e-12, limit=400)[0]
    delta = _surface_displacement(0.0, a, c, sigma_0)
    gap = lambda r: r * r / 2.0 - delta + _surface_displacement(r, a, c, sigma_0)  # noqa: E731
    assert force == pytest.approx(P, abs=1e-9), "force"
    assert delta == pytest.approx(Delta, abs=1e-9), "approach"
    assert abs(gap(0.5 * a)) < 1e-9 and abs(gap(0.9 * a)) < 1e-9, "gap inside the contact"
    assert gap(c) == pytest.approx(h_0, abs=1e-9), "gap at the cohesive zone's edge (the m equation)"


@pytest.mark.parametrize("lam", [0.3, 1.0])
def test_noncontact_branch_matches_boussinesq_integration(lam):
    """The a = 0 branch at C = C_0 / 2: sigma_0 on r < c, the gap h_0 at r = c fixes Delta, the centre
    gap follows; both from the Boussinesq integral (allowed 1e-9, as above)."""
    C = 0.5 * maugis_dugdale_noncontact_curve(lam)["C_0"]
    branch = maugis_dugdale_noncontact_curve(lam, [C])
    sigma_0, h_0 = lam / 2.0, 2.0 / (math.pi * lam)
    u_edge = 4.0 / (math.pi * E_STAR) * integrate.quad(
        lambda t: -sigma_0 * (t / C) * special.ellipk((t / C) ** 2), 0.0, C, epsabs=1e-14, limit=200)[0]
    delta = C * C / 2.0 + u_edge - h_0
    assert branch["Delta"][0] == pytest.approx(delta, abs=1e-9)
    assert branch["P"][0] == pytest.approx(-math.pi * C * C * sigma_0, abs=1e-12)
    assert branch["centre_gap"][0] == pytest.approx(-delta - 2.0 / E_STAR * sigma_0 * C, abs=1e-9)


@pytest.mark.parametrize("lam", [0.01, 0.3, 1.0, 5.0])
def test_branches_meet_at_zero_contact_radius(lam):
    """The contact branch's A -> 0 end (m = 1e9, A ~ 1e-9) is the no-contact branch's closed end C_0
    (centre gap 0): P, Delta and c agree to the O(A) left (allowed 1e-7)."""
    end = maugis_dugdale_curve(lam, [1e9])
    closed = maugis_dugdale_noncontact_curve(lam)
    assert closed["centre_gap"][-1] == pytest.approx(0.0, abs=1e-12)
    for key in ("P", "Delta", "C"):
        assert end[key][0] == pytest.approx(closed[key][-1], abs=1e-7), key


def test_equation_as_printed_holds_on_the_curve():
    """Johnson & Greenwood's m equation, evaluated as printed with arcsec m = arccos(1/m), is satisfied
    along the default curve where m >= 1.01 (residual allowed 1e-10; the cancellation in
    (m^2 - 2) arcsec m + sqrt(m^2 - 1) costs ~ 1e-13 there)."""
    for lam in (0.1, 1.0, 5.0):
        cv = maugis_dugdale_curve(lam)
        A, m = cv["A"], cv["m"]
        keep = m >= 1.01
        A, m = A[keep], m[keep]
        s, asec = np.sqrt(m * m - 1.0), np.arccos(1.0 / m)
        residual = (lam * A**2 / 2.0 * ((m * m - 2.0) * asec + s)
                    + 4.0 * lam**2 * A / 3.0 * (s * asec - m + 1.0) - 1.0)
        assert np.max(np.abs(residual)) < 1e-10, lam
        assert np.allclose(cv["P"][keep], A**3 - lam * A**2 * (s + m * m * asec), rtol=0, atol=1e-12)
        assert np.all(np.diff(cv["A"]) > 0)


def test_dmt_limit():
    """lambda -> 0: Derjaguin, Muller & Toporov (1975): P = A^3 - 2, Delta = A^2, pull-off -2 (-2 pi w R).
    On 0.2 < A < 3 the deviations shrink as lambda^(1/2) (P: 2.7e-2 at 1e-3, 2.8e-3 at 1e-4; Delta:
    4.8e-2, 1.5e-2), the pull-off's as lambda^(3/2) (5.4e-5, 1.7e-6)."""
    errors = {}
    for lam in (1e-3, 1e-4):
        cv = maugis_dugdale_curve(lam)
        A = cv["A"]
        sel = (A > 0.2) & (A < 3.0)
        errors[lam] = (np.max(np.abs(cv["P"][sel] - (A[sel] ** 3 - 2.0))),
                       np.max(np.abs(cv["Delta"][sel] - A[sel] ** 2)),
                       abs(maugis_dugdale_pull_off(lam) + 2.0))
    assert errors[1e-4][0] < 4e-3 and errors[1e-4][1] < 2e-2 and errors[1e-4][2] < 3e-6, errors
    for k in range(3):
        assert errors[1e-4][k] < errors[1e-3][k] / 2.5, (k, errors)  # converging, >= lambda^(1/2)


def test_jkr_limit():
    """lambda -> infinity: Johnson, Kendall & Roberts (1971), in these units P = A^3 - sqrt(6 A^3),
    Delta = A^2 - (2/3) sqrt(6 A); load-control pull-off -3/2 at A^3 = 3/2; under fixed grips the
    jump-out at P = -5/6, Delta = -3 / 6^(2/3) (delta = -(3/4)(pi^2 w^2 R / E*^2)^(1/3)), A = 6^(-1/3);
    the jump-in at delta = 0 to P = -4/3 (= -8/9 of the pull-off), A^3 = 8/3 (Johnson 1985, Contact
    Mechanics, section 5.5; Maugis 2000, Contact, Adhesion and Rupture of Elastic Solids, ch. 5).
    Measured at lambda = 1000: curve within 1.0e-5 (P) and 2.7e-6 (Delta) on 0.2 < A < 3, shrinking as
    1/lambda^2 (100 x smaller than at lambda = 100); the instabilities within 6e-7, the jump-in within
    4.4e-4 (its Delta = -2 / (pi lambda) -> 0 as 1/lambda)."""
    lam = 1000.0
    cv, cv_100 = maugis_dugdale_curve(lam), maugis_dugdale_curve(100.0)
    for c in (cv, cv_100):
        A = c["A"]
        sel = (A > 0.2) & (A < 3.0)
        c["dP"] = np.max(np.abs(c["P"][sel] - (A[sel] ** 3 - np.sqrt(6.0 * A[sel] ** 3))))
        c["dD"] = np.max(np.abs(c["Delta"][sel] - (A[sel] ** 2 - 2.0 / 3.0 * np.sqrt(6.0 * A[sel]))))
    assert cv["dP"] < 2e-5 and cv["dD"] < 5e-6
    assert cv["dP"] < cv_100["dP"] / 50 and cv["dD"] < cv_100["dD"] / 50
    crit = maugis_dugdale_critical_points(lam)
    expected = {
        "P_pull_off_load_control": -1.5, "A_pull_off_load_control": 1.5 ** (1 / 3),
        "P_jump_out": -5 / 6, "Delta_jump_out": -3 * 6 ** (-2 / 3), "A_jump_out": 6 ** (-1 / 3),
    }
    for key, value in expected.items():
        assert crit[key] == pytest.approx(value, abs=2e-6), key
    assert crit["P_after_jump_in"] == pytest.approx(-4 / 3, abs=1e-3)
    assert crit["A_after_jump_in"] == pytest.approx((8 / 3) ** (1 / 3), abs=1e-3)


def _cos_pull_off(lam):
    """Carpick, Ogletree & Salmeron (1999), J. Colloid Interface Sci. 211, 395, eq. 12a: their fit of
    Maugis's pull-off force, in units of pi w R."""
    x = 4.04 * lam**1.4
    return -7.0 / 4.0 + 0.25 * (x - 1.0) / (x + 1.0)


def _cos_zero_load_radius(lam):
    """Carpick, Ogletree & Salmeron (1999), eq. 12b: their fit of Maugis's contact radius at zero load, A."""
    x = 2.28 * lam**1.3
    return 1.54 + 0.279 * (x - 1.0) / (x + 1.0)


@pytest.mark.parametrize("lam", LAMBDAS)
def test_against_carpick_ogletree_salmeron_fits(lam):
    """Pull-off force and zero-load contact radius against COS's published fits of Maugis's curves.
    The fits are empirical (three-figure coefficients, exact only in the DMT and JKR limits); measured
    deviations: pull-off 1.03, 1.66, 1.22, 0.10, 0.54, 0.56, 0.42 % and zero-load radius 1.34, 0.05,
    0.78, 0.78, 0.17, 0.51, 0.54 % at lambda = 0.1, 0.3, 0.5, 1, 2, 3, 5. Allowed 2 %."""
    P_c = maugis_dugdale_critical_points(lam)["P_pull_off_load_control"]
    assert P_c == pytest.approx(_cos_pull_off(lam), rel=0.02)
    # zero load: the retraction path at P = 0 (P rises monotonically with Delta on its contact part)
    Deltas = np.linspace(0.0, 4.0, 4001)
    P = maugis_dugdale_force_at(lam, Deltas, "retract")
    k = int(np.flatnonzero(P > 0.0)[0])
    Delta_0 = Deltas[k - 1] - P[k - 1] * (Deltas[k] - Deltas[k - 1]) / (P[k] - P[k - 1])
    A_0 = float(maugis_dugdale_state_at(lam, Delta_0, "retract")["A"])
    assert A_0 == pytest.approx(_cos_zero_load_radius(lam), rel=0.02)


@pytest.mark.parametrize("lam", [1e-3, 0.1, 0.5, 1.0, 2.0, 5.0, 20.0])
def test_existing_pull_off_is_the_curve_minimum(lam):
    """maugis_dugdale_pull_off(lam) is the minimum of P on the sampled contact branch: never above it,
    and below it by no more than the sampling can miss (A steps 0.002 near the minimum, |d2P/dA2| < 10:
    < 1e-5)."""
    P_c = maugis_dugdale_pull_off(lam)
    assert P_c == maugis_dugdale_critical_points(lam)["P_pull_off_load_control"]
    grid_min = float(np.min(maugis_dugdale_curve(lam)["P"]))
    assert 0.0 <= grid_min - P_c < 1e-5, (grid_min, P_c)


def _dDelta_dA(lam, A):
    """d(Delta)/dA on the contact branch by central differences (step 1e-5)."""
    cv = maugis_dugdale_curve(lam, _m_at(lam, np.array([A - 1e-5, A + 1e-5])))
    return (cv["Delta"][1] - cv["Delta"][0]) / (cv["A"][1] - cv["A"][0])


def _m_at(lam, A):
    """m at contact radii A (bisection on the printed equation, m from 1 + 1e-12 to 1e12)."""
    lo, hi = np.full(A.shape, math.log(1e-12)), np.full(A.shape, math.log(1e12))
    for _ in range(120):
        mid = 0.5 * (lo + hi)
        m = 1.0 + np.exp(mid)
        cv = maugis_dugdale_curve(lam, m)
        hi, lo = np.where(cv["A"] < A, mid, hi), np.where(cv["A"] < A, lo, mid)
    return 1.0 + np.exp(0.5 * (lo + hi))


@pytest.mark.parametrize("lam", np.geomspace(0.01, 20.0, 9).round(4).tolist())
def test_load_control_minimum_lies_on_displacement_stable_part(lam):
    """At the load-control pull-off d(Delta)/dA > 0: a displacement-driven retraction passes through it,
    so its most tensile force is the load-control pull-off force, and it jumps out later at a less
    tensile force."""
    crit = maugis_dugdale_critical_points(lam)
    assert _dDelta_dA(lam, crit["A_pull_off_load_control"]) > 0.0
    assert crit["P_most_tensile_displacement_control"] == pytest.approx(crit["P_pull_off_load_control"], abs=1e-12)
    assert crit["P_jump_out"] > crit["P_pull_off_load_control"]
    assert crit["Delta_jump_out"] < crit["Delta_pull_off_load_control"]


def _assert_jump(crit, point, on_noncontact_branch, C, P, rel):
    """The critical point ``point`` of ``maugis_dugdale_critical_points``: on the no-contact branch
    (A = 0) at the closed-form radius C and load P, or else on the contact branch (A > 0)."""
    if on_noncontact_branch:
        assert crit[f"A_{point}"] == 0.0
        assert crit[f"C_{point}"] == pytest.approx(C, rel=rel)
        assert crit[f"P_{point}"] == pytest.approx(P, rel=rel)
    else:
        assert crit[f"A_{point}"] > 0.0


@pytest.mark.parametrize("lam", [0.05, 0.3, 0.9, 0.95, 1.0, 3.0])
def test_jump_out_point(lam):
    """Displacement-controlled jump-out: below LAMBDA_JUMP_OUT_ON_CONTACT_BRANCH on the no-contact
    branch at C = 8 lambda / (3 pi), P = -32 lambda^3 / (9 pi); above it on the contact branch where
    d(Delta)/dA = 0 (central difference < 1e-4 of its 1.5 at large A)."""
    crit = maugis_dugdale_critical_points(lam)
    C_0 = maugis_dugdale_noncontact_curve(LAMBDA_JUMP_OUT_ON_CONTACT_BRANCH)["C_0"]
    assert C_0 == pytest.approx(8 * LAMBDA_JUMP_OUT_ON_CONTACT_BRANCH / (3 * math.pi), rel=1e-12)
    _assert_jump(crit, "jump_out", lam < LAMBDA_JUMP_OUT_ON_CONTACT_BRANCH,
                 8 * lam / (3 * math.pi), -32 * lam**3 / (9 * math.pi), rel=1e-6)
    if crit["A_jump_out"] > 0.0:
        assert abs(_dDelta_dA(lam, crit["A_jump_out"])) < 1e-4


@pytest.mark.parametrize("lam", [0.1, 0.5, 0.7, 1.0, 5.0])
def test_jump_in_and_the_two_paths(lam):
    """Approach: free (P = 0) up to Delta = -2 / (pi lambda) (undeformed centre gap h_0), then the jump-in:
    below LAMBDA_JUMP_IN_ON_NONCONTACT_BRANCH onto the no-contact branch at C = 16 lambda / (3 pi),
    P = -128 lambda^3 / (9 pi), above it into contact. Retraction: tensile down to the jump-out, free
    below. Beyond the hysteresis window the two paths agree."""
    crit = maugis_dugdale_critical_points(lam)
    D_in, D_out = crit["Delta_jump_in"], crit["Delta_jump_out"]
    assert D_in == pytest.approx(-2 / (math.pi * lam), rel=1e-15)
    _assert_jump(crit, "after_jump_in", lam < LAMBDA_JUMP_IN_ON_NONCONTACT_BRANCH,
                 16 * lam / (3 * math.pi), -128 * lam**3 / (9 * math.pi), rel=1e-9)
    approach = maugis_dugdale_force_at(lam, np.array([D_in - 1e-9, D_in + 1e-9]), "approach")
    assert approach[0] == 0.0 and approach[1] == pytest.approx(crit["P_after_jump_in"], abs=1e-6)
    retract = maugis_dugdale_force_at(lam, np.array([D_out - 1e-9, D_out + 1e-9]), "retract")
    assert retract[0] == 0.0 and retract[1] == pytest.approx(crit["P_jump_out"], abs=1e-4)
    beyond = np.linspace(max(D_in, 0.0) + 0.5, 6.0, 12)
    np.testing.assert_allclose(maugis_dugdale_force_at(lam, beyond, "approach"),
                               maugis_dugdale_force_at(lam, beyond, "retract"), rtol=0, atol=1e-12)


def test_state_at_lies_on_the_curve():
    """Each state maugis_dugdale_state_at returns is an equilibrium at the asked Delta: the contact ones
    reproduce Delta and P through the printed equations (1e-9), the no-contact ones the a = 0 branch."""
    lam = 0.8
    Deltas = np.linspace(-1.2, 3.0, 37)
    for branch in ("approach", "retract"):
        st = maugis_dugdale_state_at(lam, Deltas, branch)
        contact = st["in_contact"]
        cv = maugis_dugdale_curve(lam, _m_at(lam, st["A"][contact]))
        np.testing.assert_allclose(cv["Delta"], Deltas[contact], rtol=0, atol=1e-9)
        np.testing.assert_allclose(cv["P"], st["P"][contact], rtol=0, atol=1e-9)
        cohesive = (~contact) & (st["C"] > 0.0)
        off = maugis_dugdale_noncontact_curve(lam, st["C"][cohesive])
        np.testing.assert_allclose(off["Delta"], Deltas[cohesive], rtol=0, atol=1e-9)
        assert np.all(st["P"][~contact & (st["C"] == 0.0)] == 0.0)


def test_si_units_dmt_and_jkr():
    """maugis_dugdale_si in SI: lambda as maugis_parameter; at lambda = 1e-4 the DMT law
    F = 4 E* a^3 / (3 R) - 2 pi w R, delta = a^2 / R (Derjaguin et al. 1975) within the limit's own
    deviation at that lambda (test_dmt_limit: 2.8e-3 pi w R in force, 1.5e-2 approach units in delta;
    allowed 4e-3 and 2e-2 of them); at lambda = 30 the JKR pull-offs, -3/2 pi w R under load control
    and -5/6 pi w R under fixed grips (relative deviations 1.2e-4 and 5e-5 there; allowed 2e-4)."""
    E_star, R, w = 100e9, 1e-6, 0.5
    sigma_dmt = 1e-4 / (9 * R / (2 * math.pi * w * E_star**2)) ** (1 / 3)
    si = maugis_dugdale_si(E_star, R, w, sigma_dmt)
    pair = SimpleNamespace(E_star=E_star)
    assert si["lambda"] == pytest.approx(maugis_parameter(pair, R, sigma_dmt, w), rel=1e-12)
    scales = si["scales"]
    assert scales["approach"] == pytest.approx(scales["radius"] ** 2 / R, rel=1e-12)
    F_dmt = 4 * E_star * si["a"] ** 3 / (3 * R) - 2 * math.pi * w * R
    sel = (si["a"] > 0.2 * scales["radius"]) & (si["a"] < 3.0 * scales["radius"])
    assert np.max(np.abs(si["force"][sel] - F_dmt[sel])) < 4e-3 * scales["force"]
    assert np.max(np.abs(si["delta_z"][sel] - si["a"][sel] ** 2 / R)) < 2e-2 * scales["approach"]
    assert si["pull_off_force_load_control"] == pytest.approx(-2 * math.pi * w * R, rel=1e-5)
    assert si["max_tensile_force_displacement_control"] == pytest.approx(si["pull_off_force_load_control"],
                                                                         rel=1e-12)
    assert si["delta_z_jump_in"] == pytest.approx(-w / sigma_dmt, rel=1e-12)
    si_jkr = maugis_dugdale_si(E_star, R, w, 3e5 * sigma_dmt)
    assert si_jkr["lambda"] == pytest.approx(30.0, rel=1e-12)
    assert si_jkr["pull_off_force_load_control"] == pytest.approx(-1.5 * math.pi * w * R, rel=2e-4)
    assert si_jkr["pull_off_force_displacement_control"] == pytest.approx(-5 / 6 * math.pi * w * R, rel=2e-4)


def test_bad_input():
    with pytest.raises(ValueError, match="lambda"):
        maugis_dugdale_curve(-1.0)
    with pytest.raises(ValueError, match="exceed 1"):
        maugis_dugdale_curve(1.0, [1.0, 2.0])
    with pytest.raises(ValueError, match="branch"):
        maugis_dugdale_force_at(1.0, 0.0, "sideways")
    with pytest.raises(ValueError, match="sigma_0"):
        maugis_dugdale_si(1e11, 1e-6, 0.5, 0.0)


@pytest.mark.parametrize("lam", [0.1, 0.5, 0.9, 1.0, 3.0, 10.0])
def test_one_jump_each_way(lam):
    """The displacement-driven paths through maugis_dugdale_si's curve are unbroken: the retraction
    path is one run of states from the jump-out to the largest contact, the approach path the first
    touch (c = 0) and one run from the jump-in's landing (one jump each way)."""
    E_star, R, w = 100e9, 1e-6, 0.5
    sigma_0 = lam / (9 * R / (2 * math.pi * w * E_star**2)) ** (1 / 3)
    si = maugis_dugdale_si(E_star, R, w, sigma_0)
    retraction = np.flatnonzero(si["on_retraction_path"])
    approach = np.flatnonzero(si["on_approach_path"])
    assert np.all(np.diff(retraction) == 1) and retraction[-1] == len(si["force"]) - 1
    assert approach[0] == 0 and np.all(np.diff(approach[1:]) == 1) and approach[-1] == len(si["force"]) - 1
    assert si["force"][retraction[0]] == pytest.approx(si["pull_off_force_displacement_control"], rel=1e-12)
    assert si["delta_z"][approach[1]] >= si["delta_z_jump_in"]

"""Closed-form reference solutions (MODEL.md section 8): Hertz, Cattaneo-Mindlin, Mindlin-Deresiewicz
and Savkoor-Briggs in SI units; the Maugis-Dugdale adhesive sphere in Johnson & Greenwood's (1997)
units, with an SI wrapper."""

from __future__ import annotations

import math


def hertz(pair, radius: float, delta_z: float) -> dict:
    """Hertz's frictionless sphere-on-flat contact at approach ``delta_z`` [m].

    Returns a (contact radius) [m], force F_z [N], p0 (max pressure) [Pa].
    """
    a = math.sqrt(radius * delta_z)
    return {
        "a": a,
        "force": 4.0 / 3.0 * pair.E_star * math.sqrt(radius) * delta_z**1.5,
        "p0": 2.0 * pair.E_star * a / (math.pi * radius),
    }


def mindlin(pair, radius: float, delta_z: float, mu: float, ratio: float) -> dict:
    """Cattaneo-Mindlin partial slip at Q / (mu P) = ``ratio`` (identical materials, Coulomb mu).

    Returns stick radius c [m], tangential displacement delta_x [m] and its value at gross slip.
    """
    h = hertz(pair, radius, delta_z)
    a, P = h["a"], h["force"]
    delta_max = 3.0 * mu * P / (16.0 * a) * pair.mindlin_compliance
    return {
        "c": a * (1.0 - ratio) ** (1.0 / 3.0),
        "delta_x": delta_max * (1.0 - (1.0 - ratio) ** (2.0 / 3.0)),
        "delta_x_max": delta_max,
    }


def mindlin_deresiewicz(normal_force: float, contact_radius: float, mu: float, compliance: float,
                        amplitude: float) -> dict:
    """A sphere under a constant normal force P, its tangential displacement cycled between
    -amplitude and +amplitude (Coulomb mu; Mindlin & Deresiewicz 1953; Johnson, Contact Mechanics,
    ch. 7). Exact where the normal and tangential problems uncouple (Dundurs beta = 0: identical
    materials, or a rigid body on an incompressible one).

    ``normal_force`` P [N]; ``contact_radius`` a [m], Hertz's for P; ``mu`` [-]; ``compliance``
    1/G* = (2 - nu1)/G1 + (2 - nu2)/G2 [1/Pa] (``MaterialPair.mindlin_compliance``); ``amplitude``
    delta* [m], > 0. Partial slip while delta* <= delta_s = 3 mu P / (16 a G*), the displacement at
    gross slip: the force amplitude Q* follows from delta* = delta_s (1 - (1 - x)^(2/3)), x =
    Q* / (mu P), and the energy dissipated per cycle is W = (9 mu^2 P^2 / (10 a G*)) [1 - (1 -
    x)^(5/3) - (5 x / 6)(1 + (1 - x)^(2/3))] (about Q*^3 / (36 mu P a G*) for small x; 3 mu^2 P^2 /
    (20 a G*) at x = 1). Beyond delta_s the sphere slides: Q* = mu P and W = 3 mu^2 P^2 / (20 a G*)
    + 4 mu P (delta* - delta_s).

    Returns delta_gross (delta_s) [m], force_amplitude (Q*) [N], ratio (x) [-], energy (W) [J],
    energy_ratio (Fouvry's A = W / (4 delta* Q*)) [-], 0.2 at the transition, regime ("partial
    slip" or "gross slip").
    """
    if not (amplitude > 0.0 and normal_force > 0.0 and contact_radius > 0.0 and mu > 0.0 and compliance > 0.0):
        raise ValueError("mindlin_deresiewicz needs a positive normal force, contact radius, mu, compliance and "
                         "amplitude")
    mu_p = mu * normal_force
    delta_s = 3.0 * mu_p * compliance / (16.0 * contact_radius)
    scale = mu_p**2 * compliance / contact_radius  # mu^2 P^2 / (a G*) [J]
    if amplitude < delta_s:
        x = 1.0 - (1.0 - amplitude / delta_s) ** 1.5
        energy = 0.9 * scale * (1.0 - (1.0 - x) ** (5.0 / 3.0) - 5.0 * x / 6.0 * (1.0 + (1.0 - x) ** (2.0 / 3.0)))
        regime = "partial slip"
    else:
        x = 1.0
        energy = 0.15 * scale + 4.0 * mu_p * (amplitude - delta_s)
        regime = "gross slip"
    force = x * mu_p
    return {"delta_gross": delta_s, "force_amplitude": force, "ratio": x, "energy": energy,
            "energy_ratio": energy / (4.0 * amplitude * force), "regime": regime}


def mindlin_deresiewicz_loop(normal_force: float, contact_radius: float, mu: float, compliance: float,
                             amplitude: float, delta) -> tuple:
    """The two branches of :func:`mindlin_deresiewicz`'s loop at displacements ``delta`` [m]
    (array-like, within +-amplitude): (unloading, from +amplitude down; loading, from -amplitude
    up), each the tangential force [N]. Masing's rule on the first loading Q = mu P (1 - (1 -
    delta / delta_s)^(3/2)): Q = Q* - 2 mu P (1 - (1 - (delta* - delta) / (2 delta_s))^(3/2)) down,
    the mirror image up; where (delta* -+ delta) exceeds 2 delta_s the sphere slides at -+mu P."""
    import numpy as np

    r = mindlin_deresiewicz(normal_force, contact_radius, mu, compliance, amplitude)
    mu_p, q, d_s = mu * normal_force, r["force_amplitude"], r["delta_gross"]
    d = np.asarray(delta, dtype=float)

    def turned(travel):  # the change of force after a reversal, over a travel [m] since it
        return 2.0 * mu_p * (1.0 - (1.0 - np.clip(travel / (2.0 * d_s), 0.0, 1.0)) ** 1.5)

    return q - turned(amplitude - d), -q + turned(d + amplitude)


def savkoor_briggs(normal_force: float, tangential_force: float, radius: float, E_star: float, compliance: float,
                   work_of_adhesion: float) -> dict:
    """Contact radius of an adhesive elastic sphere on a flat under a normal force P and a
    tangential force T in full stick (Savkoor, A. R. & Briggs, G. A. D. (1977), Proc. R. Soc.
    Lond. A 356, 103-114; JKR at T = 0).

    The tangential force adds Mindlin's full-stick shear, a mode II stress intensity at the
    contact edge, and its energy release rate T^2 / (32 pi a^3 G*) to JKR's (mode I): with the
    edge advancing where their sum equals w (an ideally brittle interface, the same toughness in
    both modes),
      a^3 = (R / K) [P + 3 pi w R + sqrt(6 pi w R P + (3 pi w R)^2 - T^2 E* / (4 G*))],  K = 4 E* / 3,
    up to the critical force T_c^2 = (4 G* / E*)(6 pi w R P + (3 pi w R)^2), where the root
    vanishes and the contact peels to a_c^3 = (R / K)(P + 3 pi w R); beyond T_c there is no
    stuck equilibrium. For P = 0: a_c^3 = a_0^3 / 2.

    ``normal_force`` P [N], compressive positive, at least -3 pi w R / 2 (JKR's pull-off under
    load control); ``tangential_force`` T [N] (its sign does not matter); ``radius`` R [m];
    ``E_star`` E* [Pa] (``MaterialPair.E_star``); ``compliance`` 1/G* = (2 - nu1)/G1 + (2 - nu2)/G2
    [1/Pa] (``MaterialPair.mindlin_compliance``: full stick gives delta_x = T / (8 a G*));
    ``work_of_adhesion`` w [J/m^2].

    Returns "a" [m] (nan beyond T_c), "a_jkr" [m] (JKR's radius at P, T = 0), "critical_force"
    T_c [N], "a_critical" a_c [m] and "ratio" |T| / T_c [-].
    """
    P, T = float(normal_force), abs(float(tangential_force))
    for name, value in (("radius", radius), ("E_star", E_star), ("compliance", compliance),
                        ("work_of_adhesion", work_of_adhesion)):
        if not (value > 0.0 and math.isfinite(value)):
            raise ValueError(f"savkoor_briggs: {name} must be positive and finite, got {value!r}")
    adhesion = 3.0 * math.pi * work_of_adhesion * radius  # 3 pi w R [N]
    root_jkr = 2.0 * adhesion * P + adhesion**2  # 6 pi w R P + (3 pi w R)^2 [N^2]
    if not root_jkr >= 0.0:
        raise ValueError(f"savkoor_briggs: P = {P!r} N is below JKR's pull-off -3 pi w R / 2 = {-adhesion / 2:.6g} N")
    G_star = 1.0 / compliance
    scale = radius / (4.0 * E_star / 3.0)  # R / K [m^3/N]
    root = root_jkr - T * T * E_star / (4.0 * G_star)
    critical = math.sqrt(4.0 * G_star / E_star * root_jkr)
    return {
        "a": (scale * (P + adhesion + math.sqrt(root))) ** (1.0 / 3.0) if root >= 0.0 else math.nan,
        "a_jkr": (scale * (P + adhesion + math.sqrt(root_jkr))) ** (1.0 / 3.0),
        "critical_force": critical,
        "a_critical": (scale * (P + adhesion)) ** (1.0 / 3.0),
        "ratio": T / critical if critical > 0.0 else math.inf,
    }


def maugis_dugdale_pull_off(lam: float) -> float:
    """Maugis-Dugdale pull-off force over pi w R for the Maugis parameter lambda [-], under load control.

    Johnson & Greenwood (1997), J. Colloid Interface Sci. 192, 326-333, after Maugis (1992):
    with m = c / a (cohesive-zone to contact radius), A = a (4 E* / (3 pi w R^2))^(1/3),
    P = F / (pi w R), lambda = sigma_0 (9 R / (2 pi w E*^2))^(1/3):
      (lambda A^2 / 2) [(m^2 - 2) arcsec m + sqrt(m^2 - 1)]
        + (4 lambda^2 A / 3) [sqrt(m^2 - 1) arcsec m - m + 1] = 1
      P = A^3 - lambda A^2 [sqrt(m^2 - 1) + m^2 arcsec m]
    The pull-off force is the minimum of P along the equilibrium curve (it tends to -2, DMT, as
    lambda -> 0 and to -1.5, JKR, as lambda -> infinity). The same number as
    ``maugis_dugdale_critical_points(lam)["P_pull_off_load_control"]``.
    """
    return maugis_dugdale_critical_points(lam)["P_pull_off_load_control"]


def maugis_parameter(pair, radius: float, sigma_0: float, work_of_adhesion: float) -> float:
    """lambda = sigma_0 (9 R / (2 pi w E*^2))^(1/3) [-]."""
    return sigma_0 * (9.0 * radius / (2.0 * math.pi * work_of_adhesion * pair.E_star**2)) ** (1.0 / 3.0)


# --------------------------------------------------------------------------------------------------
# Maugis-Dugdale sphere: the whole equilibrium curve, its instabilities, and the force-approach paths
# --------------------------------------------------------------------------------------------------
#
# Maugis (1992), J. Colloid Interface Sci. 150, 243-269, in the notation of Johnson & Greenwood (1997),
# J. Colloid Interface Sci. 192, 326-333. With K = 4 E* / 3 (E* the pair's contact modulus [Pa]),
# w the work of adhesion [J/m^2], R the sphere radius [m], sigma_0 the Dugdale stress [Pa] acting
# while the gap is below h_0 = w / sigma_0 [m]:
#   A = a / (pi w R^2 / K)^(1/3) = a (4 E* / (3 pi w R^2))^(1/3)      contact radius a [m]
#   C = c / (pi w R^2 / K)^(1/3),  m = c / a                          cohesive-zone radius c [m]
#   P = F / (pi w R)                                                  F [N], > 0 compressive
#   Delta = delta / (pi^2 w^2 R / K^2)^(1/3)
#         = delta (16 E*^2 / (9 pi^2 w^2 R))^(1/3)                    delta [m], > 0 approach
#   lambda = 2 sigma_0 / (pi w K^2 / R)^(1/3) = sigma_0 (9 R / (2 pi w E*^2))^(1/3)
#   H_0 = h_0 / (pi^2 w^2 R / K^2)^(1/3) = 2 / (pi lambda)
# Contact branch (a > 0), s = sqrt(m^2 - 1), arcsec m = arctan s:
#   (lambda A^2 / 2) [(m^2 - 2) arcsec m + s] + (4 lambda^2 A / 3) [s arcsec m - m + 1] = 1
#   P = A^3 - lambda A^2 [s + m^2 arcsec m]
#   Delta = A^2 - (4/3) lambda A s
# No-contact branch (a = 0): sigma_0 over the disc r < c, gap h_0 at r = c, gap >= 0 at r = 0. The
# surface displacements of a uniform pressure on a circle (Johnson 1985, Contact Mechanics, section 3.2:
# 2 p c / E* at the centre, 4 p c / (pi E*) at the edge) give
#   P = -pi lambda C^2 / 2,   Delta = C^2 / 2 - 8 lambda C / (3 pi) - 2 / (pi lambda),   0 <= C <= C_0,
# C_0 the positive root of (pi lambda / 4) C^2 + (4 lambda^2 / 3)(pi / 2 - 1) C - 1 = 0, where the gap
# at the centre closes; there it meets the contact branch's A -> 0 end (m A -> C_0).
# The whole curve is parametrised here by u: u = C / C_0 in [0, 1] on the no-contact branch and
# u = 1 + 1 / s on the contact branch (u -> 1 as A -> 0, u -> infinity as A -> infinity); every
# quantity (A, C, P, Delta) is continuous in u and the contact grows with u.

#: lambda (0.938) below which a retraction under displacement control leaves through the no-contact
#: branch (its jump-out at C = 8 lambda / (3 pi), a force of only -32 lambda^3 / (9 pi)); above it the
#: jump-out is on the contact branch, where d(Delta)/dA = 0. It is the lambda at which C_0 = 8 lambda / (3 pi).
LAMBDA_JUMP_OUT_ON_CONTACT_BRANCH = (9.0 * math.pi / (16.0 * (math.pi - 1.0))) ** (1.0 / 3.0)
#: lambda (0.655) below which an approach under displacement control jumps onto the no-contact branch
#: (at C = 16 lambda / (3 pi)); above it the jump-in lands in contact. It is the lambda at which
#: C_0 = 16 lambda / (3 pi).
LAMBDA_JUMP_IN_ON_NONCONTACT_BRANCH = (9.0 / 32.0) ** (1.0 / 3.0)

_MD_SERIES_BELOW = 0.05  # s below which (m^2 - 2) arcsec m + s is summed as a series (cancellation)


def _check_lambda(lam) -> float:
    lam = float(lam)
    if not (lam > 0.0 and math.isfinite(lam)):
        raise ValueError(f"Maugis parameter lambda must be positive and finite, got {lam!r}")
    return lam


def _md_brackets(s):
    """The contact branch's bracketed terms at s = sqrt(m^2 - 1) [-] (numpy arrays).

    Returns (f_2, f_1, f_P, m) with f_2 = (m^2 - 2) arcsec m + s, f_1 = s arcsec m - m + 1,
    f_P = s + m^2 arcsec m. f_2 ~ (4/3) s^3 loses all digits to cancellation as s -> 0: below
    s = 0.05 it is summed as sum_j (-1)^(j-1) 4 j / (4 j^2 - 1) s^(2j+1), j <= 10 (the first term left
    out is 1e-26 of the sum).
    """
    import numpy as np

    s = np.asarray(s, dtype=float)
    asec = np.arctan(s)
    m = np.sqrt(1.0 + s * s)
    small = s < _MD_SERIES_BELOW
    s_small = np.where(small, s, 0.0)
    series = np.zeros_like(s)
    for j in range(1, 11):
        series += (-1) ** (j - 1) * 4.0 * j / (4.0 * j * j - 1.0) * s_small ** (2 * j + 1)
    f_2 = np.where(small, series, (s * s - 1.0) * asec + s)
    f_1 = s * asec - s * s / (1.0 + m)  # m - 1 = s^2 / (1 + m), no cancellation
    f_p = s + m * m * asec
    return f_2, f_1, f_p, m


def _md_contact_from_s(lam: float, s):
    """Contact-branch state (A, m, P, Delta) at s = sqrt(m^2 - 1) > 0 [-]."""
    import numpy as np

    f_2, f_1, f_p, m = _md_brackets(s)
    a_2 = 0.5 * lam * f_2
    a_1 = 4.0 * lam * lam / 3.0 * f_1
    A = 2.0 / (a_1 + np.sqrt(a_1 * a_1 + 4.0 * a_2))  # positive root of a_2 A^2 + a_1 A - 1 = 0
    P = A**3 - lam * A * A * f_p
    Delta = A * A - 4.0 / 3.0 * lam * A * np.asarray(s, dtype=float)
    return A, m, P, Delta


def _md_noncontact_end(lam: float) -> float:
    """C_0: cohesive radius over (pi w R^2 / K)^(1/3) where the no-contact branch closes at the centre."""
    b = 4.0 * lam * lam / 3.0 * (math.pi / 2.0 - 1.0)
    a = math.pi * lam / 4.0
    return 2.0 / (b + math.sqrt(b * b + 4.0 * a))


def _md_s_of_A(lam: float, A):
    """Invert the contact branch: s = sqrt(m^2 - 1) at contact radii A > 0 (A decreases with s)."""
    import numpy as np

    A = np.asarray(A, dtype=float)
    lo = np.full(A.shape, math.log(1e-12))
    hi = np.full(A.shape, math.log(1e12))
    for _ in range(110):  # bisection in log s: the bracket shrinks to 1e-31 of 55 units
        mid = 0.5 * (lo + hi)
        f_2, f_1, _, _ = _md_brackets(np.exp(mid))
        residual = 0.5 * lam * f_2 * A * A + 4.0 * lam * lam / 3.0 * f_1 * A - 1.0  # increases with s
        hi = np.where(residual > 0.0, mid, hi)
        lo = np.where(residual > 0.0, lo, mid)
    return np.exp(0.5 * (lo + hi))


def _md_state(lam: float, u):
    """The whole curve's state at path parameter u >= 0: dict of A, C, m, P, Delta (numpy arrays).

    u in [0, 1]: no-contact branch, C = u C_0, A = 0 (m is inf there). u > 1: contact branch, s = 1 / (u - 1).
    """
    import numpy as np

    u = np.atleast_1d(np.asarray(u, dtype=float))
    C_0 = _md_noncontact_end(lam)
    off = u <= 1.0
    C_off = np.clip(u, 0.0, 1.0) * C_0
    s = 1.0 / np.where(off, 1.0, u - 1.0)
    A, m, P, Delta = _md_contact_from_s(lam, s)
    P_off = -math.pi * lam * C_off**2 / 2.0
    Delta_off = C_off**2 / 2.0 - 8.0 * lam * C_off / (3.0 * math.pi) - 2.0 / (math.pi * lam)
    return {
        "A": np.where(off, 0.0, A),
        "C": np.where(off, C_off, m * A),
        "m": np.where(off, np.inf, m),
        "P": np.where(off, P_off, P),
        "Delta": np.where(off, Delta_off, Delta),
    }


def _md_default_A(A_max: float):
    """Contact radii for the sampled contact branch: geometric to 0.02, then steps of at most 0.002."""
    import numpy as np

    n = max(int(math.ceil((A_max - 0.02) / 0.002)), 2)
    return np.concatenate([np.geomspace(1e-5, 0.02, 120, endpoint=False), np.linspace(0.02, A_max, n)])


def maugis_dugdale_curve(lam: float, m_values=None) -> dict:
    """Maugis-Dugdale contact branch (a > 0), stable and unstable parts, in Johnson & Greenwood's units.

    Maugis (1992), J. Colloid Interface Sci. 150, 243; notation of Johnson & Greenwood (1997),
    J. Colloid Interface Sci. 192, 326. With K = 4 E* / 3, s = sqrt(m^2 - 1), arcsec m = arctan s:
      (lambda A^2 / 2) [(m^2 - 2) arcsec m + s] + (4 lambda^2 A / 3) [s arcsec m - m + 1] = 1
      P = A^3 - lambda A^2 [s + m^2 arcsec m]
      Delta = A^2 - (4/3) lambda A s
    lam: Maugis parameter lambda = sigma_0 (9 R / (2 pi w E*^2))^(1/3) [-] (``maugis_parameter``).
    m_values: cohesive-to-contact radius ratios m = c / a > 1 [-]; by default the m that put the
      contact radius at A = 1e-5 ... 0.02 (geometric) and 0.02 ... 5 (steps of 0.002).
    Returns numpy arrays, in the order of m_values (the default: A increasing):
      "A" = a / (pi w R^2 / K)^(1/3) = a (4 E* / (3 pi w R^2))^(1/3), contact radius a [m];
      "P" = F / (pi w R), force F [N], positive compressive;
      "Delta" = delta / (pi^2 w^2 R / K^2)^(1/3) = delta (16 E*^2 / (9 pi^2 w^2 R))^(1/3),
        approach delta [m], positive into contact (interference);
      "m" = c / a; "C" = m A, the cohesive-zone radius c in A's unit.
    As lambda -> 0 the branch tends to DMT (P = A^3 - 2, Delta = A^2), as lambda -> infinity to JKR
    (P = A^3 - sqrt(6 A^3), Delta = A^2 - (2/3) sqrt(6 A)). The no-contact branch (a = 0) that
    continues it at A -> 0 is ``maugis_dugdale_noncontact_curve``.
    """
    import numpy as np

    lam = _check_lambda(lam)
    if m_values is None:
        s = _md_s_of_A(lam, _md_default_A(5.0))
    else:
        m_values = np.asarray(m_values, dtype=float)
        if not np.all(m_values > 1.0):
            raise ValueError("m_values must all exceed 1 (m = c / a; m -> 1 is infinite contact radius)")
        s = np.sqrt((m_values - 1.0) * (m_values + 1.0))
    A, m, P, Delta = _md_contact_from_s(lam, s)
    return {"A": A, "P": P, "Delta": Delta, "m": m, "C": m * A}


def maugis_dugdale_noncontact_curve(lam: float, C_values=None) -> dict:
    """The Dugdale no-contact branch (a = 0) that continues the Maugis-Dugdale curve below A = 0.

    The stress sigma_0 acts on the disc r < c where the gap is below h_0 = w / sigma_0; the surfaces
    do not touch (gap at the centre >= 0). From the uniform-pressure-on-a-circle displacements
    (Johnson 1985, Contact Mechanics, section 3.2), in Johnson & Greenwood's units:
      P = -pi lambda C^2 / 2,   Delta = C^2 / 2 - 8 lambda C / (3 pi) - 2 / (pi lambda),
      centre gap / (pi^2 w^2 R / K^2)^(1/3) = -Delta - 4 lambda C / 3 >= 0,
    for 0 <= C <= C_0, C = c / (pi w R^2 / K)^(1/3), C_0 the positive root of
    (pi lambda / 4) C^2 + (4 lambda^2 / 3)(pi / 2 - 1) C - 1 = 0 (the centre gap closes: the contact
    branch's A -> 0 end). C = 0 is the first touch of the cohesive zone, at Delta = -2 / (pi lambda),
    where the undeformed centre gap is h_0.
    lam: Maugis parameter [-]. C_values: cohesive radii in [0, C_0]; by default 801 from 0 to C_0.
    Returns numpy arrays "C", "P", "Delta", "centre_gap" and the float "C_0".
    """
    import numpy as np

    lam = _check_lambda(lam)
    C_0 = _md_noncontact_end(lam)
    C = np.linspace(0.0, C_0, 801) if C_values is None else np.asarray(C_values, dtype=float)
    if np.any(C < 0.0) or np.any(C > C_0 * (1.0 + 1e-12)):
        raise ValueError(f"C_values must lie in [0, C_0 = {C_0:.6g}] for lambda = {lam:g}")
    Delta = C**2 / 2.0 - 8.0 * lam * C / (3.0 * math.pi) - 2.0 / (math.pi * lam)
    return {"C": C, "P": -math.pi * lam * C**2 / 2.0, "Delta": Delta,
            "centre_gap": -Delta - 4.0 * lam * C / 3.0, "C_0": C_0}


def _md_u_grid(lam: float, A_max: float):
    """Path parameters sampling the whole curve: the no-contact branch, then the contact branch to A_max."""
    import numpy as np

    s = _md_s_of_A(lam, _md_default_A(A_max))
    C_0 = _md_noncontact_end(lam)
    # the no-contact branch's own turning point C* = 8 lambda / (3 pi) and its jump-in state 2 C*
    turning = np.array([8.0, 16.0]) * lam / (3.0 * math.pi) / C_0
    noncontact = np.concatenate([np.linspace(0.0, 1.0, 401), np.geomspace(1e-7, 1.0, 200), turning[turning < 1.0]])
    return np.concatenate([np.unique(noncontact), 1.0 + 1.0 / s])


def _md_refine_extremum(lam: float, key: str, u, values, k: int, sign: float) -> float:
    """Refine the grid extremum values[k] (sign +1: minimum, -1: maximum) of key in u; returns u."""
    from scipy.optimize import minimize_scalar

    lo, hi = u[max(k - 1, 0)], u[min(k + 1, len(u) - 1)]
    f = lambda x: sign * float(_md_state(lam, x)[key][0])  # noqa: E731
    res = minimize_scalar(f, bounds=(lo, hi), method="bounded", options={"xatol": 1e-13 * max(1.0, hi)})
    return float(res.x) if res.fun <= sign * values[k] else float(u[k])


def _md_bisect(lam: float, Delta_target, u_lo, u_hi):
    """u in [u_lo, u_hi] where Delta(u) = Delta_target (vectorised bisection; Delta(u_lo) <= target)."""
    import numpy as np

    lo, hi = np.array(u_lo, dtype=float), np.array(u_hi, dtype=float)
    rising = _md_state(lam, hi)["Delta"] >= _md_state(lam, lo)["Delta"]
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        below = _md_state(lam, mid)["Delta"] < Delta_target
        move_lo = below == rising
        lo = np.where(move_lo, mid, lo)
        hi = np.where(move_lo, hi, mid)
    return 0.5 * (lo + hi)


class _MDPath:
    """The sampled whole curve of one lambda with its critical points merged into the samples."""

    def __init__(self, lam: float, A_max: float):
        import numpy as np

        self.lam, self.A_max = lam, A_max
        u = _md_u_grid(lam, A_max)
        st = _md_state(lam, u)
        P, D = st["P"], st["Delta"]
        extra = []
        # load control: the first local minimum of P met coming from large A
        k = len(P) - 1
        while k > 0 and P[k - 1] < P[k]:
            k -= 1
        self.u_pull_off_load = _md_refine_extremum(lam, "P", u, P, k, +1.0)
        extra.append(self.u_pull_off_load)
        # displacement control: local minima (retraction folds) and maxima (approach folds) of Delta
        interior = np.arange(1, len(D) - 1)
        for idx in interior[(D[interior] <= D[interior - 1]) & (D[interior] < D[interior + 1])]:
            extra.append(_md_refine_extremum(lam, "Delta", u, D, int(idx), +1.0))
        for idx in interior[(D[interior] >= D[interior - 1]) & (D[interior] > D[interior + 1])]:
            extra.append(_md_refine_extremum(lam, "Delta", u, D, int(idx), -1.0))
        self.u = np.unique(np.concatenate([u, np.array(extra)]))
        st = _md_state(lam, self.u)
        self.A, self.C, self.P, self.Delta = st["A"], st["C"], st["P"], st["Delta"]
        self.Delta_first_touch = -2.0 / (math.pi * lam)
        # approach: the record highs of Delta along u; retraction: the record lows seen from large A
        self.on_approach = self.Delta >= np.maximum.accumulate(self.Delta)
        self.on_retraction = self.Delta <= np.minimum.accumulate(self.Delta[::-1])[::-1]
        self.on_retraction &= self.u > 0.0  # u = 0 is the first-touch state, which is free (P = 0)

    def states_at(self, Delta, branch: str) -> dict:
        """A, C, P at approaches Delta on the approach or retraction path (see maugis_dugdale_state_at)."""
        import numpy as np

        Delta = np.asarray(Delta, dtype=float)
        flat = np.atleast_1d(Delta).ravel()
        if np.any(flat > self.Delta[-1]):
            raise ValueError(f"Delta {flat.max():g} beyond the sampled curve (A_max {self.A_max:g})")
        u_lo = np.zeros_like(flat)
        u_hi = np.zeros_like(flat)
        free = np.zeros(flat.shape, dtype=bool)
        if branch == "approach":
            free = flat <= self.Delta_first_touch
            i = np.searchsorted(np.maximum.accumulate(self.Delta), flat, side="left")  # first Delta_i >= target
            i = np.clip(i, 1, len(self.u) - 1)
            u_lo, u_hi = self.u[i - 1], self.u[i]
        elif branch == "retract":
            lows = np.minimum.accumulate(self.Delta[::-1])[::-1]  # non-decreasing in index
            i = np.searchsorted(lows, flat, side="right") - 1  # last index with min over [i:] <= target
            free = i < 1
            i = np.clip(i, 1, len(self.u) - 2)
            u_lo, u_hi = self.u[i], self.u[i + 1]
        else:
            raise ValueError(f"branch must be 'approach' or 'retract', got {branch!r}")
        u = _md_bisect(self.lam, flat, u_lo, u_hi)
        st = _md_state(self.lam, u)
        out = {}
        for key in ("A", "C", "P"):
            out[key] = np.where(free, 0.0, st[key]).reshape(Delta.shape)
        out["in_contact"] = (~free & (u > 1.0)).reshape(Delta.shape)
        return out


_MD_PATH_CACHE: dict = {}


def _md_path(lam: float, A_max: float = 5.0) -> _MDPath:
    key = (float(lam), float(A_max))
    if key not in _MD_PATH_CACHE:
        if len(_MD_PATH_CACHE) > 64:
            _MD_PATH_CACHE.clear()
        _MD_PATH_CACHE[key] = _MDPath(float(lam), float(A_max))
    return _MD_PATH_CACHE[key]


def maugis_dugdale_critical_points(lam: float) -> dict:
    """Instabilities of the Maugis-Dugdale sphere at Maugis parameter lambda [-], Johnson & Greenwood units.

    The whole equilibrium curve is the no-contact branch (``maugis_dugdale_noncontact_curve``) followed
    by the contact branch (``maugis_dugdale_curve``); along it the contact grows. Returns floats:
    - Load control (force F prescribed, the retraction ends where dP/dA = 0):
      "P_pull_off_load_control", "A_pull_off_load_control", "Delta_pull_off_load_control".
    - Displacement control (approach delta prescribed, e.g. a rigid approach stepped down; retraction
      follows the curve while d(Delta) / d(contact size) > 0 and jumps out at its vertical tangent in
      the (Delta, P) plane, the minimum of Delta over the curve; the curve has no other local minimum
      of Delta, so the retraction jumps once, and the approach once, for every lambda tested):
      "P_jump_out", "Delta_jump_out", "A_jump_out", "C_jump_out". For lambda above
      LAMBDA_JUMP_OUT_ON_CONTACT_BRANCH (0.938) the jump-out is on the contact branch (A > 0, where
      d(Delta)/dA = 0); below it the contact branch is displacement-stable down to A = 0 and the
      retraction goes on along the no-contact branch to C = 8 lambda / (3 pi), where it jumps out at
      P = -32 lambda^3 / (9 pi) (A = 0).
      "P_most_tensile_displacement_control": the most tensile force along that retraction path. The
      load-control minimum of P lies on the displacement-stable part of the curve for every lambda
      (a state stable under dead load is stable under a rigid grip; the tests check
      d(Delta)/dA > 0 there for lambda = 0.01 ... 20), so this equals "P_pull_off_load_control":
      a displacement-driven simulation measures the load-control pull-off force as its most tensile
      force (to within its step), and separates later, at the less tensile "P_jump_out".
    - Approach under displacement control: the force is zero until the undeformed centre gap reaches
      h_0, at "Delta_jump_in" = -2 / (pi lambda); the Dugdale stress then switches on at once (the law
      is discontinuous) and the state jumps to the first displacement-stable state at that Delta:
      "P_after_jump_in", "A_after_jump_in", "C_after_jump_in". For lambda below
      LAMBDA_JUMP_IN_ON_NONCONTACT_BRANCH (0.655) it lands on the no-contact branch at
      C = 16 lambda / (3 pi), P = -128 lambda^3 / (9 pi); above it, in contact. A smooth law (or a
      smoothed Dugdale law) starts attracting before Delta_jump_in, so this jump is the Dugdale law's.
    """
    import numpy as np

    lam = _check_lambda(lam)
    path = _md_path(lam)
    load = _md_state(lam, path.u_pull_off_load)
    ret = np.flatnonzero(path.on_retraction)
    k_out = int(ret[0])  # retraction leaves the curve at its first retraction-path state (lowest u)
    app = _md_state(lam, _md_bisect(lam, path.Delta_first_touch, *_md_first_crossing(path)))
    return {
        "lambda": lam,
        "P_pull_off_load_control": float(load["P"][0]),
        "A_pull_off_load_control": float(load["A"][0]),
        "Delta_pull_off_load_control": float(load["Delta"][0]),
        "P_jump_out": float(path.P[k_out]),
        "Delta_jump_out": float(path.Delta[k_out]),
        "A_jump_out": float(path.A[k_out]),
        "C_jump_out": float(path.C[k_out]),
        "P_most_tensile_displacement_control": float(path.P[ret].min()),
        "Delta_jump_in": path.Delta_first_touch,
        "P_after_jump_in": float(app["P"][0]),
        "A_after_jump_in": float(app["A"][0]),
        "C_after_jump_in": float(app["C"][0]),
    }


def _md_first_crossing(path: _MDPath):
    """Bracket (u_lo, u_hi) of the first upward crossing of the first-touch Delta after the curve's start."""
    import numpy as np

    above = np.flatnonzero(path.Delta[1:] >= path.Delta_first_touch) + 1
    i = int(above[0])
    return path.u[i - 1], path.u[i]


def maugis_dugdale_state_at(lam: float, Delta, branch: str = "retract") -> dict:
    """Maugis-Dugdale state at approach(es) Delta under displacement control, on one path.

    lam: Maugis parameter [-]. Delta: approach(es) delta (16 E*^2 / (9 pi^2 w^2 R))^(1/3) [-], positive
    into contact, scalar or array. branch:
    - "approach": the path met when Delta is increased from far apart: free (P = 0) up to the first
      touch of the cohesive zone at Delta = -2 / (pi lambda), then the jump-in (see
      ``maugis_dugdale_critical_points``), then the displacement-stable states with the contact
      growing (at each Delta, the first state along the curve with Delta(u) >= Delta).
    - "retract": the path met when Delta is decreased from deep contact: the displacement-stable
      states with the contact shrinking (at each Delta, the last state along the curve with
      Delta(u) <= Delta) down to the jump-out, free (P = 0) below it.
    Both paths are made of equilibrium states of the Maugis-Dugdale equations (contact branch) and of
    the Dugdale no-contact branch; they coincide where the curve is single-valued in Delta.
    Returns arrays shaped like Delta: "P" = F / (pi w R), "A" = a / (pi w R^2 / K)^(1/3) (0 out of
    contact), "C" = c / (pi w R^2 / K)^(1/3) (0 when free), "in_contact" (bool). Each state is solved
    to 1e-12 on the curve (bisection between its samples), not interpolated.
    """
    import numpy as np

    lam = _check_lambda(lam)
    d_max = float(np.max(np.asarray(Delta, dtype=float), initial=0.0))
    A_max = 5.0
    while True:
        path = _md_path(lam, A_max)
        if path.Delta[-1] >= d_max:
            break
        A_max = math.ceil(math.sqrt(max(d_max, 0.0)) + 2.0)
    return path.states_at(Delta, branch)


def maugis_dugdale_force_at(lam: float, Delta, branch: str = "retract"):
    """Force P = F / (pi w R) [-] at approach(es) Delta [-] on the approach or retraction path.

    See ``maugis_dugdale_state_at`` for the paths and the units; returns a float for a scalar Delta,
    an array otherwise.
    """
    import numpy as np

    P = maugis_dugdale_state_at(lam, Delta, branch)["P"]
    return float(P) if np.ndim(P) == 0 else P


def maugis_dugdale_scales(E_star: float, radius: float, work_of_adhesion: float, sigma_0: float) -> dict:
    """Johnson & Greenwood's units for a sphere of ``radius`` R [m] on a flat, SI in and out.

    E_star: contact modulus E* [Pa]; work_of_adhesion: w [J/m^2]; sigma_0: Dugdale stress [Pa].
    Returns "lambda" [-], "force" = pi w R [N], "radius" = (pi w R^2 / K)^(1/3) [m] (unit of a and c),
    "approach" = (pi^2 w^2 R / K^2)^(1/3) [m] (unit of delta), "h_0" = w / sigma_0 [m], K = 4 E* / 3.
    """
    for name, value in (("E_star", E_star), ("radius", radius), ("work_of_adhesion", work_of_adhesion),
                        ("sigma_0", sigma_0)):
        if not (value > 0.0 and math.isfinite(value)):
            raise ValueError(f"{name} must be positive and finite, got {value!r}")
    K = 4.0 * E_star / 3.0
    return {
        "lambda": 2.0 * sigma_0 / (math.pi * work_of_adhesion * K * K / radius) ** (1.0 / 3.0),
        "force": math.pi * work_of_adhesion * radius,
        "radius": (math.pi * work_of_adhesion * radius**2 / K) ** (1.0 / 3.0),
        "approach": (math.pi**2 * work_of_adhesion**2 * radius / K**2) ** (1.0 / 3.0),
        "h_0": work_of_adhesion / sigma_0,
    }


def maugis_dugdale_si(E_star: float, radius: float, work_of_adhesion: float, sigma_0: float,
                      max_contact_radius: float | None = None) -> dict:
    """Maugis-Dugdale sphere on a flat in SI units: the whole equilibrium curve and its instabilities.

    E_star: contact modulus E* [Pa] (``pair.E_star``); radius: R [m]; work_of_adhesion: w [J/m^2];
    sigma_0: Dugdale stress [Pa], acting while the gap is below h_0 = w / sigma_0.
    max_contact_radius: the largest contact radius a [m] on the returned curve (default 5 units of
    (pi w R^2 / K)^(1/3), K = 4 E* / 3).
    Returns, along the curve from the first touch of the cohesive zone (c = 0) to the largest contact,
    the no-contact branch (a = 0) first, numpy arrays:
      "delta_z" approach delta [m], positive into contact; "force" F [N], positive compressive;
      "a" contact radius [m]; "c" cohesive-zone radius [m];
      "on_approach_path", "on_retraction_path": whether a displacement-driven approach / retraction
      passes through the state (``maugis_dugdale_state_at``);
    and floats: "lambda"; "pull_off_force_load_control" [N] = min F, the load-control pull-off, with
    "delta_z_pull_off_load_control" [m] and "a_pull_off_load_control" [m];
    "pull_off_force_displacement_control" [N], the force at the jump-out of a displacement-driven
    retraction (vertical tangent of the curve in the (delta_z, F) plane), with "delta_z_jump_out" [m]
    and "a_jump_out" [m]; "max_tensile_force_displacement_control" [N], the most tensile force along
    the displacement-driven retraction: it equals the load-control pull-off force for every lambda
    (the F minimum lies on the displacement-stable part), so a simulation stepping a rigid approach
    delta_z down measures min F as its most tensile force and jumps out later, at the smaller
    pull_off_force_displacement_control; "delta_z_jump_in" [m] = -h_0 and "force_after_jump_in" [N]
    on approach; "scales" (``maugis_dugdale_scales``).
    """
    import numpy as np

    scales = maugis_dugdale_scales(E_star, radius, work_of_adhesion, sigma_0)
    lam = scales["lambda"]
    A_max = 5.0 if max_contact_radius is None else float(max_contact_radius) / scales["radius"]
    path = _md_path(lam, A_max)
    crit = maugis_dugdale_critical_points(lam)
    F, L, a = scales["force"], scales["approach"], scales["radius"]
    return {
        "lambda": lam,
        "delta_z": path.Delta * L,
        "force": path.P * F,
        "a": path.A * a,
        "c": path.C * a,
        "on_approach_path": path.on_approach.copy(),
        "on_retraction_path": path.on_retraction.copy(),
        "pull_off_force_load_control": crit["P_pull_off_load_control"] * F,
        "delta_z_pull_off_load_control": crit["Delta_pull_off_load_control"] * L,
        "a_pull_off_load_control": crit["A_pull_off_load_control"] * a,
        "pull_off_force_displacement_control": crit["P_jump_out"] * F,
        "delta_z_jump_out": crit["Delta_jump_out"] * L,
        "a_jump_out": crit["A_jump_out"] * a,
        "max_tensile_force_displacement_control": crit["P_most_tensile_displacement_control"] * F,
        "delta_z_jump_in": crit["Delta_jump_in"] * L,
        "force_after_jump_in": crit["P_after_jump_in"] * F,
        "scales": scales,
    }

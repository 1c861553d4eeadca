"""Closed-form reference solutions (MODEL.md section 8), SI units."""

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


def maugis_dugdale_pull_off(lam: float) -> float:
    """Maugis-Dugdale pull-off force over pi w R for the Maugis parameter lambda [-].

    Johnson & Greenwood (1997), J. Colloid Interface Sci. 192, 326-333, after Maugis (1992):
    with m = c / a (cohesive-zone to contact radius), A = a (4 E* / (3 pi w R^2))^(1/3),
    P = F / (pi w R), lambda = sigma_0 (9 R / (2 pi w E*^2))^(1/3):
      (lambda A^2 / 2) [(m^2 - 2) arcsec m + sqrt(m^2 - 1)]
        + (4 lambda^2 A / 3) [sqrt(m^2 - 1) arcsec m - m + 1] = 1
      P = A^3 - lambda A^2 [sqrt(m^2 - 1) + m^2 arcsec m]
    The pull-off force is the minimum of P along the equilibrium curve (it tends to -2, DMT, as
    lambda -> 0 and to -1.5, JKR, as lambda -> infinity).
    """
    import numpy as np
    from scipy.optimize import minimize_scalar

    def load(log_m_minus_1):
        m = 1.0 + math.exp(log_m_minus_1)
        s = math.sqrt(m * m - 1.0)
        asec = math.atan(s)
        a2 = 0.5 * lam * ((m * m - 2.0) * asec + s)
        a1 = 4.0 * lam * lam / 3.0 * (s * asec - m + 1.0)
        # a2 A^2 + a1 A - 1 = 0, positive root
        A = (-a1 + math.sqrt(a1 * a1 + 4.0 * a2)) / (2.0 * a2) if a2 > 0 else 1.0 / a1
        return A**3 - lam * A * A * (s + m * m * asec)

    grid = np.linspace(-14.0, 10.0, 2401)
    vals = np.array([load(x) for x in grid])
    k = int(np.argmin(vals))
    lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]
    res = minimize_scalar(load, bounds=(lo, hi), method="bounded", options={"xatol": 1e-10})
    return float(min(res.fun, vals[k]))


def maugis_parameter(pair, radius: float, sigma_0: float, work_of_adhesion: float) -> float:
    """lambda = sigma_0 (9 R / (2 pi w E*^2))^(1/3) [-]."""
    return sigma_0 * (9.0 * radius / (2.0 * math.pi * work_of_adhesion * pair.E_star**2)) ** (1.0 / 3.0)

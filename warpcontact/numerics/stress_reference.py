"""Closed forms of the stress below the surface: the point forces of Boussinesq and Cerruti and
the stresses on the axis under a Hertz pressure, the references of the tests of the evaluation
(``warpcontact.numerics.stress``). SI units, tension positive."""

from __future__ import annotations

import math

import numpy as np


def boussinesq_point_stress(x, y, z, nu: float) -> dict:
    """Stress [Pa per N] of a unit normal force pressing on the half-space at the origin, at (x, y)
    and depth z > 0 [m] (Johnson 1985, eq. 3.18, cylindrical, turned to Cartesian; tension
    positive). Dict by ``stress.COMPONENTS``."""
    x, y, z = np.broadcast_arrays(*(np.asarray(v, dtype=np.float64) for v in (x, y, z)))
    r = np.hypot(x, y)
    rho = np.sqrt(r * r + z * z)
    with np.errstate(divide="ignore", invalid="ignore"):
        c, s = np.where(r > 0, x / r, 1.0), np.where(r > 0, y / r, 0.0)
        # (1 - z/rho)/r^2 = 1/(rho (rho + z)): no cancellation on the axis
        sr = ((1 - 2 * nu) / (rho * (rho + z)) - 3 * z * r * r / rho**5) / (2 * np.pi)
        st = -(1 - 2 * nu) * (1.0 / (rho * (rho + z)) - z / rho**3) / (2 * np.pi)
    sz = -3 * z**3 / (2 * np.pi * rho**5)
    trz = -3 * r * z * z / (2 * np.pi * rho**5)
    return {"sigma_xx": sr * c * c + st * s * s, "sigma_yy": sr * s * s + st * c * c, "sigma_zz": sz,
            "sigma_xy": (sr - st) * s * c, "sigma_xz": trz * c, "sigma_yz": trz * s}


def cerruti_point_stress(x, y, z, nu: float) -> dict:
    """Stress [Pa per N] of a unit tangential force along +x on the half-space surface at the
    origin, at (x, y) and depth z > 0 [m] (Cerruti; Johnson 1985, section 3.5; tension
    positive). Dict by ``stress.COMPONENTS``."""
    x, y, z = np.broadcast_arrays(*(np.asarray(v, dtype=np.float64) for v in (x, y, z)))
    rho = np.sqrt(x * x + y * y + z * z)
    b = (1 - 2 * nu) / (rho + z) ** 2
    f = -x / (2 * np.pi * rho**3)
    return {
        "sigma_xx": f * (3 * x * x / rho**2 - b * (rho**2 - y * y - 2 * rho * y * y / (rho + z))),
        "sigma_yy": f * (3 * y * y / rho**2 - b * (3 * rho**2 - x * x - 2 * rho * x * x / (rho + z))),
        "sigma_zz": -3 * x * z * z / (2 * np.pi * rho**5),
        "sigma_xy": -y / (2 * np.pi * rho**3)
        * (3 * x * x / rho**2 - b * (x * x - rho**2 + 2 * rho * x * x / (rho + z))),
        "sigma_xz": -3 * x * x * z / (2 * np.pi * rho**5),
        "sigma_yz": -3 * x * y * z / (2 * np.pi * rho**5),
    }


def hertz_axis_stress(z_over_a, nu: float) -> dict:
    """Stresses on the axis under a Hertz pressure p0 sqrt(1 - r^2/a^2), per p0, at depths
    z/a > 0 (Johnson 1985, eq. 3.45): sigma_zz = -1/(1 + z^2/a^2), sigma_rr = sigma_tt =
    -(1 + nu) (1 - (z/a) atan(a/z)) + 1/(2 (1 + z^2/a^2)); von Mises |sigma_zz - sigma_rr|,
    maximum shear half that."""
    s = np.asarray(z_over_a, dtype=np.float64)
    szz = -1.0 / (1.0 + s * s)
    srr = -(1.0 + nu) * (1.0 - s * np.arctan(1.0 / s)) + 0.5 / (1.0 + s * s)
    return {"sigma_zz": szz, "sigma_rr": srr, "von_mises": np.abs(szz - srr), "tresca": 0.5 * np.abs(szz - srr)}


def hertz_von_mises_max(nu: float) -> tuple[float, float]:
    """(largest von Mises stress / p0, its depth / a) on the Hertz axis (``hertz_axis_stress``):
    0.620 at 0.481 for nu = 0.3. Golden-section search on (0.05, 2) (one maximum there)."""
    lo, hi = 0.05, 2.0
    g = (math.sqrt(5.0) - 1.0) / 2.0
    f = lambda s: float(hertz_axis_stress(s, nu)["von_mises"])
    for _ in range(200):
        a, b = hi - g * (hi - lo), lo + g * (hi - lo)
        if f(a) > f(b):
            hi = b
        else:
            lo = a
    s = 0.5 * (lo + hi)
    return f(s), s

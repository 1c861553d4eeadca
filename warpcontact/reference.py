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

"""The gap before deformation of the sphere over the flat (MODEL.md section 3), made on the device."""

from typing import Any

import warp as wp

wp.set_module_options({"enable_backward": False})


@wp.kernel
def sphere_gap(n: int, radius: wp.float64, paraboloid: int, gap: wp.array2d(dtype=Any)):
    """gap[i, j] <- h0 / dx at the centre of cell (row i, column j) of an n x n grid centred on the
    first point of contact, in cells (``radius``: R / dx), computed in float64 and rounded to the
    array's type: r^2 / (2 R) for the paraboloid, else R - sqrt(R^2 - r^2) written
    r^2 / (R + sqrt(R^2 - r^2)) (no cancellation), as ``Sphere.initial_gap`` computes it on the
    host (whose domain check, r < R, stays there)."""
    i, j = wp.tid()
    half = wp.float64(0.5) * wp.float64(n - 1)
    x = wp.float64(j) - half
    y = wp.float64(i) - half
    r2 = x * x + y * y
    h = r2 / (wp.float64(2.0) * radius)
    if paraboloid == 0:
        h = r2 / (radius + wp.sqrt(radius * radius - r2))
    gap[i, j] = type(gap[i, j])(h)


for _scalar in (wp.float32, wp.float64):
    wp.overload(sphere_gap, [int, wp.float64, int, wp.array2d(dtype=_scalar)])

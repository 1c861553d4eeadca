"""Closed-form influence coefficients of the coupled Boussinesq-Cerruti operator (MODEL.md section 2).

Each point-force kernel of the relative surface displacement of the two half-spaces is integrated
exactly over a rectangular cell of half-widths (a, b) carrying a uniform traction. Conventions:

* ``pressure`` p >= 0 pushes the bodies together; ``u_z`` is the sum of the two normal surface
  displacements into the bodies, so the gap is h = h0 - delta_z + u_z.
* ``shear`` q is the tangential traction that the sphere exerts on the flat (the flat exerts -q
  on the sphere); ``u_t`` = u^(2) - u^(1) is the tangential surface displacement of the flat
  relative to the sphere, so the slip of the sphere relative to the flat is s = delta - u_t.
  (p, q) and (u_z, u_t) are work-conjugate, hence the operator is symmetric.

Point-force kernels (r^2 = x^2 + y^2, x = observation minus source):
  ZZ: 1/(pi E*) 1/r
  XX: (A/r + B x^2/r^3)/(2 pi), YY: (A/r + B y^2/r^3)/(2 pi), XY = YX: B x y/r^3/(2 pi)
  XZ (u_x from p): +D/(4 pi) x/r^2,  YZ: +D/(4 pi) y/r^2
  ZX (u_z from q_x): -D/(4 pi) x/r^2, ZY: -D/(4 pi) y/r^2   (reciprocity: K_xz[i, j] = K_zx[j, i])
With D > 0 (copper on steel) a pressure makes the flat's surface move outwards relative to the
sphere's: the sphere's surface moves towards the contact centre (Johnson 1985, eq. 3.22b).

Cell integrals use antiderivatives F with d^2F/dx dy = kernel, evaluated at the four corners:
  1/r: x asinh(y/|x|) + y asinh(x/|y|)   (Love 1929)
  x^2/r^3: y asinh(x/|y|);  y^2/r^3: x asinh(y/|x|);  x y/r^3: -r
  x/r^2: x atan(y/x) + y ln r;  y/r^2: y atan(x/y) + x ln r
(terms that depend on one variable only are dropped: they cancel in the corner sum).
"""

from __future__ import annotations

import numpy as np

from .materials import MaterialPair

#: Order of the six distinct kernels (matches kernels/spectral.py).
KERNELS = ("zz", "xx", "yy", "xy", "xz", "yz")


def _xasinh(x, y):
    """x asinh(y/|x|), 0 where x = 0."""
    ax = np.abs(x)
    with np.errstate(divide="ignore", invalid="ignore"):
        v = x * np.arcsinh(y / ax)
    return np.where(ax == 0.0, 0.0, v)


def _xatan_ylnr(x, y):
    """x atan(y/x) + y ln r, continuous, 0 at the origin."""
    r2 = x * x + y * y
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = x * np.arctan(y / x)
        t2 = 0.5 * y * np.log(r2)
    return np.where(x == 0.0, 0.0, t1) + np.where(y == 0.0, 0.0, t2)


ANTIDERIVATIVES = {
    "inv_r": lambda x, y: _xasinh(x, y) + _xasinh(y, x),
    "xx_r3": lambda x, y: _xasinh(y, x),
    "yy_r3": lambda x, y: _xasinh(x, y),
    "xy_r3": lambda x, y: -np.sqrt(x * x + y * y),
    "x_r2": _xatan_ylnr,
    "y_r2": lambda x, y: _xatan_ylnr(y, x),
}


def cell_integral(name: str, X, Y, a: float, b: float) -> np.ndarray:
    """Integral of the elementary kernel ``name`` over the cell [X-a, X+a] x [Y-b, Y+b] [m]."""
    F = ANTIDERIVATIVES[name]
    return F(X + a, Y + b) - F(X + a, Y - b) - F(X - a, Y + b) + F(X - a, Y - b)


def point_kernels(pair: MaterialPair) -> dict:
    """Each kernel of KERNELS as (coefficient, elementary kernels) sums: kernel = sum c * elementary."""
    pi = np.pi
    return {
        "zz": [(1.0 / (pi * pair.E_star), "inv_r")],
        "xx": [(pair.A / (2 * pi), "inv_r"), (pair.B / (2 * pi), "xx_r3")],
        "yy": [(pair.A / (2 * pi), "inv_r"), (pair.B / (2 * pi), "yy_r3")],
        "xy": [(pair.B / (2 * pi), "xy_r3")],
        "xz": [(pair.D / (4 * pi), "x_r2")],
        "yz": [(pair.D / (4 * pi), "y_r2")],
    }


def influence_coefficients(pair: MaterialPair, ny: int, nx: int, dx: float, dy: float, padded: bool = True) -> dict:
    """Displacement [m] at a cell centre per unit traction [Pa] on a cell at each offset.

    Returns a dict KERNELS -> float64 arrays. With ``padded`` (the DC-FFT layout) each array has
    shape (2 ny, 2 nx) in wrap-around order: entry [k, l] is the offset (k, l) for k < ny and
    (k - 2 ny) for k > ny; the unused middle row/column (offset +-ny, +-nx) is zero. Without
    ``padded``, arrays of shape (2 ny - 1, 2 nx - 1) with offsets -(n-1) ... n-1 in order.
    """
    # Offsets in natural order, -n ... n-1 (padded) or -(n-1) ... n-1, and the cell corners
    # between them: each antiderivative is evaluated once per corner of the lattice, and a cell's
    # integral is the difference of its four corners (a quarter of the evaluations of doing each
    # cell apart: the set-up of large grids is these evaluations).
    first_y, first_x = (ny, nx) if padded else (ny - 1, nx - 1)
    count_y, count_x = (2 * ny, 2 * nx) if padded else (2 * ny - 1, 2 * nx - 1)
    corner_y = (np.arange(count_y + 1, dtype=np.float64) - first_y - 0.5) * dy
    corner_x = (np.arange(count_x + 1, dtype=np.float64) - first_x - 0.5) * dx
    CX, CY = np.meshgrid(corner_x, corner_y, indexing="xy")
    elementary = {}
    for name, F in ANTIDERIVATIVES.items():
        corners = F(CX, CY)
        cells = corners[1:, 1:] - corners[:-1, 1:] - corners[1:, :-1] + corners[:-1, :-1]
        del corners
        if padded:  # natural order -> wrap-around order: offset k at index k mod 2n
            cells = np.roll(cells, (-first_y, -first_x), axis=(0, 1))
        elementary[name] = cells
    del CX, CY
    out = {}
    for kname, terms in point_kernels(pair).items():
        arr = sum(c * elementary[e] for c, e in terms)
        if padded:
            arr[ny, :] = 0.0
            arr[:, nx] = 0.0
        out[kname] = arr
    return out

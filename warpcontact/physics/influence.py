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

import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from .materials import MaterialPair

#: Order of the six distinct kernels (matches kernels/spectral.py).
KERNELS = ("zz", "xx", "yy", "xy", "xz", "yz")
#: the part of each kernel's spectrum that is not zero: a kernel even in x and in y (zz, xx, yy)
#: or odd in both (xy) has a real spectrum; one odd in x or in y only (xz, yz) an imaginary one.
#: The coefficients keep these symmetries on the padded grid (the middle row and column, offset
#: +-n, are zero), so the other part is rounding (tests/test_influence.py).
SPECTRUM_PARTS = {"zz": "real", "xx": "real", "yy": "real", "xy": "real", "xz": "imag", "yz": "imag"}


def _xasinh(x, y):
    """x asinh(y/|x|), 0 where x = 0."""
    ax = np.abs(x)
    with np.errstate(divide="ignore", invalid="ignore"):
        v = x * np.arcsinh(y / ax)
    return np.where(ax == 0.0, 0.0, v)


def _corner_terms(x, y) -> dict:
    """The antiderivative of each elementary kernel (module docstring; x/r^2: x atan(y/x) + y ln r,
    0 on the axes where a term's factor is 0) at the points (x, y) (arrays that broadcast), as a
    dict by name. Their shared parts are computed once: x asinh(y/|x|) and y asinh(x/|y|) (1/r is
    their sum, x^2/r^3 and y^2/r^3 one each), r, and ln r^2 (x/r^2 and y/r^2 both)."""
    xa, ya = _xasinh(x, y), _xasinh(y, x)
    r2 = x * x + y * y
    with np.errstate(divide="ignore", invalid="ignore"):
        log_r2 = np.log(r2)
        x_atan, y_atan = x * np.arctan(y / x), y * np.arctan(x / y)
        y_log, x_log = 0.5 * y * log_r2, 0.5 * x * log_r2
    x0, y0 = x == 0.0, y == 0.0
    return {
        "inv_r": xa + ya,
        "xx_r3": ya,
        "yy_r3": xa,
        "xy_r3": -np.sqrt(r2),
        "x_r2": np.where(x0, 0.0, x_atan) + np.where(y0, 0.0, y_log),
        "y_r2": np.where(y0, 0.0, y_atan) + np.where(x0, 0.0, x_log),
    }


def cell_integral(name: str, X, Y, a: float, b: float) -> np.ndarray:
    """Integral of the elementary kernel ``name`` over the cell [X-a, X+a] x [Y-b, Y+b] [m]."""
    def F(x, y):
        return _corner_terms(x, y)[name]

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


def _layout(ny: int, nx: int, padded: bool) -> tuple[int, int, int, int]:
    """(first_y, first_x, count_y, count_x): the cells' offsets in natural order are -first ...
    count - first - 1 (-n ... n-1 padded, -(n-1) ... n-1 not), their corners between them."""
    if padded:
        return ny, nx, 2 * ny, 2 * nx
    return ny - 1, nx - 1, 2 * ny - 1, 2 * nx - 1


#: cell rows per block of ``influence_coefficients`` (each block's temporaries: about 15 arrays of
#: (rows + 1) x (2 nx + 1) float64, ``resources.INFLUENCE_BLOCK_ARRAYS``)
BLOCK_ROWS = 64


def influence_coefficients(pair: MaterialPair, ny: int, nx: int, dx: float, dy: float, padded: bool = True,
                           workers: int | None = None) -> dict:
    """Displacement [m] at a cell centre per unit traction [Pa] on a cell at each offset.

    Returns a dict KERNELS -> float64 arrays. With ``padded`` (the DC-FFT layout) each array has
    shape (2 ny, 2 nx) in wrap-around order: entry [k, l] is the offset (k, l) for k < ny and
    (k - 2 ny) for k > ny; the unused middle row/column (offset +-ny, +-nx) is zero. Without
    ``padded``, arrays of shape (2 ny - 1, 2 nx - 1) with offsets -(n-1) ... n-1 in order.

    The antiderivatives are evaluated once per cell corner (a cell's integral is the difference of
    its four corners), in blocks of ``BLOCK_ROWS`` cell rows on ``workers`` threads (default: one
    per CPU; numpy's element-wise functions release the GIL). The set-up of a large grid is these
    evaluations. n = 2048 on this project's 2-core machine: 5.0 s one antiderivative at a time on
    one thread (before), 3.15 s with the shared parts on one thread, 1.35 s on two.
    """
    first_y, first_x, count_y, count_x = _layout(ny, nx, padded)
    corner_y = (np.arange(count_y + 1, dtype=np.float64) - first_y - 0.5) * dy
    corner_x = (np.arange(count_x + 1, dtype=np.float64) - first_x - 0.5) * dx
    kernels = point_kernels(pair)
    out = {k: np.empty((count_y, count_x)) for k in kernels}

    def block(row0: int):
        """Cell rows row0 ... row0 + BLOCK_ROWS - 1 (natural order) of every kernel."""
        row1 = min(row0 + BLOCK_ROWS, count_y)
        corners = _corner_terms(corner_x[None, :], corner_y[row0:row1 + 1, None])
        cells = {name: c[1:, 1:] - c[:-1, 1:] - c[1:, :-1] + c[:-1, :-1] for name, c in corners.items()}
        # natural order -> wrap-around order: offset k at index k mod 2n
        rows = (np.arange(row0, row1) - first_y) % count_y if padded else slice(row0, row1)
        for kname, terms in kernels.items():
            arr = sum(c * cells[e] for c, e in terms)
            out[kname][rows] = np.roll(arr, -first_x, axis=1) if padded else arr

    starts = range(0, count_y, BLOCK_ROWS)
    workers = workers or os.cpu_count() or 1
    if workers > 1 and len(starts) > 1:
        with ThreadPoolExecutor(max_workers=min(workers, len(starts))) as pool:
            list(pool.map(block, starts))  # list(): re-raises a block's exception here
    else:
        for row0 in starts:
            block(row0)
    if padded:
        for arr in out.values():
            arr[ny, :] = 0.0
            arr[:, nx] = 0.0
    return out


#: the device path's corner arrays (kernels/influence.py) for each elementary kernel: (group, pick).
#: A group's corner terms are computed together (``corner_asinh_terms``: x asinh(y/|x|), y
#: asinh(x/|y|); ``corner_radius``: r; ``corner_atan_log_terms``: the x/r^2 and y/r^2
#: antiderivatives), and pick says which of its arrays (a, b) make the elementary antiderivative:
#: a + b, a, b or -a (the kernels' PICK_SUM, PICK_A, PICK_B, PICK_MINUS_A). As ``_corner_terms``.
ELEMENTARY_CORNERS = {
    "inv_r": ("asinh", 0),
    "xx_r3": ("asinh", 2),
    "yy_r3": ("asinh", 1),
    "xy_r3": ("radius", 3),
    "x_r2": ("atan_log", 1),
    "y_r2": ("atan_log", 2),
}


def device_coefficients(pair: MaterialPair, ny: int, nx: int, dx: float, dy: float, device, padded: bool = True,
                        scale: float = 1.0):
    """``influence_coefficients`` computed by Warp kernels on ``device`` (kernels/influence.py),
    times ``scale``: yields (name, float64 ``wp.array2d``) in KERNELS order, each array made when
    asked for, so a consumer that lets each go (the FFT backend's ``influence_spectra``) holds one
    at a time. The corner terms of a group (ELEMENTARY_CORNERS) are computed once, before the
    first kernel that needs them, and let go when the next group starts: at most two corner
    arrays of (rows + 1) x (cols + 1) and one coefficient array at a time (beyond what the
    consumer keeps). Same layout, formulas and order of operations as the numpy path; float64
    whatever the model's float type. The coefficient table is ``point_kernels``."""
    import warp as wp

    from warpcontact.kernels import influence as kernels

    device = wp.get_device(device)
    first_y, first_x, count_y, count_x = _layout(ny, nx, padded)
    corner_kernels = {"asinh": (kernels.corner_asinh_terms, 2), "radius": (kernels.corner_radius, 1),
                      "atan_log": (kernels.corner_atan_log_terms, 2)}
    shift_y, shift_x = (first_y, first_x) if padded else (0, 0)
    zero_row, zero_col = (ny, nx) if padded else (-1, -1)
    held_group, corners = None, None
    table = point_kernels(pair)
    for name in KERNELS:
        terms = table[name]
        groups = {ELEMENTARY_CORNERS[e][0] for _, e in terms}
        if len(groups) != 1 or len(terms) > 2:  # the cell kernel takes two terms of one group
            raise ValueError(f"influence kernel {name}: terms {terms} are not two of one corner group")
        group = groups.pop()
        if group != held_group:
            held_group, corners = group, None  # the last group's arrays go before the next's come
            kernel, count = corner_kernels[group]
            corners = [wp.empty((count_y + 1, count_x + 1), dtype=wp.float64, device=device) for _ in range(count)]
            wp.launch(kernel, dim=corners[0].shape, inputs=[first_y, first_x, float(dy), float(dx)], outputs=corners,
                      device=device)
        a, b = corners[0], corners[-1]  # (radius: one array, b unused)
        (c0, e0), (c1, e1) = terms[0], terms[1] if len(terms) == 2 else (0.0, None)
        pick1 = ELEMENTARY_CORNERS[e1][1] if e1 is not None else -1
        out = wp.empty((count_y, count_x), dtype=wp.float64, device=device)
        wp.launch(kernels.boussinesq_cerruti_cells, dim=out.shape,
                  inputs=[a, b, float(c0), ELEMENTARY_CORNERS[e0][1], float(c1), pick1, float(scale), shift_y, shift_x,
                          zero_row, zero_col],
                  outputs=[out], device=device)
        yield name, out
        del out  # the consumer's copy is the only one while the next is made


def chan_circulant(padded):
    """T. Chan's optimal circulant (``kernels/influence.py``, ``chan_circulant``) of a kernel on the
    (ny, nx) grid from its DC-FFT coefficients ``padded``, a (2 ny, 2 nx) float64 array in
    wrap-around order: a numpy array (then computed on the CPU, returned as numpy) or a Warp array
    (computed on its device, returned as a Warp array there). Its circulant is the one of least
    Frobenius distance from the kernel's Toeplitz matrix on the grid (T. F. Chan, "An optimal
    circulant preconditioner for Toeplitz systems", SIAM J. Sci. Stat. Comput. 9, 1988): the
    preconditioners' approximate inverse on transforms of ny nx entries, not 4 ny nx."""
    import warp as wp

    from warpcontact.kernels import influence as kernels

    host = not isinstance(padded, wp.array)
    # (a contiguous float64 host array is read where it is: no copy of the 4 ny nx coefficients)
    source = wp.array(np.ascontiguousarray(padded, dtype=np.float64), dtype=wp.float64, device="cpu",
                      copy=False) if host else padded
    ny, nx = source.shape[0] // 2, source.shape[1] // 2
    out = wp.empty((ny, nx), dtype=wp.float64, device=source.device)
    wp.launch(kernels.chan_circulant, dim=out.shape, inputs=[source], outputs=[out], device=source.device)
    return out.numpy() if host else out


def influence_coefficients_device(pair: MaterialPair, ny: int, nx: int, dx: float, dy: float, device,
                                  padded: bool = True, scale: float = 1.0) -> dict:
    """``influence_coefficients`` on ``device``: a dict KERNELS -> float64 ``wp.array2d`` (all six
    held; ``device_coefficients`` makes them one at a time)."""
    return dict(device_coefficients(pair, ny, nx, dx, dy, device, padded, scale))

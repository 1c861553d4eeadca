"""Products of B cases' traction spectra with their influence spectra, and the padding around the
batched transforms (``fft/batch.py``).

A stack of spectra is a (rows, 2 n, n + 1) array of complex numbers held as 2-vectors (the
half-spectrum layout of ``numpy.fft.rfft2`` on the (2 n, 2 n) padded grid); a pair (x, y) of
stacks is one (2, B, 2 n, n + 1) array. The influence spectra of the B cases are (P, 2 n, n + 1)
real arrays, P = 1 (every case on one material pair) or B (a row each): case b reads row
``min(b, P - 1)``. K_tt's blocks ``xx``, ``xy``, ``yy`` are real (even kernels); the coupling
blocks K_xz, K_yz are imaginary (kernels odd in one axis) and stored as their imaginary parts
``xz``, ``yz``, as ``kernels/spectral.py`` stores one case's. Every influence spectrum already
holds the inverse transform's 1 / (4 n^2), so the cropped inverse is the product.

Each product kernel is launched over (rows, 2 n, chunks) and thread (b, i, c) does the entries j
of row i from ``c * per`` to ``(c + 1) * per`` (on CUDA one entry per thread; on the CPU a whole
row per thread), each entry read and written once: one pass over the spectra where array
expressions make a temporary per operation.
"""

from typing import Any

import warp as wp

from .overloads import register_complex_overloads, register_float_overloads
from .spectral import times_i

wp.set_module_options({"enable_backward": False})


@wp.func
def influence_row(influence: wp.array3d(dtype=Any), case: int):
    """The row of a (P, 2 n, n + 1) stack of influence spectra that case ``case`` reads."""
    return wp.min(case, influence.shape[0] - 1)


@wp.kernel
def batch_spectral_scale(multiplier: wp.array3d(dtype=Any), spectra: wp.array3d(dtype=Any), per: int):
    """spectra[b] <- multiplier[row of b] spectra[b], in place (K_zz or its circulant inverse)."""
    b, i, c = wp.tid()
    k = influence_row(multiplier, b)
    for j in range(c * per, wp.min((c + 1) * per, spectra.shape[2])):
        spectra[b, i, j] = multiplier[k, i, j] * spectra[b, i, j]


@wp.kernel
def batch_spectral_tangential(xx: wp.array3d(dtype=Any), xy: wp.array3d(dtype=Any), yy: wp.array3d(dtype=Any),
                              pair: wp.array4d(dtype=Any), per: int):
    """(u_x, u_y) = [[xx, xy], [xy, yy]] (q_x, q_y) of each case, in place on ``pair``: K_tt,
    or its circulant inverse (the tangential preconditioner)."""
    b, i, c = wp.tid()
    k = influence_row(xx, b)
    for j in range(c * per, wp.min((c + 1) * per, pair.shape[3])):
        qx = pair[0, b, i, j]
        qy = pair[1, b, i, j]
        kxy = xy[k, i, j]
        pair[0, b, i, j] = xx[k, i, j] * qx + kxy * qy
        pair[1, b, i, j] = kxy * qx + yy[k, i, j] * qy


@wp.kernel
def batch_spectral_tangential_coupled(xx: wp.array3d(dtype=Any), xy: wp.array3d(dtype=Any),
                                      yy: wp.array3d(dtype=Any), xz: wp.array3d(dtype=Any),
                                      yz: wp.array3d(dtype=Any), pressure: wp.array3d(dtype=Any),
                                      pair: wp.array4d(dtype=Any), per: int):
    """(u_x, u_y) = K_tt (q_x, q_y) + K_tz p of each case, in place on ``pair`` (K_xz = i xz)."""
    b, i, c = wp.tid()
    k = influence_row(xx, b)
    for j in range(c * per, wp.min((c + 1) * per, pair.shape[3])):
        qx = pair[0, b, i, j]
        qy = pair[1, b, i, j]
        ip = times_i(pressure[b, i, j])
        kxy = xy[k, i, j]
        pair[0, b, i, j] = xx[k, i, j] * qx + kxy * qy + xz[k, i, j] * ip
        pair[1, b, i, j] = kxy * qx + yy[k, i, j] * qy + yz[k, i, j] * ip


@wp.kernel
def batch_spectral_cross_tangential(xz: wp.array3d(dtype=Any), yz: wp.array3d(dtype=Any),
                                    pressure: wp.array3d(dtype=Any), per: int, pair: wp.array4d(dtype=Any)):
    """The pressure's tangential displacement (u_x, u_y) = K_tz p of each case into ``pair``."""
    b, i, c = wp.tid()
    k = influence_row(xz, b)
    for j in range(c * per, wp.min((c + 1) * per, pair.shape[3])):
        ip = times_i(pressure[b, i, j])
        pair[0, b, i, j] = xz[k, i, j] * ip
        pair[1, b, i, j] = yz[k, i, j] * ip


@wp.kernel
def batch_spectral_cross_normal(xz: wp.array3d(dtype=Any), yz: wp.array3d(dtype=Any), pair: wp.array4d(dtype=Any),
                                per: int, normal: wp.array3d(dtype=Any)):
    """The shear's normal displacement u_z = K_zt q of each case into ``normal`` (K_zt = -K_tz:
    the kernels are odd)."""
    b, i, c = wp.tid()
    k = influence_row(xz, b)
    for j in range(c * per, wp.min((c + 1) * per, pair.shape[3])):
        normal[b, i, j] = -times_i(xz[k, i, j] * pair[0, b, i, j] + yz[k, i, j] * pair[1, b, i, j])


@wp.kernel
def batch_spectral_coupled(xx: wp.array3d(dtype=Any), xy: wp.array3d(dtype=Any), yy: wp.array3d(dtype=Any),
                           xz: wp.array3d(dtype=Any), yz: wp.array3d(dtype=Any), zz: wp.array3d(dtype=Any),
                           normal_block: int, pressure: wp.array3d(dtype=Any), pair: wp.array4d(dtype=Any),
                           per: int):
    """The coupled product of each case's tractions, in place on their spectra: (u_x, u_y) = K_tt
    (q_x, q_y) + K_tz p into ``pair``, u_z = K_zt q into ``pressure``, plus K_zz p where
    ``normal_block`` (``zz``: K_zz's spectrum, of every pair in scaled units; else not read)."""
    b, i, c = wp.tid()
    k = influence_row(xx, b)
    for j in range(c * per, wp.min((c + 1) * per, pair.shape[3])):
        qx = pair[0, b, i, j]
        qy = pair[1, b, i, j]
        p = pressure[b, i, j]
        ip = times_i(p)
        kxz = xz[k, i, j]
        kyz = yz[k, i, j]
        kxy = xy[k, i, j]
        pair[0, b, i, j] = xx[k, i, j] * qx + kxy * qy + kxz * ip
        pair[1, b, i, j] = kxy * qx + yy[k, i, j] * qy + kyz * ip
        uz = -times_i(kxz * qx + kyz * qy)
        if normal_block != 0:
            uz = uz + zz[0, i, j] * p
        pressure[b, i, j] = uz


@wp.kernel
def batch_pad(field: wp.array2d(dtype=Any), width: int, padded: wp.array3d(dtype=Any)):
    """Each row's field (row-major cells, ``width`` wide) into the (n, n) corner of its padded
    grid (whose other entries stay zero)."""
    r, cell = wp.tid()
    row = cell // width
    padded[r, row, cell - row * width] = field[r, cell]


@wp.kernel
def batch_crop(padded: wp.array3d(dtype=Any), width: int, field: wp.array2d(dtype=Any)):
    """Each row's field (row-major cells, ``width`` wide) <- the (n, n) corner of its padded grid."""
    r, cell = wp.tid()
    row = cell // width
    field[r, cell] = padded[r, row, cell - row * width]


register_float_overloads(batch_pad)
register_float_overloads(batch_crop)
for _kernel in (batch_spectral_scale, batch_spectral_tangential, batch_spectral_tangential_coupled,
                batch_spectral_cross_tangential, batch_spectral_cross_normal, batch_spectral_coupled):
    register_complex_overloads(_kernel, ("spectra", "pair", "pressure", "normal"))

"""Products of traction spectra with the influence spectra of the coupled elastic operator.

The spectra of the six distinct influence kernels are stored in one real array ``influence`` of
shape (6, sy, sx), in the order ``ZZ, XX, YY, XY, XZ, YZ`` (``XZ``: u_x from p). Each kernel is
even or odd in x and in y (MODEL.md section 2; ``influence.SPECTRUM_PARTS``), so each spectrum is
real or imaginary: ZZ, XX, YY (even, even) and XY (odd, odd) are real, XZ (odd in x) and YZ (odd
in y) imaginary, and only that part is kept (what is dropped is rounding, about 1e-16 of the
largest entry). The traction spectra are complex numbers as 2-vectors. By reciprocity the "normal
from shear" kernels are the negatives of ``XZ`` and ``YZ``.

Each kernel is launched over (rows, chunks) and thread (i, c) does the entries j of row i from
``c * per`` to ``(c + 1) * per``: on CUDA one entry per thread (chunks = columns, per = 1); on the
CPU, where Warp runs the threads one after another, a whole row per thread (chunks = 1, per =
columns), which halves the per-entry overhead (n = 512: 2.57 -> 1.24 ms for the normal product).
"""

from typing import Any

import warp as wp

from .reduce import Cells, block_add, cell_index

# no adjoints: nothing differentiates these kernels, and compiling them doubles the build
wp.set_module_options({"enable_backward": False})

ZZ = wp.constant(0)
XX = wp.constant(1)
YY = wp.constant(2)
XY = wp.constant(3)
XZ = wp.constant(4)
YZ = wp.constant(5)


@wp.func
def times_i(a: Any):
    """i a, for a complex number held as a 2-vector (re, im)."""
    return type(a)(-a[1], a[0])


@wp.kernel
def spectral_normal(influence: wp.array3d(dtype=Any), spectrum: wp.array2d(dtype=Any), per: int):
    """u_z = K_zz p in Fourier space, in place on ``spectrum``."""
    i, c = wp.tid()
    for j in range(c * per, wp.min((c + 1) * per, spectrum.shape[1])):
        spectrum[i, j] = influence[ZZ, i, j] * spectrum[i, j]


@wp.func
def first_entry(thread: int, cells: Cells, width: int):
    """The (row, column) of a reducing thread's first entry of a row-major 2-D array ``width``
    wide (entry e = ``cell_index(thread, cells, 0)``), and the (rows, columns) its entries
    advance by (``cells.inner``): a thread carries (i, j) from one entry to the next
    (:func:`next_entry`), one integer division per thread, not per entry (the CPU's sweep: n =
    512, 2.4 -> 1.0 ms)."""
    first = cell_index(thread, cells, 0)
    i = first // width
    di = cells.inner // width
    return i, first - i * width, di, cells.inner - di * width


@wp.func
def next_entry(i: int, j: int, di: int, dj: int, width: int):
    """The (row, column) of a reducing thread's next entry after (i, j) (:func:`first_entry`)."""
    i += di
    j += dj
    if j >= width:
        i += 1
        j -= width
    return i, j


@wp.func
def parseval_weight(i: int, j: int, first_row: int, half_axis: int, half_length: int, energy_scale: Any):
    """The weight of spectrum entry (i, j) in a sum over the padded grid by Parseval's identity:
    ``energy_scale`` where the index along ``half_axis`` (the real transform's non-negative
    frequencies, of length ``half_length`` in real space; rows counted from ``first_row``) is 0
    or half_length / 2, twice it elsewhere."""
    f = wp.where(half_axis == 0, first_row + i, j)
    return wp.where(f == 0 or 2 * f == half_length, energy_scale, energy_scale + energy_scale)


@wp.kernel
def spectral_normal_energy(
    influence: wp.array3d(dtype=Any),
    spectrum: wp.array2d(dtype=Any),
    half_axis: int,
    half_length: int,
    energy_scale: Any,
    inverse: int,
    slot: int,
    first_row: int,
    mirror: int,
    cells: Cells,
    sums: wp.array(dtype=Any),
):
    """u_z = K_zz p in Fourier space, in place on ``spectrum``, and sums[slot] += (K p) . p, the
    sum over the padded grid, by Parseval's identity: ``energy_scale`` * sum_k w_k K(k) |P(k)|^2,
    with w = 1 where the index along ``half_axis`` (the axis of the real transform's non-negative
    frequencies, of length ``half_length`` in real space) is 0 or half_length / 2, 2 elsewhere
    (``FFTBackend.half_axis``). A reducing kernel (kernels/reduce.py) over the n entries of the
    spectrum, row-major; ``first_row``: the spectrum's first row (the CPU splits the launch by
    rows, ``launch.FirstRow``). ``mirror`` > 0: the length of the spectrum's full axis (the one
    that is not ``half_axis``); K_zz is even, so K_zz(k) = K_zz(-k), and entries past the middle
    of that axis read K_zz at their mirror image: the kernel reads half of K_zz's spectrum
    (CUDA; the CPU's split launches hold only their own rows of it: 0 there).

    With ``inverse`` = 1 the multiplier is 1 / K_zz(k) instead (0 where K_zz(k) <= 0; it is
    positive on the padded grids, about 0.18 at the highest frequency and 2.2 n at the lowest,
    scaled): the circulant inverse of the operator, the normal solver's preconditioner, and
    the sum is g . M g for the gap g whose spectrum it is."""
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    width = spectrum.shape[1]
    zero = energy_scale - energy_scale
    energy = zero
    i, j, di, dj = first_entry(thread, cells, width)
    for k in range(cells.per):
        e = cell_index(thread, cells, k)
        if e < cells.n:
            s = spectrum[i, j]
            ki = i
            kj = j
            if mirror > 0:
                if half_axis == 1 and 2 * i > mirror:
                    ki = mirror - i
                elif half_axis == 0 and 2 * j > mirror:
                    kj = mirror - j
            kzz = influence[ZZ, ki, kj]
            if inverse != 0:
                kzz = wp.where(kzz > kzz - kzz, type(kzz)(1.0) / kzz, kzz - kzz)
            spectrum[i, j] = kzz * s
            weight = parseval_weight(i, j, first_row, half_axis, half_length, energy_scale)
            energy += weight * type(energy_scale)(kzz * wp.dot(s, s))
        i, j = next_entry(i, j, di, dj, width)
    block_add(sums, slot, energy)


@wp.kernel
def spectral_tangential(
    influence: wp.array3d(dtype=Any), spectrum_x: wp.array2d(dtype=Any), spectrum_y: wp.array2d(dtype=Any), per: int
):
    """(u_x, u_y) = K_tt (q_x, q_y) in Fourier space, in place."""
    i, c = wp.tid()
    for j in range(c * per, wp.min((c + 1) * per, spectrum_x.shape[1])):
        qx = spectrum_x[i, j]
        qy = spectrum_y[i, j]
        kxy = influence[XY, i, j]
        spectrum_x[i, j] = influence[XX, i, j] * qx + kxy * qy
        spectrum_y[i, j] = kxy * qx + influence[YY, i, j] * qy


@wp.func
def shear_products(
    influence: wp.array3d(dtype=Any),
    p: Any,
    spectrum_x: wp.array2d(dtype=Any),
    spectrum_y: wp.array2d(dtype=Any),
    i: int,
    j: int,
):
    """At entry (i, j), p the pressure's spectrum there: (u_x, u_y) = K_tp p + K_tt q into
    ``spectrum_x``, ``spectrum_y``; returns the shear's normal displacement K_zt q."""
    qx = spectrum_x[i, j]
    qy = spectrum_y[i, j]
    kxy = influence[XY, i, j]
    kxz = influence[XZ, i, j]
    kyz = influence[YZ, i, j]
    ip = times_i(p)
    spectrum_x[i, j] = kxz * ip + influence[XX, i, j] * qx + kxy * qy
    spectrum_y[i, j] = kyz * ip + kxy * qx + influence[YY, i, j] * qy
    return -times_i(kxz * qx + kyz * qy)


@wp.kernel
def spectral_coupled(
    influence: wp.array3d(dtype=Any),
    spectrum_z: wp.array2d(dtype=Any),
    spectrum_x: wp.array2d(dtype=Any),
    spectrum_y: wp.array2d(dtype=Any),
    per: int,
):
    """(u_z, u_x, u_y) = K (p, q_x, q_y) with the full symmetric 3x3 operator, in place
    (K_xz = i influence[XZ], K_yz = i influence[YZ])."""
    i, c = wp.tid()
    for j in range(c * per, wp.min((c + 1) * per, spectrum_z.shape[1])):
        p = spectrum_z[i, j]
        spectrum_z[i, j] = influence[ZZ, i, j] * p + shear_products(influence, p, spectrum_x, spectrum_y, i, j)


@wp.kernel
def spectral_coupled_shear(
    influence: wp.array3d(dtype=Any),
    spectrum_z: wp.array2d(dtype=Any),
    spectrum_x: wp.array2d(dtype=Any),
    spectrum_y: wp.array2d(dtype=Any),
    per: int,
):
    """The tangential displacement of pressure and shear (u_x, u_y) = K_tp p + K_tt q, and the
    shear's normal displacement u_z = K_zt q (the pressure's own K_zz p left out), in place: the
    full operator of :func:`spectral_coupled` without its ZZ block."""
    i, c = wp.tid()
    for j in range(c * per, wp.min((c + 1) * per, spectrum_z.shape[1])):
        spectrum_z[i, j] = shear_products(influence, spectrum_z[i, j], spectrum_x, spectrum_y, i, j)


@wp.kernel
def spectral_cross_normal(
    influence: wp.array3d(dtype=Any),
    spectrum_z: wp.array2d(dtype=Any),
    spectrum_x: wp.array2d(dtype=Any),
    spectrum_y: wp.array2d(dtype=Any),
    per: int,
):
    """The shear's normal displacement u_z = K_zt q into ``spectrum_z`` (from the shear's
    spectra, left as they are)."""
    i, c = wp.tid()
    for j in range(c * per, wp.min((c + 1) * per, spectrum_z.shape[1])):
        spectrum_z[i, j] = -times_i(influence[XZ, i, j] * spectrum_x[i, j] + influence[YZ, i, j] * spectrum_y[i, j])


@wp.kernel
def spectral_cross_tangential(
    influence: wp.array3d(dtype=Any),
    spectrum_z: wp.array2d(dtype=Any),
    spectrum_x: wp.array2d(dtype=Any),
    spectrum_y: wp.array2d(dtype=Any),
    per: int,
):
    """The pressure's tangential displacement (u_x, u_y) = K_tp p into ``spectrum_x``,
    ``spectrum_y`` (from the pressure's spectrum in ``spectrum_z``, left as it is)."""
    i, c = wp.tid()
    for j in range(c * per, wp.min((c + 1) * per, spectrum_z.shape[1])):
        ip = times_i(spectrum_z[i, j])
        spectrum_x[i, j] = influence[XZ, i, j] * ip
        spectrum_y[i, j] = influence[YZ, i, j] * ip


@wp.kernel
def spectrum_part(spectrum: wp.array2d(dtype=Any), component: int, part: wp.array2d(dtype=Any)):
    """part <- the real (``component`` 0) or imaginary (1) part of ``spectrum`` (set-up)."""
    i, j = wp.tid()
    part[i, j] = spectrum[i, j][component]


for _r, _v in ((wp.float32, wp.vec2f), (wp.float64, wp.vec2d)):
    wp.overload(spectrum_part, {"spectrum": wp.array2d(dtype=_v), "component": int, "part": wp.array2d(dtype=_r)})
    wp.overload(spectral_normal, {"influence": wp.array3d(dtype=_r), "spectrum": wp.array2d(dtype=_v), "per": int})
    wp.overload(
        spectral_normal_energy,
        {"influence": wp.array3d(dtype=_r), "spectrum": wp.array2d(dtype=_v), "half_axis": int, "half_length": int,
         "energy_scale": _r, "inverse": int, "slot": int, "first_row": int, "mirror": int, "cells": Cells,
         "sums": wp.array(dtype=_r)},
    )
    wp.overload(
        spectral_tangential,
        {"influence": wp.array3d(dtype=_r), "spectrum_x": wp.array2d(dtype=_v), "spectrum_y": wp.array2d(dtype=_v),
         "per": int},
    )
    for _k in (spectral_coupled, spectral_coupled_shear, spectral_cross_normal, spectral_cross_tangential):
        wp.overload(
            _k,
            {
                "influence": wp.array3d(dtype=_r),
                "spectrum_z": wp.array2d(dtype=_v),
                "spectrum_x": wp.array2d(dtype=_v),
                "spectrum_y": wp.array2d(dtype=_v),
                "per": int,
            },
        )


# float32 spectra and influence, the sum in float64 (SolverSettings.preconditioner_float32)
wp.overload(
    spectral_normal_energy,
    {"influence": wp.array3d(dtype=wp.float32), "spectrum": wp.array2d(dtype=wp.vec2f), "half_axis": int,
     "half_length": int, "energy_scale": wp.float64, "inverse": int, "slot": int, "first_row": int, "mirror": int,
     "cells": Cells, "sums": wp.array(dtype=wp.float64)},
)

# --- the circulant inverse of the tangential block: the tangential solver's preconditioner ---


@wp.func
def tangential_inverse_block(kxx: Any, kyy: Any, kxy: Any, eigen_floor: Any):
    """(M_xx, M_yy, M_xy): the inverse of the symmetric 2x2 block [[K_xx, K_xy], [K_xy, K_yy]] of
    one wavenumber with its eigenvalues raised to at least ``eigen_floor``: M = P+ / max(l+, f)
    + P- / max(l-, f), P+- the projectors on the eigenvectors of l+- = (K_xx + K_yy) / 2 +-
    sqrt(((K_xx - K_yy) / 2)^2 + K_xy^2). On the padded grids the block is positive but for a
    few entries of the axes near the highest frequency, where the smaller eigenvalue dips to
    about -0.04 (scaled; the middle row and column of the wrap-around layout are zero), against
    0.7-2.2 n elsewhere."""
    half = type(kxx)(0.5)
    zero = half - half
    mean = half * (kxx + kyy)
    diff = half * (kxx - kyy)
    spread_sq = diff * diff + kxy * kxy
    above = mean - eigen_floor  # l- >= floor <=> mean - floor >= spread
    if above >= zero and above * above >= spread_sq:
        # all but a few entries: the plain inverse (one division; no square root, which made the
        # kernel 4 times slower on the CPU)
        inv_det = type(kxx)(1.0) / (kxx * kyy - kxy * kxy)
        block = wp.vector(kyy * inv_det, kxx * inv_det, -kxy * inv_det)
    else:
        spread = wp.sqrt(spread_sq)
        inv_high = type(kxx)(1.0) / wp.max(mean + spread, eigen_floor)
        inv_low = type(kxx)(1.0) / wp.max(mean - spread, eigen_floor)
        # P+ = [[spread + diff, kxy], [kxy, spread - diff]] / (2 spread); any split of I where l+ = l-
        w_xx = half
        w_yy = half
        w_xy = zero
        if spread > zero:
            scale = half / spread
            w_xx = (spread + diff) * scale
            w_yy = (spread - diff) * scale
            w_xy = kxy * scale
        gap = inv_high - inv_low
        block = wp.vector(inv_low + w_xx * gap, inv_low + w_yy * gap, w_xy * gap)
    return block


@wp.kernel
def spectral_tangential_inverse_energy(
    influence: wp.array3d(dtype=Any),
    spectrum_x: wp.array2d(dtype=Any),
    spectrum_y: wp.array2d(dtype=Any),
    half_axis: int,
    half_length: int,
    energy_scale: Any,
    eigen_floor: Any,
    slot: int,
    first_row: int,
    cells: Cells,
    sums: wp.array(dtype=Any),
):
    """(z_x, z_y) = M (g_x, g_y) in Fourier space, in place, with M the circulant inverse of K_tt
    on the padded grid (:func:`tangential_inverse_block`, eigenvalues floored at ``eigen_floor``),
    and sums[slot] += g . M g summed in Fourier space (Parseval, weights as in
    :func:`spectral_normal_energy`). A reducing kernel over the n entries of the spectra, row-major;
    ``first_row``: the spectra's first row (the CPU splits the launch by rows)."""
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    width = spectrum_x.shape[1]
    zero = energy_scale - energy_scale
    energy = zero
    i, j, di, dj = first_entry(thread, cells, width)
    for k in range(cells.per):
        e = cell_index(thread, cells, k)
        if e < cells.n:
            gx = spectrum_x[i, j]
            gy = spectrum_y[i, j]
            m = tangential_inverse_block(influence[XX, i, j], influence[YY, i, j], influence[XY, i, j], eigen_floor)
            zx = m[0] * gx + m[2] * gy
            zy = m[2] * gx + m[1] * gy
            spectrum_x[i, j] = zx
            spectrum_y[i, j] = zy
            weight = parseval_weight(i, j, first_row, half_axis, half_length, energy_scale)
            energy += weight * type(energy_scale)(wp.dot(gx, zx) + wp.dot(gy, zy))
        i, j = next_entry(i, j, di, dj, width)
    block_add(sums, slot, energy)


for _r, _v in ((wp.float32, wp.vec2f), (wp.float64, wp.vec2d)):
    wp.overload(
        spectral_tangential_inverse_energy,
        {"influence": wp.array3d(dtype=_r), "spectrum_x": wp.array2d(dtype=_v), "spectrum_y": wp.array2d(dtype=_v),
         "half_axis": int, "half_length": int, "energy_scale": _r, "eigen_floor": _r, "slot": int, "first_row": int,
         "cells": Cells, "sums": wp.array(dtype=_r)},
    )
# float32 spectra and influence, the sum in float64 (SolverSettings.preconditioner_float32)
wp.overload(
    spectral_tangential_inverse_energy,
    {"influence": wp.array3d(dtype=wp.float32), "spectrum_x": wp.array2d(dtype=wp.vec2f),
     "spectrum_y": wp.array2d(dtype=wp.vec2f), "half_axis": int, "half_length": int, "energy_scale": wp.float64,
     "eigen_floor": wp.float32, "slot": int, "first_row": int, "cells": Cells, "sums": wp.array(dtype=wp.float64)},
)


@wp.kernel
def float32_copy(source: wp.array3d(dtype=wp.float64), target: wp.array3d(dtype=wp.float32)):
    """``target`` <- ``source`` rounded to float32, entry by entry (influence spectra for the
    float32 preconditioner, ``ElasticOperator.inverse_transforms``)."""
    k, i, j = wp.tid()
    target[k, i, j] = wp.float32(source[k, i, j])

"""Kernels of the subsurface stress: influence coefficients at a depth, their spectra combined
into the stress spectra of one body, and the derived fields (von Mises, maximum shear, principal
stresses, hydrostatic) with their maxima.

The orchestration, the formulas' derivation and their references are in ``warpcontact/numerics/stress.py``.
Lengths are in cells (x, y, z divided by the cell size dx); tractions and stresses in the model's
scaled units (divided by E*).

Basis functions. The stress of a uniform traction on a cell is a combination (``stress.py``,
``STRESS_TABLE``) of 14 functions ``corner_term(b, x, y, z)``, each an antiderivative in x and y
of a derivative of Love's potential Omega = z ln(rho + z) - rho; the integral over a cell is their
sum over its four corners with signs (+ - - +). ``basis_corners`` evaluates one of them on the
(n + 1) x (n + 1) corners of the quadrant's cells, once per corner (each is shared by four
cells), and ``basis_quadrant`` sums them for the offsets (0..n-1) x (0..n-1) of the cells,
weighted for the spectral reconstruction of the whole padded kernel from this quadrant (``stress_spectra``): each basis kernel is even or odd in x and
in y (``BASIS_PARITY``), so the quadrant holds all of it.
"""

from typing import Any

import warp as wp

# no adjoints: nothing differentiates these kernels, and compiling them doubles the build
wp.set_module_options({"enable_backward": False})

#: stress components, in the order xx, yy, zz, xy, xz, yz
N_COMPONENTS = wp.constant(6)
#: traction components, in the order p, q_x, q_y
N_LOADS = wp.constant(3)
#: derived fields, in the order von Mises, maximum shear, principal 1 >= 2 >= 3, hydrostatic
N_DERIVED = wp.constant(6)


@wp.func
def corner_term(basis: int, x: wp.float64, y: wp.float64, z: wp.float64) -> wp.float64:
    """Basis function ``basis`` at the corner offset (x, y) and depth z > 0 (cells), float64.

    rho = sqrt(x^2 + y^2 + z^2). The functions (d^2 / dx dy of each is the derivative of Omega
    named in ``stress.BASIS``):
    0 ln(rho + z), 1 -y/(rho + z), 2 -x/(rho + z), 3 y/(rho (rho + z)), 4 x/(rho (rho + z)),
    5 1/rho, 6 atan(y/x) - atan(z y/(x rho)), 7 atan(x/y) - atan(z x/(y rho)),
    8 -x y/(rho (x^2 + z^2)), 9 -x y/(rho (y^2 + z^2)), 10 ln(rho + y), 11 ln(rho + x),
    12 z/(rho (rho + y)), 13 z/(rho (rho + x)).
    Corners lie at half-integer x and y (never 0); the quadrant's corners have x, y >= -1/2, so
    rho + x and rho + y stay away from cancellation.
    """
    rho = wp.sqrt(x * x + y * y + z * z)
    rz = rho + z
    one = wp.float64(1.0)
    v = wp.float64(0.0)
    if basis == 0:
        v = wp.log(rz)
    elif basis == 1:
        v = -y / rz
    elif basis == 2:
        v = -x / rz
    elif basis == 3:
        v = y / (rho * rz)
    elif basis == 4:
        v = x / (rho * rz)
    elif basis == 5:
        v = one / rho
    elif basis == 6:
        v = wp.atan(y / x) - wp.atan(z * y / (x * rho))
    elif basis == 7:
        v = wp.atan(x / y) - wp.atan(z * x / (y * rho))
    elif basis == 8:
        v = -x * y / (rho * (x * x + z * z))
    elif basis == 9:
        v = -x * y / (rho * (y * y + z * z))
    elif basis == 10:
        v = wp.log(rho + y)
    elif basis == 11:
        v = wp.log(rho + x)
    elif basis == 12:
        v = z / (rho * (rho + y))
    else:
        v = z / (rho * (rho + x))
    return v


@wp.kernel
def basis_corners(basis: int, depth: wp.float64, row0: int, corners: wp.array2d(dtype=wp.float64)):
    """corners[i, j] <- ``corner_term`` of basis ``basis`` at the cell corner (x, y) = (j - 1/2,
    i - 1/2) cells and ``depth`` (cells), for the (n + 1) x (n + 1) corners of the quadrant's
    cells; row i = row0 + the thread's row (a part of the rows: ``SubsurfaceStress._rows``)."""
    r, j = wp.tid()
    i = r + row0
    h = wp.float64(0.5)
    corners[i, j] = corner_term(basis, wp.float64(j) - h, wp.float64(i) - h, depth)


@wp.kernel
def basis_quadrant(corners: wp.array2d(dtype=wp.float64), weighted: int, row0: int, out: wp.array2d(dtype=Any)):
    """out[i, j] <- the integral of a basis kernel over the cell at offset (x, y) = (j, i) cells,
    [x - 1/2, x + 1/2] x [y - 1/2, y + 1/2]: its corner terms (``basis_corners``) summed over the
    cell's corners with signs (+ - - +), in float64 and then cast to out's type; row i = row0 +
    the thread's row. With ``weighted``: times w(i) w(j), w(0) = 1 and 2 elsewhere (each offset
    off an axis stands for its mirror images too: ``stress_spectra``)."""
    r, j = wp.tid()
    i = r + row0
    v = corners[i + 1, j + 1] - corners[i, j + 1] - corners[i + 1, j] + corners[i, j]
    if weighted != 0:
        if i > 0:
            v = v * wp.float64(2.0)
        if j > 0:
            v = v * wp.float64(2.0)
    out[i, j] = out.dtype(v)


@wp.func
def times_i(a: Any):
    """i a, for a complex number held as a 2-vector (re, im)."""
    return type(a)(-a[1], a[0])


@wp.func
def basis_kernel(basis_spectra: wp.array2d(dtype=Any), row0: int, slots: wp.array(dtype=int), basis: int, kind: int,
                 rows: int, i: int, j: int, mi: int, mj: int, zero: Any):
    """kappa of basis ``basis`` at entry (i, j): the spectrum of its whole kernel on the padded
    grid, real for ``kind`` 0 and 3 and i kappa for 1 and 2 (``stress_spectra``), from its
    quadrant's spectrum F at (i, j) and Fm at the mirrored (mi, mj), in the stack's spectrum
    ``slots[basis]`` from row ``row0``; ``zero`` where that slot is negative (a basis no term of
    the evaluation uses, its spectrum not made)."""
    slot = slots[basis]
    if slot < 0:
        return zero
    f = basis_spectra[row0 + slot * rows + i, j]
    fm = basis_spectra[row0 + slot * rows + mi, mj]
    half = zero + type(zero)(0.5)
    if kind == 0:
        return half * (f[0] + fm[0])
    elif kind == 1:
        return half * (f[1] + fm[1])
    elif kind == 2:
        return half * (f[1] - fm[1])
    return half * (f[0] - fm[0])


@wp.func
def traction_spectrum(traction_spectra: wp.array2d(dtype=Any), row: int, j: int, scale: Any):
    """scale times the traction spectrum at (row, j); zero, unread, where ``scale`` is zero (a
    load left out: its spectrum not made)."""
    t = traction_spectra.dtype()
    if scale != type(scale)(0.0):
        t = scale * traction_spectra[row, j]
    return t


@wp.func
def body_stress_spectra(
    basis_spectra: wp.array2d(dtype=Any),
    basis_row0: int,
    slots: wp.array(dtype=int),
    traction_spectra: wp.array2d(dtype=Any),
    traction_row0: int,
    two_nu: Any,
    z: Any,
    p_scale: Any,
    qx_scale: Any,
    qy_scale: Any,
    half_axis: int,
    rows: int,
    i: int,
    j: int,
    stress: wp.array2d(dtype=Any),
    stress_row0: int,
):
    """Entry (i, j) of the six stress spectra of one body at one depth (``stress_spectra``): its
    stress table (``warpcontact.numerics.stress.stress_table``, whose docstring gives the same
    sums, B_b the basis kernels) written out term by term, for Poisson's ratio two_nu / 2 and the
    depth ``z`` [cells]; the tractions (p, q_x, q_y) times ``p_scale``, ``qx_scale``,
    ``qy_scale`` (1 / (2 pi), the sphere's shear negated, zero for a load left out, times any
    normalisation of the inverse transforms). The basis spectra from row ``basis_row0`` (basis b
    in slot ``slots[b]``), the tractions' from ``traction_row0``, the results from row
    ``stress_row0`` of their stacks."""
    mi = i
    mj = j
    if half_axis == 1:
        mi = (rows - i) % rows
    else:
        cols = basis_spectra.shape[1]
        mj = (cols - j) % cols
    zero = z - z
    one = zero + type(z)(1.0)
    two = one + one
    # the 14 basis kernels (BASIS_PARITY: 0 even in x and y, 1 odd in x, 2 odd in y, 3 odd in both)
    b0 = basis_kernel(basis_spectra, basis_row0, slots, 0, 3, rows, i, j, mi, mj, zero)
    b1 = basis_kernel(basis_spectra, basis_row0, slots, 1, 1, rows, i, j, mi, mj, zero)
    b2 = basis_kernel(basis_spectra, basis_row0, slots, 2, 2, rows, i, j, mi, mj, zero)
    b3 = basis_kernel(basis_spectra, basis_row0, slots, 3, 1, rows, i, j, mi, mj, zero)
    b4 = basis_kernel(basis_spectra, basis_row0, slots, 4, 2, rows, i, j, mi, mj, zero)
    b5 = basis_kernel(basis_spectra, basis_row0, slots, 5, 3, rows, i, j, mi, mj, zero)
    b6 = basis_kernel(basis_spectra, basis_row0, slots, 6, 0, rows, i, j, mi, mj, zero)
    b7 = basis_kernel(basis_spectra, basis_row0, slots, 7, 0, rows, i, j, mi, mj, zero)
    b8 = basis_kernel(basis_spectra, basis_row0, slots, 8, 0, rows, i, j, mi, mj, zero)
    b9 = basis_kernel(basis_spectra, basis_row0, slots, 9, 0, rows, i, j, mi, mj, zero)
    b10 = basis_kernel(basis_spectra, basis_row0, slots, 10, 1, rows, i, j, mi, mj, zero)
    b11 = basis_kernel(basis_spectra, basis_row0, slots, 11, 2, rows, i, j, mi, mj, zero)
    b12 = basis_kernel(basis_spectra, basis_row0, slots, 12, 1, rows, i, j, mi, mj, zero)
    b13 = basis_kernel(basis_spectra, basis_row0, slots, 13, 2, rows, i, j, mi, mj, zero)
    p = traction_spectrum(traction_spectra, traction_row0 + i, j, p_scale)
    qx = traction_spectrum(traction_spectra, traction_row0 + rows + i, j, qx_scale)
    qy = traction_spectrum(traction_spectra, traction_row0 + 2 * rows + i, j, qy_scale)
    # an odd kernel's spectrum is i kappa: the products with its bases' sums take the factor i
    ip = times_i(p)
    iqx = times_i(qx)
    iqy = times_i(qy)
    # p:   xx = -B6 - 2nu B7 - z B8;  yy = -2nu B6 - B7 - z B9;  zz = -B6 - B7 + z (B8 + B9);
    #      xy = (2nu - 1) B0 - z B5;  xz = -z B12;  yz = -z B13.
    # q_x: xx = -2nu B1 + 2 B10 + z (B3 + B12);  yy = 2nu (B1 + B10) - z B3;  zz = -z B12;
    #      xy = 2nu B2 + B11 - z B4;  xz = -B6 - B7 - z B8;  yz = -z B5.
    # q_y: q_x's with x and y exchanged (bases 1-2, 3-4, 6-7, 8-9, 10-11, 12-13; xx-yy, xz-yz).
    sxx = (-b6 - two_nu * b7 - z * b8) * p + (-two_nu * b1 + two * b10 + z * (b3 + b12)) * iqx \
        + (two_nu * (b2 + b11) - z * b4) * iqy
    syy = (-two_nu * b6 - b7 - z * b9) * p + (two_nu * (b1 + b10) - z * b3) * iqx \
        + (-two_nu * b2 + two * b11 + z * (b4 + b13)) * iqy
    szz = (-b6 - b7 + z * (b8 + b9)) * p - (z * b12) * iqx - (z * b13) * iqy
    sxy = ((two_nu - one) * b0 - z * b5) * p + (two_nu * b2 + b11 - z * b4) * iqx + (two_nu * b1 + b10 - z * b3) * iqy
    sxz = -(z * b12) * ip + (-b6 - b7 - z * b8) * qx - (z * b5) * qy
    syz = -(z * b13) * ip - (z * b5) * qx + (-b7 - b6 - z * b9) * qy
    stress[stress_row0 + i, j] = sxx
    stress[stress_row0 + rows + i, j] = syy
    stress[stress_row0 + 2 * rows + i, j] = szz
    stress[stress_row0 + 3 * rows + i, j] = sxy
    stress[stress_row0 + 4 * rows + i, j] = sxz
    stress[stress_row0 + 5 * rows + i, j] = syz


@wp.kernel
def stress_spectra(
    basis_spectra: wp.array2d(dtype=Any),
    traction_spectra: wp.array2d(dtype=Any),
    slots: wp.array(dtype=int),
    two_nu: Any,
    z: Any,
    p_scale: Any,
    qx_scale: Any,
    qy_scale: Any,
    half_axis: int,
    rows: int,
    row0: int,
    stress: wp.array2d(dtype=Any),
):
    """The spectra of the six stress components of one body at one depth, from the spectra of
    the weighted basis quadrants (``basis_quadrant``) and of the tractions acting on it.

    For basis b with spectrum F of its weighted quadrant, the spectrum of the whole kernel on the
    padded grid (offsets -(n-1)..n-1 each way) is, with Fm = F at (kx, -ky) (the full axis of the
    real transform's layout is y; ``half_axis`` is x's axis in the array):
    even/even 1/2 Re(F + Fm); odd in x 1/2 i Im(F + Fm); odd in y 1/2 i Im(F - Fm);
    odd/odd 1/2 Re(F - Fm) (``basis_kernel``). Then each stress spectrum is the sum over the
    loads l and bases b of the stress table's coefficient times K_b t_l (a DC-FFT product, Liu,
    Wang & Liu 2000), its 44 non-zero terms written out (``body_stress_spectra``: 5-7 times
    faster than a loop over a table of terms, which branched on each). Row i = row0 + the
    thread's row.

    Each stack of spectra is one 2-D array of ``rows``-row blocks, spectrum k in rows k rows ..
    (k + 1) rows - 1: Warp keeps strides as 32-bit ints, and a (k, rows, cols) array's first
    stride, one whole spectrum, passes 2^31 bytes at n = 8192 in complex128."""
    r, j = wp.tid()
    body_stress_spectra(basis_spectra, 0, slots, traction_spectra, 0, two_nu, z, p_scale, qx_scale, qy_scale, half_axis,
                        rows, r + row0, j, stress, 0)


@wp.func
def stress_at(stress: wp.array3d(dtype=Any), i: int, j: int):
    """The six components (xx, yy, zz, xy, xz, yz) of ``stress[0..5, i, j]``."""
    return stress[0, i, j], stress[1, i, j], stress[2, i, j], stress[3, i, j], stress[4, i, j], stress[5, i, j]


@wp.func
def principal_stresses(sxx: Any, syy: Any, szz: Any, sxy: Any, sxz: Any, syz: Any):
    """(s1, s2, s3), s1 >= s2 >= s3: the eigenvalues of the symmetric stress tensor by Warp's
    ``eig3`` (Jacobi rotations: accurate where two coincide, as on the Hertz axis, where the
    cubic's trigonometric solution loses half the digits), sorted."""
    vectors, d = wp.eig3(wp.matrix(sxx, sxy, sxz, sxy, syy, syz, sxz, syz, szz, shape=(3, 3)))
    hi = wp.max(d[0], wp.max(d[1], d[2]))
    lo = wp.min(d[0], wp.min(d[1], d[2]))
    return wp.vector(hi, d[0] + d[1] + d[2] - hi - lo, lo)


@wp.func
def von_mises(sxx: Any, syy: Any, szz: Any, sxy: Any, sxz: Any, syz: Any):
    """sqrt(3 J2) of the stress (xx, yy, zz, xy, xz, yz)."""
    normal = (sxx - syy) * (sxx - syy) + (syy - szz) * (syy - szz) + (szz - sxx) * (szz - sxx)
    j2 = type(sxx)(0.5) * normal * (type(sxx)(1.0) / type(sxx)(3.0)) + sxy * sxy + sxz * sxz + syz * syz
    return wp.sqrt(type(sxx)(3.0) * j2)


@wp.kernel
def derived_fields(stress: wp.array3d(dtype=Any), derived: wp.array3d(dtype=Any)):
    """derived[:, i, j] <- von Mises sqrt(3 J2), maximum shear (s1 - s3) / 2, principal stresses
    s1 >= s2 >= s3, hydrostatic (sxx + syy + szz) / 3, from stress[0..5, i, j] (xx, yy, zz, xy,
    xz, yz)."""
    i, j = wp.tid()
    sxx, syy, szz, sxy, sxz, syz = stress_at(stress, i, j)
    half = type(sxx)(0.5)
    third = type(sxx)(1.0) / type(sxx)(3.0)
    p = principal_stresses(sxx, syy, szz, sxy, sxz, syz)
    derived[0, i, j] = von_mises(sxx, syy, szz, sxy, sxz, syz)
    derived[1, i, j] = half * (p[0] - p[2])
    derived[2, i, j] = p[0]
    derived[3, i, j] = p[1]
    derived[4, i, j] = p[2]
    derived[5, i, j] = (sxx + syy + szz) * third


@wp.kernel
def von_mises_field(stress: wp.array3d(dtype=Any), derived: wp.array3d(dtype=Any)):
    """derived[0, i, j] <- von Mises sqrt(3 J2) of stress[0..5, i, j] (xx, yy, zz, xy, xz, yz):
    ``derived_fields``' first field alone (no principal stresses), for the yield check."""
    i, j = wp.tid()
    sxx, syy, szz, sxy, sxz, syz = stress_at(stress, i, j)
    derived[0, i, j] = von_mises(sxx, syy, szz, sxy, sxz, syz)


@wp.kernel
def row_maxima(fields: wp.array3d(dtype=Any), field: int, values: wp.array(dtype=Any),
               columns: wp.array(dtype=int)):
    """values[i], columns[i] <- the largest entry of row i of fields[field] and its column (the
    first where several tie): one thread per row; the host takes the largest of the rows."""
    i = wp.tid()
    best = fields[field, i, 0]
    col = int(0)
    for j in range(1, fields.shape[2]):
        v = fields[field, i, j]
        if v > best:
            best = v
            col = j
    values[i] = best
    columns[i] = col


@wp.kernel
def take_line(fields: wp.array3d(dtype=Any), index: int, along_x: int, out: wp.array2d(dtype=Any)):
    """out[f, k] <- fields[f] along the row ``index`` (``along_x`` = 1: fields[f, index, k]) or the
    column ``index`` (0: fields[f, k, index]): a section through the grid, for every field f."""
    f, k = wp.tid()
    if along_x != 0:
        out[f, k] = fields[f, index, k]
    else:
        out[f, k] = fields[f, k, index]


# ---------------------------------------------------------------------------------------------
# Many planes at once (``warpcontact.numerics.stress_batch``): a plane is one depth below one
# case's surface; the stacks hold each plane's spectra one above the other, as above.


@wp.kernel
def plane_basis_corners(depths: wp.array(dtype=wp.float64), bases: wp.array(dtype=int),
                        corners: wp.array3d(dtype=wp.float64)):
    """corners[p B + s, i, j] <- ``basis_corners`` of basis ``bases[s]`` at depth ``depths[p]``
    (cells), B = len(bases): the bases a chunk of planes uses, at each of its distinct depths."""
    k, i, j = wp.tid()
    used = bases.shape[0]
    p = k // used
    h = wp.float64(0.5)
    corners[k, i, j] = corner_term(bases[k - p * used], wp.float64(j) - h, wp.float64(i) - h, depths[p])


@wp.kernel
def plane_basis_quadrants(corners: wp.array3d(dtype=wp.float64), out: wp.array3d(dtype=Any)):
    """out[k] <- ``basis_quadrant`` (weighted) of corners[k]."""
    k, i, j = wp.tid()
    v = corners[k, i + 1, j + 1] - corners[k, i, j + 1] - corners[k, i + 1, j] + corners[k, i, j]
    if i > 0:
        v = v * wp.float64(2.0)
    if j > 0:
        v = v * wp.float64(2.0)
    out[k, i, j] = out.dtype(v)


@wp.kernel
def plane_stress_spectra(
    basis_spectra: wp.array2d(dtype=Any),
    traction_spectra: wp.array2d(dtype=Any),
    plane_case: wp.array(dtype=int),
    plane_depth: wp.array(dtype=int),
    bodies: int,
    used: int,
    slots: wp.array(dtype=int),
    coefficients: wp.array2d(dtype=Any),
    half_axis: int,
    rows: int,
    stress: wp.array2d(dtype=Any),
):
    """``stress_spectra`` of every body at every plane: entry q = p ``bodies`` + body (plane p,
    its case ``plane_case[p]``, its depth the ``plane_depth[p]``-th of the chunk's distinct ones)
    combines its depth's ``used`` basis spectra (basis b in slot ``slots[b]``) with the case's
    three traction spectra by ``coefficients[q]`` = (2 nu, z, p_scale, qx_scale, qy_scale)
    (``body_stress_spectra``), into the six stress spectra from row 6 q ``rows``."""
    q, i, j = wp.tid()
    p = q // bodies
    body_stress_spectra(basis_spectra, plane_depth[p] * used * rows, slots, traction_spectra,
                        plane_case[p] * N_LOADS * rows, coefficients[q, 0], coefficients[q, 1], coefficients[q, 2],
                        coefficients[q, 3], coefficients[q, 4], half_axis, rows, i, j, stress, q * N_COMPONENTS * rows)


@wp.kernel
def plane_von_mises_rows(stress: wp.array3d(dtype=Any), values: wp.array2d(dtype=Any),
                         columns: wp.array2d(dtype=int)):
    """values[q, i], columns[q, i] <- the largest von Mises stress along row i of entry q (its six
    components stress[6 q .. 6 q + 5]) and its column (the first where several tie): one thread
    per row; the host takes the largest of each entry's rows."""
    q, i = wp.tid()
    c = N_COMPONENTS * q
    best = von_mises(stress[c, i, 0], stress[c + 1, i, 0], stress[c + 2, i, 0], stress[c + 3, i, 0],
                     stress[c + 4, i, 0], stress[c + 5, i, 0])
    col = int(0)
    for j in range(1, stress.shape[2]):
        v = von_mises(stress[c, i, j], stress[c + 1, i, j], stress[c + 2, i, j], stress[c + 3, i, j],
                      stress[c + 4, i, j], stress[c + 5, i, j])
        if v > best:
            best = v
            col = j
    values[q, i] = best
    columns[q, i] = col


for _r, _v in ((wp.float32, wp.vec2f), (wp.float64, wp.vec2d)):
    wp.overload(basis_quadrant, {"corners": wp.array2d(dtype=wp.float64), "weighted": int, "row0": int,
                                 "out": wp.array2d(dtype=_r)})
    wp.overload(stress_spectra, {"basis_spectra": wp.array2d(dtype=_v), "traction_spectra": wp.array2d(dtype=_v),
                                 "slots": wp.array(dtype=int), "two_nu": _r, "z": _r, "p_scale": _r, "qx_scale": _r,
                                 "qy_scale": _r, "half_axis": int, "rows": int, "row0": int,
                                 "stress": wp.array2d(dtype=_v)})
    wp.overload(derived_fields, {"stress": wp.array3d(dtype=_r), "derived": wp.array3d(dtype=_r)})
    wp.overload(von_mises_field, {"stress": wp.array3d(dtype=_r), "derived": wp.array3d(dtype=_r)})
    wp.overload(row_maxima, {"fields": wp.array3d(dtype=_r), "field": int, "values": wp.array(dtype=_r),
                             "columns": wp.array(dtype=int)})
    wp.overload(take_line, {"fields": wp.array3d(dtype=_r), "index": int, "along_x": int,
                            "out": wp.array2d(dtype=_r)})
    wp.overload(plane_basis_quadrants, {"corners": wp.array3d(dtype=wp.float64), "out": wp.array3d(dtype=_r)})
    wp.overload(plane_stress_spectra, {"basis_spectra": wp.array2d(dtype=_v), "traction_spectra": wp.array2d(dtype=_v),
                                       "plane_case": wp.array(dtype=int), "plane_depth": wp.array(dtype=int),
                                       "bodies": int, "used": int, "slots": wp.array(dtype=int),
                                       "coefficients": wp.array2d(dtype=_r), "half_axis": int, "rows": int,
                                       "stress": wp.array2d(dtype=_v)})
    wp.overload(plane_von_mises_rows, {"stress": wp.array3d(dtype=_r), "values": wp.array2d(dtype=_r),
                                       "columns": wp.array2d(dtype=int)})

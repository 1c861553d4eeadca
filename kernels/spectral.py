"""Products of traction spectra with the influence spectra of the coupled elastic operator.

The spectra of the six distinct influence kernels are stored in one array ``influence`` of shape
(6, sy, sx), complex numbers as 2-vectors, in the order
``ZZ, XX, YY, XY, XZ, YZ`` (``XZ``: u_x from p). By reciprocity the "normal from shear" kernels
are the negatives of ``XZ`` and ``YZ`` (MODEL.md section 2).
"""

from typing import Any

import warp as wp

ZZ = wp.constant(0)
XX = wp.constant(1)
YY = wp.constant(2)
XY = wp.constant(3)
XZ = wp.constant(4)
YZ = wp.constant(5)


@wp.func
def cmul(a: Any, b: Any):
    """Complex product of two complex numbers held as 2-vectors (re, im)."""
    return type(a)(a[0] * b[0] - a[1] * b[1], a[0] * b[1] + a[1] * b[0])


@wp.kernel
def spectral_normal(influence: wp.array3d(dtype=Any), spectrum: wp.array2d(dtype=Any)):
    """u_z = K_zz p in Fourier space, in place on ``spectrum``."""
    i, j = wp.tid()
    spectrum[i, j] = cmul(influence[ZZ, i, j], spectrum[i, j])


@wp.kernel
def spectral_tangential(
    influence: wp.array3d(dtype=Any), spectrum_x: wp.array2d(dtype=Any), spectrum_y: wp.array2d(dtype=Any)
):
    """(u_x, u_y) = K_tt (q_x, q_y) in Fourier space, in place."""
    i, j = wp.tid()
    qx = spectrum_x[i, j]
    qy = spectrum_y[i, j]
    kxy = influence[XY, i, j]
    spectrum_x[i, j] = cmul(influence[XX, i, j], qx) + cmul(kxy, qy)
    spectrum_y[i, j] = cmul(kxy, qx) + cmul(influence[YY, i, j], qy)


@wp.kernel
def spectral_coupled(
    influence: wp.array3d(dtype=Any),
    spectrum_z: wp.array2d(dtype=Any),
    spectrum_x: wp.array2d(dtype=Any),
    spectrum_y: wp.array2d(dtype=Any),
):
    """(u_z, u_x, u_y) = K (p, q_x, q_y) with the full symmetric 3x3 operator, in place."""
    i, j = wp.tid()
    p = spectrum_z[i, j]
    qx = spectrum_x[i, j]
    qy = spectrum_y[i, j]
    kxy = influence[XY, i, j]
    kxz = influence[XZ, i, j]
    kyz = influence[YZ, i, j]
    spectrum_z[i, j] = cmul(influence[ZZ, i, j], p) - cmul(kxz, qx) - cmul(kyz, qy)
    spectrum_x[i, j] = cmul(kxz, p) + cmul(influence[XX, i, j], qx) + cmul(kxy, qy)
    spectrum_y[i, j] = cmul(kyz, p) + cmul(kxy, qx) + cmul(influence[YY, i, j], qy)


@wp.kernel
def spectral_cross(
    influence: wp.array3d(dtype=Any),
    spectrum_z: wp.array2d(dtype=Any),
    spectrum_x: wp.array2d(dtype=Any),
    spectrum_y: wp.array2d(dtype=Any),
):
    """Only the normal-tangential coupling: u_z = K_zt q, (u_x, u_y) = K_tp p, in place."""
    i, j = wp.tid()
    p = spectrum_z[i, j]
    kxz = influence[XZ, i, j]
    kyz = influence[YZ, i, j]
    spectrum_z[i, j] = -cmul(kxz, spectrum_x[i, j]) - cmul(kyz, spectrum_y[i, j])
    spectrum_x[i, j] = cmul(kxz, p)
    spectrum_y[i, j] = cmul(kyz, p)


for _v in (wp.vec2f, wp.vec2d):
    wp.overload(spectral_normal, {"influence": wp.array3d(dtype=_v), "spectrum": wp.array2d(dtype=_v)})
    wp.overload(
        spectral_tangential,
        {"influence": wp.array3d(dtype=_v), "spectrum_x": wp.array2d(dtype=_v), "spectrum_y": wp.array2d(dtype=_v)},
    )
    for _k in (spectral_coupled, spectral_cross):
        wp.overload(
            _k,
            {
                "influence": wp.array3d(dtype=_v),
                "spectrum_z": wp.array2d(dtype=_v),
                "spectrum_x": wp.array2d(dtype=_v),
                "spectrum_y": wp.array2d(dtype=_v),
            },
        )

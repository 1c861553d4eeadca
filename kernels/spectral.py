"""Products of traction spectra with the influence spectra of the coupled elastic operator.

The spectra of the six distinct influence kernels are stored in one array ``influence`` of shape
(6, sy, sx), complex numbers as 2-vectors, in the order
``ZZ, XX, YY, XY, XZ, YZ`` (``XZ``: u_x from p). By reciprocity the "normal from shear" kernels
are the negatives of ``XZ`` and ``YZ`` (MODEL.md section 2).

Each kernel is launched over (rows, chunks) and thread (i, c) does the entries j of row i from
``c * per`` to ``(c + 1) * per``: on CUDA one entry per thread (chunks = columns, per = 1); on the
CPU, where Warp runs the threads one after another, a whole row per thread (chunks = 1, per =
columns), which halves the per-entry overhead (n = 512: 2.57 -> 1.24 ms for the normal product).
"""

from typing import Any

import warp as wp

# no adjoints: nothing differentiates these kernels, and compiling them doubles the build
wp.set_module_options({"enable_backward": False})

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
def spectral_normal(influence: wp.array3d(dtype=Any), spectrum: wp.array2d(dtype=Any), per: int):
    """u_z = K_zz p in Fourier space, in place on ``spectrum``."""
    i, c = wp.tid()
    for j in range(c * per, wp.min((c + 1) * per, spectrum.shape[1])):
        spectrum[i, j] = cmul(influence[ZZ, i, j], spectrum[i, j])


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
        spectrum_x[i, j] = cmul(influence[XX, i, j], qx) + cmul(kxy, qy)
        spectrum_y[i, j] = cmul(kxy, qx) + cmul(influence[YY, i, j], qy)


@wp.kernel
def spectral_coupled(
    influence: wp.array3d(dtype=Any),
    spectrum_z: wp.array2d(dtype=Any),
    spectrum_x: wp.array2d(dtype=Any),
    spectrum_y: wp.array2d(dtype=Any),
    per: int,
):
    """(u_z, u_x, u_y) = K (p, q_x, q_y) with the full symmetric 3x3 operator, in place."""
    i, c = wp.tid()
    for j in range(c * per, wp.min((c + 1) * per, spectrum_z.shape[1])):
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
    per: int,
):
    """Only the normal-tangential coupling: u_z = K_zt q, (u_x, u_y) = K_tp p, in place."""
    i, c = wp.tid()
    for j in range(c * per, wp.min((c + 1) * per, spectrum_z.shape[1])):
        p = spectrum_z[i, j]
        kxz = influence[XZ, i, j]
        kyz = influence[YZ, i, j]
        spectrum_z[i, j] = -cmul(kxz, spectrum_x[i, j]) - cmul(kyz, spectrum_y[i, j])
        spectrum_x[i, j] = cmul(kxz, p)
        spectrum_y[i, j] = cmul(kyz, p)


for _v in (wp.vec2f, wp.vec2d):
    wp.overload(spectral_normal, {"influence": wp.array3d(dtype=_v), "spectrum": wp.array2d(dtype=_v), "per": int})
    wp.overload(
        spectral_tangential,
        {"influence": wp.array3d(dtype=_v), "spectrum_x": wp.array2d(dtype=_v), "spectrum_y": wp.array2d(dtype=_v),
         "per": int},
    )
    for _k in (spectral_coupled, spectral_cross):
        wp.overload(
            _k,
            {
                "influence": wp.array3d(dtype=_v),
                "spectrum_z": wp.array2d(dtype=_v),
                "spectrum_x": wp.array2d(dtype=_v),
                "spectrum_y": wp.array2d(dtype=_v),
                "per": int,
            },
        )

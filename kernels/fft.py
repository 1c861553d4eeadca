"""Row transforms of the dependency-free DC-FFT backend, on Warp's ``tile_fft`` / ``tile_ifft``.

``tile_fft`` transforms the last axis of a tile whose length is a compile-time constant, so the
kernels are made per transform length and float type by :func:`row_fft_kernels`, which caches them;
the four kernels of one (length, dtype) share one Warp module and compile together, once per
device. Each kernel is launched with ``wp.launch_tiled`` over rows, one tile row per block.

A row is read with ``tile_load`` at offset (row, 0): entries past the end of the source row are
read as zeros (that is the zero padding), and ``tile_store`` drops entries past the end of the
destination row (that is the truncation). Sources and destinations may be transposed views, which
is how the backend turns rows into columns without a transpose kernel. Complex numbers are
2-vectors (re, im); transforms are unnormalised, X_k = sum_n x_n exp(-2 pi i k n / L).

No ``from __future__ import annotations`` here: the kernel factories annotate their arguments with
the dtype chosen at run time, which needs the annotations evaluated when the kernel is defined.
"""

import warp as wp


# no adjoints: nothing differentiates these kernels, and compiling them doubles the build
wp.set_module_options({"enable_backward": False})


@wp.func
def complex_from_real_f64(x: wp.float64) -> wp.vec2d:
    return wp.vec2d(x, wp.float64(0.0))


@wp.func
def complex_from_real_f32(x: wp.float32) -> wp.vec2f:
    return wp.vec2f(x, wp.float32(0.0))


@wp.func
def real_part_f64(z: wp.vec2d) -> wp.float64:
    return z[0]


@wp.func
def real_part_f32(z: wp.vec2f) -> wp.float32:
    return z[0]


#: (length, dtype) -> dict of the four row kernels; see :func:`row_fft_kernels`.
_ROW_FFT_KERNELS = {}


def row_fft_kernels(length: int, dtype) -> dict:
    """The four row-transform kernels for rows of ``length`` complex entries, made once and cached.

    Args:
        length: transform length L (a compile-time tile size).
        dtype: ``wp.float32`` or ``wp.float64``; complex numbers are ``wp.vec2f`` / ``wp.vec2d``.

    Returns:
        dict with the kernels

        ``forward_real(field, rows_q)``
            row i of the real ``field`` (shorter than L: zero-padded) -> its DFT, stored into row i
            of ``rows_q`` (narrower than L: truncated).
        ``forward(rows_r, rows_q)``
            complex row i of ``rows_r`` (zero-padded) -> its DFT in row i of ``rows_q``.
        ``inverse_scaled(rows_q, row_scale, rows_r)``
            unnormalised inverse DFT of complex row i of ``rows_q``, times ``row_scale[i]``, into
            row i of ``rows_r`` (truncated).
        ``inverse_real(rows_q, field)``
            real part of the unnormalised inverse DFT of complex row i of ``rows_q`` (zero-padded)
            into row i of the real ``field`` (truncated).
    """
    key = (int(length), dtype)
    kernels = _ROW_FFT_KERNELS.get(key)
    if kernels is not None:
        return kernels

    L = int(length)
    if dtype == wp.float64:
        real, cplx = wp.float64, wp.vec2d
        to_complex, real_part = complex_from_real_f64, real_part_f64
    elif dtype == wp.float32:
        real, cplx = wp.float32, wp.vec2f
        to_complex, real_part = complex_from_real_f32, real_part_f32
    else:
        raise TypeError(f"row_fft_kernels: dtype must be wp.float32 or wp.float64, got {dtype!r}")

    module = wp.get_module(f"warpcontact_fft_L{L}_{dtype.__name__}")

    def forward_real(field: wp.array2d(dtype=real), rows_q: wp.array2d(dtype=cplx)):
        i = wp.tid()
        x = wp.tile_load(field, shape=(1, L), offset=(i, 0))
        z = wp.tile_map(to_complex, x)
        wp.tile_fft(z)
        wp.tile_store(rows_q, z, offset=(i, 0))

    def forward(rows_r: wp.array2d(dtype=cplx), rows_q: wp.array2d(dtype=cplx)):
        i = wp.tid()
        z = wp.tile_load(rows_r, shape=(1, L), offset=(i, 0))
        wp.tile_fft(z)
        wp.tile_store(rows_q, z, offset=(i, 0))

    def inverse_scaled(rows_q: wp.array2d(dtype=cplx), row_scale: wp.array(dtype=real), rows_r: wp.array2d(dtype=cplx)):
        i = wp.tid()
        z = wp.tile_load(rows_q, shape=(1, L), offset=(i, 0))
        wp.tile_ifft(z)
        wp.tile_store(rows_r, z * row_scale[i], offset=(i, 0))

    def inverse_real(rows_q: wp.array2d(dtype=cplx), field: wp.array2d(dtype=real)):
        i = wp.tid()
        z = wp.tile_load(rows_q, shape=(1, L), offset=(i, 0))
        wp.tile_ifft(z)
        wp.tile_store(field, wp.tile_map(real_part, z), offset=(i, 0))

    kernels = {
        f.__name__: wp.kernel(f, module=module, enable_backward=False)
        for f in (forward_real, forward, inverse_scaled, inverse_real)
    }
    _ROW_FFT_KERNELS[key] = kernels
    return kernels


# --- zero padding and truncation around library transforms (FFTBackend.forward / inverse) ---

from typing import Any  # noqa: E402

from .overloads import mixed_float_overloads, register_float_overloads  # noqa: E402


@wp.kernel
def pad_field(field: wp.array2d(dtype=Any), per: int, padded: wp.array2d(dtype=Any)):
    """padded[i, j] <- field[i, j] on the (ny, nx) corner of a backend's ``padded_input``, whose
    other entries are zero and never written; rounded to the backend's float type (a float32
    backend beside float64 fields: ``SolverSettings.response_float32``). Launched over (rows,
    chunks) (``LaunchCache.launch_rows``: on the CPU a row per thread, split over the threads)."""
    i, c = wp.tid()
    for j in range(c * per, wp.min((c + 1) * per, field.shape[1])):
        padded[i, j] = padded.dtype(field[i, j])


@wp.kernel
def crop_field(padded: wp.array2d(dtype=Any), scale: Any, per: int, field: wp.array2d(dtype=Any)):
    """field[i, j] <- scale * padded[i, j]: the kept (ny, nx) corner of an unnormalised inverse
    transform, with its 1 / (4 nx ny), in the field's float type. Launched as ``pad_field``."""
    i, c = wp.tid()
    for j in range(c * per, wp.min((c + 1) * per, field.shape[1])):
        field[i, j] = field.dtype(padded[i, j] * scale)


for _k in (pad_field, crop_field):
    register_float_overloads(_k)
# a float32 backend's buffers beside float64 fields (``SolverSettings.response_float32``)
mixed_float_overloads(pad_field, ("padded",))
mixed_float_overloads(crop_field, ("padded", "scale"))

"""FFT backends behind one interface (see :class:`FFTBackend`).

========  ==========  =====================================================================
name      devices     what
========  ==========  =====================================================================
scipy     cpu         scipy.fft, real-to-complex, worker threads (default on CPU)
cupy      cuda        cuFFT through CuPy, zero-copy via DLPack (default on CUDA if installed)
warp      cpu, cuda   Warp ``tile_fft``: no dependency beyond Warp (default on CUDA without CuPy)
========  ==========  =====================================================================
"""

from __future__ import annotations

import warp as wp

from ..errors import InputError
from .base import FFTBackend

BACKENDS = ("auto", "scipy", "cupy", "warp")


def available_backends(device) -> list[str]:
    """Names of the backends that can run on ``device`` here."""
    device = wp.get_device(device)
    if device.is_cpu:
        return ["scipy", "warp"]
    from . import cupy_backend

    return (["cupy"] if cupy_backend.available() else []) + ["warp"]


def make_fft(name: str, ny: int, nx: int, device, dtype) -> FFTBackend:
    """The FFT backend ``name`` ("auto" picks the fastest available) for an (ny, nx) grid."""
    device = wp.get_device(device)
    if name not in BACKENDS:
        raise InputError("solver.fft", f"unknown FFT backend {name!r}; choose one of {', '.join(BACKENDS)}")
    if name == "auto":
        name = available_backends(device)[0]
    if name not in available_backends(device):
        raise InputError(
            "solver.fft", f"backend {name!r} is not available on {device}; available: {available_backends(device)}"
        )
    if name == "scipy":
        from .scipy_backend import ScipyFFT

        return ScipyFFT(ny, nx, device, dtype)
    if name == "cupy":
        from .cupy_backend import CupyFFT

        return CupyFFT(ny, nx, device, dtype)
    from .warp_backend import WarpTileFFT

    return WarpTileFFT(ny, nx, device, dtype)


__all__ = ["FFTBackend", "BACKENDS", "available_backends", "make_fft"]

"""FFT backends behind one interface (see :class:`FFTBackend`).

========  ==========  =====================================================================
name      devices     what
========  ==========  =====================================================================
fftw      cpu         FFTW through pyFFTW (optional extra), the scipy layout (default on CPU if installed)
scipy     cpu         scipy.fft, real-to-complex, worker threads (default on CPU without pyFFTW)
cupy      cuda        cuFFT through CuPy, zero-copy via DLPack (default on CUDA if installed)
warp      cpu, cuda   Warp ``tile_fft``: no dependency beyond Warp (default on CUDA without CuPy)
========  ==========  =====================================================================
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..errors import InputError
from .names import BACKENDS, DEVICE_KIND

if TYPE_CHECKING:
    from .base import FFTBackend

#: what installs the backends that are optional extras
OPTIONAL = {"fftw": "pyFFTW is not installed: pip install 'warpcontact[fftw]'",
            "cupy": "CuPy is not installed: pip install 'warpcontact[gpu]'"}


def available_backends(device) -> list[str]:
    """Names of the backends that can run on ``device`` here."""
    import warp as wp

    device = wp.get_device(device)
    if device.is_cpu:
        from . import fftw_backend

        return (["fftw"] if fftw_backend.available() else []) + ["scipy", "warp"]
    from . import cupy_backend

    return (["cupy"] if cupy_backend.available() else []) + ["warp"]


def make_fft(name: str, ny: int, nx: int, device, dtype) -> FFTBackend:
    """The FFT backend ``name`` ("auto" picks the fastest available) for an (ny, nx) grid."""
    import warp as wp

    device = wp.get_device(device)
    if name not in BACKENDS:
        raise InputError("solver.fft", f"unknown FFT backend {name!r}; choose one of {', '.join(BACKENDS)}")
    if name == "auto":
        name = available_backends(device)[0]
    if name not in available_backends(device):
        kind = "cpu" if device.is_cpu else "cuda"
        hint = f" ({OPTIONAL[name]})" if DEVICE_KIND.get(name) == kind and name in OPTIONAL else ""
        raise InputError(
            "solver.fft",
            f"backend {name!r} is not available on {device}{hint}; available: {available_backends(device)}",
        )
    if name == "fftw":
        from .fftw_backend import FFTWBackend

        return FFTWBackend(ny, nx, device, dtype)
    if name == "scipy":
        from .scipy_backend import ScipyFFT

        return ScipyFFT(ny, nx, device, dtype)
    if name == "cupy":
        from .cupy_backend import CupyFFT

        return CupyFFT(ny, nx, device, dtype)
    from .warp_backend import WarpTileFFT

    return WarpTileFFT(ny, nx, device, dtype)


def make_periodic_fft(name: str, ny: int, nx: int, device, dtype) -> "FFTBackend | None":
    """The transforms of the (ny, nx) grid itself, periodic, with no zero padding
    (``FFTBackend.periodic``), of the backend ``name`` (a backend made by :func:`make_fft`: its
    ``name``), on which the preconditioners' circulants run (``ElasticOperator.inverse_transforms``);
    None for a backend without them (the ``warp`` backend, whose tile transforms are of the padded
    lengths)."""
    import warp as wp

    device = wp.get_device(device)
    if name == "fftw":
        from .fftw_backend import PeriodicFFTW

        return PeriodicFFTW(ny, nx, device, dtype)
    if name == "scipy":
        from .scipy_backend import PeriodicScipyFFT

        return PeriodicScipyFFT(ny, nx, device, dtype)
    if name == "cupy":
        from .cupy_backend import CupyFFT

        return CupyFFT(ny, nx, device, dtype, periodic=True)
    return None


def __getattr__(name: str):
    """``FFTBackend`` on first use (PEP 562): the backend names (.names) load without Warp."""
    if name == "FFTBackend":
        from .base import FFTBackend

        return FFTBackend
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["FFTBackend", "BACKENDS", "DEVICE_KIND", "available_backends", "make_fft"]

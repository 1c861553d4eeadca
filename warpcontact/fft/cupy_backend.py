"""cuFFT on CUDA devices, through the library that CuPy ships: the default backend there.

The transforms are cuFFT 2-D plans (real-to-complex forward, complex-to-real inverse) of the
(2 ny, 2 nx) padded grid, made once per grid and called through ``ctypes`` on Warp's stream, into
buffers allocated once as Warp arrays. Nothing is allocated and no stream is synchronised per
transform, so the solvers' iterations, transforms included, can be captured in CUDA graphs.
CuPy is used only to load its cuFFT (``available()`` and ``_cufft_library``); CuPy's own FFT
functions allocate their outputs and padded copies on every call and cannot be captured.

Per transform:

- forward: ``pad_field`` copies the (ny, nx) field into the corner of a (2 ny, 2 nx) buffer whose
  other entries stay zero (nothing else writes there), then D2Z (R2C in float32) into the
  spectrum, shape (2 ny, nx + 1), the layout of ``numpy.fft.rfft2`` of the padded field.
- inverse: Z2D (C2R) of the spectrum (overwritten, as cuFFT's complex-to-real transforms do) into
  a second (2 ny, 2 nx) buffer, then ``crop_field`` keeps its (ny, nx) corner times 1 / (4 nx ny).

Memory: the two padded buffers (four spectra's worth of reals, about two spectra) and one work
area shared by both plans.
"""

from __future__ import annotations

import ctypes
import ctypes.util

import numpy as np
import warp as wp

from ..kernels.fft import crop_field, pad_field
from .base import FFTBackend

# cufftType
_R2C, _C2R, _D2Z, _Z2D = 0x2A, 0x2C, 0x6A, 0x6C
_LIB = None


def available() -> bool:
    try:
        import cupy  # noqa: F401

        return cupy.cuda.runtime.getDeviceCount() > 0
    except Exception:
        return False


def _cufft_library():
    """The cuFFT shared library CuPy loads (found in this process's memory map after a tiny CuPy
    transform), else the system's; loaded once."""
    global _LIB
    if _LIB is not None:
        return _LIB
    import cupy

    cupy.fft.rfft(cupy.zeros(8))  # makes CuPy load its cuFFT
    path = None
    try:
        with open("/proc/self/maps") as fh:
            for line in fh:
                name = line.rsplit(None, 1)[-1] if "/" in line else ""
                if name.rsplit("/", 1)[-1].startswith("libcufft.so"):
                    path = name
                    break
    except OSError:
        pass
    path = path or ctypes.util.find_library("cufft")
    if path is None:
        raise RuntimeError("fft: cupy backend: the cuFFT library was not found (is CuPy installed for this CUDA?)")
    lib = ctypes.CDLL(path)
    handle_p, size_p = ctypes.POINTER(ctypes.c_int), ctypes.POINTER(ctypes.c_size_t)
    lib.cufftCreate.argtypes = [handle_p]
    lib.cufftSetAutoAllocation.argtypes = [ctypes.c_int, ctypes.c_int]
    lib.cufftMakePlan2d.argtypes = [ctypes.c_int, ctypes.c_int, ctypes.c_int, ctypes.c_int, size_p]
    lib.cufftSetWorkArea.argtypes = [ctypes.c_int, ctypes.c_void_p]
    lib.cufftSetStream.argtypes = [ctypes.c_int, ctypes.c_void_p]
    lib.cufftDestroy.argtypes = [ctypes.c_int]
    for name in ("cufftExecD2Z", "cufftExecZ2D", "cufftExecR2C", "cufftExecC2R"):
        getattr(lib, name).argtypes = [ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p]
    _LIB = lib
    return lib


def _check(result: int, what: str):
    if result != 0:
        raise RuntimeError(f"fft: cupy backend: {what} failed with cufftResult {result}")


class CupyFFT(FFTBackend):
    name = "cupy"

    def __init__(self, ny, nx, device, dtype):
        super().__init__(ny, nx, device, dtype)
        if not self.device.is_cuda:
            raise ValueError(f"fft: the cupy backend runs on CUDA devices only, not on {self.device}")
        self._lib = lib = _cufft_library()
        double = dtype == wp.float64
        self._exec_forward = lib.cufftExecD2Z if double else lib.cufftExecR2C
        self._exec_inverse = lib.cufftExecZ2D if double else lib.cufftExecC2R
        self._scale = dtype(1.0 / (4.0 * self.nx * self.ny))  # typed: a kernel argument
        with wp.ScopedDevice(self.device):
            self._padded_in = wp.zeros(self.padded_shape, dtype=dtype)  # zero outside the field's corner, always
            self._padded_out = wp.zeros(self.padded_shape, dtype=dtype)
            self._plans = []
            sizes = []
            for kind in ((_D2Z, _Z2D) if double else (_R2C, _C2R)):
                plan, size = ctypes.c_int(0), ctypes.c_size_t(0)
                _check(lib.cufftCreate(ctypes.byref(plan)), "cufftCreate")
                self._plans.append(plan.value)
                _check(lib.cufftSetAutoAllocation(plan.value, 0), "cufftSetAutoAllocation")
                _check(lib.cufftMakePlan2d(plan.value, 2 * self.ny, 2 * self.nx, kind, ctypes.byref(size)), "cufftMakePlan2d")
                sizes.append(size.value)
            # 16-byte entries: the work area of a large grid has more bytes than an int32 shape holds
            self._work = wp.empty(max(1, -(-max(sizes) // 16)), dtype=wp.vec4f)
            #: bytes of cuFFT's work area (shared by both plans)
            self.work_bytes = max(sizes)
            stream = wp.get_stream(self.device).cuda_stream
            for plan in self._plans:
                _check(lib.cufftSetWorkArea(plan, ctypes.c_void_p(self._work.ptr)), "cufftSetWorkArea")
                _check(lib.cufftSetStream(plan, ctypes.c_void_p(stream)), "cufftSetStream")
        self._forward_plan, self._inverse_plan = self._plans

    def __del__(self):
        lib = getattr(self, "_lib", None)
        for plan in getattr(self, "_plans", ()):
            try:
                lib.cufftDestroy(plan)
            except Exception:  # interpreter shutdown
                pass

    @property
    def spectral_shape(self):
        return (2 * self.ny, self.nx + 1)

    def spectrum_of_padded(self, padded):
        return np.fft.rfft2(np.asarray(padded, dtype=np.float64))

    def library_transforms(self, field, spectrum):
        """cuFFT's D2Z and Z2D (R2C and C2R) of the padded buffers alone (``field`` unused)."""
        with wp.ScopedDevice(self.device):
            _check(self._exec_forward(self._forward_plan, self._padded_in.ptr, spectrum.ptr), "forward transform")
            _check(self._exec_inverse(self._inverse_plan, spectrum.ptr, self._padded_out.ptr), "inverse transform")

    def forward(self, field, spectrum):
        self.launches.launch(pad_field, (self.ny, self.nx), [field], [self._padded_in])
        with wp.ScopedDevice(self.device):
            _check(self._exec_forward(self._forward_plan, self._padded_in.ptr, spectrum.ptr), "forward transform")

    def inverse(self, spectrum, field):
        with wp.ScopedDevice(self.device):
            _check(self._exec_inverse(self._inverse_plan, spectrum.ptr, self._padded_out.ptr), "inverse transform")
        self.launches.launch(crop_field, (self.ny, self.nx), [self._padded_out, self._scale], [field])

"""cuFFT on CUDA devices, through the library that CuPy ships: the default backend there.

The transforms are cuFFT plans of the (2 ny, 2 nx) padded grid (real-to-complex forward,
complex-to-real inverse), made once per grid and called through ``ctypes`` on Warp's stream, into
buffers allocated once as Warp arrays. Nothing is allocated and no stream is synchronised per
transform, so the solvers' iterations, transforms included, can be captured in CUDA graphs.
CuPy is used only to load its cuFFT (``available()`` and ``_cufft_library``); CuPy's own FFT
functions allocate their outputs and padded copies on every call and cannot be captured.

Two layouts of the same transforms (``pruned``):

Both layouts read the field from the corner of a real padded buffer (``padded_input``; the base
class's ``pad_field`` copies it there, or a solver kernel writes it) and leave the unnormalised
inverse in the corner of another (``padded_output``; ``crop_field`` scales it into a field, or a
solver kernel reads it).

Pruned: the zero padding is not transformed. Forward: the (ny, 2 nx) row buffer holds the field
in its left half, its right half zero; the bottom half of the spectrum is zeroed (a memset); the
row D2Z (R2C) transforms only the ny rows, into the top half of the spectrum; the column Z2Z
(C2C) transforms its nx + 1 columns in place. Inverse: the column transform in place, the row
Z2D (C2R) only on the top ny rows, into a second (ny, 2 nx) row buffer, whose left half is the
result. The row stages do half the rows of a 2-D plan; the column stages are the same. (Columns
out of place from a buffer with a zero bottom half instead of the zeroing pass were slower: 1.80
against 1.39 ms at n = 4096.)

Which is faster depends on the size. H100, cuFFT's forward + inverse alone, pruned / 2-D, ms:
float64 0.104 / 0.124 at n = 1024, 0.483 / 0.575 at 2048, 2.59 / 2.98 at 4096
(``bench/iteration_parts.py``, which times both layouts); float32 0.057 / 0.062, 0.258 / 0.295,
1.24 / 1.14. Where 2 n is not a power of two the
column transforms take more passes, and pruned loses in float64 at every size measured, 300 to
4000 (padding and cropping included: 0.056 / 0.042 ms at n = 315, 4.85 / 3.09 at 4000; the
adhesive Table 2 cells' grids are 300-588). The default is :func:`prune_by_default`.

Unpruned (``pruned=False``, one 2-D plan each way): forward D2Z (R2C in float32) of the
(2 ny, 2 nx) padded buffer into the spectrum, shape (2 ny, nx + 1), the layout of
``numpy.fft.rfft2`` of the padded field; inverse Z2D (C2R) of the spectrum (overwritten, as
cuFFT's complex-to-real transforms do) into a second (2 ny, 2 nx) buffer.

Periodic (``periodic=True``, ``make_periodic_fft``): one 2-D plan each way of the (ny, nx) grid
itself, no padding, the spectrum (ny, nx // 2 + 1): the preconditioners' circulants.

Memory: pruned, two (ny, 2 nx) real row buffers (one spectrum's worth); 2-D, two (2 ny, 2 nx)
real padded buffers (two spectra's worth); and one work area shared by the plans: at most one
spectrum, or 4-6.5 where cuFFT uses Bluestein's algorithm (transform lengths with a large prime
factor; ``resources.cufft_work_spectra``).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
import os
from collections import OrderedDict

import numpy as np
import warp as wp

from ..kernels.spectral import spectrum_part
from .base import FFTBackend

# cufftType, and the directions of the complex-to-complex transforms
_R2C, _C2R, _C2C, _D2Z, _Z2D, _Z2Z = 0x2A, 0x2C, 0x29, 0x6A, 0x6C, 0x69
_FORWARD, _INVERSE = -1, 1
_LIB = None


def cupy_stream(stream: "wp.Stream"):
    """CuPy's view of a Warp stream (the same CUDA stream, nothing copied or synchronised), for
    CuPy's work to queue behind Warp's: ``cupy.cuda.Stream.from_external`` through the stream's
    ``__cuda_stream__`` protocol where CuPy has it (CuPy 14 warns that ``ExternalStream`` is
    deprecated, a line in every command's output), else ``ExternalStream``. Make it and use it
    inside ``cupy.cuda.Device`` of the stream's device."""
    import cupy

    from_external = getattr(cupy.cuda.Stream, "from_external", None)
    if from_external is not None:
        return from_external(stream)
    return cupy.cuda.ExternalStream(stream.cuda_stream, stream.device.ordinal)


@functools.cache
def available() -> bool:
    """True when CuPy imports and sees a CUDA device; asked once per process (CuPy's device count
    took 37 ms a call on an H100, and a solve's set-up asks five times)."""
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
    int_p = ctypes.POINTER(ctypes.c_int)
    lib.cufftMakePlanMany.argtypes = [ctypes.c_int, ctypes.c_int, int_p, int_p, ctypes.c_int, ctypes.c_int, int_p,
                                      ctypes.c_int, ctypes.c_int, ctypes.c_int, ctypes.c_int, size_p]
    lib.cufftSetWorkArea.argtypes = [ctypes.c_int, ctypes.c_void_p]
    lib.cufftSetStream.argtypes = [ctypes.c_int, ctypes.c_void_p]
    lib.cufftDestroy.argtypes = [ctypes.c_int]
    for name in ("cufftExecD2Z", "cufftExecZ2D", "cufftExecR2C", "cufftExecC2R"):
        getattr(lib, name).argtypes = [ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p]
    for name in ("cufftExecZ2Z", "cufftExecC2C"):
        getattr(lib, name).argtypes = [ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int]
    _LIB = lib
    return lib


def _power_of_two(k: int) -> bool:
    return k > 0 and k & (k - 1) == 0


def prune_by_default(ny: int, nx: int, dtype) -> bool:
    """The layout that took less time on the H100 (``bench/iteration_parts.py``: forward +
    inverse, padding and cropping included, pruned against 2-D plans):

    - float64: pruned where 2 ny and 2 nx are powers of two (n = 256-4096: 5-16 % less time),
      2-D plans elsewhere (all 15 other sizes measured, 300-4000: 1-39 % less time);
    - float32: pruned below n = 1000 (256-600: 4-13 % less) and where 2 n is a power of two
      below 4096 (512-2048: 4-11 % less); 2-D plans elsewhere (1000: 44 %, 3000: 59 %, 4096:
      8 % less). One size measured goes against the rule: 1500, where pruned takes 20 % less.
    """
    n = max(ny, nx)
    powers = _power_of_two(2 * ny) and _power_of_two(2 * nx)
    if dtype == wp.float64:
        return powers
    return n < 4096 and (powers or n < 1000)


def _check(result: int, what: str):
    if result != 0:
        raise RuntimeError(f"fft: cupy backend: {what} failed with cufftResult {result}")


def _load(dst: wp.array, src):
    """``dst`` (an input buffer of the backend's float type) <- ``src``: a host array of that type,
    or a Warp array on ``dst``'s device, cast on the device (as numpy casts on the host)."""
    if isinstance(src, wp.array):
        wp.utils.array_cast(src, dst)
    else:
        dst.assign(src)


class CupyFFT(FFTBackend):
    """cuFFT plans on one CUDA device (see the module docstring).

    Args:
        pruned: skip the transforms of the zero padding (row stages on ny rows, not 2 ny);
            False: one 2-D plan each way; None: :func:`prune_by_default`.
        periodic: transforms of the (ny, nx) grid itself, no padding (``FFTBackend.periodic``:
            the preconditioners' circulants), one 2-D plan each way; the spectrum (ny, nx // 2 + 1).
    """

    name = "cupy"

    def __init__(self, ny, nx, device, dtype, pruned: bool | None = None, periodic: bool = False):
        super().__init__(ny, nx, device, dtype)
        if not self.device.is_cuda:
            raise ValueError(f"fft: the cupy backend runs on CUDA devices only, not on {self.device}")
        self._lib = lib = _cufft_library()
        self.periodic = bool(periodic)
        self.pruned = False if periodic else prune_by_default(ny, nx, dtype) if pruned is None else bool(pruned)
        double = dtype == wp.float64
        self._real_to_complex = lib.cufftExecD2Z if double else lib.cufftExecR2C
        self._complex_to_real = lib.cufftExecZ2D if double else lib.cufftExecC2R
        self._complex_to_complex = lib.cufftExecZ2Z if double else lib.cufftExecC2C
        r2c, c2r, c2c = (_D2Z, _Z2D, _Z2Z) if double else (_R2C, _C2R, _C2C)
        points = self.padded_shape[0] * self.padded_shape[1]
        self.output_scale = dtype(1.0 / points)  # typed: a kernel argument
        self._set_parseval(1, self.padded_shape[1], points)
        ny2, nx2, nxh = 2 * self.ny, 2 * self.nx, self.nx + 1
        self._plans = []
        sizes = []
        with wp.ScopedDevice(self.device):
            if self.pruned:
                self._rows_in = wp.zeros((self.ny, nx2), dtype=dtype)  # right half zero, always
                self._rows_out = wp.zeros((self.ny, nx2), dtype=dtype)
                # rows: length 2 nx, ny of them, contiguous; columns: length 2 ny, nx + 1 of them,
                # stride nx + 1 between entries and 1 between columns
                self._row_forward = self._plan_many(sizes, nx2, 1, nx2, 1, nxh, r2c, self.ny)
                self._column_plan = self._plan_many(sizes, ny2, nxh, 1, nxh, 1, c2c, nxh)
                self._row_inverse = self._plan_many(sizes, nx2, 1, nxh, 1, nx2, c2r, self.ny)
            else:
                self._padded_in = wp.zeros(self.padded_shape, dtype=dtype)  # zero outside the field's corner, always
                self._padded_out = wp.zeros(self.padded_shape, dtype=dtype)
                self._forward_plan = self._plan_2d(sizes, r2c)
                self._inverse_plan = self._plan_2d(sizes, c2r)
            self.padded_input = self._rows_in if self.pruned else self._padded_in
            self.padded_output = self._rows_out if self.pruned else self._padded_out
            # 16-byte entries: the work area of a large grid has more bytes than an int32 shape holds
            self._work = wp.empty(max(1, -(-max(sizes) // 16)), dtype=wp.vec4f)
            #: bytes of cuFFT's work area (shared by the plans)
            self.work_bytes = max(sizes)
            stream = wp.get_stream(self.device).cuda_stream
            for plan in self._plans:
                _check(lib.cufftSetWorkArea(plan, ctypes.c_void_p(self._work.ptr)), "cufftSetWorkArea")
                _check(lib.cufftSetStream(plan, ctypes.c_void_p(stream)), "cufftSetStream")

    def _new_plan(self) -> int:
        plan = ctypes.c_int(0)
        _check(self._lib.cufftCreate(ctypes.byref(plan)), "cufftCreate")
        self._plans.append(plan.value)
        _check(self._lib.cufftSetAutoAllocation(plan.value, 0), "cufftSetAutoAllocation")
        return plan.value

    def _plan_2d(self, sizes: list, kind: int) -> int:
        plan, size = self._new_plan(), ctypes.c_size_t(0)
        _check(self._lib.cufftMakePlan2d(plan, *self.padded_shape, kind, ctypes.byref(size)), "cufftMakePlan2d")
        sizes.append(size.value)
        return plan

    def _plan_many(self, sizes: list, length, in_stride, in_dist, out_stride, out_dist, kind, batch) -> int:
        """A batch of 1-D transforms of ``length`` points (cufftMakePlanMany, advanced layout)."""
        plan, size = self._new_plan(), ctypes.c_size_t(0)
        n = (ctypes.c_int * 1)(length)
        embed = (ctypes.c_int * 1)(length)  # ignored for 1-D transforms, but must be non-null
        _check(self._lib.cufftMakePlanMany(plan, 1, n, embed, in_stride, in_dist, embed, out_stride, out_dist,
                                           kind, batch, ctypes.byref(size)), "cufftMakePlanMany")
        sizes.append(size.value)
        return plan

    def __del__(self):
        lib = getattr(self, "_lib", None)
        for plan in getattr(self, "_plans", ()):
            try:
                lib.cufftDestroy(plan)
            except Exception:  # interpreter shutdown
                pass

    @property
    def spectral_shape(self):
        rows, columns = self.padded_shape
        return (rows, columns // 2 + 1)

    def spectrum_of_padded(self, padded):
        import scipy.fft

        # on the host (tests and tools; the operator's spectra are made on the device by
        # ``influence_spectra``); scipy's threads (numpy's FFT has none)
        return scipy.fft.rfft2(np.asarray(padded, dtype=np.float64), workers=os.cpu_count() or 1)

    #: ``influence_spectra`` takes the coefficients as float64 Warp arrays on this device too
    takes_device_coefficients = True

    def influence_spectra(self, padded_arrays, parts, out, scratch):
        """``out[k]`` <- the real or imaginary part (``parts[k]``) of the spectrum of
        ``padded_arrays[k]`` (real (2 ny, 2 nx) host arrays, or float64 Warp arrays on this device,
        cast here into the float type), transformed on the device by this
        backend's own plans into ``scratch``, in its float type: each array is copied (cast) into
        the forward pass's input buffer, a half at a time in the pruned layout (the row plan takes
        ny rows; its output goes to the top or bottom half of the spectrum), and the column plan
        finishes in place. No memory beyond the backend's buffers and ``scratch``.

        In float64 the spectra equal the host's (scipy) to 3.3e-16 of the largest entry (H100, n
        up to 8191); in float32 the transform is in float32, where the host made them in float64
        and cast: within 1e-5 of the largest entry (tested), and the float32 Hertz solve is as
        close to float64 either way. Set-up
        times: README "Scale".
        """
        ny, nxh = self.ny, self.nx + 1
        bottom = ny * nxh * 2 * np.dtype(self.np_real).itemsize  # bytes to the spectrum's second half
        with wp.ScopedDevice(self.device):
            for k, (padded, part) in enumerate(zip(padded_arrays, parts)):
                if isinstance(padded, wp.array):  # float64 on this device (``device_coefficients``): cast here
                    host = padded
                else:
                    host = np.ascontiguousarray(padded, dtype=self.np_real)
                del padded
                if self.pruned:
                    for half in range(2):
                        _load(self._rows_in, host[half * ny:(half + 1) * ny])
                        _check(self._real_to_complex(self._row_forward, self._rows_in.ptr, scratch.ptr + half * bottom),
                               "row transform")
                    _check(self._complex_to_complex(self._column_plan, scratch.ptr, scratch.ptr, _FORWARD),
                           "column transform")
                else:
                    _load(self._padded_in, host)
                    _check(self._real_to_complex(self._forward_plan, self._padded_in.ptr, scratch.ptr),
                           "forward transform")
                del host
                self.launches.launch(spectrum_part, scratch.shape, [scratch, 0 if part == "real" else 1], [out[k]])
            # the forward pass's invariant: zero outside the field's corner (its pad kernels
            # write only there)
            (self._rows_in if self.pruned else self._padded_in).zero_()

    def transform_input(self, spectrum):
        with wp.ScopedDevice(self.device):
            if self.pruned:
                # the row plan fills the top half; the columns are transformed in place, so the
                # rows it skips (the zero padding) must be zero: a memset of the bottom half
                spectrum[self.ny:].zero_()
                _check(self._real_to_complex(self._row_forward, self._rows_in.ptr, spectrum.ptr), "row transform")
                _check(self._complex_to_complex(self._column_plan, spectrum.ptr, spectrum.ptr, _FORWARD),
                       "column transform")
            else:
                _check(self._real_to_complex(self._forward_plan, self._padded_in.ptr, spectrum.ptr), "forward transform")

    def transform_to_output(self, spectrum):
        with wp.ScopedDevice(self.device):
            if self.pruned:
                _check(self._complex_to_complex(self._column_plan, spectrum.ptr, spectrum.ptr, _INVERSE),
                       "inverse column transform")
                _check(self._complex_to_real(self._row_inverse, spectrum.ptr, self._rows_out.ptr), "inverse row transform")
            else:
                _check(self._complex_to_real(self._inverse_plan, spectrum.ptr, self._padded_out.ptr), "inverse transform")


class BatchedPlans:
    """cuFFT's 2-D transforms of stacks of padded grids, for the batched solves (``fft/batch.py``):
    the forward real-to-complex transform of m real (2 n, 2 n) grids into their (2 n, n + 1)
    spectra, and the inverse complex-to-real one (which overwrites the spectra, as cuFFT's
    complex-to-real transforms do), unnormalised. One plan per direction, m, n and float type
    (cufftMakePlanMany, rank 2, contiguous stacks), made when first asked and run through
    ``ctypes`` on ``stream``. The plans share one work area, made with the plan that first needs
    it larger and kept while the plans live (the ones it replaced too): a transform allocates
    nothing, so a batched solve's iterations can be captured in a CUDA graph, whose transforms
    keep the work area they were captured with.

    CuPy's own ``rfft``/``fft`` look their plans up, pad through copies and allocate their
    outputs at every call: about ten times this host time per transform on a batch of small grids,
    where the host's time is what a batched solve spends (docs/performance.md, "Many cases with
    friction solved together").

    Args:
        stream: the CUDA stream (its handle) the transforms run on.
        max_plans: the plans kept, the least recently used destroyed past it (the stream
            synchronised first); None: every plan made (a solve's, whose captured graphs replay
            them).
    """

    def __init__(self, stream: int, max_plans: int | None = None):
        self._lib = _cufft_library()
        self._stream = stream
        self._max_plans = max_plans
        self._plans: OrderedDict = OrderedDict()  # (direction, m, grid side, double) -> (plan, work bytes)
        self._work = []  # the work areas made, the current (largest) last

    def _plan(self, forward: bool, m: int, side: int, double: bool) -> tuple[int, int]:
        """The plan of m real (side, side) grids (a padded 2 n, or a periodic n)."""
        key = (forward, m, side, double)
        made = self._plans.get(key)
        if made is not None:
            self._plans.move_to_end(key)
        else:
            lib = self._lib
            plan, size = ctypes.c_int(0), ctypes.c_size_t(0)
            _check(lib.cufftCreate(ctypes.byref(plan)), "cufftCreate")
            try:
                _check(lib.cufftSetAutoAllocation(plan.value, 0), "cufftSetAutoAllocation")
                kind = (_D2Z if forward else _Z2D) if double else (_R2C if forward else _C2R)
                shape = (ctypes.c_int * 2)(side, side)
                _check(lib.cufftMakePlanMany(plan.value, 2, shape, None, 1, 0, None, 1, 0, kind, m, ctypes.byref(size)),
                       "cufftMakePlanMany")
                _check(lib.cufftSetStream(plan.value, ctypes.c_void_p(self._stream)), "cufftSetStream")
            except Exception:
                lib.cufftDestroy(plan.value)
                raise
            made = self._plans[key] = (plan.value, size.value)
            if self._max_plans is not None and len(self._plans) > self._max_plans:
                import cupy

                cupy.cuda.runtime.streamSynchronize(self._stream)  # no transform of it still queued
                while len(self._plans) > self._max_plans:
                    self._lib.cufftDestroy(self._plans.popitem(last=False)[1][0])
        return made

    def execute(self, forward: bool, source, target):
        """``target`` <- the transform of ``source`` (C-contiguous CuPy stacks on the plans' device:
        forward (m, L, L) real to (m, L, L // 2 + 1) complex, or the reverse; L = 2 n for padded
        grids, n for periodic ones)."""
        import cupy

        real, spectra = (source, target) if forward else (target, source)
        m, side = real.shape[0], real.shape[-1]
        double = real.dtype == np.float64
        complex_type = np.complex128 if double else np.complex64
        if (real.shape != (m, side, side) or spectra.shape != (m, side, side // 2 + 1) or spectra.dtype != complex_type
                or real.dtype not in (np.float64, np.float32) or not (real.flags.c_contiguous and spectra.flags.c_contiguous)):
            raise ValueError(f"fft: batched transforms of {real.shape} {real.dtype} and {spectra.shape} "
                             f"{spectra.dtype}: expected contiguous stacks (m, L, L) and (m, L, L // 2 + 1)")
        plan, size = self._plan(forward, m, side, double)
        if not self._work or self._work[-1].size < size:
            self._work.append(cupy.empty(max(1, size), dtype=cupy.uint8))
        work = self._work[-1]
        lib = self._lib
        _check(lib.cufftSetWorkArea(plan, ctypes.c_void_p(work.data.ptr)), "cufftSetWorkArea")
        run = (lib.cufftExecD2Z if forward else lib.cufftExecZ2D) if double else (
            lib.cufftExecR2C if forward else lib.cufftExecC2R)
        _check(run(plan, ctypes.c_void_p(source.data.ptr), ctypes.c_void_p(target.data.ptr)),
               "batched forward transform" if forward else "batched inverse transform")

    def release_work(self):
        """Let go of the work areas (the next transform makes one anew): only where no captured
        graph replays these plans."""
        self._work.clear()

    def __del__(self):
        lib = getattr(self, "_lib", None)
        for plan, _ in getattr(self, "_plans", {}).values():
            try:
                lib.cufftDestroy(plan)
            except Exception:  # interpreter shutdown
                pass

"""Memory a grid needs: estimate it before allocating, refuse a grid that cannot fit.

The estimate is counted from the allocations in the code, not fitted:

- ``ContactModel``: ``initial_gap``, one (n, n) field (a shape other than a sphere or paraboloid
  is made on the host with numpy first, a few (n, n) float64 arrays for a moment, before the
  influence spectra; a height map's own array stays in host memory with the case, not counted); its ``ElasticOperator``: 6 influence
  spectra in real entries (each spectrum is real or imaginary: only that part is kept) and 3
  spectral buffers in complex entries (``operator.py``), each of the FFT backend's ``spectral_shape``
  in the model's float type (scipy and cupy: (2n, n + 1); warp: (L/2 + 1, L),
  L the smallest power of two >= 2n), plus the FFT backend's work buffers: warp's ``_rows_q`` (one
  spectrum), ``_half_r`` ((n, L/2 + 1) complex), ``_row_scale`` (L/2 + 1 reals) and its
  (n, n) ``padded_input`` and ``padded_output``; scipy's padded (n, 2n) real row buffer
  (``_rows``, its ``padded_input``) and (n, n) ``padded_output``; cupy's two (n, 2n) real row
  buffers (pruned layout) or two (2n, 2n) real padded buffers (2-D plans;
  ``cupy_backend.prune_by_default`` says which).
- ``ContactState``: ``len(ContactState.FIELDS)`` fields and the int32 ``status``.
- ``NormalSolver``: 4 fields (direction, response, interference, no_displacement) and its scalars (sums,
  scalars, a residual history of max_iter + 1); ``ContactSolver``: 6 fields (known_z/x/y,
  previous x 3), 3 more with adhesion (adhesive_z/x/y), and 8 scalars; with friction also
  ``TangentialSolver``'s 7 fields
  (no_displacement, made when a solve is given no known displacement; grad, dir, resp x/y, made
  by its first solve on the whole grid) with its
  scalars, and the solver's target_x/y and shear_limit (3 fields; with adhesion scratch_x/y too). Not counted: the
  windows of the tangential solves (``SolverSettings.window``), each a model and about 18
  fields of its m x m cells (m <= 0.75 n; 8 GiB at n = 8192 float64, m = 4096), made beside
  these where they fit: on CUDA a window that does not fit in the free memory is not made and
  the solve runs on the whole grid, within this estimate. With adhesion, ``AndersonMixing`` holds 3 + 2 x DEPTH
  fields per component of its vector (4 with friction and the SMC law: the minimised turns' shears
  and adhesive shears; 3 with friction otherwise; 1 without friction) and 2 + 3 x DEPTH
  scalars; without friction also ``AdhesiveNormalSolver``: ``adhesive.PADDED_FIELDS`` + 2 x
  MEMORY fields on the padded (2n, 2n) grid (4 (n, n) fields each) and 3 (n, n) fields, and its
  padded convolution's library temporaries, about one (2n, 2n) field and two spectra
  (``ADHESIVE_TEMPORARY_*``).
- The FFT library's temporaries, an allowance (``FFT_TEMPORARY_SPECTRA``): scipy on the
  CPU allocates the row pass's (n, n + 1) output of the forward transform and the (n, 2n) output
  of the inverse's last pass, one spectrum; FFTW transforms in place and needs its plans only
  (``FFTW_PLAN_BYTES``);
  the cupy backend's cuFFT plans share one work area, allocated once (``CupyFFT.work_bytes``),
  allowed ``cufft_work_spectra(n)`` spectra (one, or up to about nine where cuFFT falls back to
  Bluestein's algorithm); Warp's tile_fft needs none beyond its work buffers (one (n, n) field
  allowed for the zero round trip that checks the kernels at set-up on CUDA).
- On the CPU, the solves' residual histories as Python lists (``SolveInfo.history``), up to
  ``max_iter + 1`` floats each for the three solves of a step (``HISTORY_RECORDS``), and the
  records of the launches split over the CPU's threads (``SPLIT_RECORD_BYTES`` per thread beyond
  the first).

Building the influence spectra takes host memory for a moment (``setup_host_bytes``): six
float64 coefficient arrays on the (2n, 2n) grid and the blocks of their evaluation on its
threads, or those arrays and the temporaries of one host transform; on the CPU 40-75 % of the
estimate above (friction and adhesion, n = 256-4096), on CUDA all of it on the host.
``check_fits`` checks both against the memory there is.

Not counted: a path's saved fields (``runner.run_path`` keeps about 13 float64 (n, n) arrays per
state of the path on the host, made by ``results.state_fields``; summaries stay on the device), and
extra states (``find_gross_slip`` holds 2, the state and the last stick state: pass ``states=2``).
"""

from __future__ import annotations

import math
import os

import numpy as np
import warp as wp

from .device import resolve_dtype
from ..errors import InputError
from ..physics.geometry import MIN_CELLS

GIB = 1024**3

#: influence spectra kept by ElasticOperator (KERNELS) and its spectral buffers
N_INFLUENCE_SPECTRA = 6
N_SPECTRAL_BUFFERS = 3
#: (n, n) fields of the solvers (counted in solvers/normal.py, contact.py, tangential.py)
NORMAL_SOLVER_FIELDS = 4
CONTACT_SOLVER_FIELDS = 6  # known_z/x/y, previous x 3
#: with adhesion: ContactSolver's adhesive_z/x/y, and with friction too its scratch_x/y and
#: shear_normal
ADHESION_FIELDS = 3
ADHESION_FRICTION_FIELDS = 3
#: components of ContactSolver's AndersonMixing with friction: 4 for the SMC law's minimised turns
#: (the shears and adhesive shears), 3 otherwise; counted as 4 (the larger)
MIXING_COMPONENTS_FRICTION = 4
#: (n, n) fields of the minimised turns (adhesion with friction, solvers/turns.py, MinimisedTurns): the coupling
#: shear and the adhesive shear held in a turn (4 with the SMC law, 2 with a normal-only law),
#: the total normal traction and a scratch field; counted for the SMC law (the larger)
MINIMISED_TURN_FIELDS = 6
TANGENTIAL_SOLVER_FIELDS = 7
FRICTION_FIELDS = 3  # ContactSolver.target_x, target_y, shear_limit
CONTACT_SOLVER_SCALARS = 6  # change
#: the adhesive solve's padded convolution (adhesion without friction): the library's spectrum,
#: one more for its intermediates, and its (2n, 2n) real output (4 (n, n) fields)
ADHESIVE_TEMPORARY_SPECTRA = 2
ADHESIVE_TEMPORARY_FIELDS = 4
#: residual histories of a step kept as Python lists (normal, tangential and final solves), each
#: up to max_iter + 1 floats of about 32 bytes (a pointer and a float object)
HISTORY_RECORDS = 3
#: host bytes per CPU thread beyond the first for the records of a coupled step's launches split
#: over the threads (``launch.LaunchCache.split``: each part's recorded launch and sums; Python
#: objects, the same at every n): measured with tracemalloc 0.24 MB at n = 256 and 0.30 MB at 512
#: with two threads, 0.20 MB more per thread with four
SPLIT_RECORD_BYTES = 320 * 1024
#: library temporaries during a transform, in spectra of the backend's shape (see module docstring)
FFT_TEMPORARY_SPECTRA = {"scipy": 1.0, "warp": 0.0}  # cupy: cufft_work_spectra(n); fftw: FFTW_PLAN_BYTES
#: FFTW's plans (twiddles, buffers) and OpenMP threads for the three spectra of an operator: the
#: process's resident memory grew 0.9-1.5 MB when they were made and run, n = 256 ... 2048, float64
#: and float32, 2 threads (the transforms are in place: no temporaries of the grid's size)
FFTW_PLAN_BYTES = 2 * 2**20


def allocation_refused(error: BaseException) -> bool:
    """Whether ``error`` is an allocation the device refused (MemoryError, or Warp's RuntimeError
    "Failed to allocate ..."), not some other failure, which the caller should raise."""
    if isinstance(error, MemoryError):
        return True
    return isinstance(error, RuntimeError) and str(error).startswith("Failed to allocate")


def _largest_prime_factor(m: int) -> int:
    largest, p = 1, 2
    while p * p <= m:
        while m % p == 0:
            largest, m = p, m // p
        p += 1
    return max(largest, m)


def cufft_work_spectra(n: int) -> float:
    """Allowance for cuFFT's work area on an n x n grid, in spectra: 1, or, where the transform
    length L = 2n has a prime factor above 127 (then cuFFT may use Bluestein's algorithm, with
    two buffers of the next power of two >= 2L - 1 per transform), 2 * that power / L + 1.

    An upper bound of ``CupyFFT.work_bytes`` measured on the H100 (cuFFT 12, 20 sizes from 64 to
    8191, both layouts, float64 and float32): at most 1 spectrum without a large prime factor;
    4.0-6.46 spectra at n = 2039 (float64), 3001, 4001, 4097, 8191 (the bound: 5.1-9.0);
    0.5-1 at n = 131 ... 1021 (bound 5-9: cuFFT needs Bluestein only for longer transforms).
    """
    length = 2 * int(n)
    if _largest_prime_factor(length) <= 127:
        return 1.0
    power = 1 << (2 * length - 2).bit_length()
    return 2.0 * power / length + 1.0
#: temporaries of one block of influence.influence_coefficients, in float64 arrays of its
#: (BLOCK_ROWS + 1, 2n + 1) corners (measured with tracemalloc: 14.4-14.9 per worker thread at
#: n = 256, 512, 1024 with 1 and 2 threads); its peak is six (2n, 2n) results plus this per thread
INFLUENCE_BLOCK_ARRAYS = 16
#: host temporaries while FFTBackend.influence_spectra transforms one coefficient array on the
#: host, in complex128 spectra of the backend's shape (tracemalloc at n = 256 and 128: scipy's
#: rfft2 2.01 in float64 and float32; the warp backend's embedding, numpy's rfft2 and the transposed
#: copy 4.25 and 3.50). The cupy backend transforms on the device: only the float32 cast of one
#: array on the host.
HOST_FFT_SPECTRA = {"fftw": 2.1, "scipy": 2.1, "warp": 4.5}


def _kind(device_kind) -> str:
    name = str(device_kind)
    if name == "cpu":
        return "cpu"
    if name.startswith("cuda"):
        return "cuda"
    raise InputError("solver.device", f"unknown device {device_kind!r}; use 'cpu', 'cuda' or 'cuda:N'")


def _resolve_fft(fft: str, kind: str) -> str:
    """The backend "auto" stands for on a device kind; only that kind's backends are imported (the
    CPU's import scipy.fft: about 0.8 s that a CUDA run does not need)."""
    from ..fft.names import BACKENDS

    if fft not in BACKENDS:
        raise InputError("solver.fft", f"unknown FFT backend {fft!r}; choose one of {', '.join(BACKENDS)}")
    if fft != "auto":
        return fft
    if kind == "cpu":
        from ..fft import fftw_backend

        return "fftw" if fftw_backend.available() else "scipy"
    from ..fft import cupy_backend

    return "cupy" if cupy_backend.available() else "warp"


def _padded_length(n: int) -> int:
    from ..fft.warp_backend import padded_length

    return padded_length(n)


#: Warp keeps array strides as 32-bit ints (warp/native/array.h: ``int strides[]``), so a stride
#: over 2^31 - 1 bytes wraps and the kernels read outside the array (measured: CUDA illegal
#: address with complex float64 spectra at n = 8192 on an H100). The operator stacks its
#: influence spectra in a (6, rows, cols) real array whose first stride is one whole spectrum:
#: that spectrum must stay under 2 GiB.
WARP_MAX_STRIDE_BYTES = 2**31 - 1


def index_limit(dtype, fft: str) -> int:
    """Largest n whose influence spectra Warp can address: the first stride of their stacked
    array, one spectrum of 2n (n + 1) real entries (scipy, cupy), must stay under 2 GiB: 11584 in
    float64 and 16383 in float32 (the three spectral buffers are separate arrays; complex spectra
    would stop it at 8191 and 11584)."""
    # "auto" as the CPU resolves it, without importing a backend: fftw, scipy and cupy share the
    # (2n, n + 1) spectrum
    fft = "scipy" if fft == "auto" else _resolve_fft(fft, "cpu")
    entry = np.dtype(_np_name(resolve_dtype(dtype))).itemsize
    lo, hi = MIN_CELLS, 1 << 20
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (mid, hi) if spectral_entries(mid, fft) * entry <= WARP_MAX_STRIDE_BYTES else (lo, mid)
    return lo


def check_index_limit(n: int, dtype, fft: str):
    """Raise InputError("grid.n", ...) when Warp cannot index the n x n problem's spectra."""
    limit = index_limit(dtype, fft)
    if n > limit:
        dname = dtype if isinstance(dtype, str) else _np_name(dtype)
        raise InputError("grid.n", f"n = {n} is over the largest grid Warp can index in {dname}, n = {limit}: "
                                   "its array strides are 32-bit, and one influence spectrum of the padded grid "
                                   "must stay under 2 GiB" + (f" (use float32 for up to n = {index_limit('float32', fft)})"
                                                              if dname == "float64" else ""))


def spectral_entries(n: int, fft: str) -> int:
    """Complex entries of one spectrum of backend ``fft`` ("scipy", "cupy" or "warp") on n x n."""
    if fft == "warp":
        length = _padded_length(n)
        return (length // 2 + 1) * length
    return 2 * n * (n + 1)


def breakdown(n: int, dtype="float64", device_kind="cpu", friction: bool = True, fft: str = "auto", *,
              states: int = 1, max_iter: int = 2000, adhesion: bool = False,
              preconditioner_float32: bool | str = "auto", preconditioner_grid: str = "periodic",
              response_float32: bool | str = "auto") -> dict:
    """Bytes per part of a ContactModel + ``states`` ContactStates + a ContactSolver, on the device.

    The operator's periodic transforms (every backend but ``warp``: ``ElasticOperator``, the
    preconditioners' circulants on the grid itself): 4 spectra of (n, n // 2 + 1) entries, 2
    spectral buffers and their (n, n) input and output grids (and on CUDA cuFFT's work area).
    ``preconditioner_float32`` (``SolverSettings.preconditioner_float32``; "auto": as it chooses
    for n on the device kind): in float64, the preconditioners' float32 transforms
    (``ElasticOperator.inverse_transforms``) of the grid ``preconditioner_grid``
    (``SolverSettings.preconditioner_grid``; "padded" where the backend has no periodic ones): 4
    influence spectra and 2 spectral buffers in float32, and a float32 backend's work buffers and
    temporaries. ``response_float32`` (``SolverSettings.response_float32``; "auto" likewise), with
    friction: the float32 transforms of the padded grid that the tangential solves' responses
    take, where the preconditioners' are not those already.

    Keys: ``spectra`` (influence and buffers), ``fft_work`` (the FFT backend's work buffers),
    ``fields`` ((n, n) arrays of the model, states and solvers), ``scalars`` (reductions and
    residual histories), ``arrays`` (the sum of those four: what the objects hold), ``fft_temporaries``
    (allowance for the FFT library), ``host_temporaries`` (the solves' Python-side residual
    histories, counted on the CPU only), ``total``.
    """
    from warpcontact.kernels import normal as nk
    from warpcontact.kernels import tangential as tk

    from warpcontact.kernels import adhesive as ak

    from ..solvers.adhesive import MEMORY, PADDED_FIELDS
    from ..solvers.fixed_point import DEPTH
    from .state import ContactState

    n = int(n)
    kind = _kind(device_kind)
    fft = _resolve_fft(fft, kind)
    wdt = resolve_dtype(dtype)
    real = np.dtype(_np_name(wdt)).itemsize
    cplx = 2 * real
    cells = n * n
    spectrum = spectral_entries(n, fft) * cplx
    spectra = N_INFLUENCE_SPECTRA * spectral_entries(n, fft) * real + N_SPECTRAL_BUFFERS * spectrum
    fft_work = n * (2 * n) * real + cells * real  # scipy: the forward pass's padded rows, the kept output
    if fft == "fftw":  # the padded rows in, the (n, 2n) rows out
        fft_work = 2 * n * (2 * n) * real
    elif fft == "warp":
        half = _padded_length(n) // 2 + 1
        fft_work = spectrum + n * half * cplx + half * real + 2 * cells * real
    elif fft == "cupy":
        from ..fft.cupy_backend import prune_by_default

        fft_work = 2 * (1 if prune_by_default(n, n, wdt) else 2) * n * (2 * n) * real
    n_fields = 1 + states * len(ContactState.FIELDS) + NORMAL_SOLVER_FIELDS + CONTACT_SOLVER_FIELDS
    n_scalars = nk.N_SUMS + nk.N_SCALARS + (max_iter + 1) + CONTACT_SOLVER_SCALARS
    if friction:
        n_fields += TANGENTIAL_SOLVER_FIELDS + FRICTION_FIELDS
        n_scalars += tk.N_SUMS + tk.N_SCALARS + (max_iter + 1)
    if adhesion:
        n_fields += (MIXING_COMPONENTS_FRICTION if friction else 1) * (3 + 2 * DEPTH) + ADHESION_FIELDS
        n_fields += ADHESION_FRICTION_FIELDS if friction else 0
        n_scalars += 2 + 3 * DEPTH
    if adhesion:  # the adhesive minimisation (with friction: the normal solve of each turn)
        n_fields += 4 * (PADDED_FIELDS + 2 * MEMORY) + 3 + (MINIMISED_TURN_FIELDS if friction else 0)
        n_scalars += ak.N_SUMS
    fields = n_fields * cells * real + states * cells * 4  # + int32 status per state
    scalars = n_scalars * real
    if fft == "fftw":  # in place: its plans only
        fft_temporaries = FFTW_PLAN_BYTES
    else:
        allowance = cufft_work_spectra(n) if fft == "cupy" else FFT_TEMPORARY_SPECTRA[fft]
        fft_temporaries = int(math.ceil(allowance * spectrum))
    if fft == "warp" and kind == "cuda":
        fft_temporaries = cells * real
    # the padded grid's transforms, before the periodic ones join (their float32 copy: half of each)
    padded_spectra = 4 * spectral_entries(n, fft) * real + 2 * spectrum
    padded_work, padded_temporaries = fft_work, fft_temporaries
    periodic = fft != "warp"  # the circulants' transforms of the grid itself (``make_periodic_fft``)
    if periodic:
        entries = n * (n // 2 + 1)
        periodic_spectra = 4 * entries * real + 2 * entries * cplx
        periodic_work = 2 * cells * real
        periodic_temporaries = int(math.ceil(cufft_work_spectra(n) * entries * cplx)) if fft == "cupy" else 0
        spectra += periodic_spectra
        fft_work += periodic_work
        fft_temporaries += periodic_temporaries
    padded32 = False  # the float32 transforms of the padded grid counted
    if _float32(n, dtype, kind, preconditioner_float32, "preconditioner"):  # a float32 backend: half of each part
        if periodic and preconditioner_grid == "periodic":
            spectra += periodic_spectra // 2
            fft_work += periodic_work // 2
            fft_temporaries += periodic_temporaries // 2
        else:
            spectra += padded_spectra // 2
            fft_work += fft_work // 2
            fft_temporaries += fft_temporaries // 2
            padded32 = True
    if friction and not padded32 and _float32(n, dtype, kind, response_float32, "response"):
        spectra += padded_spectra // 2
        fft_work += padded_work // 2
        fft_temporaries += padded_temporaries // 2
    arrays = spectra + fft_work + fields + scalars
    if adhesion:
        fft_temporaries += ADHESIVE_TEMPORARY_SPECTRA * 2 * n * (n + 1) * cplx + ADHESIVE_TEMPORARY_FIELDS * cells * real
    host_temporaries = 0
    if kind == "cpu":
        threads = os.cpu_count() or 1
        host_temporaries = HISTORY_RECORDS * (max_iter + 1) * 32 + (threads - 1) * SPLIT_RECORD_BYTES
    return {
        "spectra": spectra,
        "fft_work": fft_work,
        "fields": fields,
        "scalars": scalars,
        "arrays": arrays,
        "fft_temporaries": fft_temporaries,
        "host_temporaries": host_temporaries,
        "total": arrays + fft_temporaries + host_temporaries,
    }


def _np_name(wdt) -> str:
    import warp as wp

    return "float64" if wdt == wp.float64 else "float32"


def estimate_bytes(n: int, dtype: str, device_kind: str, friction: bool, fft: str, *, states: int = 1,
                   max_iter: int = 2000, adhesion: bool = False) -> int:
    """Bytes on the device that a ContactModel + ContactState + ContactSolver of n x n cells hold
    during a solve: their Warp arrays plus the FFT library's temporaries (and, on the CPU, the
    normal solver's host temporaries). See the module docstring for what is counted.

    Args:
        n: cells per side.
        dtype: "float64" or "float32".
        device_kind: "cpu", "cuda" or "cuda:N".
        friction: whether the solver has a friction law (a TangentialSolver and its buffers).
        fft: "auto", "scipy", "cupy" or "warp" ("auto" as ``fft.make_fft`` picks it).
        states: ContactStates alive at once (``find_gross_slip`` holds 2).
        max_iter: iteration limit of the inner solvers (sets the residual histories).
        adhesion: whether the solver has an adhesion law (the fixed point's buffers).
    """
    return breakdown(n, dtype, device_kind, friction, fft, states=states, max_iter=max_iter, adhesion=adhesion)["total"]


def setup_host_bytes(n: int, dtype="float64", fft: str = "scipy", device_kind="cpu", warp_arrays: bool = True) -> int:
    """Peak host memory while ContactModel builds the influence spectra [bytes].

    ``influence_coefficients`` returns six float64 (2n, 2n) arrays (its own peak: those and
    ``INFLUENCE_BLOCK_ARRAYS`` block temporaries per worker thread, one thread per CPU). The FFT
    backend then transforms them one at a time (``FFTBackend.influence_spectra``), each array let
    go once transformed: at the first, the six arrays and the transform's temporaries
    (``HOST_FFT_SPECTRA``; cupy: a float32 copy of one array, the transform is on the device).
    On the CPU the Warp arrays on the host add the model's first field and the six spectra, in
    the model's float type (``warp_arrays=False``: numpy's arrays alone, what tracemalloc sees).
    Measured with tracemalloc at n = 256, scipy, two coefficient threads: 310 n^2 bytes in float64
    and float32 (the coefficients' phase), against 322 n^2 here.
    """
    n = int(n)
    kind = _kind(device_kind)
    fft = _resolve_fft(fft, kind)
    real = np.dtype(_np_name(resolve_dtype(dtype))).itemsize
    from ..physics.influence import BLOCK_ROWS

    padded = (2 * n) ** 2 * 8
    coefficients = N_INFLUENCE_SPECTRA * padded
    threads = min(os.cpu_count() or 1, -(-2 * n // BLOCK_ROWS))  # one per CPU, at most one per block
    blocks = threads * INFLUENCE_BLOCK_ARRAYS * (BLOCK_ROWS + 1) * (2 * n + 1) * 8
    e = spectral_entries(n, fft)
    if fft == "cupy":
        transform = (2 * n) ** 2 * real if real != 8 else 0
    else:
        transform = HOST_FFT_SPECTRA[fft] * e * 16
    on_host = kind == "cpu" and warp_arrays
    initial_gap = n * n * real if on_host else 0  # the model's first field, already made
    influence = N_INFLUENCE_SPECTRA * e * real if on_host else 0
    return int(max(coefficients + blocks, coefficients + transform + influence) + initial_gap)


def host_memory_bytes() -> int:
    """Total RAM of this machine [bytes], lowered to the cgroup's memory limit where one is set."""
    total = 0
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemTotal:"):
                    total = int(line.split()[1]) * 1024
                    break
    except OSError:
        pass
    if not total:
        try:
            total = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (ValueError, OSError, AttributeError):
            total = 0
    for path in ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"):
        try:
            with open(path) as fh:
                text = fh.read().strip()
        except OSError:
            continue
        if text.isdigit() and 0 < int(text) < (total or 2**62):
            total = int(text)
    return total


#: device memory the estimate does not count and a CUDA problem must leave free: cuFFT's plan data
#: beside its work area, the allocator's rounding (H100: the memory in use passed the estimate by
#: 0.03 GiB at n = 8191 and 0.01 GiB at 9660 in float64; at 13668 in float32 an estimate 0.02 GiB
#: under the free memory ran out of it)
CUDA_RESERVE_BYTES = GIB // 2


def memory_limit(device) -> tuple[int, str]:
    """(bytes, description) of the memory a problem on ``device`` may use.

    CPU: the machine's total RAM (``host_memory_bytes``). CUDA: the device's free memory now
    (Warp 1.19 ``Device.free_memory``, cudaMemGetInfo), after a synchronise so that freed
    mempool blocks are returned, less ``CUDA_RESERVE_BYTES``.
    """
    import warp as wp

    from .device import resolve_device

    dev = resolve_device(device) if isinstance(device, str) else wp.get_device(device)
    if dev.is_cpu:
        return host_memory_bytes(), "RAM of this machine"
    wp.synchronize_device(dev)
    free = int(dev.free_memory)
    total = int(dev.total_memory)
    return max(0, free - CUDA_RESERVE_BYTES), (f"free memory of {dev} (of {total / GIB:.1f} GiB) less "
                                               f"{CUDA_RESERVE_BYTES / GIB:.2f} GiB kept in reserve")


#: float64 (2n + 1)^2 arrays the device path of the influence coefficients holds at once on CUDA
#: (two corner arrays and one padded coefficient array; ``influence.device_coefficients``)
DEVICE_INFLUENCE_ARRAYS = 3


def setup_device_bytes(n: int, dtype="float64", fft: str = "cupy") -> int:
    """Peak device memory while a CUDA model builds its spectra [bytes]: the spectra and FFT work
    buffers (``breakdown``) and the device path's coefficient temporaries."""
    parts = breakdown(n, dtype, "cuda", False, fft)
    return parts["spectra"] + parts["fft_work"] + DEVICE_INFLUENCE_ARRAYS * (2 * int(n) + 1) ** 2 * 8


def _required(n, dtype, kind, friction, fft, states, adhesion=False) -> int:
    """Peak bytes in the memory of ``kind``: the solve's, or the set-up's where it is larger (on
    the CPU the host set-up, which shares the memory; on CUDA the device path of the influence
    coefficients)."""
    est = estimate_bytes(n, dtype, kind, friction, fft, states=states, adhesion=adhesion)
    if kind == "cpu":
        return max(est, setup_host_bytes(n, dtype, fft, kind))
    return max(est, setup_device_bytes(n, dtype, fft))


def _bluestein_extra(n: int, dtype, fft: str, kind: str = "cpu", friction: bool = True) -> int:
    """Bytes of the cuFFT work allowance beyond one spectrum (``cufft_work_spectra``; half again
    where ``breakdown`` counts the float32 preconditioner's or responses' backend): 0 unless the cupy
    backend's transform length 2n has a prime factor above 127. Without it the need grows with
    n."""
    if fft != "cupy":
        return 0
    cplx = 2 * np.dtype(_np_name(resolve_dtype(dtype))).itemsize
    factor = cufft_work_spectra(n)

    def beyond(spectrum):  # the allowance beyond one spectrum
        return int(math.ceil(factor * spectrum)) - int(math.ceil(spectrum))

    periodic = beyond(n * (n // 2 + 1) * cplx)  # the periodic transforms' (breakdown)
    extra = beyond(spectral_entries(n, fft) * cplx) + periodic
    if _float32(n, dtype, kind, "auto", "preconditioner"):
        extra += periodic // 2 + 1  # (breakdown adds half of the periodic allowance, rounded down)
    if friction and _float32(n, dtype, kind, "auto", "response"):
        extra += beyond(spectral_entries(n, fft) * cplx) // 2 + 1  # (half of the padded allowance, rounded down)
    return extra


def _float32(n: int, dtype, kind: str, choice, part: str) -> bool:
    """Whether ``breakdown`` counts the float32 transforms of ``part``, "preconditioner" or
    "response" (``SolverSettings.preconditioner_float32``, ``response_float32``: ``choice``, or
    what its "auto" chooses for n on the device kind)."""
    from ..solvers.settings import PRECONDITIONER_FLOAT32_AUTO, RESPONSE_FLOAT32_AUTO, float32_chosen

    auto_from = PRECONDITIONER_FLOAT32_AUTO if part == "preconditioner" else RESPONSE_FLOAT32_AUTO
    return float32_chosen(choice, auto_from, n, kind == "cuda", resolve_dtype(dtype) == wp.float64)


def _fit_tests(dtype, memory_bytes: int, friction: bool, kind: str, fft: str, states: int, adhesion: bool):
    """(fits, may_fit): whether the n x n problem fits in ``memory_bytes``, and whether it would
    with the least cuFFT work area (a test monotonic in n, true wherever ``fits`` is)."""
    cap = index_limit(dtype, fft)
    if fft == "warp":
        from ..fft.warp_backend import MAX_LENGTH

        cap = min(cap, MAX_LENGTH[(kind, resolve_dtype(dtype))] // 2)

    def may_fit(n):
        need = _required(n, dtype, kind, friction, fft, states, adhesion)
        return n <= cap and need - _bluestein_extra(n, dtype, fft, kind, friction) <= memory_bytes

    def fits(n):
        return n <= cap and _required(n, dtype, kind, friction, fft, states, adhesion) <= memory_bytes

    return fits, may_fit


def largest_grid(dtype, memory_bytes: int, friction: bool, *, device_kind="cpu", fft: str = "auto",
                 states: int = 1, adhesion: bool = False) -> int:
    """Largest n whose peak memory fits in ``memory_bytes`` (0 if not even the smallest grid).

    On the CPU the peak is the larger of ``estimate_bytes`` and ``setup_host_bytes``; on CUDA it
    is ``estimate_bytes`` (the set-up peak is on the host). With the warp FFT backend the answer is
    also capped at the largest grid that backend transforms (``fft.warp_backend.MAX_LENGTH``).

    The need grows with n except for cuFFT's work area, which is larger where 2n has a large
    prime factor (``cufft_work_spectra``): some grids below the largest do not fit. The search
    bisects on the need with the least work area (monotonic), then walks down to the first n
    that fits.
    """
    kind = _kind(device_kind)
    fft = _resolve_fft(fft, kind)
    fits, may_fit = _fit_tests(dtype, memory_bytes, friction, kind, fft, states, adhesion)
    if not may_fit(MIN_CELLS):
        return 0
    lo, hi = MIN_CELLS, 2 * MIN_CELLS
    while may_fit(hi):
        lo, hi = hi, 2 * hi
    while hi - lo > 1:  # may_fit(lo), not may_fit(hi)
        mid = (lo + hi) // 2
        if may_fit(mid):
            lo = mid
        else:
            hi = mid
    while lo >= MIN_CELLS and not fits(lo):
        lo -= 1
    return lo if lo >= MIN_CELLS else 0


def _nearest_fitting(n: int, fits, largest: int) -> tuple[int, int]:
    """The grids nearest n, below and above it (0 for none), that fit."""
    below = next((m for m in range(n - 1, MIN_CELLS - 1, -1) if fits(m)), 0)
    above = next((m for m in range(n + 1, largest + 1) if fits(m)), 0)
    return below, above


def check_fits(n: int, dtype, device, friction: bool, fft: str = "auto", *, states: int = 1,
               adhesion: bool = False) -> int:
    """Raise InputError("grid.n", ...) when an n x n problem cannot fit in the memory of ``device``.

    Returns the estimate [bytes] when it fits. The message gives the estimate, the limit and the
    largest grid that fits, in GiB. On CUDA the set-up peak (host) is checked against the RAM too.
    """
    kind = _kind(device)
    fft_name = _resolve_fft(fft, kind)
    check_index_limit(n, dtype, fft_name)
    limit, what = memory_limit(device)
    need = _required(n, dtype, kind, friction, fft_name, states, adhesion)
    dname = dtype if isinstance(dtype, str) else _np_name(dtype)
    if limit and need > limit:
        best = largest_grid(dtype, limit, friction, device_kind=kind, fft=fft_name, states=states, adhesion=adhesion)
        advice = f"the largest grid that fits is n = {best}"
        if n < best:  # refused for cuFFT's work area at this length: name the nearest grids that fit
            fits, _ = _fit_tests(dtype, limit, friction, kind, fft_name, states, adhesion)
            below, above = _nearest_fitting(n, fits, best)
            near = " and ".join(f"n = {m}" for m in (below, above) if m)
            advice = (f"at 2n = {2 * n} (prime factor {_largest_prime_factor(2 * n)}) cuFFT needs a larger work "
                      f"area; the nearest grids that fit are {near}, the largest n = {best}")
        raise InputError(
            "grid.n",
            f"n = {n} needs about {need / GIB:,.2f} GiB ({dname}, {fft_name} FFT, "
            f"{'with' if friction else 'without'} friction{', with adhesion' if adhesion else ''}) but the {what} is {limit / GIB:,.2f} GiB; "
            + advice,
        )
    if kind == "cuda":
        host = host_memory_bytes()
        setup = setup_host_bytes(n, dtype, fft_name, kind)
        if host and setup > host:
            raise InputError(
                "grid.n",
                f"n = {n} needs about {setup / GIB:,.2f} GiB of host memory to build the influence spectra "
                f"but the RAM of this machine is {host / GIB:,.2f} GiB",
            )
    return estimate_bytes(n, dtype, kind, friction, fft_name, states=states, adhesion=adhesion)

"""FFTW through pyFFTW on the CPU: the scipy backend's transforms, planned once and run in place.

The same pruned pair and spectral layout as :mod:`.scipy_backend` ((2 ny, nx + 1), real-to-complex
along x): the forward pass transforms the ny data rows of the kept (ny, 2 nx) ``padded_input``
straight into the top half of the spectrum and the columns in place; the inverse transforms the
columns in place and the ny kept rows straight into the (ny, 2 nx) ``padded_output``, whose left
half the solver kernels read, unnormalised (``output_scale`` = 1 / (4 nx ny)). No temporary
arrays and no copies between the passes, which scipy.fft makes (it returns new arrays).

Plans are made on first use for each spectrum array the backend meets (an operator has three)
and kept: measured (``FFTW_MEASURE``) from ``MEASURE_FROM_CELLS`` cells on, where they take
1.2-1.5x less time than estimated ones, else estimated (``FFTW_ESTIMATE``, milliseconds to
make). What the measuring learns (FFTW's wisdom) is kept in a file per machine
(:func:`wisdom_path`), so a grid size is measured once per machine, not once per run.

Optional: ``pip install warpcontact[fftw]``. pyFFTW is BSD-licensed, but its wheels bundle FFTW,
which is GPL-2.0-or-later: see the README.
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import sys
from pathlib import Path

# pyFFTW's wheels run FFTW's threads under GNU OpenMP, whose idle threads spin for a while after
# each transform (OMP_WAIT_POLICY unset): on 2 cores they took a core from the solver's passes
# that follow (n = 512: normal_update 1.53 -> 2.70 ms, a Hertz solve 0.67-0.69 -> 0.86-0.95 s). Passive
# waiting, unless the user chose otherwise; read once, when OpenMP starts (at pyFFTW's import).
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

import numpy as np  # noqa: E402
import warp as wp  # noqa: E402

from .base import FFTBackend, cpu_threads  # noqa: E402
from .scipy_backend import PeriodicScipyFFT, ScipyFFT  # noqa: E402


#: what pyFFTW's package imports for its ``interfaces`` to other libraries (pyfftw/interfaces/
#: __init__.py: ``import scipy.fftpack`` and ``from dask.array.fft import fft_wrap``, each in a
#: try), none of which this backend uses: 0.5 s of a process's 0.7 s import on 2 cores
#: (``python -X importtime``), 0.0 s without them
PYFFTW_UNUSED_IMPORTS = ("scipy.fftpack", "dask")


def import_pyfftw():
    """pyFFTW's module, imported without the scipy and dask interfaces it would load
    (``PYFFTW_UNUSED_IMPORTS``): those not yet imported are marked missing while pyFFTW imports,
    so that its ``try`` passes over them, and unmarked after. Raises ImportError without pyFFTW.
    pyFFTW's own interfaces to them stay importable by name (``import
    pyfftw.interfaces.scipy_fft``)."""
    pyfftw = sys.modules.get("pyfftw")
    if pyfftw is not None:
        return pyfftw
    marked = [name for name in PYFFTW_UNUSED_IMPORTS if name not in sys.modules]
    for name in marked:
        sys.modules[name] = None
    try:
        import pyfftw
    finally:
        for name in marked:
            if name in sys.modules and sys.modules[name] is None:
                del sys.modules[name]
    return pyfftw


def available() -> bool:
    """True when pyFFTW can be imported."""
    try:
        import_pyfftw()
    except ImportError:
        return False
    return True


#: grids of at least this many cells get measured plans (``FFTW_MEASURE``, their wisdom kept on
#: disk: planned once per machine and size), smaller ones estimated plans: a measured plan's
#: transforms are 15-30 % faster, and its planning (0.1-5 s) is paid once per machine and size
MEASURE_FROM_CELLS = 48 * 48
#: the folder measured plans are kept in between runs (FFTW's "wisdom", a text per precision), one
#: file per machine; None: $XDG_CACHE_HOME/warpcontact or ~/.cache/warpcontact. The environment
#: variable WARPCONTACT_FFTW_WISDOM names another file, or "" for none
WISDOM_FOLDER: Path | None = None
_wisdom_loaded = False


def wisdom_path() -> Path | None:
    """The file this machine's FFTW wisdom is kept in (None: not kept, or no home folder)."""
    chosen = os.environ.get("WARPCONTACT_FFTW_WISDOM")
    if chosen is not None:
        return Path(chosen) if chosen else None
    pyfftw = import_pyfftw()

    folder = WISDOM_FOLDER
    if folder is None:
        try:
            folder = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "warpcontact"
        except RuntimeError:  # no home folder to be found
            return None
    machine = f"{platform.node()} {platform.machine()} {platform.processor()} {os.cpu_count()} {pyfftw.__version__}"
    return folder / f"fftw-wisdom-{hashlib.sha1(machine.encode()).hexdigest()[:12]}.json"


def _load_wisdom():
    """Import the kept wisdom, once per process (an unreadable file counts as none)."""
    global _wisdom_loaded
    if _wisdom_loaded:
        return
    _wisdom_loaded = True
    path = wisdom_path()
    if path is None or not path.exists():
        return
    pyfftw = import_pyfftw()

    try:
        texts = json.loads(path.read_text())
        pyfftw.import_wisdom(tuple(t.encode("ascii") for t in texts))
    except (OSError, ValueError, TypeError, AttributeError):
        pass  # measured again and written anew


def _save_wisdom():
    """Write all wisdom of this process to the kept file (atomically; a failure costs only time)."""
    path = wisdom_path()
    if path is None:
        return
    pyfftw = import_pyfftw()

    from ..files import atomic_write_bytes

    try:
        atomic_write_bytes(path, json.dumps([t.decode("ascii") for t in pyfftw.export_wisdom()]).encode())
    except OSError:
        pass


def _scratch_like(a: np.ndarray) -> np.ndarray:
    """An aligned array of ``a``'s shape, type and strides (a view into a buffer of its own), for
    measuring plans whose wisdom then serves ``a``'s layout."""
    pyfftw = import_pyfftw()
    extent = sum((d - 1) * s for d, s in zip(a.shape, a.strides)) // a.itemsize + 1
    buffer = pyfftw.empty_aligned(extent, a.dtype)
    return np.lib.stride_tricks.as_strided(buffer, a.shape, a.strides)


class FFTWPlans:
    """The transforms of one spectrum (or of a stack of them: every axis before the last two is a
    batch axis), made with the planner ``flags``: the rows' real-to-complex transform of
    ``rows_in``'s data rows and the columns' forward transform (None: no forward pair), and the
    columns' inverse and the rows' complex-to-real transform into ``rows_out`` (None: no inverse
    pair)."""

    def __init__(self, rows_in: np.ndarray | None, spectrum: np.ndarray, rows_out: np.ndarray | None, threads: int,
                 flags=()):
        pyfftw = import_pyfftw()

        ny = spectrum.shape[-2] // 2
        common = dict(flags=tuple(flags) or ("FFTW_ESTIMATE",), threads=threads)
        self.spectrum, self.ny = spectrum, ny
        if rows_in is not None:
            self.rows_forward = pyfftw.FFTW(rows_in, spectrum[..., :ny, :], axes=(-1,), direction="FFTW_FORWARD",
                                            **common)
            self.columns_forward = pyfftw.FFTW(spectrum, spectrum, axes=(-2,), direction="FFTW_FORWARD", **common)
        if rows_out is not None:
            self.columns_inverse = pyfftw.FFTW(spectrum, spectrum, axes=(-2,), direction="FFTW_BACKWARD",
                                               normalise_idft=False, **common)
            # complex-to-real overwrites its input (the spectrum's top half), which inverse transforms may
            self.rows_inverse = pyfftw.FFTW(spectrum[..., :ny, :], rows_out, axes=(-1,), direction="FFTW_BACKWARD",
                                            normalise_idft=False, **common)

    def forward(self):
        """The spectrum <- the transform of ``rows_in``'s rows zero-padded below them (the
        spectrum's bottom half zeroed between the passes)."""
        self.rows_forward.execute()
        self.spectrum[..., self.ny :, :] = 0
        self.columns_forward.execute()

    def inverse(self):
        """``rows_out`` <- the unnormalised inverse transform's top rows (the spectrum overwritten)."""
        self.columns_inverse.execute()
        self.rows_inverse.execute()

    @classmethod
    def measured(cls, rows_in: np.ndarray, spectrum: np.ndarray, rows_out: np.ndarray, threads: int,
                 measure_new: bool = True) -> "FFTWPlans":
        """Measured plans for these arrays, without touching them: from wisdom (kept on disk,
        :func:`wisdom_path`) when there is some for their layout; else measured first on scratch
        arrays of the same layout (``FFTW_MEASURE`` runs the transforms on the arrays it plans
        for) and the wisdom written back, or with ``measure_new`` False estimated plans (a grid
        used for a few solves, whose measuring would cost more than it saves). ``rows_in`` or
        ``rows_out`` None: that direction's pair not made."""
        _load_wisdom()
        wise = ("FFTW_MEASURE", "FFTW_WISDOM_ONLY")
        try:
            return cls(rows_in, spectrum, rows_out, threads, wise)
        except RuntimeError:  # no wisdom for this layout yet
            pass
        if not measure_new:
            return cls(rows_in, spectrum, rows_out, threads)
        scratch = [None if a is None else _scratch_like(a) for a in (rows_in, spectrum, rows_out)]
        cls(*scratch, threads, ("FFTW_MEASURE",))
        _save_wisdom()
        try:
            return cls(rows_in, spectrum, rows_out, threads, wise)
        except RuntimeError:  # an alignment the scratch arrays did not have: estimate
            return cls(rows_in, spectrum, rows_out, threads)


class PeriodicFFTWPlans(FFTWPlans):
    """The 2-D transforms of one spectrum (or a stack: leading batch axes) of periodic grids
    (``PeriodicFFTW``, ``BatchLibrary.periodic_forward``): real-to-complex from ``field_in`` and the
    unnormalised complex-to-real inverse into ``field_out`` (which may overwrite the spectrum),
    with the planner ``flags``; ``field_in`` or ``field_out`` None: that direction not made."""

    def __init__(self, field_in: np.ndarray | None, spectrum: np.ndarray, field_out: np.ndarray | None, threads: int,
                 flags=()):
        pyfftw = import_pyfftw()

        common = dict(axes=(-2, -1), flags=tuple(flags) or ("FFTW_ESTIMATE",), threads=threads)
        self.spectrum = spectrum
        if field_in is not None:
            self._forward = pyfftw.FFTW(field_in, spectrum, direction="FFTW_FORWARD", **common)
        if field_out is not None:
            self._inverse = pyfftw.FFTW(spectrum, field_out, direction="FFTW_BACKWARD", normalise_idft=False,
                                        **common)

    def forward(self):
        """The spectrum <- the transform of ``field_in``."""
        self._forward.execute()

    def inverse(self):
        """``field_out`` <- the unnormalised inverse transform (the spectrum overwritten)."""
        self._inverse.execute()


class _Planned:
    """What the FFTW backends share: their plans made on first use per spectrum array and kept
    (``plan_type``, of the arrays ``_plan_arrays`` gives), measured where ``measure`` (from
    wisdom, or measured anew unless ``transient``), else estimated."""

    plan_type = FFTWPlans

    def _plan_arrays(self, spectrum: wp.array2d) -> tuple:
        raise NotImplementedError

    def transient(self):
        """This backend's grid serves a few solves (a tangential solve's window, whose size
        follows the contact from state to state): plans from the machine's wisdom where it has
        some, else estimated, not measured. A path at n = 512 on a machine without wisdom met 19
        layouts, and measuring them took 14 s of its solve."""
        super().transient()
        self.measure_new = False

    def _plans_for(self, spectrum: wp.array2d) -> FFTWPlans:
        plans = self._plans.get(spectrum.ptr)
        if plans is None or plans.spectrum.shape != spectrum.shape:
            arrays = (*self._plan_arrays(spectrum), self.workers)
            kind = self.plan_type
            plans = kind.measured(*arrays, measure_new=self.measure_new) if self.measure else kind(*arrays)
            self._plans[spectrum.ptr] = plans
        return plans

    def transform_input(self, spectrum):
        self._plans_for(spectrum).forward()

    def transform_to_output(self, spectrum):
        self._plans_for(spectrum).inverse()


class FFTWBackend(_Planned, ScipyFFT):
    name = "fftw"
    #: FFTW's threads from this many cells on (``base.cpu_threads``): below it a transform is faster
    #: on one thread than on two (docs/performance.md, "Many cases: the batch engine")
    THREADS_FROM_CELLS = 256 * 256

    def __init__(self, ny, nx, device, dtype, workers: int | None = None, measure: bool | None = None):
        super().__init__(ny, nx, device, dtype, workers)
        #: the (ny, 2 nx) unnormalised inverse rows; the solver kernels read the left half
        self.padded_output = wp.zeros((ny, 2 * nx), dtype=dtype, device=self.device)
        self._output = self.padded_output.numpy()
        self.output_scale = dtype(1.0 / (4 * nx * ny))
        #: measured plans (default: from MEASURE_FROM_CELLS cells on), else estimated
        self.measure = ny * nx >= MEASURE_FROM_CELLS if measure is None else bool(measure)
        #: layouts without wisdom are measured (a grid solved on for a whole path); False: estimated
        #: (``transient``)
        self.measure_new = True
        self._plans: dict[int, FFTWPlans] = {}

    def spectrum_of_padded(self, padded):
        """The scipy backend's spectrum (layout (2 ny, nx + 1)), made by FFTW with an estimated
        plan (once per influence array: measuring would cost more than it saves), from the array
        where it is (unaligned plans: no aligned copy) into a new spectrum, its only temporary."""
        pyfftw = import_pyfftw()
        padded = np.asarray(padded, dtype=np.float64)
        spectrum = pyfftw.empty_aligned((padded.shape[0], padded.shape[1] // 2 + 1), dtype=np.complex128)
        pyfftw.FFTW(padded, spectrum, axes=(0, 1), direction="FFTW_FORWARD", threads=self.workers,
                    flags=("FFTW_ESTIMATE", "FFTW_UNALIGNED"))()
        return spectrum

    def _plan_arrays(self, spectrum):
        return self._rows, self._complex_view(spectrum), self._output

    # padding and cropping kernels around the transforms (scipy's numpy copies assume its layout)
    forward = FFTBackend.forward
    inverse = FFTBackend.inverse


class PeriodicFFTW(_Planned, PeriodicScipyFFT):
    """FFTW's 2-D transforms of the (ny, nx) grid itself, periodic (``FFTBackend.periodic``): the
    preconditioners' circulants (``make_periodic_fft``) beside an ``FFTWBackend``. Plans as
    ``FFTWBackend``'s: made on first use per spectrum, measured from wisdom (or estimated where a
    ``transient`` grid's layout has none); the inverse unnormalised (``output_scale`` 1 / (ny nx))."""

    name = "fftw"
    plan_type = PeriodicFFTWPlans

    def __init__(self, ny, nx, device, dtype, workers: int | None = None):
        super().__init__(ny, nx, device, dtype, workers or cpu_threads(ny * nx // 4, FFTWBackend.THREADS_FROM_CELLS))
        self.output_scale = dtype(1.0 / (ny * nx))
        self.measure = ny * nx >= MEASURE_FROM_CELLS
        self.measure_new = True
        self._plans: dict[int, PeriodicFFTWPlans] = {}

    def _plan_arrays(self, spectrum):
        return self._input, self._complex_view(spectrum), self._output

"""Files written whole or not at all: a temporary file and a rename, and an error naming the file
when the disk refuses (the writes of every layer: results, FFTW's wisdom, a sweep's and a fit's
records)."""

from __future__ import annotations

import errno
import io
import json
import os
import secrets
import shutil
from pathlib import Path

import numpy as np

from .errors import OutputError


def _write_temporary(tmp: Path, data) -> None:
    """Create ``tmp`` (a name of our own: O_EXCL; mode 0666 less the umask, an ordinary file's,
    not mkstemp's 0600) and write ``data`` to it: bytes (or a view of them), or a function that
    writes the file's bytes to the binary file it is given. The one place where output bytes
    reach the disk (tests make it fail with ENOSPC or EROFS)."""
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    with os.fdopen(fd, "wb") as fh:
        if callable(data):
            data(fh)
        else:
            fh.write(data)


def free_bytes(path) -> int | None:
    """Bytes free to an ordinary user on the file system of ``path`` (its nearest existing
    folder), or None when that cannot be told."""
    p = Path(path)
    while not p.exists() and p != p.parent:
        p = p.parent
    try:
        return shutil.disk_usage(p).free
    except OSError:
        return None


def output_error(path, e: OSError, action: str = "write", needed_bytes: int | None = None) -> OutputError:
    """``e`` (an OSError met while writing ``path``) as an OutputError naming the file, what
    failed and, for a full disk, the size of the file and the space left."""
    if isinstance(e, OutputError):
        return e
    free = free_bytes(Path(path).parent) if e.errno == errno.ENOSPC else None
    return OutputError(path, e.errno, e.strerror or str(e), action, needed_bytes, free)


def atomic_write_bytes(path, data, size: int | None = None):
    """Write ``data`` to ``path`` through a temporary file and a rename: readers see all or nothing.
    ``data``: bytes (or a view of them), or a function that writes them to the binary file it is
    given (then ``size``, about how many, for the error of a full disk).

    A failure (no space left, read-only file system, quota, I/O error, a folder that cannot be
    made) raises :class:`~warpcontact.errors.OutputError` naming ``path``; the file that was at
    ``path`` before is left as it was and the temporary file is removed. An interrupt
    (KeyboardInterrupt) likewise removes the temporary file and leaves ``path`` as it was.
    """
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise output_error(path.parent, e, "create the folder") from None
    tmp = path.parent / f"{path.name}.{secrets.token_hex(6)}.tmp"
    try:
        _write_temporary(tmp, data)
        os.replace(tmp, path)
    except BaseException as e:
        try:
            tmp.unlink(missing_ok=True)  # first: the space it took counts as free in the message
        except OSError:  # the file system went away under us: nothing more to do
            pass
        if isinstance(e, OSError):
            raise output_error(path, e, "write", size if callable(data) else len(data)) from None
        raise


def atomic_write_json(path, obj):
    atomic_write_bytes(path, (json.dumps(obj, indent=2, allow_nan=True) + "\n").encode())


#: arrays of this many bytes and more are written to an NPZ file uncompressed: zlib runs at about
#: 30-200 MB/s on one core (64 MiB of fields: 0.34 s for smooth contact fields, 2.0 s for noise,
#: against 0.08 s uncompressed, on this project's 2-core machine), far below a disk's speed
NPZ_COMPRESS_BELOW_BYTES = 32 * 2**20
#: bytes an array's entry adds to an uncompressed NPZ file beside its data, about (ZIP headers and
#: NumPy's own header: at most a few hundred)
NPZ_ENTRY_BYTES = 512


class Stack(tuple):
    """Arrays of one shape and type that :func:`atomic_write_npz` writes as one array stacked
    along a new first axis (``numpy.stack``'s), without stacking them in memory first."""


def _nbytes(a) -> int:
    return sum(np.asarray(p).nbytes for p in a) if isinstance(a, Stack) else np.asarray(a).nbytes


def _write_npz(fh, arrays: dict) -> None:
    """``numpy.savez``'s file (uncompressed ZIP entries NAME.npy) of ``arrays`` into the binary
    file ``fh``, a :class:`Stack`'s entry written part by part after its stacked header."""
    import zipfile

    from numpy.lib import format as npy

    with zipfile.ZipFile(fh, "w", zipfile.ZIP_STORED, allowZip64=True) as z:
        for name, a in arrays.items():
            with z.open(f"{name}.npy", "w", force_zip64=True) as f:
                if not isinstance(a, Stack):
                    npy.write_array(f, np.asanyarray(a), allow_pickle=False)
                    continue
                first = np.asarray(a[0])
                header = {"descr": npy.dtype_to_descr(first.dtype), "fortran_order": False,
                          "shape": (len(a), *first.shape)}
                npy.write_array_header_1_0(f, header)
                for part in a:
                    f.write(np.ascontiguousarray(part, dtype=first.dtype).data)


def atomic_write_npz(path, arrays: dict, compress: bool | None = None):
    """Write ``arrays`` (arrays, or :class:`Stack` s of them) to the NPZ file ``path`` atomically
    (:func:`atomic_write_bytes`); NumPy reads it with ``np.load`` either way. ``compress``: zlib
    (smaller files); default: only when the arrays hold fewer than
    :data:`NPZ_COMPRESS_BELOW_BYTES` bytes, so large grids are written at disk speed."""
    if compress is None:
        compress = sum(_nbytes(a) for a in arrays.values()) < NPZ_COMPRESS_BELOW_BYTES
    if compress:
        buf = io.BytesIO()
        np.savez_compressed(buf, **{k: np.stack(a) if isinstance(a, Stack) else a for k, a in arrays.items()})
        atomic_write_bytes(path, buf.getbuffer())
        return
    # uncompressed: written straight to the file (at n = 1024 a path's fields are 1.8 GB, which a
    # buffer in memory first took 1.2 s more to hold on an H200's host)
    size = sum(_nbytes(a) + NPZ_ENTRY_BYTES for a in arrays.values())
    atomic_write_bytes(path, lambda fh: _write_npz(fh, arrays), size)

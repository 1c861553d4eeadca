"""The time to a first answer: the command line's parser imports no solver; large fields are written
uncompressed."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from warpcontact import files
from warpcontact.records import results


def _fresh(code: str) -> subprocess.CompletedProcess:
    """``code`` run by a fresh interpreter (nothing imported yet), its output captured."""
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)


def _fresh_ok(code: str) -> subprocess.CompletedProcess:
    """:func:`_fresh`, which must exit 0 (its standard error shown where it does not)."""
    r = _fresh(code)
    assert r.returncode == 0, r.stderr
    return r


def test_the_parser_imports_neither_warp_nor_scipy():
    """`warpcontact --help` and argument parsing load no Warp, SciPy, dask or solver module (they
    cost about a second; bench/batch_overhead.py times --help)."""
    code = ("import sys; from warpcontact.cli import _parser; _parser()\n"
            "heavy = [m for m in ('warp', 'scipy', 'distributed', 'matplotlib', 'warpcontact.numerics.model', "
            "'warpcontact.solvers', 'warpcontact.kernels') if m in sys.modules]\n"
            "print(','.join(heavy))")
    r = _fresh_ok(code)
    assert r.stdout.strip() == "", f"imported by the parser: {r.stdout.strip()}"


def test_a_cuda_case_resolves_its_fft_backend_without_the_cpu_backends():
    """Resolving "auto" for a CUDA device and the index limit import neither scipy.fft nor pyFFTW
    (measured on an H100: 1.3 s of a 4.5 s whole `warpcontact solve`, before)."""
    code = ("import sys; from warpcontact.numerics import resources as r\n"
            "print(r._resolve_fft('auto', 'cuda'), r.index_limit('float64', 'auto'))\n"
            "print(','.join(m for m in ('scipy', 'pyfftw', 'warpcontact.fft.scipy_backend') if m in sys.modules))")
    r = _fresh_ok(code)
    backend_limit, imported = r.stdout.splitlines()
    assert backend_limit.split()[0] in ("cupy", "warp") and int(backend_limit.split()[1]) == 11584
    assert imported == "", f"imported: {imported}"


def test_the_fftw_backend_imports_neither_scipy_nor_dask():
    """A CPU solve with FFTW (the default where pyFFTW is installed) imports neither scipy.fft nor
    dask: pyFFTW's package would import scipy.fftpack and dask.array for interfaces this backend does
    not use (0.5 s), and the scipy backend's module, whose layout it shares, imports scipy.fft where
    a transform is first made. Both stay importable after."""
    pytest.importorskip("pyfftw")
    code = ("import sys, numpy as np; from warpcontact.fft import make_fft\n"
            "import warp as wp; f = make_fft('fftw', 8, 8, 'cpu', wp.float64)\n"
            "s = f.spectrum_of_padded(np.ones((16, 16)))\n"
            "print(','.join(m for m in ('scipy', 'dask') if m in sys.modules), abs(s[0, 0]))\n"
            "import dask.array, scipy.fftpack, pyfftw.interfaces.scipy_fft; print('importable')")
    r = _fresh_ok(code)
    imported, importable = r.stdout.splitlines()[-2:]  # after Warp's start-up lines
    assert imported == " 256.0", f"imported: {imported}"  # the spectrum's mean term: 16 x 16 ones
    assert importable == "importable"


def test_the_package_names_load_on_first_use():
    import warpcontact as wc

    assert wc.load_case.__module__ == "warpcontact.records.case" and wc.PAPER_PAIR.E_star > 0
    assert {"solve", "gross_slip", "InputError"} <= set(dir(wc))


def test_large_fields_are_written_uncompressed_small_ones_compressed(tmp_path, monkeypatch):
    monkeypatch.setattr(files, "NPZ_COMPRESS_BELOW_BYTES", 8 * 64 * 64)  # one 64 x 64 float64 field
    small = {"p": np.zeros((32, 32))}
    large = {"p": np.zeros((64, 64)), "q": np.ones((64, 64))}
    results.atomic_write_npz(tmp_path / "small.npz", small)
    results.atomic_write_npz(tmp_path / "large.npz", large)
    # zeros compress to almost nothing; uncompressed the file holds every byte
    assert (tmp_path / "small.npz").stat().st_size < small["p"].nbytes / 4
    assert (tmp_path / "large.npz").stat().st_size > sum(a.nbytes for a in large.values())
    with np.load(tmp_path / "large.npz") as f:
        assert np.array_equal(f["q"], large["q"])
    results.atomic_write_npz(tmp_path / "forced.npz", large, compress=True)
    assert (tmp_path / "forced.npz").stat().st_size < large["p"].nbytes / 4


def test_a_large_npz_goes_straight_to_its_file_and_a_full_disk_names_its_size(tmp_path, monkeypatch):
    """An uncompressed NPZ is written by NumPy straight into the temporary file (no copy of it in
    memory first): the same arrays come back, the size it is said to need is at least the file's
    (each entry's headers counted as ``NPZ_ENTRY_BYTES``) and within those headers of it, and a
    disk that fills during the write leaves the file that was there and no temporary file."""
    import errno
    import os

    from warpcontact.errors import OutputError

    monkeypatch.setattr(files, "NPZ_COMPRESS_BELOW_BYTES", 0)
    states = [np.arange(4096.0).reshape(64, 64) * k for k in range(3)]
    arrays = {"p": files.Stack(states), "stick": np.arange(4096).reshape(64, 64) % 3 == 0}
    path = tmp_path / "fields.npz"
    files.atomic_write_npz(path, arrays)
    with np.load(path) as f:  # a Stack as numpy.stack of its arrays
        assert np.array_equal(f["p"], np.stack(states)) and np.array_equal(f["stick"], arrays["stick"])
    files.atomic_write_npz(tmp_path / "small.npz", arrays, compress=True)
    with np.load(tmp_path / "small.npz") as f:
        assert np.array_equal(f["p"], np.stack(states))
    (tmp_path / "small.npz").unlink()
    size = path.stat().st_size
    estimate = sum(np.stack(a).nbytes + files.NPZ_ENTRY_BYTES for a in arrays.values())
    assert size <= estimate <= size + len(arrays) * files.NPZ_ENTRY_BYTES

    def fills_up(tmp, data):
        with open(tmp, "wb") as fh:
            data(fh)
            fh.truncate(100)
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(files, "_write_temporary", fills_up)
    with pytest.raises(OutputError) as caught:
        files.atomic_write_npz(path, {"p": np.zeros((64, 64))})
    assert caught.value.needed_bytes == 64 * 64 * 8 + files.NPZ_ENTRY_BYTES
    assert path.stat().st_size == size and [q.name for q in tmp_path.iterdir()] == ["fields.npz"]


def test_the_command_ends_its_process_with_its_status_after_the_exit_functions():
    """``warpcontact`` ends through ``cli.end_process``: what was printed is flushed, the exit
    functions run (logging's, dask's, ...), and the status is the command's; the interpreter's
    teardown is skipped (0.4-0.6 s of a solve's process)."""
    code = ("import atexit, sys; from warpcontact.cli import end_process\n"
            "atexit.register(lambda: print('exit function ran'))\n"
            "print('printed before', end=''); sys.stdout.write(' and buffered\\n'); end_process(3)\n"
            "print('never')")
    r = _fresh(code)
    assert r.returncode == 3, r.stderr
    assert r.stdout.splitlines() == ["printed before and buffered", "exit function ran"], r.stdout


def test_a_solve_through_the_command_writes_everything_and_exits_0(tmp_path):
    """The whole command, in its own process as a user runs it: result.json complete, exit 0."""
    import json

    case = tmp_path / "hertz.toml"
    case.write_text((Path(__file__).parents[1] / "examples" / "hertz.toml").read_text().replace("n = 128", "n = 32"))
    r = subprocess.run([sys.executable, "-m", "warpcontact.cli", "solve", str(case), "--out", str(tmp_path / "out"),
                        "--quiet"], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert json.loads((tmp_path / "out" / "result.json").read_text())["complete"] is True
    with np.load(tmp_path / "out" / "fields.npz") as f:
        assert f["pressure"].shape[-2:] == (32, 32)



def test_a_cpu_run_prints_no_notice_about_a_missing_cuda_driver():
    """Warp's native start-up writes "Could not find or load the NVIDIA CUDA driver" to standard
    error where no driver is installed (this machine in CI): a CPU user's every command would show
    it. ``init_warp`` leaves that line out (on a GPU machine Warp does not print it)."""
    from warpcontact.numerics.device import NO_DRIVER_NOTICE

    r = _fresh_ok("from warpcontact.numerics.device import resolve_device; print(resolve_device('cpu'))")
    assert r.stdout.strip() == "cpu"
    assert NO_DRIVER_NOTICE not in r.stderr, r.stderr


def test_init_warp_keeps_whatever_else_the_native_start_up_prints(monkeypatch, capfd):
    """Only the driver notice is dropped: another line the native library writes to file
    descriptor 2 during ``wp.init`` still reaches standard error."""
    import os

    import warp as wp

    from warpcontact.numerics import device

    def native_init():
        os.write(2, f"{device.NO_DRIVER_NOTICE}. GPU execution will not be available.\n".encode())
        os.write(2, b"Warp error: something the user must see\n")

    monkeypatch.setattr(wp, "init", native_init)
    monkeypatch.setattr(device, "_initialised", False)
    device.init_warp()
    err = capfd.readouterr().err
    assert err == "Warp error: something the user must see\n", err

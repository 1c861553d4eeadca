"""Write errors: a full disk (ENOSPC), a read-only file system (EROFS), a quota (EDQUOT), an I/O error
(EIO) while writing any output end the run with one line naming the file and what failed (for a
full disk, about how much space the file needs), exit status 74, and what was written before left
whole and valid; sweeps and tables keep their finished cases, and a rerun resumes.

The faults are injected where output bytes reach the disk (``files._write_temporary``, which
writes part of the file before failing, as a full disk does), so no mount is needed; one test
also fills a real 600 KiB tmpfs and remounts it read-only, where the machine lets it (root).
"""

import errno
import io
import json
import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from warpcontact import files, interrupts
from warpcontact.records import results
from warpcontact.cli import EXIT_WRITE_ERROR, main
from warpcontact.errors import OutputError

ROOT = Path(__file__).resolve().parents[1]
HERTZ = (ROOT / "examples" / "hertz.toml").read_text()
TABLE2_CASE = (ROOT / "examples" / "table2_k080_dz5e-5.toml").read_text()
#: 4 states (2 normal, 2 tangential) on 40 cells (the contact radius spans 9.6): a path in about a second
SHORT_PATH = TABLE2_CASE.replace("n = 96", "n = 40").replace("steps = 4 ", "steps = 2\ndelta_x = 3e-11 ")


@pytest.fixture(autouse=True)
def _signals_as_they_were():
    """main() installs the stop handlers in this process: put pytest's back afterwards."""
    saved = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}
    yield
    for s, h in saved.items():
        signal.signal(s, h)
    interrupts.reset()


def fail_writes(monkeypatch, code, when=lambda path, data: True):
    """Make every output write for which ``when(path, data)`` holds fail with ``code``, after half
    of its bytes reached the file (a disk that fills up during the write). Returns the list of the
    paths that failed."""
    real = files._write_temporary
    failed = []

    def write(tmp, data):
        target = tmp.parent / ".".join(tmp.name.split(".")[:-2])  # name.<token>.tmp -> name
        if callable(data):  # a file written by a function of its own (a large NPZ): its bytes
            buf = io.BytesIO()
            data(buf)
            data = buf.getvalue()
        if not when(target, data):
            return real(tmp, data)
        real(tmp, data[: len(data) // 2])
        failed.append(target)
        raise OSError(code, os.strerror(code))

    monkeypatch.setattr(files, "_write_temporary", write)
    return failed


def error_line(capsys) -> str:
    """The one error line of stderr (no traceback), without Warp's line about CUDA and the run's
    warnings (a coarse grid, a pressure above a yield strength)."""
    err = capsys.readouterr().err
    lines = [ln for ln in err.strip().splitlines()
             if not ln.startswith(("Warp CUDA warning", "warpcontact: warning: "))]
    assert len(lines) == 1 and "Traceback" not in err, err
    assert lines[0].startswith("warpcontact: error: cannot "), lines[0]
    return lines[0]


def no_temporary_files(folder):
    left = [p.name for p in Path(folder).rglob("*.tmp")]
    assert not left, left


def case_file(tmp_path, text, name="case.toml"):
    p = tmp_path / name
    p.write_text(text)
    return p


# --- the atomic writer ------------------------------------------------------------------------------


@pytest.mark.parametrize("code, reason", [(errno.ENOSPC, "no space left on device"),
                                          (errno.EROFS, "read-only file system"),
                                          (errno.EDQUOT, "disk quota exceeded"),
                                          (errno.EIO, "input/output error")])
def test_a_failed_write_leaves_the_old_file_and_no_temporary(tmp_path, monkeypatch, code, reason):
    target = tmp_path / "result.json"
    target.write_text('{"old": true}\n')
    fail_writes(monkeypatch, code)
    with pytest.raises(OutputError) as caught:
        results.atomic_write_json(target, {"new": list(range(1000))})
    e = caught.value
    assert e.errno == code and e.path == str(target) and e.needed_bytes == len(json.dumps(
        {"new": list(range(1000))}, indent=2)) + 1
    text = str(e)
    assert text.startswith(f"cannot write {target}: {reason}"), text
    # the size needed (8908 B) is said for the errors that more space cures
    assert ("the file needs about 8.7 KiB" in text) == (code in (errno.ENOSPC, errno.EDQUOT)), text
    assert ("free there" in text) == (code == errno.ENOSPC), text
    assert target.read_text() == '{"old": true}\n'
    assert sorted(p.name for p in tmp_path.iterdir()) == ["result.json"]


def test_a_folder_that_cannot_be_made_is_named(tmp_path, monkeypatch):
    def refuse(self, *a, **kw):
        raise OSError(errno.EROFS, os.strerror(errno.EROFS))

    monkeypatch.setattr(Path, "mkdir", refuse)
    with pytest.raises(OutputError) as caught:
        results.atomic_write_bytes(tmp_path / "new" / "result.json", b"{}")
    assert str(caught.value) == f"cannot create the folder {tmp_path / 'new'}: read-only file system"


# --- solve ------------------------------------------------------------------------------------------


def test_solve_fields_that_do_not_fit_name_the_option_that_writes_fewer(tmp_path, monkeypatch, capsys):
    """A disk with room for result.json, not for fields.npz. One line naming fields.npz, the space
    it needs and --fields; result.json holds every state, marked not complete, the error in it."""
    out = tmp_path / "out"
    failed = fail_writes(monkeypatch, errno.ENOSPC, lambda path, data: path.name == "fields.npz")
    status = main(["solve", str(case_file(tmp_path, SHORT_PATH)), "--out", str(out), "--quiet"])
    assert status == EXIT_WRITE_ERROR == 74 and failed == [out / "fields.npz"]
    line = error_line(capsys)
    assert line.startswith(f"warpcontact: error: cannot write {out / 'fields.npz'}: no space left on device "
                           "(the file needs about "), line
    assert "free there" in line and "the fields of 4 state(s) are what does not fit" in line, line
    assert "--fields last writes the last state's (about " in line and "--fields none" in line, line
    res = json.loads((out / "result.json").read_text())
    assert res["complete"] is False and res["interrupted"] is False and res["converged"] is True
    assert res["n_states"] == res["n_states_planned"] == len(res["states"]) == 4
    assert res["fields_file"] is None and res["write_error"] == line.removeprefix("warpcontact: error: ")
    assert sorted(p.name for p in out.iterdir()) == ["result.json"]

    monkeypatch.undo()  # space made: the option the line names
    assert main(["solve", str(case_file(tmp_path, SHORT_PATH)), "--out", str(out), "--quiet",
                 "--fields", "last"]) == 0
    res = json.loads((out / "result.json").read_text())
    assert res["complete"] is True and res["fields_kept"] == "last" and "write_error" not in res
    with np.load(out / "fields.npz", allow_pickle=False) as f:
        assert f["state_index"].tolist() == [3] and f["pressure"].shape == (1, 40, 40)
        assert f["delta"].tolist() == [[s["delta"][c] for c in "xyz"] for s in res["states"][-1:]]


def test_solve_into_a_read_only_folder_leaves_the_earlier_run_whole(tmp_path, monkeypatch, capsys):
    out = tmp_path / "out"
    out.mkdir()
    earlier = {"complete": True, "n_states": 1, "states": [{"converged": True}]}
    (out / "result.json").write_text(json.dumps(earlier))
    np.savez(out / "fields.npz", pressure=np.ones((1, 4, 4)))
    fields_bytes = (out / "fields.npz").read_bytes()
    fail_writes(monkeypatch, errno.EROFS)
    status = main(["solve", str(case_file(tmp_path, SHORT_PATH)), "--out", str(out), "--quiet"])
    assert status == 74
    assert error_line(capsys) == f"warpcontact: error: cannot write {out / 'result.json'}: read-only file system"
    # the first write failed: the earlier run's two files are left, and left together
    assert json.loads((out / "result.json").read_text()) == earlier
    assert (out / "fields.npz").read_bytes() == fields_bytes
    no_temporary_files(out)


def test_solve_disk_full_mid_path_keeps_the_states_written(tmp_path, monkeypatch, capsys):
    """The second write of result.json (after state 2; in a new folder nothing is written before
    the first state) fails: the run ends there; the file on disk is the first write, whole, with
    state 1, marked not complete."""
    out = tmp_path / "out"
    writes = []

    def second_result_write(path, data):
        if path.name == "result.json":
            writes.append(path)
        return len(writes) == 2

    fail_writes(monkeypatch, errno.ENOSPC, second_result_write)
    status = main(["solve", str(case_file(tmp_path, SHORT_PATH)), "--out", str(out), "--quiet"])
    assert status == 74
    line = error_line(capsys)
    assert f"cannot write {out / 'result.json'}: no space left on device (the file needs about" in line, line
    res = json.loads((out / "result.json").read_text())
    assert res["complete"] is False and res["n_states"] == len(res["states"]) == 1
    assert sorted(p.name for p in out.iterdir()) == ["result.json"]


# --- pull-off, figure -------------------------------------------------------------------------------


def test_pull_off_plot_that_does_not_fit(tmp_path, monkeypatch, capsys):
    """The plot is written with matplotlib's own writer (plots.save): its OSError is named too, and
    result.json keeps the results, not complete."""
    from warpcontact import plots

    def full(fig, path, dpi=None):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(plots, "save", full)
    text = (ROOT / "examples" / "pull_off_dmt.toml").read_text()  # n = 64, 5 states: about a second
    out = tmp_path / "po"
    status = main(["pull-off", str(case_file(tmp_path, text)), "--out", str(out), "--steps", "2", "--quiet"])
    assert status == 74
    line = error_line(capsys)
    assert line.startswith(f"warpcontact: error: cannot write {out / 'pull_off.png'}: no space left on device"), line
    res = json.loads((out / "result.json").read_text())
    assert res["complete"] is False and res["pull_off_force"] < 0 and len(res["curve"]) == 5
    assert res["write_error"] == line.removeprefix("warpcontact: error: ")


def test_figure_on_a_full_disk(tmp_path, monkeypatch, capsys):
    """An OSError of the system's from any writer reaches main: one line with its file, exit 74."""
    from warpcontact import plots

    out = tmp_path / "run"
    assert main(["solve", str(case_file(tmp_path, HERTZ.replace("n = 128 ", "n = 24 "))), "--out", str(out),
                 "--quiet"]) == 0
    capsys.readouterr()

    def full(fig, path, dpi=None):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))

    monkeypatch.setattr(plots, "save", full)
    assert main(["figure", str(out), "--out", str(tmp_path / "fig"), "--quiet"]) == 74
    assert error_line(capsys) == (f"warpcontact: error: cannot write {tmp_path / 'fig' / 'area_map.png'}: "
                                  "no space left on device")


# --- sweep ------------------------------------------------------------------------------------------


def test_sweep_disk_full_keeps_the_finished_cases_and_a_rerun_resumes(tmp_path, monkeypatch, capsys):
    case_file(tmp_path, HERTZ)
    sweep = case_file(tmp_path, 'base = "case.toml"\n[sweep]\n"grid.n" = [32, 48]\n', "sweep.toml")
    out = tmp_path / "sw"
    records = []

    def second_case(path, data):
        if path.parent.name == "cases":
            records.append(path)
        return len(records) == 2 and path.parent.name == "cases"

    fail_writes(monkeypatch, errno.ENOSPC, second_case)
    # --workers 1: the cases in this process, one after another (the second case's record is the one that fails)
    assert main(["sweep", str(sweep), "--out", str(out), "--quiet", "--workers", "1"]) == 74
    line = error_line(capsys)
    assert f"cannot write {records[1]}: no space left on device (the file needs about " in line, line
    assert line.endswith(f"; 1 of 2 case(s) finished and kept in {out}: free space and run the same command again "
                         "to resume"), line
    kept = list((out / "cases").glob("*.json"))
    assert kept == [records[0]]
    first = json.loads(kept[0].read_text())
    assert first["params"] == {"grid.n": 32} and first["converged"]
    status = json.loads((out / "sweep.json").read_text())
    assert status["complete"] is False and status["finished"] == 1 and status["finished_ids"] == [first["id"]]
    no_temporary_files(out)

    monkeypatch.undo()
    assert main(["sweep", str(sweep), "--out", str(out)]) == 0
    assert "1 computed, 1 skipped" in capsys.readouterr().err
    assert json.loads(kept[0].read_text()) == first  # kept, not recomputed
    status = json.loads((out / "sweep.json").read_text())
    assert status["complete"] is True and status["finished"] == 2


# --- table2 -----------------------------------------------------------------------------------------


def fake_cell(calls):
    """table2_cell without the solve (the write path is what is tried here): a whole record."""

    def cell(k_tau, delta_z_um, settings, on_state=None, adhesion=False, model=None):
        calls.append((k_tau, delta_z_um))
        return {"k_tau": k_tau, "delta_z_um": delta_z_um, "adhesion": adhesion, "n": settings.n,
                "delta_x_max_um": 1e-5, "paper_delta_x_max_um": 1e-5, "rel_diff_delta_x_max": 0.0, "mu": 0.5,
                "paper_mu": 0.5, "rel_diff_mu": 0.0, "mu_elastic": 0.5, "converged": True, "elapsed_s": 0.0}

    return cell


def test_table2_disk_full_keeps_the_finished_cells_and_a_rerun_resumes(tmp_path, monkeypatch, capsys):
    from warpcontact.studies import table2

    calls, writer = [], files._write_temporary
    monkeypatch.setattr(table2, "table2_cell", fake_cell(calls))
    out = tmp_path / "t2"
    argv = ["table2", "--no-adhesion", "--n", "24", "--k-tau", "0.5", "--delta-z-um", "1e-5", "5e-5", "1e-4",
            "--quiet", "--out", str(out)]
    # table2.json with its second cell does not fit
    fail_writes(monkeypatch, errno.ENOSPC,
                lambda path, data: path.name == "table2.json" and len(json.loads(data)["cells"]) == 2)
    assert main(argv) == 74
    line = error_line(capsys)
    assert f"cannot write {out / 'table2.json'}: no space left on device (the file needs about " in line, line
    assert line.endswith(f"; 1 cell(s) finished and kept in {out / 'table2.json'}: free space and run the same "
                         "command again to compute the others"), line
    assert calls == [(0.5, 1e-5), (0.5, 5e-5)]
    table = json.loads((out / "table2.json").read_text())
    assert table["complete"] is False and [c["delta_z_um"] for c in table["cells"]] == [1e-5]
    assert len((out / "table2.md").read_text().splitlines()) == 2 + 1
    no_temporary_files(out)

    monkeypatch.setattr(files, "_write_temporary", writer)  # space made
    calls.clear()
    assert main(argv) == 0
    assert calls == [(0.5, 5e-5), (0.5, 1e-4)]  # the finished cell is not computed again
    table = json.loads((out / "table2.json").read_text())
    assert table["complete"] is True and [c["delta_z_um"] for c in table["cells"]] == [1e-5, 5e-5, 1e-4]


# --- a real full disk and a real read-only file system ----------------------------------------------


@pytest.fixture
def small_tmpfs(tmp_path):
    """A 600 KiB tmpfs mounted on tmp_path/full (root only; skipped where mounting is refused)."""
    mnt = tmp_path / "full"
    mnt.mkdir()
    if os.geteuid() != 0:
        pytest.skip("mounting a small tmpfs needs root; the monkeypatched tests above cover the same code")
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=600k", "tmpfs", str(mnt)], capture_output=True, text=True)
    if r.returncode != 0:
        pytest.skip(f"mount -t tmpfs refused here ({r.stderr.strip() or r.returncode}); the monkeypatched tests "
                    "cover the same code")
    try:
        yield mnt
    finally:
        subprocess.run(["umount", str(mnt)], check=True)


def test_a_real_full_disk_then_read_only(small_tmpfs, tmp_path):
    """A real full disk, as a user meets it: Hertz at n = 256 (fields.npz of 717 KiB) into 600 KiB."""
    case = case_file(tmp_path, HERTZ.replace("n = 128 ", "n = 256 "))
    out = small_tmpfs / "out"

    def solve(*extra):
        return subprocess.run([sys.executable, "-m", "warpcontact.cli", "solve", str(case), "--out", str(out),
                               "--quiet", *extra], capture_output=True, text=True, timeout=300)

    r = solve()
    assert r.returncode == 74, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if not ln.startswith("Warp CUDA warning")]
    assert len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    assert lines[0].startswith(f"warpcontact: error: cannot write {out / 'fields.npz'}: no space left on device "
                               "(the file needs about "), lines[0]
    # 717 KiB here (zlib's compression of the fields): more than the 600 KiB the disk has, less than the raw 9 MiB
    needed = float(re.search(r"needs about ([0-9.]+) KiB; ([0-9.]+) KiB free there", lines[0]).group(1))
    assert 600 < needed < 1024, lines[0]
    assert "--fields none writes none" in lines[0]
    res = json.loads((out / "result.json").read_text())
    assert res["complete"] is False and res["n_states"] == 1 and res["converged"] and "write_error" in res
    assert sorted(p.name for p in out.iterdir()) == ["result.json"]  # the partial fields.npz removed

    r = solve("--fields", "none")  # the option the line names
    assert r.returncode == 0, r.stderr
    assert json.loads((out / "result.json").read_text())["complete"] is True

    subprocess.run(["mount", "-o", "remount,ro", str(small_tmpfs)], check=True)
    before = (out / "result.json").read_bytes()
    r = solve()
    # refused before the solve (--out is checked first, tests/test_out_refusal.py); a file system that
    # turns read-only during a run is the injected EROFS above (exit 74)
    assert r.returncode == 2 and f"--out: cannot write in {out} (read-only file system)" in r.stderr, r.stderr
    assert (out / "result.json").read_bytes() == before

"""Nothing finished is lost: `warpcontact table2` killed (SIGKILL) or stopped (SIGINT, SIGTERM) after
its first cell leaves whole files marked partial, and a rerun keeps the finished cells without
duplicating them."""

import csv
import io
import json
import signal
import subprocess
import sys
import time

import pytest

TABLE2 = [sys.executable, "-m", "warpcontact.cli", "table2", "--no-adhesion", "--n", "24", "--quiet"]
#: the first cell the full run computes (table2.cells() order), selected again by the rerun
FIRST_CELL = ["--k-tau", "0.5", "--delta-z-um", "1e-5"]
OUTPUTS = ("table2.json", "table2.md", "table2.csv")
CSV_KEYS = ["n", "k_tau", "delta_z_um", "adhesion", "sigma_max", "tau_max", "delta_n", "delta_t", "contact_shear",
            "delta_x_max_um",
            "paper_delta_x_max_um", "rel_diff_delta_x_max", "mu", "paper_mu", "rel_diff_mu", "mu_elastic", "converged",
            "yielded", "yield_margin", "elapsed_s"]
START_LIMIT_S = 120  # the first cell at n = 24 takes ~10 s here, the start included


def _default_sigint():
    # a shell that starts this test in the background may pass SIGINT on as ignored, and Python
    # then installs no KeyboardInterrupt handler: restore the default in the child
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def start(out, log):
    return subprocess.Popen([*TABLE2, "--out", str(out)], stdout=log, stderr=subprocess.STDOUT,
                            preexec_fn=_default_sigint, start_new_session=True)


def cells_on_disk(out) -> int:
    """Cells in out/table2.json (0 while it is missing; the file is whole or absent: atomic writes)."""
    try:
        return len(json.loads((out / "table2.json").read_text())["cells"])
    except FileNotFoundError:
        return 0


def wait_for(proc, ready, log_path, what, limit=START_LIMIT_S):
    """Poll ``ready()`` until it holds; fail when the run ends first or takes over ``limit`` s."""
    t0 = time.monotonic()
    while not ready():
        if proc.poll() is not None:
            pytest.fail(f"table2 ended (status {proc.returncode}) before {what}:\n{log_path.read_text()}")
        if time.monotonic() - t0 > limit:
            proc.kill()
            proc.wait()
            pytest.fail(f"not {what} after {limit} s:\n{log_path.read_text()}")
        time.sleep(0.05)


def read_outputs(out, max_tmp: int) -> list:
    """Check the folder after a run: at most ``max_tmp`` leftover temporary files, each beside a
    target that is absent or whole; every file parses and is read to its end. Returns the cells of
    table2.json (the Markdown and CSV tables hold the same cells, or those of json's previous
    write when a kill fell between the three writes of one cell)."""
    names = sorted(p.name for p in out.iterdir())
    tmps = [n for n in names if n.endswith(".tmp")]
    assert len(tmps) <= max_tmp, names
    for t in tmps:
        assert any(t.startswith(target + ".") for target in OUTPUTS), t
    assert set(names) - set(tmps) <= set(OUTPUTS), names
    assert "table2.json" in names, names  # the run was stopped only after it existed

    table = json.loads((out / "table2.json").read_text())
    assert table["complete"] is False  # every run here is stopped before its last cell
    cells = table["cells"]
    keys = [(c["n"], c["k_tau"], c["delta_z_um"]) for c in cells]
    assert len(keys) == len(set(keys)), f"duplicated cells: {keys}"
    for c in cells:
        assert {"delta_x_max_um", "mu", "converged", "paper_mu"} <= set(c), c

    if "table2.md" in names:
        lines = (out / "table2.md").read_text().splitlines()
        assert lines[0].startswith("| k_tau |") and lines[1].startswith("|---")
        assert all(ln.startswith("| ") and ln.endswith(" |") and ln.count("|") == lines[0].count("|") for ln in lines[2:]), lines
        assert len(lines) - 2 in (len(cells), len(cells) - 1), (lines, keys)
    if "table2.csv" in names:
        rows = list(csv.DictReader(io.StringIO((out / "table2.csv").read_text())))
        assert rows == [] or list(rows[0]) == CSV_KEYS
        for r in rows:
            law_keys = ("sigma_max", "tau_max", "delta_n", "delta_t", "contact_shear")  # empty in adhesionless rows
            required = [k for k in CSV_KEYS if k not in law_keys or r["adhesion"] == "True"]
            assert None not in r and all(r[k] not in (None, "") for k in required), r
            for k in ("k_tau", "delta_z_um", "delta_x_max_um", "mu", "elapsed_s"):
                float(r[k])  # a number cut off by a kill would not parse
        assert {(int(r["n"]), float(r["k_tau"]), float(r["delta_z_um"])) for r in rows} <= set(keys)
        assert len(rows) in (len(cells), len(cells) - 1)
    return cells


def rerun_first_cell(out, before: list):
    """The rerun selects a finished cell: it computes nothing, keeps every finished cell (the very
    records, elapsed times included) and writes the three files whole and consistent."""
    r = subprocess.run([*TABLE2, "--out", str(out), *FIRST_CELL], capture_output=True, text=True, timeout=300)
    assert r.returncode in (0, 3), r.stderr  # 3: a finished cell did not converge (reported, kept)
    table = json.loads((out / "table2.json").read_text())
    assert table["complete"] is True and table["interrupted"] is False  # the rerun's one cell was done before
    assert table["cells_planned"] == table["cells_done"] == 1
    (out / "table2.json").write_text(json.dumps({**table, "complete": False}))  # for read_outputs' check
    stale = [p for p in out.iterdir() if p.name.endswith(".tmp")]  # a killed run's; the rerun leaves them
    after = read_outputs(out, max_tmp=len(stale))
    key = lambda c: (c["n"], c["k_tau"], c["delta_z_um"])  # noqa: E731
    assert sorted(map(key, after)) == sorted(map(key, before))
    assert sorted(after, key=key) == sorted(before, key=key)  # not recomputed: identical records
    md_rows = len((out / "table2.md").read_text().splitlines()) - 2
    csv_rows = len(list(csv.DictReader(io.StringIO((out / "table2.csv").read_text()))))
    assert md_rows == csv_rows == len(after)


def test_sigkill_after_the_first_cell_loses_nothing(tmp_path):
    out, log_path = tmp_path / "t2", tmp_path / "log.txt"
    with open(log_path, "w") as log:
        proc = start(out, log)
        try:
            wait_for(proc, lambda: cells_on_disk(out) >= 1, log_path, "the first cell was written")
        finally:
            proc.kill()  # SIGKILL: no handler runs, a write in progress is cut off
            proc.wait(timeout=60)
    assert proc.returncode == -signal.SIGKILL
    # a kill inside atomic_write_bytes leaves its temporary file; the target is then the old one
    cells = read_outputs(out, max_tmp=1)
    assert json.loads((out / "table2.json").read_text())["interrupted"] is False  # killed: no chance to say
    assert (0.5, 1e-5) in {(c["k_tau"], c["delta_z_um"]) for c in cells}
    rerun_first_cell(out, cells)


@pytest.mark.parametrize("stop", ["SIGINT", "SIGTERM"])
def test_a_stop_after_the_first_cell_exits_128_plus_the_signal_and_keeps_the_cells(tmp_path, stop):
    signum = getattr(signal, stop)
    out, log_path = tmp_path / "t2", tmp_path / "log.txt"
    with open(log_path, "w") as log:
        proc = start(out, log)
        try:
            # the first cell's last write is table2.csv; then the second cell runs for seconds, and
            # the stop lands inside it (table2_cell), where the command catches it
            wait_for(proc, lambda: cells_on_disk(out) >= 1 and (out / "table2.csv").exists(), log_path,
                     "the first cell was written")
            time.sleep(0.5)
            proc.send_signal(signum)
            proc.wait(timeout=120)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
    text = log_path.read_text()
    assert proc.returncode == 128 + signum, text  # 130, 143: as a shell reports the signal
    assert "interrupted" in text and "Traceback" not in text, text
    assert (stop == "SIGINT") == ("interrupted: " in text) and (stop == "SIGINT") != (f"({stop})" in text), text
    cells = read_outputs(out, max_tmp=0)  # an interrupt runs atomic_write_bytes' clean-up
    table = json.loads((out / "table2.json").read_text())
    assert table["interrupted"] is True and table["stop_signal"] == stop
    assert table["cells_done"] == len(cells) < table["cells_planned"] == 12
    assert (0.5, 1e-5) in {(c["k_tau"], c["delta_z_um"]) for c in cells}
    md_rows = len((out / "table2.md").read_text().splitlines()) - 2
    assert md_rows == len(cells)  # written again, whole, on the way out
    rerun_first_cell(out, cells)


def test_an_interrupt_swallowed_by_a_destructor_is_raised_at_the_next_check(monkeypatch, capsys):
    """Ctrl-C inside a __del__ (Warp arrays free memory there) cannot be raised by Python; the
    command line's hook keeps it, silently, and the solvers' next check raises it once."""
    from warpcontact import interrupts

    monkeypatch.setattr(sys, "unraisablehook", interrupts._hook)

    class FreedDuringCtrlC:
        def __del__(self):
            raise KeyboardInterrupt

    obj = FreedDuringCtrlC()
    del obj  # the KeyboardInterrupt goes to the hook, not to this frame
    with pytest.raises(KeyboardInterrupt):
        interrupts.check()
    interrupts.check()  # raised once, not again
    assert "Exception ignored" not in capsys.readouterr().err

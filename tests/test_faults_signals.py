"""Stops sent by the system: every long command, run as a subprocess and sent SIGTERM (or SIGHUP)
at several moments, or killed with SIGKILL, keeps everything finished and marks what is partial.

What each test checks (docs/faults.md has the table):
- the exit status is 128 + the signal's number (143 SIGTERM, 129 SIGHUP), as a shell reports it;
- one line on stderr says so, and there is no traceback;
- result.json (table2.json, sweep.json) holds every state or case finished, each whole, with
  ``"interrupted": true`` and ``"complete": false``: nothing partial reads as final;
- fields.npz holds the finished states' fields, one entry per state listed;
- no temporary file is left; after SIGKILL the file says ``complete: false`` (and a rerun of a
  sweep resumes).

The moments are told by what is on disk (a state or case written), so that the tests do not
depend on the machine's speed; the paths are long enough that the run is still going when the
signal lands (a run that ends first fails the test with its log).
"""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from test_faults_writes import case_file, no_temporary_files

ROOT = Path(__file__).resolve().parents[1]
TABLE2_CASE = (ROOT / "examples" / "table2_k080_dz5e-5.toml").read_text()
PULL_OFF_CASE = (ROOT / "examples" / "pull_off_dmt.toml").read_text()
#: the paper's k_tau = 0.80 case on 64 cells, loaded in 20 normal and 20 tangential steps: 40 states,
#: about 0.15 s each on 2 CPU cores, so a path that runs for about 6 s after a start of 2-4 s
# 120 states, about 12 s on 2 CPU cores: long enough that a signal sent after a state lands in the run
LONG_PATH = TABLE2_CASE.replace("n = 96", "n = 64").replace("steps = 4 ", "steps = 60\ndelta_x = 3e-11 ")
LONG_PATH_STATES = 120
START_LIMIT_S = 120  # the start (imports, a kernel cache that may be cold) and the first state or case


def cli(*args):
    return [sys.executable, "-m", "warpcontact.cli", *map(str, args)]


def _default_sigint():
    # a shell that starts the tests in the background may pass SIGINT on as ignored
    signal.signal(signal.SIGINT, signal.SIG_DFL)


class Run:
    """A command run as a subprocess in a session of its own, its output in a log file."""

    def __init__(self, tmp_path, argv):
        self.log_path = tmp_path / "log.txt"
        self.log = open(self.log_path, "w")
        self.proc = subprocess.Popen(argv, stdout=self.log, stderr=subprocess.STDOUT, preexec_fn=_default_sigint,
                                     start_new_session=True)

    def wait_for(self, ready, what, limit=START_LIMIT_S):
        """Poll ``ready()`` until it holds; fail when the run ends first or takes over ``limit`` s."""
        t0 = time.monotonic()
        while True:
            try:
                if ready():
                    return
            except (OSError, ValueError, KeyError):  # not written yet
                pass
            if self.proc.poll() is not None:
                self.finish()
                pytest.fail(f"the run ended (status {self.proc.returncode}) before {what}:\n{self.text()}")
            if time.monotonic() - t0 > limit:
                self.kill()
                pytest.fail(f"not {what} after {limit} s:\n{self.text()}")
            time.sleep(0.02)

    def stop(self, signum, limit=60) -> int:
        """Send ``signum``; the exit status (the run must end within ``limit`` s)."""
        self.proc.send_signal(signum)
        try:
            return self.proc.wait(timeout=limit)
        except subprocess.TimeoutExpired:
            self.kill()
            pytest.fail(f"still running {limit} s after {signal.Signals(signum).name}:\n{self.text()}")
        finally:
            self.finish()

    def kill(self):
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(timeout=60)
        self.finish()

    def finish(self):
        if not self.log.closed:
            self.log.close()

    def text(self) -> str:
        return self.log_path.read_text()


def read_json(path):
    return json.loads(Path(path).read_text())


def n_states(out, key="states"):
    return len(read_json(out / "result.json")[key])


def stop_line(run: Run, name: str) -> str:
    """The one line that reports the stop: 'interrupted (SIGTERM): ...'; no traceback."""
    text = run.text()
    assert "Traceback" not in text, text
    lines = [ln for ln in text.splitlines() if ln.startswith("interrupted")]
    assert len(lines) == 1 and lines[0].startswith(f"interrupted ({name}): "), text
    return lines[0]


# --- solve ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name, after_states", [("SIGTERM", 0), ("SIGTERM", 2), ("SIGHUP", 1)])
def test_solve_stopped_keeps_the_finished_states_marked_partial(tmp_path, name, after_states):
    """SIGTERM before the first state is finished (the start record is on disk) and after two; SIGHUP
    after one."""
    signum = getattr(signal, name)
    out = tmp_path / "out"
    run = Run(tmp_path, cli("solve", case_file(tmp_path, LONG_PATH), "--out", out, "--quiet"))
    # the start record (0 states) is the run's first write: it replaces an earlier run's result.json
    run.wait_for(lambda: n_states(out) >= after_states, f"{after_states} state(s) were written")
    status = run.stop(signum)
    assert status == 128 + signum, run.text()
    line = stop_line(run, name)
    res = read_json(out / "result.json")
    done = res["n_states"]
    assert f": {done} of {LONG_PATH_STATES} state(s) finished and written to " in line, line
    assert res["complete"] is False and res["interrupted"] is True and res["stop_signal"] == name
    assert after_states <= done < res["n_states_planned"] == LONG_PATH_STATES
    assert len(res["states"]) == done and all(s["converged"] for s in res["states"])
    if done == 0:
        assert res["fields_file"] is None and not (out / "fields.npz").exists()
    else:
        assert res["fields_file"] == "fields.npz"
        with np.load(out / "fields.npz", allow_pickle=False) as f:
            assert f["state_index"].tolist() == list(range(done))
            assert f["pressure"].shape == (done, 64, 64)
            # the fields are the listed states': the last one's force is its summary's
            cell = (res["case"]["grid"]["size"] / 64) ** 2
            assert f["pressure"][-1].sum() * cell == pytest.approx(res["states"][-1]["force_elastic"]["z"], rel=1e-12)
            assert np.allclose(f["delta"][:, 2], [s["delta"]["z"] for s in res["states"]], rtol=0, atol=0)
    no_temporary_files(out)


def test_solve_killed_leaves_a_file_that_says_partial_and_no_stale_fields(tmp_path):
    """SIGKILL: no handler runs. result.json holds the states finished, whole, marked complete: false;
    the fields.npz of an earlier run in the same folder is gone (it would not match)."""
    out = tmp_path / "out"
    out.mkdir()
    np.savez(out / "fields.npz", pressure=np.zeros((1, 4, 4)))  # an earlier run's
    (out / "result.json").write_text(json.dumps({"complete": True, "n_states": 1, "states": [{}]}))
    run = Run(tmp_path, cli("solve", case_file(tmp_path, LONG_PATH), "--out", out, "--quiet"))
    run.wait_for(lambda: n_states(out) >= 2, "2 states were written")
    run.kill()
    assert run.proc.returncode == -signal.SIGKILL
    res = read_json(out / "result.json")
    assert res["complete"] is False and res["interrupted"] is False
    assert 2 <= res["n_states"] == len(res["states"]) < LONG_PATH_STATES
    assert all({"force", "converged", "delta"} <= set(s) for s in res["states"])
    assert not (out / "fields.npz").exists()


def test_solve_not_stopped_is_complete(tmp_path):
    """The control: the same kind of path, not stopped, ends with complete: true and exit 0."""
    out = tmp_path / "out"
    r = subprocess.run(cli("solve", case_file(tmp_path, LONG_PATH.replace("steps = 60", "steps = 1")), "--out", out,
                           "--quiet"), capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    res = read_json(out / "result.json")
    assert res["complete"] is True and res["interrupted"] is False and res["n_states"] == 2
    with np.load(out / "fields.npz") as f:
        assert f["state_index"].tolist() == [0, 1]


# --- gross-slip, pull-off ---------------------------------------------------------------------------


def test_gross_slip_stopped_keeps_the_finished_states(tmp_path):
    out = tmp_path / "gs"
    case = case_file(tmp_path, TABLE2_CASE.replace("n = 96", "n = 64"))
    run = Run(tmp_path, cli("gross-slip", case, "--out", out, "--quiet"))
    run.wait_for(lambda: n_states(out) >= 2, "2 states were written")
    written = n_states(out)
    status = run.stop(signal.SIGTERM)
    assert status == 143, run.text()
    stop_line(run, "SIGTERM")
    res = read_json(out / "result.json")
    assert res["complete"] is False and res["interrupted"] is True and res["stop_signal"] == "SIGTERM"
    assert res["delta_x_max"] is None and res["mu"] is None and res["converged"] is False
    assert len(res["states"]) >= written and res["states"][0]["kind"] == "normal"
    no_temporary_files(out)


def test_pull_off_stopped_keeps_the_curve_so_far(tmp_path):
    out = tmp_path / "po"
    run = Run(tmp_path, cli("pull-off", case_file(tmp_path, PULL_OFF_CASE), "--out", out, "--steps", "12", "--quiet"))
    run.wait_for(lambda: n_states(out, "curve") >= 2, "2 states were written")
    status = run.stop(signal.SIGTERM)
    assert status == 143, run.text()
    stop_line(run, "SIGTERM")
    res = read_json(out / "result.json")
    assert res["complete"] is False and res["interrupted"] is True
    assert res["pull_off_force"] is None and 2 <= len(res["curve"]) < 25
    assert not (out / "pull_off.png").exists()
    no_temporary_files(out)


# --- figure -----------------------------------------------------------------------------------------


def test_figure_of_a_case_stopped_during_its_solve(tmp_path):
    out = tmp_path / "fig"
    run = Run(tmp_path, cli("figure", case_file(tmp_path, LONG_PATH), "--out", out, "--quiet"))
    run.wait_for(lambda: n_states(out) >= 1, "a state was written")
    status = run.stop(signal.SIGTERM)
    assert status == 143, run.text()
    stop_line(run, "SIGTERM")
    res = read_json(out / "result.json")
    assert res["interrupted"] is True and res["complete"] is False and res["n_states"] >= 1
    assert (out / "fields.npz").exists() and not list(out.glob("*.png"))  # nothing drawn from a partial path


# --- sweep ------------------------------------------------------------------------------------------

#: two solve cases: a short path (2 normal + 2 tangential states), then a long one (48 states, about
#: 4 s on 2 CPU cores; 16 states took 1.3 s there, and a stop sent once the first case was written
#: could land after the second had ended): the stop lands in the second
SWEEP = """base = "case.toml"
[sweep]
"load.steps" = [2, 24]
[run]
task = "solve"
"""


def test_sweep_stopped_then_killed_then_resumed(tmp_path):
    """SIGTERM during the second case: the first is kept, sweep.json says interrupted. A rerun killed
    with SIGKILL leaves sweep.json partial; a last rerun skips the first case and finishes."""
    case_file(tmp_path, LONG_PATH)
    sweep = case_file(tmp_path, SWEEP, "sweep.toml")
    out = tmp_path / "sw"

    def finished():
        return read_json(out / "sweep.json")["finished"]

    run = Run(tmp_path, cli("sweep", sweep, "--out", out, "--quiet"))
    run.wait_for(lambda: finished() >= 1, "the first case was written")
    status = run.stop(signal.SIGTERM)
    assert status == 143, run.text()
    line = stop_line(run, "SIGTERM")
    assert "1 of 2 case(s) finished" in line, line
    st = read_json(out / "sweep.json")
    assert st["complete"] is False and st["interrupted"] is True and st["stop_signal"] == "SIGTERM"
    assert st["finished"] == 1 and st["total"] == 2 and len(list((out / "cases").glob("*.json"))) == 1
    first = st["finished_ids"][0]
    record = read_json(out / "cases" / f"{first}.json")
    assert record["params"] == {"load.steps": 2} and record["summary"]["n_states"] == 4
    no_temporary_files(out)

    # SIGKILL during the second case: the status still says 1 of 2, partial
    (tmp_path / "log.txt").unlink()
    run = Run(tmp_path, cli("sweep", sweep, "--out", out, "--quiet"))
    run.wait_for(lambda: read_json(out / "sweep.json")["interrupted"] is False, "the rerun's start was written")
    run.kill()
    st = read_json(out / "sweep.json")
    assert st["complete"] is False and st["finished"] == 1

    r = subprocess.run(cli("sweep", sweep, "--out", out), capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "1 of 2 case(s) finished before" in r.stderr and "1 computed, 1 skipped" in r.stderr, r.stderr
    st = read_json(out / "sweep.json")
    assert st["complete"] is True and st["interrupted"] is False and st["finished"] == 2
    assert read_json(out / "cases" / f"{first}.json") == record  # kept, not recomputed


# --- table2 with workers ----------------------------------------------------------------------------


def test_table2_workers_end_with_the_run(tmp_path):
    """SIGTERM to a table2 run with 2 worker processes (to its own process only, as `kill PID` does):
    the run exits 143 at once, its workers with it (no process of its session is left), and
    table2.json says interrupted."""
    out = tmp_path / "t2"
    run = Run(tmp_path, cli("table2", "--no-adhesion", "--n", "24", "--workers", "2", "--quiet", "--out", out))
    run.wait_for(lambda: read_json(out / "table2.json")["cells_planned"] == 12, "the run's start was written")
    time.sleep(1.0)  # the workers are starting or computing their first cells
    t0 = time.monotonic()
    status = run.stop(signal.SIGTERM)
    assert status == 143, run.text()
    # 0.4 s here; 16 s when the run waits for the cells its workers are computing (as it did)
    assert time.monotonic() - t0 < 5, "the run waited for its workers' cells"
    stop_line(run, "SIGTERM")
    t0 = time.monotonic()
    while True:  # the workers: terminated by the run; give them a moment to go
        try:
            os.killpg(run.proc.pid, 0)
        except ProcessLookupError:
            break
        if time.monotonic() - t0 > 10:
            os.killpg(run.proc.pid, signal.SIGKILL)
            pytest.fail("worker processes outlived the run")
        time.sleep(0.1)
    table = read_json(out / "table2.json")
    assert table["interrupted"] is True and table["complete"] is False
    assert table["cells_done"] == len(table["cells"]) < 12


# --- the machinery, in this process -----------------------------------------------------------------


@pytest.mark.parametrize("name, status", [("SIGTERM", 143), ("SIGHUP", 129), ("SIGINT", 130)])
def test_a_stop_signal_raises_a_keyboard_interrupt_that_knows_it(handlers, name, status):
    signum = getattr(signal, name)
    with pytest.raises(KeyboardInterrupt) as caught:
        signal.raise_signal(signum)
        time.sleep(1)  # the handler runs between bytecodes, at once
    assert isinstance(caught.value, handlers.Stop) and caught.value.signum == signum
    assert handlers.exit_status(caught.value) == handlers.exit_status() == status
    assert handlers.describe() == ("interrupted" if name == "SIGINT" else f"interrupted ({name})")


def test_a_stop_inside_deferred_lands_after_the_block(handlers):
    done = []
    with pytest.raises(handlers.Stop):
        with handlers.deferred():
            signal.raise_signal(signal.SIGTERM)
            done.append("written")  # the block goes on to its end
    assert done == ["written"]
    with handlers.deferred(raise_after=False):  # the last writes: a second signal is only remembered
        signal.raise_signal(signal.SIGTERM)
        done.append("last")
    assert done == ["written", "last"] and handlers.received() == signal.SIGTERM


def test_an_ignored_sighup_stays_ignored(handlers):
    """nohup: the user asked for SIGHUP to be ignored; install() leaves it so."""
    signal.signal(signal.SIGHUP, signal.SIG_IGN)
    handlers.install()
    assert signal.getsignal(signal.SIGHUP) is signal.SIG_IGN


def test_a_stop_during_the_set_up_writes_nothing(handlers, tmp_path, monkeypatch, capsys):
    """Before a command's first write (the model being built) a stop leaves the folder as it was."""
    from warpcontact.studies import runner
    from warpcontact.cli import main

    def stopped(case, model=None):  # runner.build's signature
        raise handlers.Stop(signal.SIGTERM)

    monkeypatch.setattr(runner, "build", stopped)
    out = tmp_path / "out"
    assert main(["solve", str(case_file(tmp_path, LONG_PATH)), "--out", str(out), "--quiet"]) == 143
    err = capsys.readouterr().err
    assert f"interrupted (SIGTERM): stopped during the set-up, before anything was written to {out}" in err, err
    assert not out.exists()


def test_figure_stopped_while_drawing_keeps_the_figures_drawn(handlers, tmp_path, monkeypatch, capsys):
    """A solve stopped after 2 of 4 states, drawn: the figure says the run is partial; a stop after the
    first PNG leaves it whole and exits 143."""
    from warpcontact import plots
    from warpcontact.cli import main

    out = tmp_path / "run"
    case = case_file(tmp_path, LONG_PATH.replace("steps = 60", "steps = 2").replace("n = 64", "n = 40"))
    from warpcontact.solvers import contact

    real_step, steps = contact.ContactSolver.step, []

    def step_then_stop(self, *a, **kw):
        if len(steps) == 2:
            raise handlers.Stop(signal.SIGTERM)
        steps.append(1)
        return real_step(self, *a, **kw)

    monkeypatch.setattr(contact.ContactSolver, "step", step_then_stop)
    assert main(["solve", str(case), "--out", str(out), "--quiet"]) == 143
    monkeypatch.undo()
    capsys.readouterr()

    real_save, saved = plots.save, []

    def save_then_stop(fig, path, dpi=None):
        if saved:
            raise handlers.Stop(signal.SIGTERM)
        real_save(fig, path, dpi=dpi)
        saved.append(path)

    monkeypatch.setattr(plots, "save", save_then_stop)
    assert main(["figure", str(out), "--out", str(tmp_path / "fig"), "--quiet"]) == 143
    err = capsys.readouterr().err
    assert f"{out / 'result.json'} is not complete: its run was stopped (SIGTERM) after 2 of 4 states" in err, err
    assert f"interrupted (SIGTERM): stopped while drawing; 1 of 3 figure(s) written to {tmp_path / 'fig'}" in err
    assert [p.name for p in (tmp_path / "fig").iterdir()] == ["area_map.png"]
    assert (tmp_path / "fig" / "area_map.png").read_bytes()[:4] == b"\x89PNG"


def test_once_a_command_is_stopping_a_second_signal_waits(handlers):
    """After stopping(): signals are remembered, not raised (the last writes are not cut)."""
    with pytest.raises(handlers.Stop) as caught:
        signal.raise_signal(signal.SIGTERM)
    assert handlers.stopping(caught.value) == signal.SIGTERM
    signal.raise_signal(signal.SIGHUP)  # not raised
    assert handlers.exit_status() == 143  # the first stop decides

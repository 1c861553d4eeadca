"""``warpcontact sweep``: every combination run and written at once, reruns skip finished cases,
bad sweep files refused naming the key."""

import argparse
import csv
import io
import json
import time
from pathlib import Path

import pytest
import warp as wp

from warpcontact.studies import runner
from warpcontact.cli.sweep import add_parser, cmd_sweep
from warpcontact.errors import InputError
from warpcontact.studies.sweep_spec import case_id, load_sweep

ROOT = Path(__file__).resolve().parents[1]
PAPER_CASE = ROOT / "examples" / "table2_k080_dz5e-5.toml"
HERTZ_CASE = ROOT / "examples" / "hertz.toml"
MU_B_080 = 0.7698  # k_vm / sqrt(k_tau^-2 - 1) at k_tau = 0.80


def parse(*argv):
    parser = argparse.ArgumentParser(prog="warpcontact")
    add_parser(parser.add_subparsers(dest="command", required=True))
    return parser.parse_args([str(a) for a in argv])


def write_sweep(tmp_path, text, name="sweep.toml"):
    p = tmp_path / name
    p.write_text(text)
    return p


def paper_base(tmp_path, n=36):
    """The paper's k_tau = 0.80 case with n cells, beside the sweep file. (n = 36: at n = 32 one
    state of the k_tau = 0.80 gross-slip path stops at a residual of 2.6e-10 > tol, not converged.)"""
    text = PAPER_CASE.read_text().replace("n = 96", f"n = {n}")
    (tmp_path / "base.toml").write_text(text)
    return 'base = "base.toml"\n'


def read_csv(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def test_sweep_writes_cases_and_csv_and_resumes(tmp_path, capsys):
    sweep = write_sweep(tmp_path, paper_base(tmp_path) + '[sweep]\n"friction.k_tau" = [0.8, 0.95]\n'
                        '"load.delta_z" = [5e-11]\n')
    out = tmp_path / "out"
    assert cmd_sweep(parse("sweep", sweep, "--out", out)) == 0
    err = capsys.readouterr().err
    assert "k_tau=0.8,delta_z=5e-11" in err and "k_tau=0.95,delta_z=5e-11" in err  # a line per case

    files = sorted((out / "cases").glob("*.json"))
    assert len(files) == 2
    recs = {json.loads(f.read_text())["params"]["friction.k_tau"]: json.loads(f.read_text()) for f in files}
    assert set(recs) == {0.8, 0.95}
    for k, rec in recs.items():
        assert rec["params"] == {"friction.k_tau": k, "load.delta_z": 5e-11}
        assert rec["id"] == case_id(rec["params"]) and (out / "cases" / f"{rec['id']}.json").exists()
        assert rec["task"] == "gross-slip" and rec["status"] == "ok" and rec["converged"]
        assert rec["case"]["friction"]["k_tau"] == k and rec["case"]["grid"]["n"] == 36
        assert rec["case"]["load"]["delta_z"] == 5e-11 and rec["elapsed_s"] > 0
        s = rec["summary"]
        assert s["converged"] and s["delta_x_max"] > 0 and s["mu"] == pytest.approx(s["force"]["x"] / s["force"]["z"])
    assert recs[0.8]["summary"]["mu"] == pytest.approx(MU_B_080, rel=0.03)
    assert recs[0.95]["summary"]["mu"] > recs[0.8]["summary"]["mu"]

    rows = read_csv(out / "sweep.csv")
    assert len(rows) == 2
    header = list(rows[0])
    assert header[:2] == ["friction.k_tau", "load.delta_z"]  # parameter columns first
    assert [float(r["friction.k_tau"]) for r in rows] == [0.8, 0.95]  # in sweep order
    assert all(float(r["load.delta_z"]) == 5e-11 and r["status"] == "ok" for r in rows)
    assert float(rows[0]["mu"]) == pytest.approx(recs[0.8]["summary"]["mu"], rel=1e-12)
    assert {"id", "label", "delta_x_max", "force_x", "force_z", "elapsed_s"} <= set(header)
    assert (out / "sweep.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"  # the plot, after the table

    before = {f.name: f.read_bytes() for f in files}
    csv_before = (out / "sweep.csv").read_bytes()
    t0 = time.perf_counter()
    assert cmd_sweep(parse("sweep", sweep, "--out", out, "--quiet")) == 0  # nothing left to compute
    assert time.perf_counter() - t0 < 2.0
    assert {f.name: f.read_bytes() for f in sorted((out / "cases").glob("*.json"))} == before
    assert (out / "sweep.csv").read_bytes() == csv_before

    # a changed base (another grid) is not the same case: recomputed, only the one asked for
    sweep2 = write_sweep(tmp_path, paper_base(tmp_path, n=24) + '[sweep]\n"friction.k_tau" = [0.8]\n'
                         '"load.delta_z" = [5e-11]\n', name="sweep2.toml")
    assert cmd_sweep(parse("sweep", sweep2, "--out", out, "--quiet")) in (0, 3)
    rows = read_csv(out / "sweep.csv")
    assert len(rows) == 1 and json.loads((out / "cases" / f"{rows[0]['id']}.json").read_text())["case"]["grid"]["n"] == 24


SOLVE_SWEEP = f"""base = "{HERTZ_CASE.as_posix()}"
[sweep]
"grid.n" = [32]
# the second path reaches the domain's edge: an InputError at run time, recorded
"load.path" = [[[0.0, 0.0, 1.0e-10]], [[0.0, 0.0, 1.0e-10], [0.0, 0.0, 3.9e-10]]]
[run]
task = "solve"
"""


def test_solve_task_records_an_error_and_goes_on(tmp_path, capsys):
    out = tmp_path / "out"
    assert cmd_sweep(parse("sweep", write_sweep(tmp_path, SOLVE_SWEEP), "--out", out, "--quiet")) == 3
    assert "grid.size" in capsys.readouterr().err
    rows = read_csv(out / "sweep.csv")
    assert [r["status"] for r in rows] == ["ok", "error"]
    ok = json.loads((out / "cases" / f"{rows[0]['id']}.json").read_text())
    assert ok["summary"]["converged"] and ok["summary"]["n_states"] == 1 and ok["summary"]["force"]["z"] > 0
    bad = json.loads((out / "cases" / f"{rows[1]['id']}.json").read_text())
    assert "edge" in bad["error"] and "grid.size" in bad["error"] and not bad["converged"] and "summary" not in bad


def test_ctrl_c_keeps_what_finished(tmp_path, monkeypatch, capsys):
    real, calls = runner.run_path, []

    def solve_then_interrupt(case, **kw):
        calls.append(case)
        if len(calls) > 1:
            raise KeyboardInterrupt
        return real(case, **kw)

    monkeypatch.setattr(runner, "run_path", solve_then_interrupt)
    sweep = write_sweep(tmp_path, f'base = "{HERTZ_CASE.as_posix()}"\n[sweep]\n"grid.n" = [24, 32]\n')
    out = tmp_path / "out"
    # --workers 1: the cases in this process, where the patched runner.run_path is
    assert cmd_sweep(parse("sweep", sweep, "--out", out, "--quiet", "--workers", "1")) == 130
    assert "interrupted" in capsys.readouterr().err
    assert len(list((out / "cases").glob("*.json"))) == 1 and len(read_csv(out / "sweep.csv")) == 1
    monkeypatch.setattr(runner, "run_path", real)
    assert cmd_sweep(parse("sweep", sweep, "--out", out, "--quiet")) == 0  # resumes: the second case only
    assert [r["grid.n"] for r in read_csv(out / "sweep.csv")] == ["24", "32"]


@pytest.mark.parametrize(
    "sweep_text, key",
    [
        ('[sweep]\n"friction.k_tua" = [0.5]\n', "sweep.friction.k_tua"),
        ('[sweep]\n"grid.cells" = [32]\n', "sweep.grid.cells"),
        ('[sweep]\n"rubber.k_tau" = [0.5]\n', "sweep.rubber.k_tau"),
        ('[sweep]\n"friction.k_tau" = []\n', "sweep.friction.k_tau"),
        ('[sweep]\n"friction.k_tau" = 0.5\n', "sweep.friction.k_tau"),
        ('[sweep]\n"friction.k_tau" = [0.5, 0.5]\n', "sweep.friction.k_tau"),
        ('[sweep]\n"friction.k_tau" = [0.5]\n[run]\ntask = "bisect"\n', "run.task"),
        ('[sweep]\n"friction.k_tau" = [0.5]\n[run]\ntask = "gross-slip"\nspeed = 2\n', "run.speed"),
        ('[sweep]\n"friction.k_tau" = [0.5, 1.5]\n', "sweep.friction.k_tau"),  # a combination the case check refuses
        ('[sweep]\n', "sweep"),
        ('[sweep]\n"friction.k_tau" = [0.5]\n[grid]\nn = 32\n', "grid"),
    ],
)
def test_bad_sweep_files_name_the_key(tmp_path, sweep_text, key):
    sweep = write_sweep(tmp_path, paper_base(tmp_path) + sweep_text)
    with pytest.raises(InputError) as e:
        cmd_sweep(parse("sweep", sweep, "--out", tmp_path / "out"))
    assert e.value.key == key, str(e.value)
    assert not (tmp_path / "out").exists()  # refused before anything runs


def test_combination_errors_name_the_combination(tmp_path):
    # 2a at delta_z = 2e-10 m is 89 nm: the 67 nm domain of the base cannot hold it
    sweep = write_sweep(tmp_path, paper_base(tmp_path) + '[sweep]\n"friction.k_tau" = [0.8]\n'
                        '"load.delta_z" = [5e-11, 2e-10]\n')
    with pytest.raises(InputError) as e:
        load_sweep(sweep)
    assert e.value.key == "grid.size" and "k_tau=0.8,delta_z=2e-10" in str(e.value)


def test_inline_base_nested_keys_and_default_task(tmp_path):
    base = "".join(f"[base.{line[1:]}" if line.startswith("[") else line
                   for line in HERTZ_CASE.read_text().splitlines(keepends=True))
    sw = load_sweep(write_sweep(tmp_path, base + "[sweep]\ngrid.n = [16, 24]\nload.delta_z = [5e-11, 1e-10]\n"),
                    dtype="float32")
    assert sw.task == "solve" and sw.keys == ("grid.n", "load.delta_z") and len(sw.cases) == 4
    assert [c.label for c in sw.cases][:2] == ["n=16,delta_z=5e-11", "n=16,delta_z=1e-10"]
    assert len({c.id for c in sw.cases}) == 4
    c = sw.cases[-1].case
    assert c.grid.n == 24 and c.load.delta_z == 1e-10 and c.solver.dtype == "float32" and c.solver.tol == 1e-5
    with pytest.raises(InputError) as e:  # the base of this sweep has no [base.friction]
        load_sweep(write_sweep(tmp_path, base + '[sweep]\n"grid.n" = [16]\n[run]\ntask = "gross-slip"\n'))
    assert e.value.key == "run.task"


def test_help_has_an_example(capsys):
    with pytest.raises(SystemExit):
        parse("sweep", "--help")
    assert "example:" in capsys.readouterr().out


class Terminal(io.StringIO):
    def isatty(self):
        return True


def test_progress_bar_over_cases_on_a_terminal(tmp_path):
    """On a terminal: a bar over the cases, redrawn with the running case's states, and each
    finished case's result line kept whole above it; with quiet, nothing."""
    from warpcontact.studies.sweep import run_sweep

    text = PAPER_CASE.read_text().replace("n = 96", "n = 32").replace("E = 205e9\nnu = 0.31", "E = 106e9\nnu = 0.33")
    (tmp_path / "base.toml").write_text(text)  # the flat of the sphere's material: one turn a state, fast
    sw = load_sweep(write_sweep(tmp_path, 'base = "base.toml"\n[sweep]\n"friction.k_tau" = [0.5, 0.8]\n'))
    term = Terminal()
    report = run_sweep(sw, tmp_path / "out", log=term)
    assert report.all_converged
    chunks = term.getvalue().split("\r")
    assert any(c.startswith("sweep [###############---------------] 1/2  it ") for c in chunks)
    lines = [c.rstrip() for c in chunks if c.endswith("\n")]
    assert [ln.split(":")[0] for ln in lines[:2]] == ["sweep [1/2] k_tau=0.5", "sweep [2/2] k_tau=0.8"]
    assert term.getvalue().endswith("\n") and lines[-1].startswith("sweep [" + "#" * 30 + "] 2/2")
    term = Terminal()
    run_sweep(load_sweep(write_sweep(tmp_path, 'base = "base.toml"\n[sweep]\n"friction.k_tau" = [0.95]\n')),
              tmp_path / "out", quiet=True, log=term)
    # quiet: no bar and no result line; warnings are printed either way (k_tau = 0.95 on this pair
    # yields near the surface at delta_x_max, margin 0.95: the yield check's one line)
    assert all(ln.startswith("warpcontact: warning: ") for ln in term.getvalue().splitlines())
    assert "sweep [" not in term.getvalue()


def count_batches(monkeypatch) -> list:
    """The number of cases of each batched solve made from now on (``solve_batch``'s calls)."""
    from warpcontact.studies import batch_solve

    batches, solve_batch = [], batch_solve.solve_batch
    monkeypatch.setattr(batch_solve, "solve_batch",
                        lambda cases, **kw: batches.append(len(cases)) or solve_batch(cases, **kw))
    return batches


BATCH_SWEEP = f"""base = "{HERTZ_CASE.as_posix()}"
[sweep]
"grid.n" = [32]
"sphere.E" = [106e9, 150e9]
# the last path reaches the domain's edge: an InputError at run time, recorded
"load.path" = [[[0.0, 0.0, 4e-11], [0.0, 0.0, 1.0e-10]], [[0.0, 0.0, 7e-11]], [[0.0, 0.0, 3.9e-10]]]
[run]
task = "solve"
"""


def test_batched_solve_sweep_records_what_one_case_at_a_time_records(tmp_path, monkeypatch):
    """``--batch 4``: the cases of normal contact solved together (on the CPU only when asked),
    each record as one case at a time writes it: statuses, errors, states, contact areas and
    warnings the same, the forces and yield margins within 1e-8 (both solves stop at a relative
    residual of 1e-10; the batched and the single solve's iterates differ in rounding)."""
    from warpcontact.studies.batch import Placement
    from warpcontact.studies.sweep import batched_cases

    path = write_sweep(tmp_path, BATCH_SWEEP)
    cases = [sc.case for sc in load_sweep(path).cases]
    assert batched_cases("solve", cases, Placement(workers=1)) == []  # the CPU: one at a time by default
    assert len(batched_cases("solve", cases, Placement(workers=1), batch=4)) == 6
    assert batched_cases("gross-slip", cases, Placement(workers=1), batch=4) == []
    assert batched_cases("solve", cases, Placement(workers=1), batch=0) == []
    one, together = tmp_path / "one", tmp_path / "together"
    assert batched_cases("solve", cases, Placement(workers=2)) == []  # workers of a cluster: theirs
    assert len(batched_cases("solve", cases, Placement(workers=2), batch=4)) == 6  # asked for: batched wherever they run
    batches = count_batches(monkeypatch)
    assert cmd_sweep(parse("sweep", path, "--out", one, "--quiet", "--batch", "0", "--workers", "1")) == 3
    assert batches == []
    assert cmd_sweep(parse("sweep", path, "--out", together, "--quiet", "--batch", "4", "--workers", "1")) == 3
    assert batches == [6]
    a, b = read_csv(one / "sweep.csv"), read_csv(together / "sweep.csv")
    assert [r["id"] for r in a] == [r["id"] for r in b]
    assert [r["status"] for r in b] == ["ok", "ok", "error"] * 2
    for ra in a:
        x = json.loads((one / "cases" / f"{ra['id']}.json").read_text())
        y = json.loads((together / "cases" / f"{ra['id']}.json").read_text())
        assert (x["status"], x["converged"], x.get("error"), x["params"]) == (y["status"], y["converged"],
                                                                               y.get("error"), y["params"])
        assert sorted(x["warnings"]) == sorted(y["warnings"])
        if "summary" in x:
            s, t = x["summary"], y["summary"]
            assert (s["n_states"], s["contact_area"], s["yielded"]) == (t["n_states"], t["contact_area"], t["yielded"])
            assert t["force"]["z"] == pytest.approx(s["force"]["z"], rel=1e-8)
            assert t["yield_margin"] == pytest.approx(s["yield_margin"], rel=1e-8)
    assert cmd_sweep(parse("sweep", path, "--out", together, "--quiet", "--batch", "4")) == 3  # a rerun: all skipped
    with pytest.raises(InputError, match="--batch"):
        cmd_sweep(parse("sweep", path, "--out", together, "--batch", "-1"))


@pytest.mark.gpu
@pytest.mark.skipif(wp.get_cuda_device_count() == 0, reason="no CUDA device here")
def test_a_solve_sweep_on_cuda_is_batched_by_default(tmp_path, monkeypatch):
    """On CUDA, in this process, the cases of normal contact are batched without being asked;
    their records as one case at a time writes them (forces within 1e-8: both solves stop at a
    relative residual of 1e-10)."""
    batches = count_batches(monkeypatch)
    path = write_sweep(tmp_path, BATCH_SWEEP)
    one, together = tmp_path / "one", tmp_path / "together"
    for out, more in ((one, ["--batch", "0"]), (together, [])):
        assert cmd_sweep(parse("sweep", path, "--out", out, "--quiet", "--device", "cuda", "--workers", "1", *more)) == 3
    assert batches == [6]
    a, b = read_csv(one / "sweep.csv"), read_csv(together / "sweep.csv")
    assert [(r["id"], r["status"]) for r in a] == [(r["id"], r["status"]) for r in b]
    for ra, rb in zip(a, b):
        if ra["status"] == "ok":
            assert float(rb["force_z"]) == pytest.approx(float(ra["force_z"]), rel=1e-8)
            assert rb["contact_area"] == ra["contact_area"]


def test_cases_solved_together_are_cut_into_tasks_of_a_grid_for_the_workers():
    """``batched_groups``: the cases of one grid size, device and float type, the largest grids
    first; ``batch`` at a time where given; by default about ``TASKS_PER_WORKER`` tasks a worker of
    equal size, never under ``FRICTION_MIN_BATCH`` (fewer with friction would be solved one at a
    time) nor over ``DEFAULT_BATCH`` (the most a batched solve takes), every case in one task."""
    from types import SimpleNamespace

    from warpcontact.studies.batch_solve import DEFAULT_BATCH, FRICTION_MIN_BATCH
    from warpcontact.studies.sweep import TASKS_PER_WORKER, batched_groups

    def cases(n, count, device="cuda", dtype="float64"):
        return [SimpleNamespace(grid=SimpleNamespace(n=n), solver=SimpleNamespace(device=device, dtype=dtype))] * count

    def sizes(groups):
        return [len(g) for g in groups]

    mixed = cases(128, 100) + cases(256, 10) + cases(128, 40, dtype="float32")
    groups = batched_groups(mixed, None, workers=2)
    assert sorted(i for g in groups for i in g) == list(range(150))
    assert sizes(groups) == [10, 34, 33, 33, 40]  # n = 256 first; 100 cases: three of at least 32
    assert all(len({(mixed[i].grid.n, mixed[i].solver.dtype) for i in g}) == 1 for g in groups)
    assert sizes(batched_groups(cases(128, 100), 40, workers=2)) == [40, 40, 20]  # as asked
    assert sizes(batched_groups(cases(64, 1024), None, workers=2)) == [128] * 2 * TASKS_PER_WORKER
    assert max(sizes(batched_groups(cases(64, 3000), None, workers=1))) <= DEFAULT_BATCH["cuda"]
    assert min(sizes(batched_groups(cases(64, 70), None, workers=8))) >= FRICTION_MIN_BATCH


def test_a_group_tasks_outcomes_go_back_case_by_case():
    """``each_case``: a task of cases solved together hands each outcome back with its case's own
    task, in order, then calls ``after`` once (the sweep's table); a single case's task passes
    through; a False from the writer stops the group there and ends the run."""
    from warpcontact.studies.batch import Task, each_case

    own = [Task(f"c{i}", f"case {i}", None) for i in range(3)]
    group = Task("batch-c0", "3 cases", None, cases=3)
    written, tables = [], []

    def on_result(task, outcome):
        written.append((task.key, outcome))
        return outcome != "stop"

    on_task = each_case(on_result, {group.key: own}, after=lambda: tables.append(len(written)))
    assert on_task(group, ["a", "b", "c"]) is True
    assert written == [("c0", "a"), ("c1", "b"), ("c2", "c")] and tables == [3]
    assert on_task(Task("c9", "case 9", None), "d") is True and written[-1] == ("c9", "d")
    written.clear()
    assert on_task(group, ["a", "stop", "c"]) is False
    assert written == [("c0", "a"), ("c1", "stop")] and tables == [3]

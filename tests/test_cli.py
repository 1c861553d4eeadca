"""The command line: results written, user mistakes end with exit 2 and one line."""

import csv
import io
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
HERTZ = (ROOT / "examples" / "hertz.toml").read_text()


def run_cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "warpcontact.cli", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, timeout=600)


def small_case(tmp_path, text=HERTZ, **replace):
    for old, new in replace.items():
        text = text.replace(old, new)
    p = tmp_path / "case.toml"
    p.write_text(text)
    return p


def test_solve_writes_result_and_fields(tmp_path):
    case = small_case(tmp_path, **{"n = 128": "n = 48"})
    r = run_cli("solve", case, "--out", tmp_path / "out", "--quiet")
    assert r.returncode == 0, r.stderr
    res = json.loads((tmp_path / "out" / "result.json").read_text())
    for key in ("force", "contact_area", "contact_radius", "max_pressure", "converged", "iterations", "residual",
                "device", "dtype", "elapsed_s", "case", "software"):
        assert key in res, key
    assert res["converged"] and res["device"] == "cpu" and res["dtype"] == "float64"
    hertz_force = 4 / 3 * 78.02824e9 * np.sqrt(10e-6) * 1e-10**1.5
    assert res["force"]["z"] == pytest.approx(hertz_force, rel=5e-3)
    with np.load(tmp_path / "out" / "fields.npz", allow_pickle=False) as f:
        assert f["pressure"].shape == (1, 48, 48)
        assert f["pressure"].sum() * (res["case"]["grid"]["size"] / 48) ** 2 == pytest.approx(res["force"]["z"])


@pytest.mark.parametrize(
    "replace, key",
    [
        ({"E = 106e9": "E = -106e9"}, "sphere.E"),
        ({"nu = 0.33": "nu = 0.7"}, "sphere.nu"),
        ({"n = 128": "n = 4"}, "grid.n"),
        ({'device = "cpu"': 'device = "tpu"'}, "solver.device"),
        ({"[load]": "[load]\nbogus = 1"}, "load.bogus"),
        ({"delta_z = 1.0e-10       # m (1.0e-4 um, the paper's third depth)": ""}, "load.delta_z"),
    ],
)
def test_bad_case_exits_2_with_one_line(tmp_path, replace, key):
    case = small_case(tmp_path, **replace)
    r = run_cli("solve", case, "--out", tmp_path / "out", "--quiet")
    assert r.returncode == 2
    lines = [ln for ln in r.stderr.strip().splitlines() if not ln.startswith("Warp CUDA warning")]
    assert len(lines) == 1 and key in lines[0], r.stderr
    assert "Traceback" not in r.stderr


def test_cuda_asked_where_none_exists(tmp_path):
    import warp as wp

    if wp.get_cuda_device_count() > 0:
        pytest.skip("a CUDA device is present: this checks the refusal on machines without one")
    r = run_cli("solve", small_case(tmp_path), "--out", tmp_path / "o", "--device", "cuda", "--quiet")
    assert r.returncode == 2 and "solver.device" in r.stderr and "Traceback" not in r.stderr


def test_help_has_an_example():
    r = run_cli("solve", "--help")
    assert r.returncode == 0 and "example:" in r.stdout


TABLE2_CASE = (ROOT / "examples" / "table2_k080_dz5e-5.toml").read_text()


def test_gross_slip_command(tmp_path):
    case = small_case(tmp_path, TABLE2_CASE, **{"n = 96": "n = 40"})
    r = run_cli("gross-slip", case, "--out", tmp_path / "gs", "--quiet")
    assert r.returncode == 0, r.stderr
    res = json.loads((tmp_path / "gs" / "result.json").read_text())
    assert res["converged"] and res["delta_x_max"] > 0 and res["delta_x_gross"] >= res["delta_x_max"]
    assert res["mu"] == pytest.approx(res["force"]["x"] / res["force"]["z"])
    kinds = [s["kind"] for s in res["states"]]
    assert kinds[:4] == ["normal"] * 4 and "bisect" in kinds
    # the bracket is 1 % wide or less
    assert res["delta_x_gross"] - res["delta_x_max"] <= 0.0100001 * res["delta_x_max"]


def test_gross_slip_needs_friction(tmp_path):
    case = small_case(tmp_path, TABLE2_CASE, **{'[friction]\nlaw = "tabor"\nk_tau = 0.80           # k_vm defaults to 1/sqrt(3)': ""})
    r = run_cli("gross-slip", case, "--out", tmp_path / "gs", "--quiet")
    assert r.returncode == 2 and "friction" in r.stderr and "Traceback" not in r.stderr


def test_table2_writes_cells_and_resumes(tmp_path):
    out = tmp_path / "t2"
    sel = ["--k-tau", "0.8", "--delta-z-um", "5e-5", "1e-5"]
    r = run_cli("table2", "--no-adhesion", "--n", "24", *sel, "--out", out)
    assert r.returncode in (0, 3), r.stderr
    results = [ln for ln in r.stderr.splitlines() if ln.startswith("table2 [")]  # not a terminal: result lines
    assert [ln.split(": ")[0] for ln in results] == ["table2 [1/2] n 24 k_tau 0.80 delta_z 1.0e-05 um adhesionless",
                                                     "table2 [2/2] n 24 k_tau 0.80 delta_z 5.0e-05 um adhesionless"]
    assert "\r" not in r.stderr
    cells = json.loads((out / "table2.json").read_text())["cells"]
    assert {(c["k_tau"], c["delta_z_um"]) for c in cells} == {(0.8, 5e-5), (0.8, 1e-5)}
    for c in cells:
        for key in ("delta_x_max_um", "mu", "paper_delta_x_max_um", "paper_mu", "rel_diff_delta_x_max", "rel_diff_mu"):
            assert key in c
    assert (out / "table2.md").read_text().count("\n") == 4 and (out / "table2.csv").exists()
    before = (out / "table2.json").read_text()
    r = run_cli("table2", "--no-adhesion", "--n", "24", *sel, "--out", out, "--quiet")  # nothing left to do
    assert r.returncode in (0, 3) and (out / "table2.json").read_text() == before


def test_table2_workers_give_the_cells_of_one_process(tmp_path):
    """--workers 2 computes the cells in two spawned processes: the same numbers as one process
    (CPU runs are deterministic: compared exactly), every cell written, in the table's order."""
    sel = ["--no-adhesion", "--n", "24", "--k-tau", "0.8", "--delta-z-um", "5e-5", "1e-5", "--quiet"]
    r1 = run_cli("table2", *sel, "--out", tmp_path / "one")
    r2 = run_cli("table2", *sel, "--workers", "2", "--out", tmp_path / "two")
    assert r1.returncode in (0, 3) and r2.returncode == r1.returncode, r2.stderr
    one, two = (json.loads((tmp_path / d / "table2.json").read_text())["cells"] for d in ("one", "two"))
    assert [(c["k_tau"], c["delta_z_um"]) for c in two] == [(c["k_tau"], c["delta_z_um"]) for c in one]
    for a, b in zip(one, two):
        assert (a["delta_x_max_um"], a["mu"], a["states"]) == (b["delta_x_max_um"], b["mu"], b["states"])
    r = run_cli("table2", *sel, "--workers", "0", "--out", tmp_path / "zero")
    assert r.returncode == 2 and "--workers" in r.stderr and "Traceback" not in r.stderr


def test_table2_unknown_cell_is_refused(tmp_path):
    r = run_cli("table2", "--no-adhesion", "--k-tau", "0.7", "--out", tmp_path / "t", "--quiet")
    assert r.returncode == 2 and "--k-tau" in r.stderr


def test_table2_adhesive_cell_and_its_law_in_the_resume_key(tmp_path):
    """An adhesive cell runs with the given SMC parameters and records them; a rerun with other
    parameters computes the cell again instead of taking the old one."""
    out = tmp_path / "t2a"
    sel = ["--adhesion-only", "--n", "24", "--k-tau", "0.5", "--delta-z-um", "1e-4", "--out", out, "--quiet"]
    r = run_cli("table2", *sel)
    assert r.returncode in (0, 3), r.stderr
    (cell,) = json.loads((out / "table2.json").read_text())["cells"]
    assert cell["adhesion"] and cell["adhesion_law"]["sigma_max"] == 1e6 and cell["paper_mu"] == 0.357
    r = run_cli("table2", *sel, "--sigma-max", "2e6")
    cells = json.loads((out / "table2.json").read_text())["cells"]
    assert sorted(c["adhesion_law"]["sigma_max"] for c in cells) == [1e6, 2e6]
    # the law is in every output: Markdown and CSV name it per row
    md = (out / "table2.md").read_text()
    assert "SMC 1e+06 / 1e+06 Pa, 5e-12 / 5e-12 m" in md and "SMC 2e+06 / 1e+06 Pa" in md
    rows = list(csv.DictReader(io.StringIO((out / "table2.csv").read_text())))
    assert sorted(float(r["sigma_max"]) for r in rows) == [1e6, 2e6] and {r["delta_n"] for r in rows} == {"5e-12"}


@pytest.mark.parametrize("option, value", [("--sigma-max", "-1"), ("--delta-n", "0"), ("--tau-max", "nan")])
def test_table2_bad_adhesion_option_is_refused(tmp_path, option, value):
    r = run_cli("table2", option, value, "--out", tmp_path / "t", "--quiet")
    assert r.returncode == 2 and option in r.stderr and "Traceback" not in r.stderr


def test_contact_beyond_the_domain_is_an_error(tmp_path):
    """delta_z grown after the case check (explicit path): the contact reaches the edge -> exit 2."""
    text = HERTZ.replace("delta_z = 1.0e-10       # m (1.0e-4 um, the paper's third depth)",
                         "path = [[0.0, 0.0, 1.0e-10], [0.0, 0.0, 3.9e-10]]").replace("n = 128", "n = 32")
    r = run_cli("solve", small_case(tmp_path, text), "--out", tmp_path / "o", "--quiet")
    assert r.returncode == 2 and "grid.size" in r.stderr and "edge" in r.stderr and "Traceback" not in r.stderr
    res = json.loads((tmp_path / "o" / "result.json").read_text())
    assert res["n_states"] == 1  # the state finished before the error is kept


def test_coarse_contact_warns(tmp_path):
    r = run_cli("solve", small_case(tmp_path, **{"n = 128": "n = 12"}), "--out", tmp_path / "o", "--quiet")
    assert r.returncode == 0 and "warning" in r.stderr and "grid.n >=" in r.stderr


def test_grid_too_large_for_memory_is_refused_before_allocating(tmp_path):
    r = run_cli("solve", small_case(tmp_path, **{"n = 128": "n = 200000"}),
                "--out", tmp_path / "o", "--quiet")
    assert r.returncode == 2 and "grid.n" in r.stderr and "GiB" in r.stderr and "Traceback" not in r.stderr


def test_pull_off_command(tmp_path):
    """DMT regime (Tabor parameter 0.074): the pull-off force is within 3 % of 2 pi R w and the
    curve and its plot are written."""
    case = small_case(tmp_path, (ROOT / "examples" / "pull_off_dmt.toml").read_text())
    r = run_cli("pull-off", case, "--out", tmp_path / "po", "--steps", "8", "--quiet")
    assert r.returncode == 0, r.stderr
    res = json.loads((tmp_path / "po" / "result.json").read_text())
    assert res["converged"] and res["tabor_parameter"] == pytest.approx(0.0743, rel=1e-2)
    assert abs(res["pull_off_force"] / res["dmt_pull_off"] - 1) < 0.03
    assert len(res["curve"]) == 17 and (tmp_path / "po" / "pull_off.png").read_bytes()[:4] == b"\x89PNG"


def test_pull_off_needs_adhesion(tmp_path):
    r = run_cli("pull-off", small_case(tmp_path), "--out", tmp_path / "po", "--quiet")
    assert r.returncode == 2 and "adhesion" in r.stderr and "Traceback" not in r.stderr


# --- a solve that cannot converge: exit 3, one line, results written and marked ---

#: the paper's k_tau = 0.80 case on 32 cells, the flat of the sphere's material (no coupling: one
#: turn a state, about a second), each conjugate-gradient solve stopped after 1 iteration
UNCONVERGED_GROSS_SLIP = {"n = 96": "n = 32", "E = 205e9\nnu = 0.31": "E = 106e9\nnu = 0.33",
                          'dtype = "float64"': 'dtype = "float64"\nmax_iter = 1'}


def one_line(r):
    """The one line that reports the outcome, past Warp's CUDA line and the run's warnings (a
    coarse grid, a pressure above a yield strength)."""
    lines = [ln for ln in r.stderr.strip().splitlines()
             if not ln.startswith(("Warp CUDA warning", "warpcontact: warning: "))]
    assert len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    return lines[0]


def test_gross_slip_not_converged_exits_3(tmp_path):
    case = small_case(tmp_path, TABLE2_CASE, **UNCONVERGED_GROSS_SLIP)
    r = run_cli("gross-slip", case, "--out", tmp_path / "gs", "--quiet")
    assert r.returncode == 3 and one_line(r).startswith("not converged: ")
    res = json.loads((tmp_path / "gs" / "result.json").read_text())
    assert res["converged"] is False and res["case"]["solver"]["max_iter"] == 1
    assert not all(s["converged"] for s in res["states"])
    # the bracket comes from unconverged states: no number for it, and a note saying why
    assert res["delta_x_max"] is None and res["delta_x_gross"] is None and res["mu"] is None
    assert "did not converge" in res["note"] and "delta_x_max" in res["note"] and "mu" in res["note"]


def test_pull_off_not_converged_exits_3(tmp_path):
    text = (ROOT / "examples" / "pull_off_dmt.toml").read_text().replace("n = 64", "n = 32")
    # each conjugate-gradient solve stopped after 1 iteration, short of a tolerance under float64's
    # rounding (the iteration limit alone is not enough: warm-started over the fixed point's turns,
    # the preconditioned solves of 32 cells reach 1e-15 one iteration at a time); such a state
    # turns until its turn limit, 20 here (the default 1000 takes 20 s more and tests nothing more)
    text += "\n[solver]\nmax_iter = 1\ntol = 1e-18\nmax_turns = 20\n"
    r = run_cli("pull-off", small_case(tmp_path, text), "--out", tmp_path / "po", "--steps", "2", "--quiet")
    assert r.returncode == 3 and one_line(r).startswith("not converged: ")
    res = json.loads((tmp_path / "po" / "result.json").read_text())
    assert res["converged"] is False and len(res["curve"]) == 5 and not all(c["converged"] for c in res["curve"])
    assert res["pull_off_force"] is None and res["pull_off_delta_z"] is None and "pull_off_force" in res["note"]
    assert (tmp_path / "po" / "pull_off.png").exists()


def test_pull_off_out_of_turns_says_to_raise_max_turns(tmp_path):
    """A frictionless adhesive step is one minimisation (one turn); a state that the minimisation
    leaves to the fixed point needs several turns: with max_turns = 1 no state takes more than one
    turn (two with the fixed point's retry from zero tractions), and where one stops unconverged the message names the setting to raise (exit 3)."""
    text = (ROOT / "examples" / "pull_off_dmt.toml").read_text().replace("n = 64", "n = 32")
    text += "\n[solver]\nmax_turns = 1\n"
    r = run_cli("pull-off", small_case(tmp_path, text), "--out", tmp_path / "po", "--steps", "2", "--quiet")
    res = json.loads((tmp_path / "po" / "result.json").read_text())
    assert res["case"]["solver"]["max_turns"] == 1
    assert all(c.get("outer_iterations", 1) <= 2 for c in res["curve"])  # + the retry from zero tractions
    if any(not c["converged"] for c in res["curve"]):
        line = one_line(r)
        assert r.returncode == 3 and line.startswith("not converged: ") and "solver.max_turns = 1" in line, line
    else:
        assert r.returncode == 0, r.stderr


# --- an adhesive law still pulling on the domain's edge: one warning naming grid.size ---

EDGE_SMC = "\n[adhesion]\nlaw = \"smc\"\nsigma_max = 3.6788e7\ntau_max = 3.6788e7\ndelta_n = 5e-10\ndelta_t = 5e-10\n"


def test_adhesion_at_the_edge_warns(tmp_path):
    """delta_n = 5e-10 m on the 4 a domain of hertz.toml: the gap at the edge is 0.2 delta_n."""
    case = small_case(tmp_path, HERTZ + EDGE_SMC, **{"n = 128": "n = 32"})
    r = run_cli("solve", case, "--out", tmp_path / "o", "--quiet")
    assert r.returncode == 0, r.stderr
    warned = [ln for ln in r.stderr.splitlines() if ln.startswith("warpcontact: warning: the adhesive tension")]
    assert len(warned) == 1 and "grid.size >= 6.1" in warned[0], r.stderr


def test_gross_slip_ctrl_c_keeps_the_finished_states(tmp_path, monkeypatch, capsys):
    """Ctrl-C during the search: exit 130, result.json with the states finished so far, the
    search's results null and the file marked interrupted."""
    from warpcontact.studies import slip_search
    from warpcontact.cli import main

    real = slip_search.solve_search

    def interrupted_after_3(search, solver):
        on_state = search.on_state

        def hook(k, s):
            on_state(k, s)
            if k == 2:
                raise KeyboardInterrupt

        search.on_state = hook
        return real(search, solver)

    monkeypatch.setattr(slip_search, "solve_search", interrupted_after_3)
    fast = {k: v for k, v in UNCONVERGED_GROSS_SLIP.items() if k != 'dtype = "float64"'}
    case = small_case(tmp_path, TABLE2_CASE, **fast)
    assert main(["gross-slip", str(case), "--out", str(tmp_path / "gs"), "--quiet"]) == 130
    assert capsys.readouterr().err.startswith("interrupted: 3 state(s) finished and written to ")
    res = json.loads((tmp_path / "gs" / "result.json").read_text())
    assert res["interrupted"] and res["converged"] is False and len(res["states"]) == 3
    assert res["delta_x_max"] is None and res["mu"] is None and res["case"]["grid"]["n"] == 32


def test_solve_fields_option_writes_the_last_state_or_none(tmp_path):
    """--fields last: one entry, the last state's (state_index says which); none: no fields.npz, and
    the run is complete all the same."""
    from warpcontact import cli
    from warpcontact.studies import runner

    assert cli.FIELDS_CHOICES == runner.FIELDS_CHOICES  # the parser's copy of the choices
    case = small_case(tmp_path, TABLE2_CASE, **{"n = 96": "n = 40", "steps = 4 ": "steps = 2\ndelta_x = 3e-11 "})
    r = run_cli("solve", case, "--out", tmp_path / "last", "--fields", "last", "--quiet")
    assert r.returncode == 0, r.stderr
    res = json.loads((tmp_path / "last" / "result.json").read_text())
    assert res["complete"] and res["fields_kept"] == "last" and res["n_states"] == 4
    with np.load(tmp_path / "last" / "fields.npz", allow_pickle=False) as f:
        assert f["state_index"].tolist() == [3] and f["pressure"].shape == (1, 40, 40)
        cell = (res["case"]["grid"]["size"] / 40) ** 2
        assert f["pressure"][0].sum() * cell == pytest.approx(res["states"][3]["force_elastic"]["z"], rel=1e-12)
    r = run_cli("solve", case, "--out", tmp_path / "none", "--fields", "none", "--quiet")
    assert r.returncode == 0, r.stderr
    res = json.loads((tmp_path / "none" / "result.json").read_text())
    assert res["complete"] and res["fields_file"] is None and res["n_states"] == 4
    assert sorted(p.name for p in (tmp_path / "none").iterdir()) == ["result.json"]

"""``warpcontact fit``: parameters recovered from data the solver made, their standard errors,
identifiability reported, bad fit files refused naming the key or the CSV line, resumption from
the cache, a stop that keeps what finished, and a fit on a scheduler given by address.

Grids are small (n = 32) so the file runs in about a minute on 2 CPU cores: the recovered values
are compared with what the same grid gives, not with the paper."""

import csv
import json
import math
import signal
from pathlib import Path

import numpy as np
import pytest

from warpcontact import api, interrupts
from warpcontact.records.case import case_from_dict, load_case
from warpcontact.cli import main
from warpcontact.errors import InputError
from warpcontact.studies.fit import OUTPUTS, covariance, load_fit, run_fit

ROOT = Path(__file__).resolve().parents[1]
PAPER_CASE = ROOT / "examples" / "table2_k080_dz5e-5.toml"
HERTZ_CASE = ROOT / "examples" / "hertz.toml"
#: the three gross-slip rows: delta_z [m] and a domain of 3 Hertz radii a = sqrt(R delta_z) each
GS_ROWS = [(1.0e-11, 3.0e-8), (3.0e-11, 5.196e-8), (5.0e-11, 6.708e-8)]
K_TAU_TRUE = 0.7
#: the Hertz rows (solve task): delta_z [m] on one domain of 1.04e-7 m at n = 32 (3 a at the deepest;
#: the contact radius spans 8.7 cells at the shallowest)
HERTZ_DZ = [8.0e-11, 1.0e-10, 1.2e-10]
E_TRUE = 106e9


def write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def write_csv(path: Path, header, rows) -> Path:
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        w.writerows(rows)
    return path


def gross_slip_base(folder: Path) -> Path:
    """The paper's case at n = 32, one normal step (the tests' grid; the gross slip search still
    bisects delta_x_max to the fit's rel_tol)."""
    text = PAPER_CASE.read_text().replace("n = 96", "n = 32").replace("steps = 4", "steps = 1")
    return write(folder / "base.toml", text)


def hertz_base(folder: Path) -> Path:
    text = HERTZ_CASE.read_text().replace("n = 128", "n = 32").replace("size = 1.265e-7", "size = 1.04e-7")
    return write(folder / "hertz.toml", text)


@pytest.fixture(scope="module")
def gs_data(tmp_path_factory):
    """mu and delta_x_max of the three rows at k_tau = 0.7, made by the solver (rel_tol = 1e-3, the
    fit's default bracket)."""
    folder = tmp_path_factory.mktemp("gs")
    base = load_case(gross_slip_base(folder)).to_dict()
    rows = []
    for dz, size in GS_ROWS:
        d = json.loads(json.dumps(base))
        d["load"]["delta_z"], d["grid"]["size"], d["friction"]["k_tau"] = dz, size, K_TAU_TRUE
        r = api.gross_slip(case_from_dict(d), rel_tol=1e-3)
        assert r["converged"]
        rows.append((dz, size, r["mu"], r["delta_x_max"]))
    return folder, rows


@pytest.fixture(scope="module")
def hertz_forces():
    """F_z [N] of the Hertz rows at E = 106 GPa, made by the solver."""
    base = load_case(HERTZ_CASE).to_dict()
    out = []
    for dz in HERTZ_DZ:
        d = json.loads(json.dumps(base))
        d["grid"]["n"], d["grid"]["size"], d["load"]["delta_z"] = 32, 1.04e-7, dz
        res = api.solve(case_from_dict(d))
        assert res.converged
        out.append(res.states[-1]["force"]["z"])
    return out


K_TAU_FIT = """base = "base.toml"
[data]
file = "data.csv"
[fit]
"friction.k_tau" = { min = 0.3, max = 0.97, start = 0.5 }
[run]
task = "gross-slip"
"""


def test_k_tau_recovered_from_three_gross_slip_rows_and_a_rerun_computes_nothing(gs_data, tmp_path, capsys):
    """A known answer: k_tau = 0.7 from mu and delta_x_max at three delta_z, start 0.5, within
    0.005 and within 3 stderr (noise-free data: the stderr is the residual variance of the model's
    own bisection noise, so the two tests are not the same one). Then the same command again: every
    evaluation comes from DIR/evaluations, none is computed, the result is the same."""
    folder, rows = gs_data
    fit_file = write(folder / "fit.toml", K_TAU_FIT)
    write_csv(folder / "data.csv", ["load.delta_z", "grid.size", "mu", "delta_x_max"],
              [(dz, size, repr(mu), repr(dx)) for dz, size, mu, dx in rows])
    out = tmp_path / "out"
    from warpcontact.studies import batch

    built = batch._cache_stats["built"]
    assert main(["fit", str(fit_file), "--out", str(out), "--workers", "1"]) == 0
    err = capsys.readouterr().err
    assert "fit [iteration 1] k_tau=0.5: residual rms" in err and "fit: friction.k_tau = 0.69" in err
    # one model per row's grid for the whole fit, though it ran a batch per Jacobian (k_tau does not
    # change the model): a cache dropped between batches builds 3 per batch
    assert "fit [iteration 2]" in err and batch._cache_stats["built"] - built == len(GS_ROWS)
    assert not batch._models  # dropped at the fit's end

    result = json.loads((out / "fit.json").read_text())
    p = result["parameters"]["friction.k_tau"]
    assert result["converged"] and result["complete"]
    assert abs(p["value"] - K_TAU_TRUE) < 0.005, p
    assert 0 < p["stderr"] < 0.005 and abs(p["value"] - K_TAU_TRUE) <= 3 * p["stderr"] + 1e-9, p
    assert p["at_bound"] is None and p["identified"] and result["warnings"] == []
    assert result["correlation"]["matrix"] == [[1.0]]
    assert result["stderr_scaled_by_residual_variance"] is True  # no sigma columns
    ev = result["evaluations"]
    assert ev["computed"] > 0 and ev["count"] == ev["computed"] + ev["cached"]
    assert len(list((out / "evaluations").glob("*.json"))) == ev["computed"]
    # every gross-slip output a CSV may name is in the result the engine made
    rec = json.loads(next((out / "evaluations").glob("*.json")).read_text())
    flat = {f"{k}_{s}" if isinstance(v, dict) else k for k, v in rec["summary"].items()
            for s in (v if isinstance(v, dict) else [None])}
    assert set(OUTPUTS["gross-slip"]) <= flat, set(OUTPUTS["gross-slip"]) - flat

    fitted = load_case(out / "fitted.toml")  # loadable by `warpcontact solve`
    assert fitted.friction.k_tau == p["value"] and fitted.grid.n == 32
    assert (out / "fit.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"

    assert main(["fit", str(fit_file), "--out", str(out), "--workers", "1", "--quiet"]) == 0
    again = json.loads((out / "fit.json").read_text())
    assert again["evaluations"]["computed"] == 0 and again["evaluations"]["cached"] == again["evaluations"]["count"]
    assert again["parameters"]["friction.k_tau"]["value"] == p["value"]


def hertz_fit(folder: Path, forces, extra_fit="", sigma=None, noise=None, start=60e9) -> Path:
    hertz_base(folder)
    header = ["load.delta_z", "force_z"] + (["sigma_force_z"] if sigma else [])
    rows = []
    for dz, f, e in zip(HERTZ_DZ, forces, noise if noise is not None else [0.0] * len(forces)):
        rows.append([dz, repr(float(f * (1.0 + e)))] + ([repr(float(sigma * f))] if sigma else []))
    write_csv(folder / "data.csv", header, rows)
    return write(folder / "fit.toml", f'base = "hertz.toml"\n[data]\nfile = "data.csv"\n[fit]\n'
                 f'"sphere.E" = {{ min = 20e9, max = 400e9, start = {start!r}, scale = "log" }}\n{extra_fit}'
                 '[run]\ntask = "solve"\n')


def e_star(e1, nu1=0.33, e2=205e9, nu2=0.31):
    return 1.0 / ((1 - nu1 ** 2) / e1 + (1 - nu2 ** 2) / e2)


def test_noisy_data_with_sigma_columns_give_the_least_squares_value_and_its_stderr(hertz_forces, tmp_path):
    """F_z of a frictionless contact at fixed delta_z is proportional to E* (the solver's pressure
    scales with it), so the weighted least-squares E* of noisy F_z has a closed form, c E*_true with
    c = sum(F d / s^2) / sum(F^2 / s^2), and its standard error in ln E is
    0.01 / (sqrt(3) dlnE*/dlnE) for 1 % errors on three rows. The fit gives both (to 1e-4 and 2 %:
    the solver's tol is 1e-10, the difference step 1e-5 of ln E) and the true E lies within 3 of
    its stderr (sigma columns: no rescaling by the chi-square)."""
    noise = np.random.default_rng(7).normal(0.0, 0.01, len(HERTZ_DZ))
    fit_file = hertz_fit(tmp_path, hertz_forces, sigma=0.01, noise=noise)
    report = run_fit(load_fit(fit_file), tmp_path / "out", quiet=True)
    assert report.converged and report.error is None
    p = report.parameters["sphere.E"]
    F = np.array(hertz_forces)
    d, s = F * (1 + noise), 0.01 * F
    c = np.sum(F * d / s ** 2) / np.sum(F ** 2 / s ** 2)
    es = c * e_star(E_TRUE)
    e_expected = (1 - 0.33 ** 2) / (1 / es - (1 - 0.31 ** 2) / 205e9)
    assert abs(p["value"] / e_expected - 1) < 1e-4, (p["value"], e_expected)
    dlog = e_star(E_TRUE) * (1 - 0.33 ** 2) / E_TRUE  # d ln E* / d ln E
    assert abs(p["relative_stderr"] / (0.01 / (math.sqrt(3) * dlog)) - 1) < 0.02, p
    assert abs(p["value"] - E_TRUE) < 3 * p["stderr"], p
    assert report.result["stderr_scaled_by_residual_variance"] is False
    assert report.result["reduced_chi_square"] < 1.0 + 3.0 * math.sqrt(2.0 / 2)  # the model fits: no warning
    assert report.warnings == []


def test_a_parameter_the_data_cannot_fix_gets_a_warning_and_no_confident_stderr(hertz_forces, tmp_path, capsys):
    """sphere.yield_strength does not enter a frictionless elastic solve (only the yield check
    after it): its column of the Jacobian is zero, J^T J is singular. Its stderr is inf, its
    correlations undefined, a warning names it; E is still recovered."""
    fit_file = hertz_fit(tmp_path, hertz_forces, start=80e9,
                         extra_fit='"sphere.yield_strength" = { min = 200e6, max = 400e6, start = 250e6 }\n')
    assert main(["fit", str(fit_file), "--out", str(tmp_path / "out"), "--workers", "1", "--quiet"]) == 0
    err = capsys.readouterr().err
    assert "warning: fit.sphere.yield_strength: the data do not fix this parameter" in err
    result = json.loads((tmp_path / "out" / "fit.json").read_text())
    ys, e = result["parameters"]["sphere.yield_strength"], result["parameters"]["sphere.E"]
    assert ys["stderr"] == math.inf and not ys["identified"]
    assert e["identified"] and abs(e["value"] / E_TRUE - 1) < 1e-4
    assert result["correlation"]["matrix"][0][1] is None
    assert "NOT fixed by the data" in (tmp_path / "out" / "fitted.toml").read_text()


def test_two_parameters_recovered_from_two_outputs(tmp_path):
    """E and the sphere's radius from F_z and the peak pressure at three depths (Hertz: F ~ E* R^1/2,
    p_max ~ E* R^-1/2, so the pair fixes both), data made by the solver at E = 106 GPa, R = 10 um;
    start 80 GPa, 8 um. Noise-free: both come back to 1e-4 (the solver's tol is 1e-10; the fit ends
    on a step under 1e-6 of the unit parameters), each within 3 stderr, their correlation finite."""
    base = load_case(HERTZ_CASE).to_dict()
    rows = []
    for dz in HERTZ_DZ:
        d = json.loads(json.dumps(base))
        d["grid"]["n"], d["grid"]["size"], d["load"]["delta_z"] = 32, 1.04e-7, dz
        s = api.solve(case_from_dict(d)).states[-1]
        rows.append([dz, repr(s["force"]["z"]), repr(s["max_pressure"])])
    hertz_base(tmp_path)
    write_csv(tmp_path / "data.csv", ["load.delta_z", "force_z", "max_pressure"], rows)
    fit_file = write(tmp_path / "fit.toml", 'base = "hertz.toml"\n[data]\nfile = "data.csv"\n[fit]\n'
                     '"sphere.E" = { min = 20e9, max = 400e9, start = 80e9, scale = "log" }\n'
                     '"sphere.radius" = { min = 5e-6, max = 15e-6, start = 8e-6, scale = "log" }\n'
                     '[run]\ntask = "solve"\n')
    report = run_fit(load_fit(fit_file), tmp_path / "out", quiet=True)
    assert report.converged and report.warnings == []
    for key, true in (("sphere.E", E_TRUE), ("sphere.radius", 10e-6)):
        p = report.parameters[key]
        assert abs(p["value"] / true - 1) < 1e-4 and abs(p["value"] - true) <= 3 * p["stderr"] + 1e-12 * true, (key, p)
    c = report.correlation[0][1]
    assert c is not None and -1 < c < 1


def test_covariance_of_a_known_jacobian():
    """(J^T J)^-1 times r.r / (m - p) with rescaling; a zero column is infinite, the other kept."""
    J = np.array([[1.0, 0.0], [2.0, 0.0], [0.0, 0.0]])
    r = np.array([0.1, -0.1, 0.2])
    cov, s2, _ = covariance(J, r, rescale=True)
    assert s2 == pytest.approx(0.06 / 1) and cov[0, 0] == pytest.approx(0.06 / 5) and cov[1, 1] == math.inf
    cov, s2, _ = covariance(np.array([[1.0, 1.0], [1.0, -1.0], [2.0, 0.0]]), r, rescale=False)
    assert s2 == 1.0 and np.allclose(cov, np.linalg.inv(np.array([[6.0, 0.0], [0.0, 2.0]])))


GOOD_CSV = "load.delta_z,grid.size,mu\n1e-11,3e-8,0.56\n5e-11,6.708e-8,0.56\n"


F = K_TAU_FIT
#: (what is wrong, fit file, CSV, what the one-line error must say)
BAD_FILES = [
    ("unknown key", F.replace("friction.k_tau", "friction.k_tua"), GOOD_CSV,
     "fit.friction.k_tua: unknown case key; did you mean 'friction.k_tau'?"),
    ("key not in the case", F.replace('"friction.k_tau"', '"adhesion.sigma_max"'), GOOD_CSV,
     "fit.adhesion.sigma_max: the base case has no [adhesion] table"),
    ("integer key", F.replace('"friction.k_tau"', '"grid.n"'), GOOD_CSV, "fit.grid.n: is an integer setting"),
    ("min >= max", F.replace("max = 0.97", "max = 0.3"), GOOD_CSV, "fit.friction.k_tau.max: must exceed min"),
    ("start outside", F.replace("start = 0.5", "start = 0.99"), GOOD_CSV, "fit.friction.k_tau.start"),
    ("log with min 0", F.replace("min = 0.3,", "min = 0.0,").replace("}", ', scale = "log" }'), GOOD_CSV,
     "fit.friction.k_tau.min: must be positive for scale"),
    ("bound fails the case check", F.replace("max = 0.97", "max = 1.0"), GOOD_CSV, "fit.friction.k_tau: "),
    ("unknown spec key", F.replace("min = 0.3", "mn = 0.3"), GOOD_CSV, "fit.friction.k_tau.mn: unknown key"),
    ("bad task", F.replace('task = "gross-slip"', 'task = "gross_slip"'), GOOD_CSV, "run.task"),
    ("unknown run key", F + "tsk = 1\n", GOOD_CSV, "run.tsk: unknown key"),
    ("no CSV", F.replace('file = "data.csv"', 'file = "nothing.csv"'), GOOD_CSV, "data.file: "),
    ("empty CSV", F, "", "data.file: "),
    ("header only", F, "load.delta_z,mu\n", "data.csv line 1: holds a header but no measurement"),
    ("unknown output", F, "load.delta_z,mux\n1e-11,0.5\n", "data.csv line 1: column 'mux' is neither a case key"),
    ("unknown condition", F, "load.delta_z,grid.sise,mu\n1e-11,3e-8,0.5\n",
     "data.csv line 1: column 'grid.sise': unknown case key"),
    ("non-numeric cell", F, "load.delta_z,grid.size,mu\n1e-11,3e-8,0.56\n5e-11,6.708e-8,about 0.5\n",
     "data.csv line 3: column mu: 'about 0.5' is not a number"),
    ("row fails the case check", F, "load.delta_z,grid.size,mu\n1e-11,3e-8,0.56\n5e-11,4e-8,0.56\n",
     "data.csv line 3: column grid.size: must exceed"),
    ("sigma 0", F, "load.delta_z,grid.size,mu,sigma_mu\n1e-11,3e-8,0.56,0\n",
     "data.csv line 2: column sigma_mu: must be positive"),
    ("fitted and a column", F, "friction.k_tau,load.delta_z,grid.size,mu\n0.5,1e-11,3e-8,0.56\n",
     "fit.friction.k_tau: is also a column"),
    ("no [data]", F.replace("[data]\n", "").replace('file = "data.csv"\n', ""), GOOD_CSV, "data: is required"),
]


@pytest.mark.parametrize("fit_text,csv_text,key", [b[1:] for b in BAD_FILES], ids=[b[0] for b in BAD_FILES])
def test_bad_fit_files_are_refused_naming_the_key_or_line(tmp_path, capsys, fit_text, csv_text, key):
    gross_slip_base(tmp_path)
    write(tmp_path / "data.csv", csv_text)
    fit_file = write(tmp_path / "fit.toml", fit_text)
    assert main(["fit", str(fit_file), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("warpcontact: error: ") and key in err, err
    assert "Traceback" not in err and err.count("\n") == 1
    assert not (tmp_path / "out").exists()  # refused before anything ran


def test_a_stop_keeps_the_finished_evaluations_and_a_rerun_resumes(hertz_forces, tmp_path, monkeypatch, capsys):
    """SIGTERM while the fourth case runs: exit 143, the three finished cases kept in
    DIR/evaluations, fit.json says interrupted; the rerun computes the rest and converges."""
    from warpcontact.studies import sweep

    fit_file = hertz_fit(tmp_path, hertz_forces)
    real, calls = sweep.run_case, []

    def stop_on_the_fourth(*args, **kw):
        calls.append(1)
        if len(calls) == 4:
            raise interrupts.Stop(signal.SIGTERM)
        return real(*args, **kw)

    monkeypatch.setattr(sweep, "run_case", stop_on_the_fourth)
    out = tmp_path / "out"
    assert main(["fit", str(fit_file), "--out", str(out), "--workers", "1", "--quiet"]) == 143
    err = capsys.readouterr().err
    assert err.startswith("interrupted (SIGTERM): 3 case(s) computed now") and "rerun to resume" in err
    stopped = json.loads((out / "fit.json").read_text())
    assert stopped["interrupted"] and not stopped["complete"] and stopped["stop_signal"] == "SIGTERM"
    assert len(list((out / "evaluations").glob("*.json"))) == 3
    monkeypatch.setattr(sweep, "run_case", real)
    assert main(["fit", str(fit_file), "--out", str(out), "--workers", "1", "--quiet"]) == 0
    done = json.loads((out / "fit.json").read_text())
    assert done["converged"] and done["evaluations"]["cached"] >= 3
    assert abs(done["parameters"]["sphere.E"]["value"] / E_TRUE - 1) < 1e-4


def test_a_fit_runs_on_a_scheduler_given_by_address(hertz_forces, tmp_path):
    """The cluster of another process (a LocalCluster of one worker process, as `dask scheduler`
    and `dask worker` would be): [run] scheduler sends every evaluation there; the cluster keeps
    running after the fit."""
    from distributed import LocalCluster

    from warpcontact.studies.batch import Placement

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None,
                      host="127.0.0.1") as cluster:
        fit_file = hertz_fit(tmp_path, hertz_forces)
        write(fit_file, fit_file.read_text() + f'scheduler = "{cluster.scheduler_address}"\n')
        fit = load_fit(fit_file)
        assert fit.scheduler == cluster.scheduler_address
        report = run_fit(fit, tmp_path / "out", quiet=True, placement=Placement(scheduler=fit.scheduler))
        assert report.converged and abs(report.parameters["sphere.E"]["value"] / E_TRUE - 1) < 1e-4
        assert report.evaluations["where"] == f"the cluster at {cluster.scheduler_address}"
        assert len(cluster.scheduler.workers) == 1


def test_load_fit_reads_nested_keys_a_default_start_and_dotted_output_names(tmp_path):
    gross_slip_base(tmp_path)
    write(tmp_path / "data.csv", "load.delta_z,grid.size,force.x,sigma_force.x\n1e-11,3e-8,1e-9,1e-10\n")
    fit = load_fit(write(tmp_path / "fit.toml", 'base = "base.toml"\n[data]\nfile = "data.csv"\n'
                         "[fit]\nfriction.k_tau = { min = 0.3, max = 0.97 }\n"))
    p, = fit.parameters
    assert p.key == "friction.k_tau" and p.start == 0.8  # the base's value
    assert fit.outputs == ("force_x",) and fit.columns == {"force_x": "force.x"} and fit.weighted
    assert fit.task == "gross-slip" and fit.rel_tol == 1e-3
    with pytest.raises(InputError) as e:  # force.x is no output of a pull-off
        load_fit(write(tmp_path / "fit.toml", 'base = "base.toml"\n[data]\nfile = "data.csv"\n[fit]\n'
                       '"friction.k_tau" = { min = 0.3, max = 0.97 }\n[run]\ntask = "pull-off"\n'))
    assert e.value.key == "data.csv line 1" and "'force.x'" in e.value.problem


def test_a_trial_point_that_gives_no_output_is_a_bad_point_not_the_end(hertz_forces, tmp_path, monkeypatch, capsys):
    """Cases above E = 80 GPa give no F_z here (as a cell pulled into tension gives no mu): the fit
    from 60 GPa towards the data's 106 GPa steps into them, counts them as bad points, says so,
    and ends where every output is given (at most 80 GPa) instead of stopping with an error."""
    from warpcontact.studies import sweep

    real = sweep.run_case

    def no_force_above_80_gpa(task, rel_tol, case, *args, **kw):
        out = real(task, rel_tol, case, *args, **kw)
        if case.pair.sphere.E > 80e9 and "summary" in out:
            out["summary"]["force"]["z"] = None
        return out

    monkeypatch.setattr(sweep, "run_case", no_force_above_80_gpa)
    fit_file = hertz_fit(tmp_path, hertz_forces)
    report = run_fit(load_fit(fit_file), tmp_path / "out", quiet=False)
    err = capsys.readouterr().err
    assert report.error is None, report.error
    assert "a trial point is counted as bad" in err and "gives no force_z" in err, err
    e = report.parameters["sphere.E"]["value"]
    assert 60e9 < e <= 80e9, e


def test_a_fit_batched_gives_what_one_case_at_a_time_gives(hertz_forces, tmp_path, monkeypatch):
    """``--batch 3`` (task "solve", normal contact): every evaluation's cases solved together
    (``run_batched``; on the CPU only when asked), none left to the batch engine, and the fit ends
    where the fit of one case at a time (``--batch 0``) ends: E within 1e-6 (the batched and the
    single solves both stop at a relative residual of 1e-10; their forces agree within 1e-8 and the
    fit recovers E to 1e-4 of the truth either way)."""
    from warpcontact.studies import batch, batch_solve

    fit_file = hertz_fit(tmp_path, hertz_forces)
    solved, engine = [], []  # cases per batched call; cases per batch of the engine
    real_solve, real_run = batch_solve.solve_batch, batch.run_tasks
    monkeypatch.setattr(batch_solve, "solve_batch", lambda cases, **kw: solved.append(len(cases)) or real_solve(cases, **kw))
    monkeypatch.setattr(batch, "run_tasks", lambda tasks, *a, **kw: engine.append(len(tasks)) or real_run(tasks, *a, **kw))
    run = ["fit", str(fit_file), "--workers", "1", "--quiet", "--out"]
    assert main(run + [str(tmp_path / "batched"), "--batch", "3"]) == 0
    assert solved and engine == []
    calls = len(solved)
    assert main(run + [str(tmp_path / "one"), "--batch", "0"]) == 0
    assert len(solved) == calls and engine
    a, b = (json.loads((tmp_path / name / "fit.json").read_text()) for name in ("batched", "one"))
    assert a["evaluations"]["batched"] == a["evaluations"]["computed"] == sum(solved)
    assert a["evaluations"]["where"] == "this process, batched solves"
    assert b["evaluations"]["batched"] == 0 and b["evaluations"]["computed"] == sum(engine)
    va, vb = (r["parameters"]["sphere.E"]["value"] for r in (a, b))
    assert abs(va / vb - 1) < 1e-6 and abs(va / E_TRUE - 1) < 1e-4, (va, vb)


def test_a_fit_batched_on_a_worker_gives_what_this_process_gives(hertz_forces, tmp_path):
    """``--batch 3 --scheduler ADDRESS``: each evaluation's cases go to the cluster's worker as
    tasks of three cases of one grid solved together (``sweep.run_cases_batched``), and the fit
    ends where the batched fit in this process ends: E within 1e-6 (the worker's FFTW plans may
    round otherwise; both solves stop at a relative residual of 1e-10)."""
    from distributed import LocalCluster

    from warpcontact.studies import batch, sweep

    def ring(signum, frame):
        raise TimeoutError("the fit on a cluster took more than 240 s")

    fit_file = hertz_fit(tmp_path, hertz_forces)
    tasks = []
    real_run = batch.run_tasks
    run = ["fit", str(fit_file), "--batch", "3", "--quiet", "--out"]
    assert main(run + [str(tmp_path / "here"), "--workers", "1"]) == 0
    previous = signal.signal(signal.SIGALRM, ring)
    signal.alarm(240)
    try:
        with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None,
                          host="127.0.0.1") as cluster:
            batch.run_tasks = lambda t, *a, **kw: tasks.extend(t) or real_run(t, *a, **kw)
            try:
                assert main(run + [str(tmp_path / "there"), "--scheduler", cluster.scheduler_address]) == 0
            finally:
                batch.run_tasks = real_run
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    assert tasks and all((t.fn, t.cases) == (sweep.run_cases_batched, 3) for t in tasks)
    a, b = (json.loads((tmp_path / name / "fit.json").read_text()) for name in ("here", "there"))
    assert b["evaluations"]["batched"] == b["evaluations"]["computed"] == 3 * len(tasks)
    assert b["evaluations"]["where"].startswith("the cluster at")
    va, vb = (r["parameters"]["sphere.E"]["value"] for r in (a, b))
    assert abs(va / vb - 1) < 1e-6, (va, vb)


def test_a_fits_gross_slip_evaluations_batched_are_those_of_one_case_at_a_time(gs_data, tmp_path):
    """The gross-slip rows at one k_tau evaluated with ``batch`` 3 (the searches walk together)
    and one case at a time: the same statuses and delta_x_max, mu within 2e-9 relative (a batched
    search's states are its own search's; both solve each state to a relative residual of 1e-10)."""
    from warpcontact.studies.batch import Placement
    from warpcontact.studies.fit_evaluations import _Evaluator

    folder, rows = gs_data
    fit_file = write(folder / "fit.toml", K_TAU_FIT)
    write_csv(folder / "data.csv", ["load.delta_z", "grid.size", "mu", "delta_x_max"],
              [(dz, size, repr(mu), repr(dx)) for dz, size, mu, dx in rows])
    fit = load_fit(fit_file)
    point = {"friction.k_tau": 0.6}
    together = _Evaluator(fit, tmp_path / "batched", Placement(workers=1), batch=3)
    alone = _Evaluator(fit, tmp_path / "one", Placement(workers=1), batch=0)
    (a,), (b,) = together.outcomes([point]), alone.outcomes([point])
    assert together.batched == len(GS_ROWS) and not together.batches and alone.batched == 0
    for ra, rb in zip(a, b):
        assert ra["status"] == rb["status"] == "ok"
        assert ra["summary"]["delta_x_max"] == rb["summary"]["delta_x_max"]
        assert abs(ra["summary"]["mu"] / rb["summary"]["mu"] - 1) < 2e-9

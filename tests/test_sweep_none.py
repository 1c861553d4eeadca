"""A sweep switches a law off: ``"adhesion.law"`` or ``"friction.law"`` = [..., "none"] runs that
combination without the table (its other keys ignored there), and sweep.png draws the results
against the swept values after the table is written."""

import argparse
import csv
import errno
import json
import warnings
from pathlib import Path

import numpy as np
import pytest

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

import warpcontact as wc
from warpcontact import plots
from warpcontact.cli import main
from warpcontact.cli.sweep import add_parser, cmd_sweep
from warpcontact.errors import InputError
from warpcontact.records.case import case_from_dict
from warpcontact.studies.sweep_spec import load_sweep

ROOT = Path(__file__).resolve().parents[1]
#: SMC adhesion in the DMT regime at delta_z = 1 nm; 32 cells: a solve in about a tenth of a second
ADHESIVE_BASE = (ROOT / "examples" / "pull_off_dmt.toml").read_text().replace("n = 64", "n = 32")
#: the paper's k_tau = 0.80 pair, 2 normal and 2 tangential states on 40 cells (delta_x = 30 pm)
FRICTION_BASE = ((ROOT / "examples" / "table2_k080_dz5e-5.toml").read_text()
                 .replace("n = 96", "n = 40").replace("steps = 4 ", "steps = 2\ndelta_x = 3e-11 "))
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def parse(*argv):
    parser = argparse.ArgumentParser(prog="warpcontact")
    add_parser(parser.add_subparsers(dest="command", required=True))
    return parser.parse_args([str(a) for a in argv])


def sweep_file(tmp_path, base_text, sweep_text, name="sweep.toml"):
    (tmp_path / "base.toml").write_text(base_text)
    p = tmp_path / name
    p.write_text('base = "base.toml"\n' + sweep_text)
    return p


def read_csv(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def records(out, rows):
    return [json.loads((out / "cases" / f"{r['id']}.json").read_text()) for r in rows]


def without(base_text, table):
    d = load_case_text(base_text).to_dict()
    assert table in d
    del d[table]
    return d


def load_case_text(text):
    return case_from_dict(tomllib.loads(text))


def solve_alone(case_dict):
    """The last state of ``case_dict`` solved on its own (its coarse-grid and yield warnings, which
    the sweep records too, silenced)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return wc.solve(case_dict, fields="none").states[-1]


def assert_png(path):
    data = path.read_bytes()
    assert data[:8] == PNG_SIGNATURE, path
    from matplotlib.image import imread

    img = imread(path)
    assert img.ndim == 3 and img.shape[0] > 100 and img.shape[1] > 100
    assert float(np.ptp(img[..., :3])) > 0.5  # something is drawn: not a blank canvas


def test_adhesion_law_none_runs_without_the_table_and_plots(tmp_path, capsys, monkeypatch):
    sweep = sweep_file(tmp_path, ADHESIVE_BASE, '[sweep]\n"adhesion.law" = ["smc", "none"]\n[run]\ntask = "solve"\n')
    out = tmp_path / "out"
    assert cmd_sweep(parse("sweep", sweep, "--out", out, "--quiet", "--workers", "1")) == 0
    rows = read_csv(out / "sweep.csv")
    assert [r["adhesion.law"] for r in rows] == ["smc", "none"]
    assert [r["label"] for r in rows] == ["law=smc", "law=none"]
    smc, none = records(out, rows)
    assert smc["params"] == {"adhesion.law": "smc"} and none["params"] == {"adhesion.law": "none"}
    assert smc["case"]["adhesion"]["law"] == "smc" and "adhesion" not in none["case"]
    assert "ignored" not in none and "ignored" not in rows[0]  # no other swept key of [adhesion]

    # without adhesion: no adhesive zone, and no tension pulling the sphere in: more compressive F_z
    assert smc["summary"]["adhesive_area"] > 0 and none["summary"]["adhesive_area"] == 0
    assert none["summary"]["force"]["z"] > smc["summary"]["force"]["z"] > 0
    assert none["summary"]["force"]["z"] == none["summary"]["force_elastic"]["z"]
    # the "none" row is the base case with its [adhesion] table removed, solved on its own
    alone = solve_alone(without(ADHESIVE_BASE, "adhesion"))
    assert none["summary"]["force"]["z"] == pytest.approx(alone["force"]["z"], rel=1e-12, abs=0)
    assert none["summary"]["contact_area"] == pytest.approx(alone["contact_area"], rel=1e-12, abs=0)

    png = out / "sweep.png"
    assert_png(png)
    assert png.stat().st_mtime_ns >= (out / "sweep.csv").stat().st_mtime_ns  # after the table
    assert png.stat().st_mtime_ns <= (out / "sweep.json").stat().st_mtime_ns  # complete: every output written
    assert json.loads((out / "sweep.json").read_text())["complete"] is True
    capsys.readouterr()

    # a plot that cannot be written: one line naming it, exit 74, the table and the cases kept
    table = (out / "sweep.csv").read_bytes()
    png.unlink()

    def full_disk(fig, path, dpi=None):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(plots, "save", full_disk)
    assert main(["sweep", str(sweep), "--out", str(out), "--quiet", "--workers", "1"]) == 74
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert f"cannot write {png}: no space left on device" in err, err
    assert err.endswith(f"every case and sweep.csv are kept in {out}: free space and run the same command again to "
                        "draw the plot"), err
    assert (out / "sweep.csv").read_bytes() == table and not png.exists()
    assert json.loads((out / "sweep.json").read_text())["complete"] is False  # an output is missing

    # a figure that cannot be drawn: a warning, the results stand, exit 0
    monkeypatch.undo()

    def broken(*a, **k):
        raise ValueError("no axis for this")

    monkeypatch.setattr(plots, "sweep_figure", broken)
    assert main(["sweep", str(sweep), "--out", str(out), "--quiet", "--workers", "1"]) == 0
    err = capsys.readouterr().err
    assert "warning:" in err and "sweep.png not drawn (ValueError: no axis for this)" in err, err
    assert (out / "sweep.csv").read_bytes() == table and not png.exists()

    # a stop while drawing: the cases and the table stand, sweep.json is not complete, exit 130
    monkeypatch.undo()

    def stopped(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(plots, "sweep_figure", stopped)
    assert main(["sweep", str(sweep), "--out", str(out), "--quiet", "--workers", "1"]) == 130
    assert "interrupted: 2 of 2 case(s) finished and written" in capsys.readouterr().err
    assert (out / "sweep.csv").read_bytes() == table and not png.exists()
    assert json.loads((out / "sweep.json").read_text())["complete"] is False

    monkeypatch.undo()  # a rerun computes nothing and draws the plot
    assert main(["sweep", str(sweep), "--out", str(out), "--quiet", "--workers", "1"]) == 0
    assert_png(png)
    assert json.loads((out / "sweep.json").read_text())["complete"] is True


def test_friction_law_none_is_frictionless_and_its_swept_keys_ignored(tmp_path):
    sweep = sweep_file(tmp_path, FRICTION_BASE, '[sweep]\n"friction.law" = ["tabor", "none"]\n'
                       '"friction.k_tau" = [0.8]\n[run]\ntask = "solve"\n')
    out = tmp_path / "out"
    assert cmd_sweep(parse("sweep", sweep, "--out", out, "--quiet", "--workers", "1")) == 0
    rows = read_csv(out / "sweep.csv")
    assert [r["friction.law"] for r in rows] == ["tabor", "none"]
    assert [r["ignored"] for r in rows] == ["", "friction.k_tau"]  # the column says which swept key had no effect
    tabor, none = records(out, rows)
    assert none["ignored"] == ["friction.k_tau"] and "ignored" not in tabor
    assert "friction" not in none["case"] and tabor["case"]["friction"]["k_tau"] == 0.8
    # sheared by delta_x = 30 pm: friction resists, a frictionless contact does not
    assert tabor["summary"]["force"]["x"] > 0 and none["summary"]["force"]["x"] == 0
    alone = solve_alone(without(FRICTION_BASE, "friction"))
    assert none["summary"]["force"]["z"] == pytest.approx(alone["force"]["z"], rel=1e-12, abs=0)
    assert_png(out / "sweep.png")


def test_none_passes_the_checks_before_running(tmp_path):
    """A swept key of a table switched off is no refusal; what "none" leaves a task without is,
    naming the swept law; every other message is the case check's."""
    sw = load_sweep(sweep_file(tmp_path, ADHESIVE_BASE, '[sweep]\n"adhesion.law" = ["smc", "none"]\n'
                               '"adhesion.sigma_max" = [1e7, 2e7]\n"adhesion.delta_n" = [1e-9]\n'))
    assert sw.task == "solve" and len(sw.cases) == 4
    assert [c.case.adhesion is None for c in sw.cases] == [False, False, True, True]
    assert [c.ignored for c in sw.cases][2:] == [("adhesion.sigma_max", "adhesion.delta_n")] * 2
    assert sw.cases[1].case.adhesion.sigma_max == 2e7 and sw.cases[0].ignored == ()

    # a base without the table: "none" is the base as it is
    frictionless = FRICTION_BASE.split("[friction]")[0]  # the case's [sphere], [flat], [grid], [load]
    sw = load_sweep(sweep_file(tmp_path, frictionless,
                               '[sweep]\n"friction.law" = ["none"]\n"grid.n" = [32]\n'))
    assert sw.cases[0].case.friction is None and sw.cases[0].ignored == ()

    with pytest.raises(InputError) as e:  # gross-slip (the default with [friction]) needs friction
        load_sweep(sweep_file(tmp_path, FRICTION_BASE, '[sweep]\n"friction.law" = ["tabor", "none"]\n'))
    assert e.value.key == "sweep.friction.law" and "task = 'solve'" in str(e.value)
    assert "(in the sweep case law=none)" in str(e.value)
    with pytest.raises(InputError) as e:
        load_sweep(sweep_file(tmp_path, ADHESIVE_BASE,
                              '[sweep]\n"adhesion.law" = ["none"]\n[run]\ntask = "pull-off"\n'))
    assert e.value.key == "sweep.adhesion.law" and "'pull-off'" in str(e.value)

    # another value is the case check's, unchanged
    with pytest.raises(InputError) as e:
        load_sweep(sweep_file(tmp_path, ADHESIVE_BASE, '[sweep]\n"adhesion.law" = ["smc", "off"]\n'))
    d = load_case_text(ADHESIVE_BASE).to_dict()
    d["adhesion"]["law"] = "off"
    with pytest.raises(InputError) as direct:
        case_from_dict(d)
    assert e.value.key == "sweep.adhesion.law"
    assert e.value.problem == f"{direct.value.problem} (in the sweep case law=off)"


def test_refused_none_is_one_line_and_exit_2(tmp_path, capsys):
    sweep = sweep_file(tmp_path, FRICTION_BASE, '[sweep]\n"friction.law" = ["none"]\n[run]\ntask = "gross-slip"\n')
    assert main(["sweep", str(sweep), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("warpcontact: error: sweep.friction.law: 'none' leaves no friction") and "\n" not in err
    assert not (tmp_path / "out").exists()


def _rec(params, summary, status="ok", ignored=()):
    r = {"params": params, "status": status, "summary": summary}
    if ignored:
        r["ignored"] = list(ignored)
    return r


def test_sweep_figure_lines_categories_and_panels():
    # gross-slip: two panels (delta_x_max, mu) against k_tau, a line per delta_z
    recs = [_rec({"friction.k_tau": k, "load.delta_z": dz}, {"delta_x_max": 0.5 * k * dz, "mu": k})
            for k in (0.5, 0.8) for dz in (1e-11, 5e-11)]
    recs[-1] = _rec(recs[-1]["params"], None, status="error")
    fig = plots.sweep_figure(recs, ["friction.k_tau", "load.delta_z"], "gross-slip")
    axes = fig.axes
    assert len(axes) == 2
    assert "delta_{x,max}" in axes[0].get_ylabel() and "[pm]" in axes[0].get_ylabel()
    assert "mu" in axes[1].get_ylabel() and axes[0].get_xlabel() == "friction.k_tau"
    labels = [ln.get_label() for ln in axes[0].get_lines()]
    assert labels == ["delta_z = 10 pm", "delta_z = 50 pm"]
    assert np.isnan(axes[0].get_lines()[1].get_ydata()[-1])  # the error: a gap
    assert axes[1].get_lines()[0].get_ydata().tolist() == [0.5, 0.8]

    # a law on the x axis: its names as category labels, in sweep order; one swept key: one line
    recs = [_rec({"adhesion.law": law}, {"force": {"x": 0.0, "y": 0.0, "z": f}, "contact_radius": 3e-8})
            for law, f in (("smc", 3.0e-6), ("none", 3.3e-6))]
    fig = plots.sweep_figure(recs, ["adhesion.law"], "solve")
    force, radius = fig.axes
    assert [t.get_text() for t in force.get_xticklabels()] == ["smc", "none"]
    assert len(force.get_lines()) == 1 and force.get_lines()[0].get_xdata().tolist() == [0.0, 1.0]
    assert "F_z" in force.get_ylabel() and "contact radius" in radius.get_ylabel()  # no shear: the radius

    # pull-off: one panel; a switched-off table's ignored keys are named in a note
    recs = [_rec({"load.delta_z": dz, "adhesion.w": 0.05}, {"pull_off_force": -3e-7}, ignored=["adhesion.w"])
            for dz in (1e-10, 1e-9)]
    fig = plots.sweep_figure(recs, ["load.delta_z", "adhesion.w"], "pull-off")
    assert len(fig.axes) == 1 and "pull-off force" in fig.axes[0].get_ylabel()
    assert any("adhesion.w ignored" in t.get_text() for t in fig.texts)


def test_a_pull_off_line_without_a_tabor_parameter():
    """A pull-off case of a shape with no Hertz reference (a punch, a cone, a height map) has no
    Tabor parameter (None in its summary): its line gives the force alone, where a sphere's also
    gives the parameter."""
    from warpcontact.studies.sweep import _result_text

    sphere = _result_text("pull-off", {"pull_off_force": -1.5e-9, "tabor_parameter": 0.25})
    punch = _result_text("pull-off", {"pull_off_force": -1.5e-9, "tabor_parameter": None})
    assert sphere == "pull-off force -1.5000e-09 N (Tabor parameter 0.25)"
    assert punch == "pull-off force -1.5000e-09 N"

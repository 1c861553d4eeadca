"""Figures of solved states (warpcontact.plots) and the ``figure`` sub-command (warpcontact.cli.figure)."""

import argparse
from pathlib import Path

import numpy as np
import pytest
from matplotlib.figure import Figure
from matplotlib.text import Text

from warpcontact import plots
from warpcontact.physics.adhesion import SMC
from warpcontact.records.case import load_case
from warpcontact.cli.figure import add_parser, cmd_figure
from warpcontact.errors import InputError
from warpcontact.studies.runner import run_path

ROOT = Path(__file__).resolve().parents[1]
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _partial_slip_case(folder: Path) -> Path:
    """The Table 2 example (k_tau 0.80, delta_z 5e-5 um) on 48 x 48 cells, shifted to delta_x = 3.5e-11 m."""
    text = (ROOT / "examples" / "table2_k080_dz5e-5.toml").read_text()
    assert "n = 96" in text and "steps = 4" in text
    text = text.replace("n = 96", "n = 48", 1).replace("steps = 4", "delta_x = 3.5e-11\nsteps = 2", 1)
    path = folder / "case.toml"
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def solved(tmp_path_factory):
    """(fields dict, NPZ path) of the solved partial-slip path: its last state has stick and slip cells."""
    folder = tmp_path_factory.mktemp("solved")
    result = run_path(load_case(_partial_slip_case(folder)))
    assert result.converged
    fields = result.stacked_fields()
    npz = folder / "fields.npz"
    np.savez_compressed(npz, **fields)
    return fields, npz


@pytest.fixture(scope="module")
def fields(solved):
    f = solved[0]
    last = -1
    contact, stick = f["contact_mask"][last], f["stick_mask"][last]
    assert stick.any() and (contact & ~stick).any(), "the test case must end in partial slip"
    return f


def _rgb(fig: Figure) -> np.ndarray:
    fig.canvas.draw()
    return np.asarray(fig.canvas.buffer_rgba())[..., :3].astype(int)


def _inside_axes(fig: Figure, rgb: np.ndarray) -> np.ndarray:
    """The pixels of the first axes (the map), without the legend below it."""
    x0, y0, x1, y1 = fig.axes[0].get_window_extent().extents
    h = rgb.shape[0]
    return rgb[int(h - y1) + 2:int(h - y0) - 2, int(x0) + 2:int(x1) - 2]


def _orange(rgb):  # the paper's stick colour, #D95319 (217, 83, 25)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    return (r > 180) & (g > 50) & (g < 130) & (b < 70)


def _blue(rgb):  # the paper's contact colour, #0072BD (0, 114, 189)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    return (r < 50) & (g > 80) & (g < 150) & (b > 160)


def _yellow(rgb):  # the paper's adhesive colour, #EDB120 (237, 177, 32)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    return (r > 200) & (g > 150) & (g < 210) & (b < 80)


def test_each_function_returns_a_figure(fields):
    for fn in (plots.area_map, plots.field_maps, plots.profile):
        fig = fn(fields)
        assert isinstance(fig, Figure)
        assert _rgb(fig).shape[2] == 3  # draws on its own Agg canvas


def test_no_pyplot_state_is_left_behind(fields):
    import sys

    plots.area_map(fields)
    plots.field_maps(fields)
    if "matplotlib.pyplot" in sys.modules:  # another test may have imported it: nothing of ours is open
        import matplotlib.pyplot as plt

        assert plt.get_fignums() == []


def test_save_writes_a_png_atomically(fields, tmp_path):
    path = tmp_path / "sub" / "area.png"
    plots.save(plots.area_map(fields), path, dpi=60)
    assert path.read_bytes()[:8] == PNG_SIGNATURE
    assert [p.name for p in path.parent.iterdir()] == ["area.png"]  # no temporary file left
    first = path.read_bytes()
    plots.save(plots.profile(fields), path, dpi=60)  # replaced whole
    assert path.read_bytes()[:8] == PNG_SIGNATURE and path.read_bytes() != first


def test_area_map_legend_names_the_areas_in_nm2(fields):
    fig = plots.area_map(fields)
    legend = fig.legends[0] if fig.legends else fig.axes[0].get_legend()
    texts = [t.get_text() for t in legend.get_texts()]
    dA = (fields["x"][1] - fields["x"][0]) * (fields["y"][1] - fields["y"][0]) * 1e18
    stick_nm2 = fields["stick_mask"][-1].sum() * dA
    stick = [t for t in texts if "stick" in t]
    assert stick and float(stick[0].split(": ")[1].split(" nm")[0].replace(",", "")) == pytest.approx(stick_nm2, rel=1e-3)
    # the areas add up as printed: contact = stick + slip to the last printed figure (2 + 0.293 = 2)
    import re

    contact = [t for t in texts if "A_c" in t][0]
    a_c, slip = (float(v.replace(",", "")) for v in re.findall(r"([\d,]+\.?\d*) nm", contact))
    a_st = float(re.findall(r"([\d,]+\.?\d*) nm", stick[0])[0].replace(",", ""))
    decimals = len(re.findall(r"[\d,]+\.?(\d*) nm", contact)[0])
    assert abs(a_st + slip - a_c) <= 1.01 * 10.0**-decimals, texts
    assert a_st >= 100 * 10.0**-decimals or a_st == 0  # 3 significant figures at least
    assert any("A_c" in t and "contact" in t for t in texts)
    assert any("A_{adh}" in t and "no adhesion" in t for t in texts)  # absent: the legend says so
    ax = fig.axes[0]
    assert ax.get_xlabel() == "x [nm]" and ax.get_ylabel() == "y [nm]"
    assert ax.get_aspect() == 1.0


def test_area_map_zooms_on_the_contact_with_a_margin(fields):
    ax = plots.area_map(fields).axes[0]
    x0, x1 = ax.get_xlim()
    rows, cols = np.nonzero(fields["contact_mask"][-1])
    h = (fields["x"][1] - fields["x"][0]) * 1e9
    cx0, cx1 = fields["x"][cols.min()] * 1e9 - h / 2, fields["x"][cols.max()] * 1e9 + h / 2
    assert x0 < cx0 and x1 > cx1  # the whole contact shows
    assert (x1 - x0) == pytest.approx(1.3 * max(cx1 - cx0, (rows.max() - rows.min() + 1) * h), rel=1e-6)
    assert (x1 - x0) < 0.95 * (fields["x"][-1] - fields["x"][0]) * 1e9  # zoomed in


def test_area_map_colours_stick_orange_and_slip_blue(fields):
    fig = plots.area_map(fields)
    rgb = _inside_axes(fig, _rgb(fig))
    n_orange, n_blue = _orange(rgb).sum(), _blue(rgb).sum()
    assert n_orange > 2000 and n_blue > 2000, (n_orange, n_blue)
    assert not _yellow(rgb).any()  # no adhesion in this file
    # more slip than stick at the last state: more blue than orange, as in the cells
    cells_stick, cells_slip = fields["stick_mask"][-1].sum(), (fields["contact_mask"][-1] & ~fields["stick_mask"][-1]).sum()
    assert cells_slip > cells_stick and n_blue > n_orange
    # the orange stick patch lies inside the blue ring of slip cells
    ys, xs = np.nonzero(_orange(rgb))
    yb, xb = np.nonzero(_blue(rgb))
    assert abs(xs.mean() - xb.mean()) < 0.15 * (xb.max() - xb.min())
    assert xb.min() < xs.min() and xb.max() > xs.max()


@pytest.mark.parametrize("drop", [False, True])
def test_no_adhesion_means_no_yellow_and_the_legend_says_so(fields, drop):
    """A solve without adhesion writes zero adhesive fields; older files have none: same figure."""
    f = dict(fields)
    if drop:
        for key in ("adhesive_mask", "adhesive_pressure", "adhesive_shear_x", "adhesive_shear_y"):
            f.pop(key, None)
    assert not plots.has_adhesion(f)
    fig = plots.area_map(f)
    assert not _yellow(_rgb(fig)).any()
    texts = [t.get_text() for t in fig.legends[0].get_texts()]
    assert any("A_{adh}" in t and "no adhesion" in t for t in texts), texts
    for fn in (plots.field_maps, plots.profile):
        assert isinstance(fn(f), Figure)


def test_area_map_draws_an_adhesive_rim_yellow(fields):
    f = {k: np.array(v) for k, v in fields.items()}
    contact = f["contact_mask"]
    grown = contact.copy()
    for ax in (1, 2):
        grown |= np.roll(contact, 1, axis=ax) | np.roll(contact, -1, axis=ax)
    f["adhesive_mask"] = grown & ~contact
    f["adhesive_pressure"] = np.where(f["adhesive_mask"], -1e6, 0.0)
    fig = plots.area_map(f)
    assert _yellow(_rgb(fig)).sum() > 200
    texts = [t.get_text() for t in fig.legends[0].get_texts()]
    assert any("A_{adh}" in t and "nm$^2$" in t and "no adhesion" not in t for t in texts)
    assert isinstance(plots.profile(f), Figure)


def test_field_maps_has_four_panels_with_unit_colour_bars(fields):
    fig = plots.field_maps(fields)
    labels = " ".join(ax.get_ylabel() for ax in fig.axes)
    for unit in ("pressure [MPa]", "[MPa]", "gap $h$ [nm]"):
        assert unit in labels, labels
    maps = [ax for ax in fig.axes if ax.get_xlabel() == "x [nm]"]
    assert len(maps) == 4
    assert _orange(_rgb(fig)).any() and _blue(_rgb(fig)).any()


def test_profile_in_mpa_and_nm_with_the_shear_limit_of_the_file(fields):
    ax = plots.profile(fields).axes[0]
    assert ax.get_xlabel() == "x [nm]" and "MPa" in ax.get_ylabel()  # p0 of about 110 MPa: MPa
    peak = max(np.nanmax(np.asarray(line.get_ydata(), dtype=float)) for line in ax.get_lines())
    assert peak == pytest.approx(fields["pressure"][-1].max() * 1e-6, rel=0.05)  # the centre row carries ~p0
    # fields.npz holds the law's q_max (Tabor + von Mises, MODEL.md section 5): drawn, and the title has no excuse
    p = fields["pressure"]
    k_vm, s_y, k_tau = 1 / np.sqrt(3), 200e6, 0.80
    mu_b = k_vm / np.sqrt(k_tau**-2 - 1)
    law = np.minimum(mu_b * p, k_vm * np.sqrt(np.maximum(s_y**2 - p**2, 0)))
    assert np.allclose(fields["shear_limit"], law, rtol=1e-9, atol=1e-9 * s_y)
    assert any("limit" in line.get_label() for line in ax.get_lines())
    assert "no shear limit" not in ax.get_title()
    # a fields file without shear_limit: the title says so
    ax = plots.profile({k: v for k, v in fields.items() if k != "shear_limit"}).axes[0]
    assert not any("limit" in line.get_label() for line in ax.get_lines()) and "no shear limit" in ax.get_title()


def test_state_title_in_the_axes_unit(fields):
    """One unit system per figure: the displacements in the title in nm, as the axes."""
    title = plots.area_map(fields).axes[0].get_title()
    dz, dx = fields["delta"][-1][2], fields["delta"][-1][0]
    assert f"= {dz * 1e9:.4g} nm" in title and f"= {dx * 1e9:.4g} nm" in title and "µm" not in title, title


def test_pull_off_curve_in_the_scale_of_its_data():
    """An nN curve (an AFM tip's) is drawn in nN, its approach in nm."""
    curve = [{"branch": b, "delta": {"z": z}, "force": {"z": f}} for b, z, f in (
        ("approach", -0.6e-9, -1e-10), ("approach", 0.1e-9, 9e-9), ("retract", -0.3e-9, -3.8e-8))]
    result = {"curve": curve, "pull_off_force": -3.8e-8, "pull_off_delta_z": -0.3e-9, "dmt_pull_off": -1.26e-8,
              "jkr_pull_off": -9.4e-9, "tabor_parameter": 0.09}
    ax = plots.pull_off_curve(result).axes[0]
    assert "[nN]" in ax.get_ylabel() and "[nm]" in ax.get_xlabel(), (ax.get_xlabel(), ax.get_ylabel())
    ys = np.concatenate([np.asarray(line.get_ydata(), dtype=float) for line in ax.get_lines()])
    assert np.nanmin(ys) == pytest.approx(-38.0)
    assert plots.si_scale([2e3], "Pa") == (1e3, "kPa") and plots.si_scale([4.4e9], "Pa") == (1e9, "GPa")


def test_pull_off_curve_writes_micronewtons_with_the_micro_sign():
    """A µN curve (a micrometre sphere's) is labelled µN, with the micro sign, not "uN"."""
    curve = [{"branch": b, "delta": {"z": z}, "force": {"z": f}} for b, z, f in (
        ("approach", -2e-9, -1e-8), ("approach", 1e-9, 4e-6), ("retract", -1e-9, -3.1e-6))]
    result = {"curve": curve, "pull_off_force": -3.1e-6, "pull_off_delta_z": -1e-9, "dmt_pull_off": -2.6e-6,
              "jkr_pull_off": -1.9e-6}
    fig = plots.pull_off_curve(result)
    ax = fig.axes[0]
    assert "[\u00b5N]" in ax.get_ylabel(), ax.get_ylabel()
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert any(t.endswith("-3.1 \u00b5N") for t in legend), legend
    texts = [t.get_text() for t in fig.findobj(Text)]
    assert not any("uN" in t or "um]" in t for t in texts), texts
    assert plots.si_scale([2.5e-5], "m") == (1e-6, "\u00b5m")


def test_state_index_out_of_range(fields):
    n = fields["pressure"].shape[0]
    with pytest.raises(IndexError):
        plots.area_map(fields, index=n)
    assert isinstance(plots.area_map(fields, index=-n), Figure)


# ---------------------------------------------------------------------------------------------- CLI


def _parser():
    parser = argparse.ArgumentParser(prog="warpcontact")
    sub = parser.add_subparsers(dest="command", required=True)
    add_parser(sub)
    return parser


def test_cmd_figure_writes_three_pngs(solved, tmp_path):
    _, npz = solved
    for source in (npz.parent, npz):  # a solve's folder or the NPZ itself
        out = tmp_path / ("from_" + Path(source).name)
        args = _parser().parse_args(["figure", str(source), "--out", str(out), "--quiet"])
        assert cmd_figure(args) == 0
        for name in ("area_map.png", "fields.png", "profile.png"):
            assert (out / name).read_bytes()[:8] == PNG_SIGNATURE, name


def test_cmd_figure_of_a_case_file_solves_it_then_draws(tmp_path):
    """A case file is solved into --out as 'solve' would (result.json, fields.npz), then drawn."""
    import json

    case = _partial_slip_case(tmp_path)
    out = tmp_path / "fig"
    args = _parser().parse_args(["figure", str(case), "--out", str(out), "--quiet"])
    assert cmd_figure(args) == 0
    result = json.loads((out / "result.json").read_text())
    assert all(s["converged"] for s in result["states"]) and len(result["states"]) == 4
    assert np.load(out / "fields.npz")["pressure"].shape == (4, 48, 48)
    for name in ("area_map.png", "fields.png", "profile.png"):
        assert (out / name).read_bytes()[:8] == PNG_SIGNATURE, name


def test_cmd_figure_state_option(solved, tmp_path, capsys):
    _, npz = solved
    args = _parser().parse_args(["figure", str(npz), "--out", str(tmp_path / "s1"), "--state", "1"])
    assert cmd_figure(args) == 0
    assert "state 1" in capsys.readouterr().err  # not quiet: names what it wrote
    for bad in ("4", "-5", "99"):
        args = _parser().parse_args(["figure", str(npz), "--out", str(tmp_path / "bad"), "--state", bad])
        with pytest.raises(InputError) as e:
            cmd_figure(args)
        assert e.value.key == "--state" and "out of range" in e.value.problem
    assert not (tmp_path / "bad").exists()


def test_cmd_figure_marks_an_unconverged_state(solved, tmp_path, capsys):
    import json
    import shutil

    _, npz = solved
    run = tmp_path / "run"
    run.mkdir()
    shutil.copy(npz, run / "fields.npz")
    n = np.load(npz)["pressure"].shape[0]
    (run / "result.json").write_text(json.dumps({"states": [{"converged": i != n - 1} for i in range(n)]}))
    args = _parser().parse_args(["figure", str(run), "--out", str(tmp_path / "fig"), "--quiet"])
    assert cmd_figure(args) == 0
    assert "did not converge" in capsys.readouterr().err
    args = _parser().parse_args(["figure", str(run), "--out", str(tmp_path / "fig0"), "--state", "0", "--quiet"])
    assert cmd_figure(args) == 0
    assert "did not converge" not in capsys.readouterr().err


def test_cmd_figure_bad_inputs_raise_input_error(tmp_path):
    bad = tmp_path / "not.npz"
    bad.write_bytes(b"this is not a zip file")
    empty = tmp_path / "empty_dir"
    empty.mkdir()
    partial = tmp_path / "partial.npz"
    np.savez(partial, pressure=np.zeros((1, 4, 4)))
    objects = tmp_path / "objects.npz"
    np.savez(objects, pressure=np.array([{"a": 1}], dtype=object))
    for source in (tmp_path / "missing.npz", empty, bad, partial, objects):
        args = _parser().parse_args(["figure", str(source), "--out", str(tmp_path / "out"), "--quiet"])
        with pytest.raises(InputError) as e:
            cmd_figure(args)
        assert e.value.key == str(source), e.value


def test_gross_slip_figures_name_the_state_and_carry_the_laws_caption(fields, tmp_path, monkeypatch):
    """figure on a gross-slip output titles its three figures with the state at gross slip and mu
    (not "state 0" of the one state it solves again) and writes under each the caption of the
    case's laws that a solve's figures carry."""
    import json

    from warpcontact.cli import figure as figure_cli

    last = {k: (v[-1:] if np.ndim(v) == 3 else v) for k, v in fields.items()}  # one state, as re-solved
    last["delta"] = fields["delta"][-1:]
    monkeypatch.setattr(figure_cli, "gross_slip_fields", lambda res: {**last, "_summary": {}})
    saved = {}
    monkeypatch.setattr(plots, "save", lambda fig, path, dpi=None: saved.__setitem__(Path(path).name, fig))
    case = {"friction": {"law": "tabor", "k_tau": 0.8}, "adhesion": None}
    dx = float(fields["delta"][-1][0])
    run = tmp_path / "gs"
    run.mkdir()
    (run / "result.json").write_text(json.dumps({"case": case, "states": [], "delta_x_max": dx, "mu": 0.4321,
                                                 "converged": True}))
    args = _parser().parse_args(["figure", str(run), "--out", str(tmp_path / "fig"), "--quiet"])
    assert cmd_figure(args) == 0
    assert sorted(saved) == ["area_map.png", "fields.png", "profile.png"]
    caption = figure_cli.laws_caption(case)
    assert caption == "Tabor + von Mises, $k_\\tau$ = 0.8;  no adhesion"
    titles = {"area_map.png": saved["area_map.png"].axes[0].get_title(),
              "fields.png": saved["fields.png"].get_suptitle(),
              "profile.png": saved["profile.png"].axes[0].get_title()}
    for name, fig in saved.items():
        title = titles[name]
        assert "state 0" not in title and "gross slip" in title and "0.4321" in title, (name, title)
        assert f"$\\delta_x$ = {dx * 1e9:.4g} nm" in title, (name, title)
        assert caption in [t.get_text() for t in fig.texts], (name, [t.get_text() for t in fig.texts])


def _solve_cli(tmp_path, *options):
    from warpcontact.cli import main

    text = _partial_slip_case(tmp_path).read_text().replace("n = 48", "n = 16", 1)
    case = tmp_path / "small.toml"
    case.write_text(text)
    out = tmp_path / "run"
    assert main(["solve", str(case), "--out", str(out), "--quiet", *options]) == 0
    return out


def test_figure_of_a_solve_without_fields_names_the_option_that_keeps_them(tmp_path, capsys):
    """A solve run with --fields none wrote no fields.npz: figure says in one line why there is
    nothing to draw and which option keeps fields, exit 2 (not a missing file's error); a folder
    with no result at all, one line too."""
    import json

    from warpcontact.cli import main

    out = _solve_cli(tmp_path, "--fields", "none")
    assert json.loads((out / "result.json").read_text())["fields_kept"] == "none"
    assert not (out / "fields.npz").exists()
    capsys.readouterr()
    for source in (out, out / "result.json"):
        assert main(["figure", str(source), "--out", str(tmp_path / "fig"), "--quiet"]) == 2
        lines = capsys.readouterr().err.strip().splitlines()
        assert len(lines) == 1, lines
        assert "--fields none" in lines[0] and "--fields last" in lines[0] and "--fields all" in lines[0], lines
        assert "no such file" not in lines[0], lines
    empty = tmp_path / "empty"
    empty.mkdir()
    assert main(["figure", str(empty), "--out", str(tmp_path / "fig"), "--quiet"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "neither result.json nor fields.npz" in lines[0], lines
    assert not (tmp_path / "fig").exists()


def test_figure_help_has_an_example(capsys):
    with pytest.raises(SystemExit):
        _parser().parse_args(["figure", "--help"])
    text = capsys.readouterr().out
    assert "example:" in text and "warpcontact figure" in text and "--state" in text


# the paper's Figures 1 and 2 (captions): (delta_z, delta_x) [m] per figure, (k_tau, adhesion) per panel
FIGURE_STATES = {"1": (5.0e-11, 4.5e-11), "2": (1.5e-10, 7.5e-11)}
FIGURE_PANELS = {"a": (0.80, False), "b": (0.80, True), "c": (0.95, False), "d": (0.95, True)}


@pytest.mark.parametrize("fig", sorted(FIGURE_STATES))
@pytest.mark.parametrize("panel", sorted(FIGURE_PANELS))
def test_figure_examples_are_the_papers_states(fig, panel):
    """examples/figureNX.toml hold the state of the paper's caption, with the table2 adhesion
    defaults on panels b and d, on one grid per figure whose domain holds the adhesive tail."""
    from warpcontact.studies import table2
    from warpcontact.records.guards import suggested_adhesive_size

    case = load_case(ROOT / "examples" / f"figure{fig}{panel}.toml")
    dz, dx = FIGURE_STATES[fig]
    k_tau, adhesive = FIGURE_PANELS[panel]
    assert (case.load.delta_z, case.load.delta_x, case.load.delta_y) == (dz, dx, 0.0)
    assert case.friction.k_tau == k_tau
    assert (case.adhesion is not None) == adhesive
    if adhesive:
        law = case.adhesion
        assert (law.sigma_max, law.tau_max, law.delta_n, law.delta_t) == (
            table2.SIGMA_MAX, table2.TAU_MAX, table2.DELTA_N, table2.DELTA_T)
    other = load_case(ROOT / "examples" / f"figure{fig}{'b' if panel in 'ab' else 'd'}.toml")
    assert case.grid == other.grid
    assert case.grid.size >= suggested_adhesive_size(table2.RADIUS, dz, SMC(
        table2.SIGMA_MAX, table2.TAU_MAX, table2.DELTA_N, table2.DELTA_T))


def test_figure2c_stick_area_is_a_ring_off_the_slipping_centre():
    """The paper's Figure 2c (k_tau 0.95, delta_z 1.5e-4 um, delta_x 7.5e-5 um) on a coarser grid
    (80 cells of 1.7 nm, the coarsest without the coarse-grid warning): at the centre the pressure exceeds the crossover p* (62 MPa), the von Mises
    branch lowers q_max there and the centre slips, while a ring of stick cells remains, shifted
    towards the sliding direction (+x) by the material dissimilarity (paper: "a hollow disc")."""
    import dataclasses

    case = load_case(ROOT / "examples" / "figure2c.toml")
    coarse = dataclasses.replace(case, grid=dataclasses.replace(case.grid, n=80))
    result = run_path(coarse)
    assert result.converged
    last = result.fields[-1]
    stick, contact = last["stick_mask"].astype(bool), last["contact_mask"].astype(bool)
    n = stick.shape[0]
    centre = (slice(n // 2 - 1, n // 2 + 1),) * 2
    assert contact[centre].all() and not stick[centre].any()
    assert stick.sum() > 0.2 * contact.sum()
    x = (np.arange(n) + 0.5) / n - 0.5
    assert (stick * x[None, :]).sum() / stick.sum() > 0  # columns are x (fields are [y, x])


def test_case_caption_names_the_laws_as_a_figure_caption_would(tmp_path):
    """figure writes the friction and adhesion laws of the case under each plot (from result.json)."""
    import json

    from warpcontact.cli.figure import case_caption

    case = {"friction": {"law": "tabor", "k_tau": 0.95}, "adhesion": {"law": "smc", "sigma_max": 1e6, "tau_max": 1e6,
                                                                      "delta_n": 5e-12, "delta_t": 5e-12}}
    (tmp_path / "result.json").write_text(json.dumps({"case": case}))
    text = case_caption(tmp_path / "fields.npz")
    assert "$k_\\tau$ = 0.95" in text and "SMC adhesion" in text and "1e+06 Pa" in text and "5e-12 m" in text
    case = {"friction": {"law": "coulomb", "mu": 0.3}, "adhesion": None}
    (tmp_path / "result.json").write_text(json.dumps({"case": case}))
    assert case_caption(tmp_path / "fields.npz") == "Coulomb, $\\mu$ = 0.3;  no adhesion"
    assert case_caption(tmp_path / "elsewhere" / "fields.npz") == ""  # no result.json: no caption


def test_field_maps_says_a_state_without_shear_has_none(fields):
    """A frictionless state (shear zero everywhere) gets a note on its shear map, not a colour scale
    of 1e-12 MPa; a state with shear keeps its scale up to the largest |q|."""
    sheared = plots.field_maps(fields)
    assert not any("no shear" in t.get_text() for ax in sheared.axes for t in ax.texts)
    flat = {k: (np.zeros_like(v) if k in ("shear_x", "shear_y", "adhesive_shear_x", "adhesive_shear_y") else v)
            for k, v in fields.items()}
    fig = plots.field_maps(flat)
    shear_map = fig.axes[1]  # the 2 x 2 maps first (row by row), their colour bars after them
    assert "shear" in shear_map.get_title()
    assert any(t.get_text() == "no shear in this state" for t in shear_map.texts)
    bar = next(ax for ax in fig.axes if "shear magnitude" in ax.get_ylabel())
    assert list(bar.get_yticks()) == [0.0]


def _load_result(patches: bool) -> dict:
    states = [{"force": {"z": f}, "contact_area": a, "mean_gap": g} for f, a, g in
              ((0.0, 0.0, 7.8e-9), (1.27e-7, 7.4e-17, 6.8e-9), (7.72e-7, 3.63e-16, 6.3e-9))]
    if patches:
        for s, p in zip(states, (0, 3, 6)):
            s["contact_patches"] = p
    return {"states": states}


@pytest.mark.parametrize("patches", [True, False])
def test_contact_load_draws_area_patches_and_gap_against_the_force(patches):
    """One panel each: the area in nm^2 (its length's prefix squared: 3.63e-16 m^2 is 363 nm^2),
    the patches where every state has them, the mean gap in nm; F_z in uN."""
    fig = plots.contact_load(_load_result(patches))
    axes = fig.axes
    assert len(axes) == (3 if patches else 2)
    assert axes[0].get_ylabel() == "contact area [nm$^2$]"
    assert max(axes[0].lines[0].get_ydata()) == pytest.approx(363.0)
    assert axes[0].get_xlabel() == "$F_z$ [µN]"
    assert axes[-1].get_ylabel() == "mean gap [nm]"
    if patches:
        assert list(axes[1].lines[0].get_ydata()) == [0, 3, 6]


def test_solve_draws_the_load_figure_for_shapes_other_than_the_sphere(tmp_path):
    """``warpcontact solve`` of a flat punch writes load.png beside result.json; of a sphere it
    does not (one contact, Hertz's curve)."""
    import subprocess
    import sys

    base = ("[sphere]\nradius = {r}\nE = 100e9\nnu = 0.3\n{profile}\n[flat]\nE = 100e9\nnu = 0.3\n"
            "[grid]\nn = 16\nsize = {size}\n[load]\ndelta_z = 1e-10\nsteps = 2\n")
    cases = {"punch": base.format(r="5e-9", profile='profile = "flat_punch"', size="1.6e-8"),
             "sphere": base.format(r="10e-6", profile="", size="1.3e-7")}
    for name, text in cases.items():
        path = tmp_path / f"{name}.toml"
        path.write_text(text)
        out = tmp_path / name
        r = subprocess.run([sys.executable, "-m", "warpcontact.cli", "solve", str(path), "--out", str(out), "--quiet"],
                           capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
        assert (out / "load.png").exists() == (name == "punch"), (name, sorted(p.name for p in out.iterdir()))

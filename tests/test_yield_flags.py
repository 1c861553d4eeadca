"""Every gross-slip, table2 and sweep result says whether a body yielded: the
check of the elastic assumption (yielding.yield_check) on the run's final state, its keys made in one
place (yielding.yield_keys) and the warning given through RunChecks (one warning of yield per run)."""

import json
import math
import tomllib
import warnings
from pathlib import Path

import pytest

from warpcontact import api
from warpcontact.records.case import case_from_dict
from warpcontact.records.guards import YieldWarning

ROOT = Path(__file__).resolve().parents[1]
PAPER = tomllib.loads((ROOT / "examples" / "table2_k080_dz5e-5.toml").read_text())


def paper_case(k_tau=0.80, n=36, **changes):
    """The paper's copper-on-steel case at delta_z = 5e-5 um (p0 = 111 MPa) on n cells."""
    d = json.loads(json.dumps(PAPER))
    d["grid"]["n"] = n
    d["friction"]["k_tau"] = k_tau
    for table, values in changes.items():
        d[table] = values if table == "friction" else {**d[table], **values}
    return case_from_dict(d)


def run(fn, *args, **kw):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        r = fn(*args, **kw)
    return r, [w for w in caught if issubclass(w.category, YieldWarning)]


def margin_of(check):
    return min(check[b]["yield_strength"] / check[b]["von_mises_max"] for b in ("sphere", "flat"))


def test_gross_slip_result_says_the_contact_stayed_elastic():
    """k_tau = 0.80: the largest von Mises stress at delta_x_max (the sphere's, copper, the softer)
    stays under both yield strengths (Table 2 at n = 48: margin 1.37); no yield warning."""
    r, yw = run(api.gross_slip, paper_case(0.80))
    assert r["yielded"] is False and not yw
    check = r["yield_check"]
    assert r["yield_margin"] == pytest.approx(margin_of(check), rel=1e-12) and r["yield_margin"] > 1.0
    assert check["sphere"]["margin"] < check["flat"]["margin"]  # the softer body is nearer yield
    json.dumps(r)


def test_gross_slip_that_yields_under_the_surface_warns_once():
    """k_tau = 0.95: the pressure (p0 = 111 MPa) stays under the copper's 200 MPa, so the surface
    pressure check says nothing, but the sphere's von Mises stress near the surface at delta_x_max
    passes 200 MPa (Table 2 at n = 48: 228 MPa, margin 0.88): yielded, and exactly one warning,
    naming the sphere."""
    r, yw = run(api.gross_slip, paper_case(0.95))
    assert r["yielded"] is True and r["yield_check"]["sphere"]["yielded"] is True
    assert r["yield_margin"] < 1.0 and r["yield_margin"] == pytest.approx(margin_of(r["yield_check"]), rel=1e-12)
    assert max(s["max_pressure"] for s in r["states"]) < 200e6  # not the pressure check's warning
    assert len(yw) == 1 and "sphere's von Mises stress" in str(yw[0].message)
    assert "delta_x_max" in str(yw[0].message) and "\n" not in str(yw[0].message)


def test_pressure_above_a_tiny_yield_strength_yields_and_warns_once():
    """Coulomb friction (the shear limit does not depend on S_Y) and a sphere yield strength of
    20 MPa under p0 = 111 MPa: the pressure check warns on the way, the stress check at
    delta_x_max finds the sphere yielded (von Mises >= 0.3 p0 anywhere in a Hertz contact: margin
    well under 1), and the run warns of yield once, not twice."""
    case = paper_case(friction={"law": "coulomb", "mu": 0.3}, sphere={"yield_strength": 20e6})
    r, yw = run(api.gross_slip, case)
    assert r["yielded"] is True and r["yield_margin"] < 0.5
    assert len(yw) == 1


def test_sweep_rows_carry_the_yield_keys():
    """A gross-slip row (result_row of the gross-slip summary) and a solve row (run_path's last
    state) carry yielded and yield_margin; a row without a check (pull-off) carries them as None."""
    from warpcontact.studies.sweep import run_case

    gs = run_case("gross-slip", 0.01, paper_case(0.95))
    row = gs["summary"]
    assert row["yielded"] is True and 0.0 < row["yield_margin"] < 1.0
    assert any("von Mises" in w for w in gs["warnings"])
    solve = run_case("solve", 0.01, paper_case(0.80))
    s = solve["summary"]
    assert s["yielded"] is False and s["yield_margin"] > 1.0 and "yield_check" in s
    assert api.result_row({"converged": True, "curve": []}) == {"converged": True, "n_states": 0,
                                                                "yielded": None, "yield_margin": None}


def test_table2_cell_reports_the_check_and_the_markdown_column():
    from warpcontact.studies.table2 import Table2Settings, markdown, table2_cell

    rec = table2_cell(0.50, 1.0e-5, Table2Settings(n=32))
    assert rec["yielded"] is False and rec["yield_margin"] == pytest.approx(margin_of(rec["yield_check"]))
    assert math.isfinite(rec["yield_margin"]) and rec["yield_margin"] > 1.0
    assert f"yes (margin {rec['yield_margin']:.3g})" in markdown([rec])


def test_gross_slip_command_prints_one_warning_line_and_writes_the_keys(tmp_path, capsys):
    from warpcontact.cli import main

    text = (ROOT / "examples" / "table2_k080_dz5e-5.toml").read_text()
    path = tmp_path / "k095.toml"
    path.write_text(text.replace("n = 96", "n = 36").replace("k_tau = 0.80", "k_tau = 0.95"))
    assert main(["gross-slip", str(path), "--out", str(tmp_path / "gs"), "--quiet"]) == 0
    lines = [ln for ln in capsys.readouterr().err.splitlines() if "von Mises" in ln]
    assert len(lines) == 1 and lines[0].startswith("warpcontact: warning: the sphere's von Mises stress")
    result = json.loads((tmp_path / "gs" / "result.json").read_text())
    assert result["yielded"] is True and result["yield_margin"] < 1.0


def _solved_state(k_tau, delta_x, n=64):
    from warpcontact.studies.runner import build
    from warpcontact.numerics.state import ContactState

    case = paper_case(k_tau=k_tau, n=n)
    model, solver, _ = build(case)
    state = ContactState(model)
    dz = case.load.delta_z
    solver.step(state, (0.0, 0.0, dz))
    solver.step(state, (delta_x, 0.0, dz))
    return model, state.to_numpy_si()


@pytest.mark.parametrize("k_tau, delta_x", [(0.5, 5e-12), (0.95, 2e-11)])
def test_yield_check_depths_find_the_maximum_of_a_fine_scan(k_tau, delta_x):
    """The yield check's depths (the surface and 9, the midpoints around each body's largest, a
    parabola) against the surface and 201 depths from 0.01 a to 2 a: each body's von Mises maximum
    within 0.5 % (the parabola's error over a spacing of a tenth of a; measured 0.1 % below the
    surface, exact at the surface). Under k_tau = 0.95 the maximum lies at the surface, 27 % above
    its value at 0.02 a (the shallowest depth the check had before)."""
    import numpy as np

    from warpcontact.numerics import stress as st
    from warpcontact.numerics import yielding

    model, fields = _solved_state(k_tau, delta_x)
    check = yielding.yield_check(model.pair, model.grid, fields)
    a = st.contact_radius(fields, model.grid.cell_area)
    depths = np.concatenate([[st.SURFACE_DEPTH_IN_CELLS * model.grid.dx], np.linspace(0.01, 2.0, 201) * a])
    scan = st.SubsurfaceStress(model.pair, model.grid, depths).von_mises_maxima(*st.tractions(fields), depths)
    for body in ("sphere", "flat"):
        assert check[body]["von_mises_max"] == pytest.approx(scan[body][:, 0].max(), rel=5e-3), body


def test_lean_von_mises_pass_matches_the_full_evaluation():
    """von_mises_maxima (the yield check's pass: stress and von Mises alone) gives the full
    evaluation's per-depth von Mises maxima and their places, to rounding."""
    import numpy as np

    from warpcontact.numerics import stress as st

    model, fields = _solved_state(0.8, 1e-11)
    a = st.contact_radius(fields, model.grid.cell_area)
    depths = np.array([0.05, 0.5, 1.0]) * a
    stress = st.SubsurfaceStress(model.pair, model.grid, depths)
    full = stress.evaluate(*st.tractions(fields))
    lean = stress.von_mises_maxima(*st.tractions(fields), depths)
    for body in ("sphere", "flat"):
        assert np.allclose(lean[body], full.bodies[body].depth_max["von_mises"], rtol=1e-12, atol=0.0), body


def test_deep_depths_on_the_half_grid_match_the_fine_grid():
    """The yield check evaluates depths from COARSE_STRESS_DEPTH_CELLS cells down on the half grid
    (tractions averaged over 2 x 2 cells) where the contact radius spans at least
    COARSE_STRESS_MIN_RADIUS_CELLS cells: on 128 cells (radius 32-33 cells) each body's von Mises
    maximum there within 0.3 % of the fine grid's (measured 0.04-0.11 % at n = 128 and 256); on
    64 cells (radius ~21) the fine grid alone."""
    import numpy as np

    from warpcontact.numerics import stress as st
    from warpcontact.numerics import yielding

    model, fields = _solved_state(0.8, 1e-11, n=128)
    dx = model.grid.dx
    radius = st.contact_radius(fields, model.grid.cell_area)
    assert radius >= yielding.COARSE_STRESS_MIN_RADIUS_CELLS * dx
    depths = np.array([8.0, 12.0, 24.0]) * dx
    tr = st.tractions(fields)
    split = yielding._YieldEvaluator(model.pair, model.grid, tr, depths, "cpu", "float64", "auto", radius)
    assert split.coarse is not None and split.coarse.grid.n == model.grid.n // 2
    coarse = split.maxima(depths)
    fine = st.SubsurfaceStress(model.pair, model.grid, depths).von_mises_maxima(*tr, depths)
    for body in ("sphere", "flat"):
        assert np.allclose(coarse[body][:, 0], fine[body][:, 0], rtol=3e-3, atol=0.0), body
    small, small_fields = _solved_state(0.8, 1e-11)
    small_radius = st.contact_radius(small_fields, small.grid.cell_area)
    assert yielding._YieldEvaluator(small.pair, small.grid, st.tractions(small_fields), depths, "cpu", "float64",
                                    "auto", small_radius).coarse is None

"""``warpcontact fit`` with a domain that follows the adhesion law (``grid.size = "law"`` or
``"table2"``, in a CSV row or as ``[run] grid_size``): each trial point's case gets the domain its
own delta_n needs, with the cell side kept; a fixed domain builds the same case as before; bad
values are refused naming the key or the CSV line.

The fits here run on a stand-in for the solver (``sweep.run_case`` replaced), so the file checks
the cases each trial builds in a few seconds; docs/fit.md gives the solved numbers."""

import math
from pathlib import Path

import pytest

from warpcontact.cli import main
from warpcontact.records.case import case_from_dict, substitute
from warpcontact.records.guards import adhesion_tail, grid_holding, suggested_adhesive_size
from warpcontact.studies.fit import load_fit, run_fit
from warpcontact.studies.fit_spec import _row_case
from warpcontact.studies.runner import adhesion_law
from warpcontact.studies.table2 import Table2Settings, cell_grid

ROOT = Path(__file__).resolve().parents[1]
PAPER_CASE = ROOT / "examples" / "table2_k080_dz5e-5.toml"
SMC = '\n[adhesion]\nlaw = "smc"\nsigma_max = 1.0e6\ntau_max = 1.0e6\ndelta_n = 5.0e-12\ndelta_t = 5.0e-12\n'
DELTA_N = 5.0e-12
FIT = ('base = "base.toml"\n[data]\nfile = "data.csv"\n[fit]\n'
       '"adhesion.delta_n" = { min = 1e-12, max = 2e-10, start = 5e-12, scale = "log" }\n[run]\n')
CSV = "load.delta_z,mu\n1.0e-11,0.79\n5.0e-11,0.81\n"


def write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def adhesive_base(folder: Path, adhesion: bool = True) -> Path:
    """The paper's case at n = 24, one normal step, with Table 2's SMC law."""
    text = PAPER_CASE.read_text().replace("n = 96", "n = 24").replace("steps = 4", "steps = 1")
    return write(folder / "base.toml", text + (SMC if adhesion else ""))


def law_fit(folder: Path, run: str = 'grid_size = "law"\n', csv: str = CSV, adhesion: bool = True) -> Path:
    adhesive_base(folder, adhesion)
    write(folder / "data.csv", csv)
    return write(folder / "fit.toml", FIT + run)


def case_at(fit, row, delta_n):
    return _row_case(fit.base_dict, row, {"adhesion.delta_n": delta_n}, fit.overrides, "data.csv", fit.grid_size)


def test_a_trial_delta_n_gets_the_domain_its_own_tail_needs(tmp_path, monkeypatch):
    """A fit of delta_n with [run] grid_size = "law", on a stand-in solver: every case a trial
    point builds holds its own law's tail at its delta_z, on the base's cell side; the side grows
    as sqrt(delta_z + 7.64 delta_n) (the sphere's gap reaches the tail there): 4x delta_n, at
    least 1.7x the side (3x the area); 25x, at least 4x."""
    from warpcontact.studies import sweep

    seen = []

    def stand_in(task, rel_tol, case, *args, **kw):  # mu rises with log(delta_n): the fit moves it
        seen.append(case)
        mu = 0.8 + 0.01 * math.log(case.adhesion.delta_n / DELTA_N)
        summary = {"converged": True, "mu": mu, "delta_x_max": 1e-11}
        return {"summary": summary, "warnings": [], "elapsed_s": 0.0}

    monkeypatch.setattr(sweep, "run_case", stand_in)
    fit = load_fit(law_fit(tmp_path, csv="load.delta_z,mu\n1.0e-11,0.81\n5.0e-11,0.81\n"))
    base = fit.base.grid
    report = run_fit(fit, tmp_path / "out", quiet=True)
    assert report.error is None, report.error
    trials = {case.adhesion.delta_n for case in seen}
    assert len(trials) >= 3, trials  # the start, a difference step and the optimiser's steps
    for case in seen:
        dz = case.load.delta_z_max
        need = suggested_adhesive_size(case.sphere.radius, dz, adhesion_law(case))
        assert case.grid.size >= need and case.grid.size >= base.size
        assert case.grid.dx == pytest.approx(base.dx, rel=1e-12)  # the cell side kept
    row = fit.rows[0]
    small, large, huge = (case_at(fit, row, DELTA_N * f).grid for f in (1, 4, 25))
    assert large.size >= 1.7 * small.size and large.size ** 2 >= 3.0 * small.size ** 2
    assert huge.size >= 4.0 * small.size
    tail = adhesion_tail(adhesion_law(case_at(fit, row, DELTA_N)))
    assert tail == pytest.approx(7.64 * DELTA_N)
    # the fitted case (fitted.toml) on the domain the rule gives the base at the fitted value
    text = (tmp_path / "out" / "fitted.toml").read_text()
    assert "[grid]" in text and report.parameters["adhesion.delta_n"]["value"] > 0


def test_table2_rule_is_the_table2_cells_grid_and_rows_may_mix(tmp_path):
    """grid.size = "table2" in a row: cell_grid of the row's delta_z (n = grid.n over 3 Hertz radii,
    grown for the tail); a row with a number keeps it, the same case as a fit without rules."""
    fit = load_fit(law_fit(tmp_path, run="", csv="load.delta_z,grid.size,mu\n1.0e-11,table2,0.79\n"
                                                 "5.0e-11,6.708e-8,0.81\n2.0e-11,law,0.8\n"))
    ruled, fixed, law = fit.rows
    for dn in (DELTA_N, 8 * DELTA_N):
        settings = Table2Settings(n=24, delta_n=dn, delta_t=dn)
        assert case_at(fit, ruled, dn).grid == cell_grid(1.0e-11, settings, settings.adhesion_law())
        case = case_at(fit, fixed, dn)
        params = {"load.delta_z": 5.0e-11, "grid.size": 6.708e-8, "adhesion.delta_n": dn}
        assert case == case_from_dict(substitute(fit.base_dict, params))  # a fixed domain: unchanged
        assert case.grid.n == 24 and case.grid.size == 6.708e-8
        grown = case_at(fit, law, dn)
        need = suggested_adhesive_size(10e-6, 2.0e-11, adhesion_law(grown))
        assert grown.grid == grid_holding(24, 6.708e-8, need)  # the base's domain grown, its cell side kept


def test_without_a_rule_the_cases_are_those_of_the_sweep_build(tmp_path):
    """No grid rule: every row's case is case_from_dict of the base with the row and the values put
    in, bit for bit, on the base's domain whatever delta_n (the domain does not follow)."""
    fit = load_fit(law_fit(tmp_path, run="", csv="load.delta_z,mu\n5.0e-11,0.81\n"))
    assert fit.grid_size is None
    row, = fit.rows
    for dn in (DELTA_N, 4 * DELTA_N):
        case = case_at(fit, row, dn)
        assert case == case_from_dict(substitute(fit.base_dict, {"load.delta_z": 5.0e-11, "adhesion.delta_n": dn}))
        assert case.grid == fit.base.grid


@pytest.mark.parametrize("run,csv,adhesion,message", [
    ('grid_size = "lw"\n', CSV, True, "run.grid_size: must be one of 'law', 'table2'"),
    ("grid_size = 3\n", CSV, True, "run.grid_size: must be one of"),
    ('grid_size = "law"\n', "load.delta_z,grid.size,mu\n1e-11,3e-8,0.8\n", True,
     "run.grid_size: the grid.size column of data.csv sets each row's domain"),
    ("", "load.delta_z,grid.size,mu\n1e-11,lw,0.8\n", True,
     "data.csv line 2: column grid.size: 'lw' is neither a number (m) nor one of 'law', 'table2'"),
    ('grid_size = "law"\n', CSV, False, "run.grid_size = \"law\" sizes the domain by the adhesion law's tail"),
    ("", "load.delta_z,grid.size,mu\n1e-11,law,0.8\n", False,
     "data.csv line 2: column grid.size = \"law\" sizes the domain by the adhesion law's tail"),
], ids=["unknown rule", "a number", "both column and run", "unknown cell", "law without adhesion",
        "law cell without adhesion"])
def test_bad_grid_rules_are_refused_naming_the_key(tmp_path, capsys, run, csv, adhesion, message):
    fit_file = law_fit(tmp_path, run=run, csv=csv, adhesion=adhesion)
    if not adhesion:
        fit_file = write(fit_file, fit_file.read_text().replace('"adhesion.delta_n" = { min = 1e-12, max = 2e-10, '
                                                                'start = 5e-12, scale = "log" }',
                                                                '"friction.k_tau" = { min = 0.3, max = 0.97 }'))
    assert main(["fit", str(fit_file), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("warpcontact: error: ") and message in err, err
    assert "Traceback" not in err and err.count("\n") == 1
    assert not (tmp_path / "out").exists()


def test_a_shape_without_a_hertz_gap_is_refused_naming_grid_size(tmp_path):
    """A cone has no sphere's gap to size the domain from: the rule is refused, naming the key."""
    from warpcontact.errors import InputError
    from warpcontact.studies.fit_spec import dict_rule_grid

    fit = load_fit(law_fit(tmp_path))
    d = substitute(fit.base_dict, {})
    d["sphere"] = {**d["sphere"], "profile": "cone"}
    with pytest.raises(InputError) as e:
        dict_rule_grid(d, "law")
    assert e.value.key == "grid.size" and "sphere's or paraboloid's gap" in e.value.problem


def test_the_laws_domain_holds_the_tail_a_fixed_one_cuts(tmp_path):
    """Solved, delta_n = 4 x 5 pm at delta_z = 5e-11 m: on the base's fixed domain (24 cells over
    3 Hertz radii) the adhesive tension on the edge warns (the tail is cut); on the law's domain
    (the same cell side, more cells) it does not, and mu rises (the tail's pull added to F_z's
    tension lowers F_z)."""
    from warpcontact.studies.sweep import run_case

    fit = load_fit(law_fit(tmp_path, run="", csv="load.delta_z,grid.size,mu\n5.0e-11,6.708e-8,0.81\n"
                                                 "5.0e-11,law,0.81\n"))
    fixed, law = (case_at(fit, row, 4 * DELTA_N) for row in fit.rows)
    assert fixed.grid.n == 24 and law.grid.n > 24 and law.grid.dx == pytest.approx(fixed.grid.dx, rel=1e-12)
    outcomes = [run_case("gross-slip", 1e-2, case) for case in (fixed, law)]
    for out in outcomes:
        assert "summary" in out and out["summary"]["converged"], out
    edge = ["cuts off the adhesive law's tail" in w for out in outcomes for w in out["warnings"]]
    assert any(edge[:len(outcomes[0]["warnings"])]) and not any(edge[len(outcomes[0]["warnings"]):]), outcomes
    assert outcomes[1]["summary"]["mu"] > outcomes[0]["summary"]["mu"]

"""A real user's first hour: each problem a new user met, as a test that fails if it comes back.

The user: an AFM tip (Si3N4, R = 20 nm, E = 310 GPa, yield 8 GPa) on Si (E = 130 GPa, yield
4 GPa, hardness 11 GPa), 20 nm domain, delta_z = 0.1 nm, delta_x = 20 pm, Tabor k_tau = 0.6,
SMC adhesion sigma_max = tau_max = 122.6 MPa, delta_n = delta_t = 0.3 nm (w = 0.1 J/m^2). The
grids are kept small (n <= 64) so that the file runs in well under a minute on 2 cores.
"""

from __future__ import annotations

import copy
import json
import math
import time
import warnings

import numpy as np
import pytest
from test_case import to_toml

from warpcontact.records.case import case_from_dict
from warpcontact.cli import main
from warpcontact.errors import InputError
from warpcontact.records.plausibility import PlausibilityWarning


def afm_dict(n: int = 32, adhesion: bool = True, friction: bool = True) -> dict:
    d = {
        "sphere": {"radius": 20e-9, "E": 310e9, "nu": 0.27, "yield_strength": 8e9},
        "flat": {"E": 130e9, "nu": 0.28, "yield_strength": 4e9, "hardness": 11e9},
        "grid": {"n": n, "size": 20e-9},
        "load": {"delta_z": 0.1e-9, "delta_x": 20e-12, "steps": 2},
    }
    if friction:
        d["friction"] = {"law": "tabor", "k_tau": 0.6}
    if adhesion:
        d["adhesion"] = {"law": "smc", "sigma_max": 122.6e6, "tau_max": 122.6e6, "delta_n": 0.3e-9,
                         "delta_t": 0.3e-9}
    return d


def write(tmp_path, d, name="case.toml"):
    f = tmp_path / name
    f.write_text(to_toml(d), encoding="utf-8")
    return f


def refused(capsys, tmp_path, d, command="solve") -> str:
    """Run ``command`` on case ``d``: exit 2 in under a few seconds, one line, nothing written."""
    t0 = time.perf_counter()
    rc = main([command, str(write(tmp_path, d)), "--out", str(tmp_path / "out"), "--quiet"])
    elapsed = time.perf_counter() - t0
    err = capsys.readouterr().err
    lines = [ln for ln in err.strip().splitlines() if ln.startswith("warpcontact")]
    assert rc == 2, err
    assert "Traceback" not in err and len(lines) == 1, err
    assert elapsed < 5.0, f"refused after {elapsed:.1f} s: the check must come before the solve"
    assert not (tmp_path / "out").exists()
    return lines[0]


# --- row 1-3: inputs in the wrong unit ------------------------------------------------------------


@pytest.mark.parametrize("command", ["solve", "gross-slip", "pull-off"])
def test_modulus_in_gpa_written_as_pa_is_refused_with_the_unit(capsys, tmp_path, command):
    d = afm_dict()
    d["sphere"]["E"] = 310  # meant GPa
    line = refused(capsys, tmp_path, d, command)
    assert "sphere.E = 310 Pa" in line and "8e10 and 2e12 Pa" in line and "(310 GPa)?" in line, line


def test_modulus_in_gpa_without_a_yield_strength_is_caught_by_the_adhesive_stress(capsys, tmp_path):
    d = afm_dict()
    d["sphere"]["E"] = 310
    del d["sphere"]["yield_strength"]
    line = refused(capsys, tmp_path, d)
    assert "sphere.E = 310 Pa makes E* = 334.4 Pa" in line and "(310 GPa)?" in line, line


def test_adhesive_length_in_nm_written_as_m_is_refused(capsys, tmp_path):
    d = afm_dict()
    d["adhesion"]["delta_n"] = 0.3  # meant nm: w ~ 1e8 J/m^2
    line = refused(capsys, tmp_path, d, "pull-off")
    assert "adhesion.delta_n = 0.3 m" in line and "w = e sigma_max delta_n = 9.998e7 J/m^2" in line, line
    assert "(0.3 nm)?" in line, line


@pytest.mark.parametrize("key, value, meant", [
    ("load.delta_z", 0.1, "1e-10 m (0.1 nm)?"),     # meant nm
])
def test_approach_in_nm_written_as_m_is_refused(capsys, tmp_path, key, value, meant):
    d = afm_dict()
    d["load"]["delta_z"] = value
    line = refused(capsys, tmp_path, d)
    assert f"{key} = {value} m" in line and meant in line, line


def test_yield_strength_in_gpa_written_as_pa_is_refused_with_the_unit(capsys, tmp_path):
    """S_Y / E = 1e-11 is no solid (they yield at 1e-4 to 0.05): a unit slip, not a warning."""
    d = afm_dict()
    d["sphere"]["yield_strength"] = 8.0  # meant GPa
    line = refused(capsys, tmp_path, d)
    assert "sphere.yield_strength = 8 Pa" in line and "(8 GPa)?" in line, line


def test_hardness_in_gpa_written_as_pa_is_refused_with_the_unit(capsys, tmp_path):
    d = afm_dict()
    d["flat"]["hardness"] = 11.0  # meant GPa
    line = refused(capsys, tmp_path, d)
    assert "flat.hardness = 11 Pa" in line and "(11 GPa)?" in line, line


def test_adhesive_stress_in_mpa_written_as_pa_warns_with_the_unit():
    """w = 1e-7 J/m^2: the law hardly acts, and nothing said so; now a warning names the unit."""
    d = afm_dict()
    d["adhesion"]["sigma_max"] = d["adhesion"]["tau_max"] = 122.6  # meant MPa
    with pytest.warns(PlausibilityWarning) as record:
        case_from_dict(d)
    text = " ".join(str(w.message) for w in record)
    assert "w = e sigma_max delta_n = 9.998e-8 J/m^2" in text and "1.226e8 Pa (122.6 MPa)" in text and "hardly acts" in text, text


def test_tangential_shift_in_nm_written_as_m_is_refused_with_the_unit(capsys, tmp_path):
    d = afm_dict()
    d["load"]["delta_x"] = 0.02  # meant nm
    line = refused(capsys, tmp_path, d)
    assert "load.delta_x" in line and "beyond the domain's half-width 1e-8 m" in line, line
    assert "2e-11 m (0.02 nm)?" in line, line


def test_an_explicit_path_beyond_the_domain_is_refused():
    d = afm_dict()
    del d["load"]
    d["load"] = {"path": [[0.0, 0.0, 1e-10], [0.0, 0.02, 1e-10]]}  # meant nm
    with pytest.raises(InputError, match=r"load.path.*0.02 m.*\(0.02 nm\)\?"):
        case_from_dict(d)


def test_radius_in_um_written_as_m_is_refused():
    """The paper's copper sphere, R = 10 um written as 10: the unit is named."""
    d = {"sphere": {"radius": 10, "E": 106e9, "nu": 0.33}, "flat": {"E": 205e9, "nu": 0.31},
         "grid": {"n": 64, "size": 1e-7}, "load": {"delta_z": 5e-11}}
    with pytest.raises(InputError) as e:
        case_from_dict(d)
    assert e.value.key == "sphere.radius" and "did you mean 1e-5 m (10 um)?" in str(e.value), e.value


def test_a_radius_no_unit_explains_names_every_length():
    d = afm_dict()
    d["sphere"]["radius"] = 10
    with pytest.raises(InputError) as e:
        case_from_dict(d)
    assert e.value.key == "grid.size" and "check the units of sphere.radius, load.delta_z and grid.size" in str(e.value)


@pytest.mark.parametrize("mutate, key, hint", [
    (lambda d: d["sphere"].update(E=310e18), "sphere.E", "stiffer than any solid"),
    (lambda d: d["flat"].update(yield_strength=4e18), "flat.yield_strength", "did you mean 4e9 Pa?"),
    (lambda d: d["flat"].update(hardness=11e18), "flat.hardness", "did you mean 1.1e10 Pa?"),
    (lambda d: d["sphere"].update(E=0.5), "sphere.E", "softer than any solid"),
    (lambda d: d["adhesion"].update(sigma_max=122.6e12), "adhesion.sigma_max", "did you mean 1.226e8 Pa?"),
    (lambda d: d["adhesion"].update(tau_max=122.6e12), "adhesion.tau_max", "did you mean 1.226e8 Pa?"),
    (lambda d: d["adhesion"].update(sigma_max=20e9), "adhesion.sigma_max", "J/m^2"),
    (lambda d: d.update(adhesion={"law": "dugdale", "sigma_0": 1e8, "h_0": 1.0}), "adhesion.h_0", "(1 nm)?"),
])
def test_values_no_solid_has_are_refused(mutate, key, hint):
    d = afm_dict()
    mutate(d)
    with pytest.raises(InputError) as e:
        case_from_dict(d)
    assert e.value.key == key and hint in str(e.value), e.value


def test_an_adhesive_stress_above_the_theoretical_strength_warns():
    d = afm_dict()
    d["adhesion"].update(sigma_max=20e9, delta_n=3e-12, tau_max=1e8)  # E* / 10 = 9.9e9 Pa < 2e10 Pa < E*
    with pytest.warns(PlausibilityWarning, match="adhesion.sigma_max = 2e10 Pa is above E\\* / 10"):
        case_from_dict(d)


@pytest.mark.parametrize("sphere, flat, grid, load, adhesion", [
    # a hydrogel sphere (1 kPa) on glass, with a weak long-ranged adhesion
    ({"radius": 1e-3, "E": 1e3, "nu": 0.45}, {"E": 70e9, "nu": 0.2}, {"n": 64, "size": 4e-4}, {"delta_z": 1e-5},
     {"law": "dugdale", "sigma_0": 50.0, "h_0": 1e-6}),
    # a cell (100 Pa) under a stiff bead
    ({"radius": 5e-6, "E": 70e9, "nu": 0.2}, {"E": 100.0, "nu": 0.5}, {"n": 64, "size": 3e-6}, {"delta_z": 1e-7},
     {"law": "smc", "sigma_max": 5.0, "tau_max": 5.0, "delta_n": 5e-9, "delta_t": 5e-9}),
    # an AFM tip on a cell (500 Pa), no adhesion; a soft elastomer (100 kPa) with a yield strength
    ({"radius": 20e-9, "E": 310e9, "nu": 0.27, "profile": "paraboloid"}, {"E": 500.0, "nu": 0.5},
     {"n": 64, "size": 60e-9}, {"delta_z": 5e-9}, None),
    ({"radius": 1e-4, "E": 1e5, "nu": 0.49, "yield_strength": 5e3}, {"E": 200e9, "nu": 0.3},
     {"n": 64, "size": 3e-5}, {"delta_z": 1e-6}, None),
])
def test_soft_matter_passes_without_a_word(sphere, flat, grid, load, adhesion):
    d = {"sphere": sphere, "flat": flat, "grid": grid, "load": load}
    if adhesion:
        d["adhesion"] = adhesion
    with warnings.catch_warnings():
        warnings.simplefilter("error", PlausibilityWarning)
        case_from_dict(d)


def test_the_users_case_passes():
    with warnings.catch_warnings():
        warnings.simplefilter("error", PlausibilityWarning)
        case = case_from_dict(afm_dict())
    assert case.adhesion.work_of_adhesion == pytest.approx(0.1, rel=1e-3)


# --- row 4: resolution checked by every command, once per run, with the grid that would do ------------


def run_cli(capsys, tmp_path, d, *argv):
    rc = main([argv[0], str(write(tmp_path, d)), "--out", str(tmp_path / "out"), "--quiet", *argv[1:]])
    return rc, capsys.readouterr().err


def warning_lines(err: str, text: str) -> list:
    return [ln for ln in err.splitlines() if ln.startswith("warpcontact: warning:") and text in ln]


def test_gross_slip_on_a_coarse_grid_warns_once_with_the_grid_that_would_do(capsys, tmp_path):
    """n = 32 puts 2.3 cells across the 1.41 nm contact radius; measured on this case (no
    adhesion): mu 0.266 at n = 32, 0.235 at 64, 0.242 at 128 (+10 %, -3 % against 128)."""
    rc, err = run_cli(capsys, tmp_path, afm_dict(32, adhesion=False), "gross-slip")
    assert rc == 0, err
    lines = warning_lines(err, "cells (under 8)")
    assert len(lines) == 1, err
    assert "the contact radius (1.41e-09 m) spans 2.3 cells" in lines[0] and "grid.n >= 128" in lines[0], lines[0]


def test_solve_warns_once_per_run_not_once_per_state(capsys, tmp_path):
    d = afm_dict(32, adhesion=False)
    d["load"]["steps"] = 4  # 8 states, the first ones with a tiny contact
    rc, err = run_cli(capsys, tmp_path, d, "solve")
    assert rc == 0, err
    lines = warning_lines(err, "cells (under")
    assert len(lines) == 1 and "at delta_z = 1e-10 m" in lines[0], err


def test_a_fine_grid_does_not_warn(capsys, tmp_path):
    d = afm_dict(64, adhesion=False, friction=False)
    d["grid"]["size"] = 8e-9  # 8 nm, 64 cells: 11 cells across the contact radius
    d["load"] = {"delta_z": 0.1e-9}
    d["flat"]["yield_strength"] = 8e9
    rc, err = run_cli(capsys, tmp_path, d, "solve")
    assert rc == 0 and "warning" not in err, err


def test_pull_off_checks_the_resolution_once(capsys, tmp_path):
    d = afm_dict(32, friction=False)
    d["load"] = {"delta_z": 0.1e-9}
    rc, err = run_cli(capsys, tmp_path, d, "pull-off", "--steps", "2")
    assert rc in (0, 3), err
    lines = warning_lines(err, "cells (under")
    assert len(lines) == 1 and "the contact radius (1.41e-09 m) spans 2.3 cells" in lines[0], err


def test_the_adhesive_zone_is_judged_by_the_same_rule():
    """A law of 5 pm range beside a contact of 11 cells: the adhesive zone, not the contact, asks
    for the finer grid. With no adhesive cell at all the zone is estimated from the Hertz gap."""
    from warpcontact.records.guards import CoarseGridWarning, RunChecks, adhesive_zone_estimate

    d = afm_dict(64, friction=False)
    d["grid"]["size"] = 8e-9
    d["adhesion"].update(delta_n=5e-12, delta_t=5e-12)
    case = case_from_dict(d)
    a = math.sqrt(20e-9 * 0.1e-9)
    zone = adhesive_zone_estimate(a, 20e-9, 5e-12)
    assert 0.1e-9 < zone < 0.3e-9  # a few pm of gap open within a fraction of a nm of the edge
    need = 16 * math.ceil(64 * 3 / (zone / (8e-9 / 64)) / 16)
    s = {"delta": {"x": 0.0, "y": 0.0, "z": 0.1e-9}, "contact_radius": a, "contact_area": math.pi * a * a,
         "adhesive_area": 0.0, "max_pressure": 1e9}
    checks = RunChecks(case)
    with pytest.warns(CoarseGridWarning, match=rf"the adhesive zone .* spans .* cells \(under 3\).*grid.n >= {need}"):
        checks.observe(s, decisive=True)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        checks.observe(s, decisive=True)  # once per run


def test_table2_grids_are_judged_by_the_same_rule():
    from warpcontact.studies.table2 import check_resolution
    from warpcontact.records.guards import CoarseGridWarning

    law = {"delta_n": 5e-12}
    with pytest.warns(CoarseGridWarning, match=r"table2 --n 16: the contact radius .* spans 5.3 cells .* --n 112"):
        check_resolution([(16, 0.8, 5e-5, False), (16, 0.8, 1.5e-4, True)], 3.0, law)
    with warnings.catch_warnings():  # the defaults (n = 128 over 3 a) resolve every cell
        warnings.simplefilter("error", CoarseGridWarning)
        check_resolution([(128, k, dz, adh) for k in (0.5, 0.8) for dz in (1e-5, 1.5e-4) for adh in (0, 1)], 3.0, law)


def test_pressure_above_a_yield_strength_warns_once_naming_the_body(capsys, tmp_path):
    """p0 = 4.4 GPa on the 4 GPa flat: the von Mises limit is zero over the centre."""
    d = afm_dict(32, adhesion=False)
    rc, err = run_cli(capsys, tmp_path, d, "solve")
    lines = warning_lines(err, "yield_strength")
    assert rc == 0 and len(lines) == 1, err
    assert "above flat.yield_strength = 4e+09 Pa" in lines[0] and "sphere" not in lines[0], lines[0]
    assert "von Mises limit" in lines[0] and "lowers mu" in lines[0], lines[0]
    d["flat"]["yield_strength"] = 6e9  # above p0: no word
    rc, err = run_cli(capsys, tmp_path, d, "solve")
    assert rc == 0 and not warning_lines(err, "yield_strength"), err


# --- row 7: one summary per kind of result --------------------------------------------------------

#: what result.json adds to a summary: the run's record
RECORD_KEYS = {"complete", "interrupted", "device", "dtype", "fft", "software", "case"}


def test_gross_slip_summary_keys_are_the_same_in_the_cli_the_api_and_a_sweep_row(capsys, tmp_path):
    import warpcontact as wc
    from warpcontact.api import result_row

    d = afm_dict(16, adhesion=False)
    rc, err = run_cli(capsys, tmp_path, d, "gross-slip")
    assert rc == 0, err
    cli = json.loads((tmp_path / "out" / "result.json").read_text())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        api = wc.gross_slip(case_from_dict(d))
    assert set(cli) - RECORD_KEYS == set(api), set(cli) ^ set(api)
    assert api["mu"] == cli["mu"] and api["force_elastic"] == cli["force_elastic"]  # same run, same numbers
    row = result_row(api)
    assert {"mu", "mu_elastic", "force", "force_elastic", "delta_x_max", "stick_area", "contact_area"} <= set(row)
    assert row["n_states"] == len(api["states"]) and "states" not in row


def test_pull_off_summary_keys_are_the_same_in_the_cli_and_the_api(capsys, tmp_path):
    import warpcontact as wc

    d = afm_dict(16, friction=False)
    d["load"] = {"delta_z": 0.1e-9}
    rc, err = run_cli(capsys, tmp_path, d, "pull-off", "--steps", "2")
    assert rc in (0, 3), err
    cli = json.loads((tmp_path / "out" / "result.json").read_text())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        api = wc.pull_off(case_from_dict(d), steps=2)
    assert set(cli) - RECORD_KEYS == set(api), set(cli) ^ set(api)
    for key in ("tabor_parameter", "work_of_adhesion", "dmt_pull_off", "jkr_pull_off"):
        assert api[key] == pytest.approx(cli[key], rel=1e-12), key
    assert api["work_of_adhesion"] == pytest.approx(math.e * 122.6e6 * 0.3e-9, rel=1e-12)
    assert api["dmt_pull_off"] == pytest.approx(-2 * math.pi * 20e-9 * api["work_of_adhesion"], rel=1e-12)


# --- row 6: a stop before the first state -------------------------------------------------------------


@pytest.fixture
def stop_at_first_step(monkeypatch):
    """The first load step raises SIGTERM's Stop, as a signal arriving inside it does."""
    import signal

    from warpcontact import interrupts
    from warpcontact.solvers import contact

    def stopped(self, *a, **kw):
        raise interrupts.Stop(signal.SIGTERM)

    monkeypatch.setattr(contact.ContactSolver, "step", stopped)
    yield
    interrupts.reset()


@pytest.mark.parametrize("command", ["solve", "gross-slip", "pull-off"])
def test_a_stop_before_the_first_state_writes_nothing_and_says_so(capsys, tmp_path, stop_at_first_step, command):
    d = afm_dict(16, adhesion=command == "pull-off", friction=command != "pull-off")
    out = tmp_path / "new" / "out"
    rc = main([command, str(write(tmp_path, d)), "--out", str(out), "--quiet"])
    err = capsys.readouterr().err
    assert rc == 143, err
    assert "interrupted (SIGTERM): stopped before the first state finished; nothing was written" in err, err
    assert not (tmp_path / "new").exists()


@pytest.mark.parametrize("command", ["solve", "gross-slip"])
def test_a_stop_before_the_first_state_over_an_earlier_run_records_the_stop(capsys, tmp_path, stop_at_first_step,
                                                                           command):
    out = tmp_path / "out"
    out.mkdir()
    (out / "result.json").write_text(json.dumps({"complete": True, "states": [{}]}))  # an earlier run's
    rc = main([command, str(write(tmp_path, afm_dict(16))), "--out", str(out), "--quiet"])
    err = capsys.readouterr().err
    assert rc == 143 and "records the stop and holds no state" in err, err
    res = json.loads((out / "result.json").read_text())
    assert res["complete"] is False and res["interrupted"] is True and res.get("states", res.get("curve")) == []


# --- row 9: small things --------------------------------------------------------------------------------


def test_version_and_help_texts(capsys):
    from warpcontact import __version__

    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0 and capsys.readouterr().out.strip() == f"warpcontact {__version__}"
    with pytest.raises(SystemExit):
        main(["gross-slip", "--help"])
    text = capsys.readouterr().out
    assert "bisect to 1 %." in text and "%%" not in text


# --- row 8: plots -------------------------------------------------------------------------------------


def test_figure_draws_a_gross_slip_and_a_pull_off_output(capsys, tmp_path):
    """figure on gross-slip's folder: the state at gross slip, solved again along the search's
    history (its force is the result's to the last digit); on pull-off's: the force-approach curve."""
    from warpcontact.cli.figure import gross_slip_fields

    d = afm_dict(16, adhesion=False)
    rc, err = run_cli(capsys, tmp_path, d, "gross-slip")
    assert rc == 0, err
    res = json.loads((tmp_path / "out" / "result.json").read_text())
    f = gross_slip_fields(res)
    assert f["_summary"]["force"] == res["force"] and f["_summary"]["delta"]["x"] == res["delta_x_max"]
    assert f["stick_mask"][0].any() and "shear_limit" in f
    assert main(["figure", str(tmp_path / "out"), "--out", str(tmp_path / "fig"), "--quiet"]) == 0
    assert sorted(p.name for p in (tmp_path / "fig").iterdir()) == ["area_map.png", "fields.png", "profile.png"]

    po = tmp_path / "po"
    po.mkdir()
    d = afm_dict(16, friction=False)
    d["load"] = {"delta_z": 0.1e-9}
    rc = main(["pull-off", str(write(po, d)), "--out", str(po / "out"), "--quiet", "--steps", "2"])
    assert rc in (0, 3), capsys.readouterr().err
    assert main(["figure", str(po / "out"), "--out", str(po / "fig"), "--quiet"]) == 0
    assert (po / "fig" / "pull_off.png").read_bytes()[:4] == b"\x89PNG"


def test_fields_npz_holds_the_shear_limit(capsys, tmp_path):
    rc, err = run_cli(capsys, tmp_path, afm_dict(32, adhesion=False), "solve")
    assert rc == 0, err
    with np.load(tmp_path / "out" / "fields.npz") as f:
        q, p = f["shear_limit"][-1], f["pressure"][-1]
    # Tabor k_tau = 0.6 (mu_b = k_vm / sqrt(k_tau^-2 - 1) = 0.433) capped by von Mises on the 4 GPa flat
    k_vm = 1 / math.sqrt(3)
    law = np.minimum(k_vm / math.sqrt(0.6**-2 - 1) * p, k_vm * np.sqrt(np.maximum(4e9**2 - p**2, 0.0)))
    assert np.allclose(q, law, rtol=1e-9, atol=1e-3) and (q[p > 4e9] == 0).all() and (p > 4e9).any()


def test_sweep_rows_carry_the_summary_keys_and_pull_off_is_a_task(tmp_path):
    """A gross-slip sweep's rows have mu_elastic and force_elastic (docs/sweeps.md names them); a
    pull-off sweep runs and its rows have the pull-off keys."""
    import csv

    from warpcontact.studies.sweep import run_sweep
    from warpcontact.studies.sweep_spec import sweep_from_dict

    base = afm_dict(16, adhesion=False)
    sw = sweep_from_dict({"base": base, "sweep": {"friction.k_tau": [0.6]}, "run": {"task": "gross-slip"}})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        report = run_sweep(sw, tmp_path / "gs", quiet=True)
    assert report.all_converged, report.records
    rows = list(csv.DictReader((tmp_path / "gs" / "sweep.csv").open()))
    assert {"mu", "mu_elastic", "force_elastic_z", "delta_x_gross", "n_states"} <= set(rows[0]), rows[0].keys()

    base = afm_dict(16, friction=False)
    base["load"] = {"delta_z": 0.1e-9}
    with pytest.raises(InputError, match="'pull-off' needs an \\[adhesion\\] table"):
        sweep_from_dict({"base": afm_dict(16, adhesion=False), "sweep": {"grid.n": [16]}, "run": {"task": "pull-off"}})
    sw = sweep_from_dict({"base": base, "sweep": {"adhesion.sigma_max": [122.6e6]}, "run": {"task": "pull-off"}})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        report = run_sweep(sw, tmp_path / "po", quiet=True)
    summary = report.records[0]["summary"]
    assert {"pull_off_force", "tabor_parameter", "work_of_adhesion", "dmt_pull_off", "jkr_pull_off"} <= set(summary)
    assert summary["n_states"] == 41 and "curve" not in summary  # 20 steps each way and the turning point


@pytest.mark.parametrize("call", ["solve", "path", "gross_slip"])
def test_the_python_api_warns_once_as_the_command_line_does(call):
    import warpcontact as wc
    from warpcontact.records.guards import CoarseGridWarning, YieldWarning

    case = case_from_dict(afm_dict(32, adhesion=False))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")  # every warning counted, none folded by the registry
        if call == "path":
            list(wc.path(case))
        else:
            getattr(wc, call)(case)
    kinds = [w.category for w in caught]
    assert kinds.count(CoarseGridWarning) == 1 and kinds.count(YieldWarning) == 1, [str(w.message) for w in caught]


def test_table2_adhesion_options_are_judged_for_plausibility(capsys, tmp_path):
    rc = main(["table2", "--delta-n", "5e-3", "--out", str(tmp_path / "t2"), "--quiet"])  # 5 mm: w = 1.4e4 J/m^2
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and err.startswith("warpcontact: error: --delta-n = 0.005 m"), err
    assert not (tmp_path / "t2").exists()


def test_a_domain_suggested_beyond_the_sphere_asks_for_the_paraboloid():
    """Row 1: the grid.size suggestion must not break the sqrt(2) R rule without saying so."""
    d = {"sphere": {"radius": 20e-9, "E": 310e9, "nu": 0.27}, "flat": {"E": 130e9, "nu": 0.28},
         "grid": {"n": 64, "size": 20e-9}, "load": {"delta_z": 8e-9}}  # 2.5 a = 31.6 nm > sqrt(2) R = 28.3 nm
    with pytest.raises(InputError) as e:
        case_from_dict(d)
    assert e.value.key == "grid.size" and "use at least 3.162e-08 m" in str(e.value)
    assert "sphere.profile = 'paraboloid'" in str(e.value), e.value


def test_the_python_api_takes_a_case_files_path_or_a_dict_as_it_takes_a_case(tmp_path):
    """``warpcontact.solve("case.toml")`` and ``solve({...})`` run the case that ``solve(Case)``
    runs: the same summary, bit for bit (one process, one device: the same operations)."""
    import warpcontact

    d = afm_dict(n=16, adhesion=False)
    path = tmp_path / "afm.toml"
    path.write_text(to_toml(d))
    by_case = warpcontact.solve(case_from_dict(d), fields="none").states[-1]
    for given in (str(path), path, d):
        got = warpcontact.solve(given, fields="none").states[-1]
        assert got["force"] == by_case["force"], (type(given).__name__, got["force"], by_case["force"])
    with pytest.raises(InputError, match="no such file"):
        warpcontact.solve(tmp_path / "missing.toml")


@pytest.mark.parametrize("key, table, value, expected", [
    ("radius", "sphere", "10 um", "write 1e-05 (10 um in m)"),
    ("E", "flat", "130 GPa", "write 1.3e+11 (130 GPa in Pa)"),
    ("yield_strength", "flat", "4 GPa", "write 4e+09 (4 GPa in Pa)"),
    ("delta_z", "load", "0.1 nm", "write 1e-10 (0.1 nm in m)"),
    ("radius", "sphere", "2e-8", "write it without quotes: 2e-08"),
    ("radius", "sphere", "20 GPa", "case files take bare numbers in SI units (m)"),
])
def test_a_number_written_with_its_unit_is_refused_with_the_si_number_to_write(key, table, value, expected):
    """Case files take bare SI numbers; a quoted number with a unit ("10 um") is refused naming the
    key, with the SI number to write where the unit is the key's (a unit of another quantity: the
    SI unit expected)."""
    d = afm_dict()
    d[table][key] = value
    with pytest.raises(InputError) as e:
        case_from_dict(d)
    assert e.value.key == f"{table}.{key}"
    assert f"got string {value!r}" in str(e.value) and expected in str(e.value), str(e.value)

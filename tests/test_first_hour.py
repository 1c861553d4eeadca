"""A real user's first hour (issue 32): each row of its table, as a test that fails if the row's
problem comes back.

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

from warpcontact.case import case_from_dict
from warpcontact.cli import main
from warpcontact.errors import InputError
from warpcontact.plausibility import PlausibilityWarning


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
    assert "sphere.E: = 310 Pa" in line and "8e10 and 2e12 Pa" in line and "(310 GPa)?" in line, line


def test_modulus_in_gpa_without_a_yield_strength_is_caught_by_the_adhesive_stress(capsys, tmp_path):
    d = afm_dict()
    d["sphere"]["E"] = 310
    del d["sphere"]["yield_strength"]
    line = refused(capsys, tmp_path, d)
    assert "sphere.E: = 310 Pa makes E* = 334.4 Pa" in line and "(310 GPa)?" in line, line


def test_adhesive_length_in_nm_written_as_m_is_refused(capsys, tmp_path):
    d = afm_dict()
    d["adhesion"]["delta_n"] = 0.3  # meant nm: w ~ 1e8 J/m^2
    line = refused(capsys, tmp_path, d, "pull-off")
    assert "adhesion.delta_n: = 0.3 m" in line and "w = e sigma_max delta_n = 9.998e7 J/m^2" in line, line
    assert "(0.3 nm)?" in line, line


@pytest.mark.parametrize("key, value, meant", [
    ("load.delta_z", 0.1, "1e-10 m (0.1 nm)?"),     # meant nm
])
def test_approach_in_nm_written_as_m_is_refused(capsys, tmp_path, key, value, meant):
    d = afm_dict()
    d["load"]["delta_z"] = value
    line = refused(capsys, tmp_path, d)
    assert f"{key}: = {value} m" in line and meant in line, line


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

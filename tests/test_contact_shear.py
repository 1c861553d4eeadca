"""The SMC law's shear inside the contact: "bounded" (the default: the contact shear alone,
bounded as a whole) or "added" (the law's shear at h = 0 and the cell's slip added to the
bounded contact shear, as the paper's text reads)."""

import copy
import math

import numpy as np
import pytest

import warpcontact as wc
from warpcontact.errors import InputError
from warpcontact.records.case import case_from_dict, tomllib
from test_first_hour import afm_dict

from pathlib import Path

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "figure2d.toml"


def figure2d(n: int = 32, contact_shear=None) -> dict:
    with open(EXAMPLE, "rb") as f:
        d = tomllib.load(f)
    d["grid"]["n"] = n
    d["solver"]["device"] = "cpu"
    if contact_shear is not None:
        d["adhesion"]["contact_shear"] = contact_shear
    return d


@pytest.fixture(scope="module")
def solved():
    return {mode: wc.solve(figure2d(contact_shear=mode), fields="last") for mode in (None, "bounded", "added")}


def test_bounded_is_the_default(solved):
    """Naming the default changes nothing: the same forces to the last bit."""
    for a, b in zip(solved[None].states, solved["bounded"].states):
        assert a["force"] == b["force"] and a["iterations"] == b["iterations"]


def test_added_puts_the_laws_shear_on_the_contact_cells(solved):
    """Inside the contact the adhesive shear is the law's, tau_max x_t e^(1 - x_t) along the slip
    (x_t = |s| / delta_t; h = 0 there): within 1e-6 of tau_max, the turns' tolerance (the law is
    evaluated at the last turn's slip, the slip then updated from tractions that changed by less
    than 1e-8 relative). With "bounded" it is zero there (under 1e-12 tau_max: the mixing of the
    adhesive fixed point leaves traces of the turns when a cell was out of contact)."""
    law = figure2d()["adhesion"]
    tau_max, delta_t = law["tau_max"], law["delta_t"]
    for mode, result in solved.items():
        f = result.fields[-1]
        contact = f["pressure"] > 0
        assert contact.sum() > 20
        q = np.hypot(f["adhesive_shear_x"], f["adhesive_shear_y"])[contact]
        if mode != "added":
            assert np.all(q < 1e-12 * tau_max)
            continue
        s = np.hypot(f["slip_x"], f["slip_y"])[contact]
        xt = s / delta_t
        expected = tau_max * xt * np.exp(1.0 - xt)
        assert np.max(np.abs(q - expected)) < 1e-6 * tau_max
        assert np.max(expected) > 0.1 * tau_max, "the slips reach the law's rising branch: the check has teeth"
        along = f["adhesive_shear_x"][contact] * f["slip_x"][contact] + f["adhesive_shear_y"][contact] * f["slip_y"][contact]
        assert np.all(along >= -1e-12 * tau_max * delta_t), "the adhesive shear on the flat is along the slip"


def test_added_changes_the_force_by_about_the_laws_shear_in_the_contact(solved):
    """F_x with the shear added exceeds the bounded one, by less than the law's shear summed over
    the contact (the contact shear it sits on top of adjusts: the stick zone's displacement
    condition holds the total)."""
    bounded, added = solved["bounded"].states[-1], solved["added"].states[-1]
    f = solved["added"].fields[-1]
    contact = f["pressure"] > 0
    cell = solved["added"].model.grid.cell_area
    law_fx = float(np.sum(f["adhesive_shear_x"][contact])) * cell
    assert added["converged"] and bounded["converged"]
    gain = added["force"]["x"] - bounded["force"]["x"]
    assert 0.0 < gain <= law_fx * (1 + 1e-9), (gain, law_fx)


def test_contact_shear_is_checked():
    d = figure2d()
    d["adhesion"]["contact_shear"] = "summed"
    with pytest.raises(InputError, match="adhesion.contact_shear"):
        case_from_dict(d)
    d = afm_dict()
    d["adhesion"] = {"law": "dugdale", "sigma_0": 1e8, "h_0": 1e-9, "contact_shear": "added"}
    with pytest.raises(InputError, match="adhesion.contact_shear.*not used by law 'dugdale'"):
        case_from_dict(d)


def test_the_case_round_trips_with_its_contact_shear():
    case = case_from_dict(figure2d(contact_shear="added"))
    assert case.adhesion.contact_shear == "added"
    assert case_from_dict(case.to_dict()) == case

"""A rigid body (``rigid = true``, ``Material.rigid()``): the limit E -> inf of one body.

The pair's constants drop the rigid body's compliance terms (MaterialPair.compliance); the
contact is then Hertz's with E* = E/(1 - nu^2) of the elastic body, the stiff-but-finite body
converges to it linearly in the compliance ratio, the normal-tangential coupling is the
dissimilar pair's (zero only against an incompressible body), and a rigid body has no stress
field to check. Grids of n <= 64 on the CPU.
"""

from __future__ import annotations

import copy
import math
import warnings

import numpy as np
import pytest
from test_case import to_toml
from test_schema import errors

import warpcontact as wc
from warpcontact.errors import InputError
from warpcontact.numerics.model import ContactModel
from warpcontact.numerics.state import ContactState
from warpcontact.numerics.stress_reference import hertz_von_mises_max
from warpcontact.physics.friction import Coulomb
from warpcontact.physics.geometry import Grid, Sphere
from warpcontact.physics.materials import Material, MaterialPair, PAPER_PAIR
from warpcontact.physics.reference import hertz
from warpcontact.records.case import case_from_dict, load_case
from warpcontact.schema import case_schema
from warpcontact.solvers import NormalSolver
from warpcontact.solvers.contact import ContactSolver

R, DZ = 10e-6, 1.0e-10
A = math.sqrt(R * DZ)
#: the elastic body: hardened steel's E and nu (nu = 0.31: compressible, so the pair is coupled)
FLAT = Material(E=205e9, nu=0.31, name="flat")
RIGID_SPHERE = MaterialPair(Material.rigid("sphere"), FLAT)


def stiff_sphere(ratio: float) -> MaterialPair:
    """A finite sphere ``ratio`` times stiffer than FLAT (beyond the case file's 2e12 Pa: the API
    takes it), nu = 0.3."""
    return MaterialPair(Material(E=ratio * FLAT.E, nu=0.3, name="sphere"), FLAT)


def compliance_ratio(pair: MaterialPair) -> float:
    """The sphere's share of the normal compliance over the flat's: (1 - nu1^2)/E1 / ((1 - nu2^2)/E2)."""
    return (1 - pair.sphere.nu**2) / pair.sphere.E / ((1 - pair.flat.nu**2) / pair.flat.E)


def normal_force(pair: MaterialPair, n: int = 64) -> float:
    """F_z [N] of the frictionless normal contact at DZ (paraboloid, domain 4 a), as tests/test_hertz.py."""
    model = ContactModel(pair, Sphere(R, "paraboloid"), Grid(n, 4 * A))
    state = ContactState(model)
    info = NormalSolver(model).solve(state, DZ)
    assert info.converged and info.residual < 1e-10, info
    return float(state.to_numpy_si()["pressure"].sum() * model.grid.cell_area)


def coupled(pair: MaterialPair, mu: float = 0.3, n: int = 64) -> dict:
    """The fields (SI) of the normal approach DZ in two steps under Coulomb friction mu."""
    model = ContactModel(pair, Sphere(R, "paraboloid"), Grid(n, 3 * A))
    solver = ContactSolver(model, Coulomb(mu))
    state = ContactState(model)
    for k in (1, 2):
        info = solver.step(state, (0.0, 0.0, DZ * k / 2))
        assert info.converged, info
    return state.to_numpy_si()


# ---------------------------------------------------------------------------------------------
# The constants.


def test_the_pair_constants_are_the_limit_of_a_stiffening_body():
    """Every composite constant of a rigid sphere is finite, has the rigid body's terms dropped
    (1/E* = (1 - nu2^2)/E2, beta = -(1 - 2 nu2) / (2 (1 - nu2))), and is the limit of a sphere
    stiffened 1e6 times (the difference is of the order of the compliance ratio, 1e-6)."""
    rigid = RIGID_SPHERE
    f = FLAT
    assert rigid.E_star == pytest.approx(f.E / (1 - f.nu**2), rel=1e-15)
    assert rigid.A == pytest.approx((1 - f.nu) / f.G, rel=1e-15)
    assert rigid.B == pytest.approx(f.nu / f.G, rel=1e-15)
    assert rigid.D == pytest.approx(-(1 - 2 * f.nu) / f.G, rel=1e-15)
    assert rigid.dundurs_beta == pytest.approx(-(1 - 2 * f.nu) / (2 * (1 - f.nu)), rel=1e-15)
    assert rigid.mindlin_compliance == pytest.approx((2 - f.nu) / f.G, rel=1e-15)
    stiff = stiff_sphere(1e6)
    for name in ("E_star", "A", "B", "D", "dundurs_beta", "mindlin_compliance"):
        r, s = getattr(rigid, name), getattr(stiff, name)
        assert math.isfinite(r) and r != 0.0, name
        assert abs(s / r - 1) < 3e-6, (name, r, s)  # the sphere's terms: 1e-6 of the flat's, times O(1)
    # a rigid flat is the mirror image: the same E*, A, B; D and beta change sign
    mirror = MaterialPair(Material(FLAT.E, FLAT.nu, name="sphere"), Material.rigid("flat"))
    assert (mirror.E_star, mirror.A, mirror.B, mirror.D) == (rigid.E_star, rigid.A, rigid.B, -rigid.D)
    # against an incompressible body the coupling vanishes, as between identical bodies
    assert MaterialPair(Material.rigid(), Material(1e6, 0.5, name="rubber")).D == 0.0


def test_a_rigid_body_is_never_the_softer():
    """The shear limit and the hardness cap take the elastic body's strengths, even where it has
    none (inf ties with the rigid body's inf)."""
    steel = Material(205e9, 0.31, yield_strength=345e6, hardness=6.2e9, name="flat")
    assert MaterialPair(Material.rigid("sphere"), steel).softer is steel
    plain = Material(205e9, 0.31, name="sphere")
    assert MaterialPair(plain, Material.rigid("flat")).softer is plain


def test_the_material_api_refuses_what_a_rigid_body_has_not():
    rigid = Material.rigid("lens")
    assert rigid.is_rigid and rigid.E == math.inf and rigid.nu is None and rigid.G == math.inf
    assert not FLAT.is_rigid
    for kwargs, key in (({"nu": 0.3}, "lens.nu"), ({"nu": None, "yield_strength": 1e9}, "lens.yield_strength"),
                        ({"nu": None, "hardness": 1e9}, "lens.hardness")):
        with pytest.raises(InputError) as e:
            Material(math.inf, name="lens", **kwargs)
        assert e.value.key == key and "rigid" in e.value.problem, e.value
    with pytest.raises(InputError) as e:
        Material(205e9, None, name="flat")  # an elastic body needs its nu
    assert e.value.key == "flat.nu"
    with pytest.raises(InputError) as e:
        MaterialPair(Material.rigid("sphere"), Material.rigid("flat"))
    assert e.value.key == "flat.rigid" and "two rigid bodies" in str(e.value) and "\n" not in str(e.value)


# ---------------------------------------------------------------------------------------------
# The contact.


def test_rigid_sphere_on_an_elastic_flat_is_hertz_with_the_flats_modulus():
    """F_z within 0.5 % of Hertz with E* = E_flat / (1 - nu_flat^2) (tests/test_hertz.py's
    tolerance; measured here at n = 64: 3.4e-4). The normal problem depends on the materials
    through E* alone, so the discretisation error is the paper pair's to rounding (1e-9: both
    solves meet the 1e-10 residual)."""
    ref = hertz(RIGID_SPHERE, R, DZ)["force"]
    assert ref == pytest.approx(4 / 3 * FLAT.E / (1 - FLAT.nu**2) * math.sqrt(R) * DZ**1.5, rel=1e-14)
    err = normal_force(RIGID_SPHERE) / ref - 1
    assert abs(err) < 5e-3, f"F_z off Hertz by {err:.2e}"
    paper_err = normal_force(PAPER_PAIR) / hertz(PAPER_PAIR, R, DZ)["force"] - 1
    assert abs(err - paper_err) < 1e-9, (err, paper_err)


def test_a_stiff_sphere_converges_to_the_rigid_one():
    """A sphere 1e4 times stiffer than the flat: F_z below the rigid sphere's by the compliance
    ratio c = (1 - nu1^2)/E1 / ((1 - nu2^2)/E2) = 1.007e-4, to 1 % of c (F_z scales with E*,
    1/E* = (1 + c) / E*_rigid; measured: 1.00675e-4 against 1.00675e-4)."""
    stiff = stiff_sphere(1e4)
    c = compliance_ratio(stiff)
    assert 0.9e-4 < c < 1.1e-4
    diff = normal_force(RIGID_SPHERE) / normal_force(stiff) - 1
    assert abs(diff / c - 1) < 0.01, (diff, c)


def test_rigid_sphere_with_friction_has_the_coupling_of_the_dissimilar_pair():
    """Under Coulomb friction (mu = 0.3) a pure normal approach of a rigid sphere on a flat of
    nu = 0.31 makes shear (beta = -0.275; measured max |q| / p0 = 0.19), none on an incompressible
    flat (nu = 0.5, D = 0). The stiffening sphere's shear converges to it linearly in the
    compliance ratio c: measured max difference / max shear = 7.7 c at 1e3 and at 1e4 times the
    flat's E (7.7e-3, 7.8e-4), asserted within 12 c, falling tenfold per decade within 20 %."""
    rigid = coupled(RIGID_SPHERE)
    q = np.hypot(rigid["shear_x"], rigid["shear_y"])
    p0 = rigid["pressure"].max()
    assert q.max() > 0.1 * p0, (q.max(), p0)
    # D < 0: the pressed flat's surface moves towards the centre relative to the rigid sphere's,
    # which holds it: the sphere's traction on the flat points outwards, q_x x > 0 (copper on
    # steel, D > 0, has q_x x < 0: tests/test_partial_slip.py)
    x = (np.arange(64) - 31.5)[None, :]
    assert np.sum(rigid["shear_x"] * x) > 0
    diffs = []
    for ratio in (1e3, 1e4):
        stiff = stiff_sphere(ratio)
        d = np.abs(coupled(stiff)["shear_x"] - rigid["shear_x"]).max() / np.abs(rigid["shear_x"]).max()
        c = compliance_ratio(stiff)
        assert d < 12 * c, (ratio, d, c)
        diffs.append(d / c)
    assert abs(diffs[1] / diffs[0] - 1) < 0.2, diffs  # linear in c
    rubber = coupled(MaterialPair(Material.rigid("sphere"), Material(205e9, 0.5, name="flat")))
    assert np.abs(rubber["shear_x"]).max() == 0.0 and np.abs(rubber["shear_y"]).max() == 0.0


def test_a_rigid_flat_mirrors_a_rigid_sphere():
    """An elastic sphere on a rigid flat is the rigid sphere on that elastic flat turned over: the
    same pressure, the shear (the sphere's traction on the flat) of the opposite sign, to the
    solvers' tolerance (1e-8 of the peak, 100 times the 1e-10 residual)."""
    a = coupled(RIGID_SPHERE)
    b = coupled(MaterialPair(Material(FLAT.E, FLAT.nu, name="sphere"), Material.rigid("flat")))
    p0, q0 = a["pressure"].max(), np.abs(a["shear_x"]).max()
    assert np.abs(a["pressure"] - b["pressure"]).max() < 1e-8 * p0
    assert np.abs(a["shear_x"] + b["shear_x"]).max() < 1e-8 * q0


# ---------------------------------------------------------------------------------------------
# Case files, the schema, the result.


def rigid_dict(body: str = "sphere", n: int = 64) -> dict:
    """A rigid ``body`` on the hertz example's other body (copper sphere or hardened steel flat)."""
    d = {
        "sphere": {"radius": R, "E": 106e9, "nu": 0.33, "yield_strength": 200e6},
        "flat": {"E": 205e9, "nu": 0.31, "yield_strength": 500e6},
        "grid": {"n": n, "size": 4 * A},
        "load": {"delta_z": DZ},
    }
    d[body] = {k: v for k, v in d[body].items() if k == "radius"} | {"rigid": True}
    return d


@pytest.mark.parametrize("body", ["sphere", "flat"])
def test_case_file_and_schema_accept_a_rigid_body(tmp_path, body):
    d = rigid_dict(body)
    f = tmp_path / "rigid.toml"
    f.write_text(to_toml(d), encoding="utf-8")
    case = load_case(f)
    rigid, elastic = (case.pair.sphere, case.pair.flat) if body == "sphere" else (case.pair.flat, case.pair.sphere)
    assert rigid.is_rigid and rigid.name == body and not elastic.is_rigid
    assert case.pair.E_star == pytest.approx(elastic.E / (1 - elastic.nu**2), rel=1e-15)
    out = case.to_dict()
    assert out[body] == ({"radius": R, "rigid": True, "profile": "sphere"} if body == "sphere" else {"rigid": True})
    assert case_from_dict(out) == case
    assert errors(case_schema(), d) == [] and errors(case_schema(), out) == []


#: (id, mutation of a rigid-sphere case, the key named). Each is refused by the program in one
#: line naming the key, and by the schema.
BAD = [
    ("E-with-rigid", lambda d: d["sphere"].update(E=106e9), "sphere.E"),
    ("nu-with-rigid", lambda d: d["sphere"].update(nu=0.33), "sphere.nu"),
    ("yield-strength-with-rigid", lambda d: d["sphere"].update(yield_strength=200e6), "sphere.yield_strength"),
    ("hardness-with-rigid-flat", lambda d: d.update(flat={"rigid": True, "hardness": 6e9},
                                                   sphere={"radius": R, "E": 106e9, "nu": 0.33}), "flat.hardness"),
    ("both-rigid", lambda d: d.update(flat={"rigid": True}), "flat.rigid"),
    ("rigid-not-boolean", lambda d: d["sphere"].update(rigid="yes"), "sphere.rigid"),
    ("rigid-false-without-E", lambda d: d["sphere"].update(rigid=False), "sphere.E"),
]


@pytest.mark.parametrize("mutate, key", [pytest.param(m, k, id=i) for i, m, k in BAD])
def test_bad_combinations_are_refused_naming_the_key(tmp_path, mutate, key):
    d = rigid_dict("sphere")
    mutate(d)
    f = tmp_path / "bad.toml"
    f.write_text(to_toml(d), encoding="utf-8")
    with pytest.raises(InputError) as e:
        load_case(f)
    message = str(e.value)
    assert e.value.key == key and message.startswith(f"{key}: ") and "\n" not in message, message
    if key != "flat.rigid":  # the schema checks each table on its own: two rigid bodies pass it
        assert errors(case_schema(), d), key


def test_moduli_beyond_any_solid_point_to_rigid():
    """E = inf, or E above diamond's, is refused naming the key and the rigid = true that means it."""
    for E in (math.inf, 3e15):
        d = rigid_dict("flat")
        d["sphere"]["E"] = E
        with pytest.raises(InputError) as e:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                case_from_dict(d)
        assert e.value.key == "sphere.E" and "sphere.rigid = true" in e.value.problem, e.value


def test_solve_skips_the_rigid_bodys_yield_check():
    """wc.solve of a rigid sphere on steel: Hertz's force (0.5 %, as above), and the yield check
    of the flat alone: its von Mises maximum Hertz's (0.6155 p0 for nu = 0.31; measured 0.6147,
    asserted to 2 %, docs/stress.md's tolerance for the solved Hertz contact), under 500 MPa:
    elastic. The sphere is marked rigid with yielded null and the reason; the subsurface stress
    likewise has the flat's field only."""
    case = case_from_dict(rigid_dict("sphere"))
    result = wc.solve(case)
    assert abs(result.states[-1]["force"]["z"] / hertz(case.pair, R, DZ)["force"] - 1) < 5e-3
    check = result.yield_check
    assert check["sphere"]["rigid"] is True and check["sphere"]["yielded"] is None
    assert check["sphere"]["von_mises_max"] is None and "rigid" in check["sphere"]["reason"]
    flat = check["flat"]
    vm = hertz_von_mises_max(FLAT.nu)[0] * hertz(case.pair, R, DZ)["p0"]
    assert flat["yielded"] is False and flat["von_mises_max"] == pytest.approx(vm, rel=0.02)
    summary = result.summary()
    assert summary["yielded"] is False and summary["yield_margin"] == pytest.approx(flat["margin"])
    stress = wc.subsurface_stress(case, layers=8, with_first_yield=False)
    assert list(stress.bodies) == ["flat"] and stress.rigid == ("sphere",)
    s = stress.summary()
    assert s["sphere"] == {"rigid": True, "yielded": None, "reason": s["sphere"]["reason"]}
    assert s["flat"]["yielded"] is False


def test_tabor_friction_takes_the_elastic_bodys_yield_strength():
    """The Tabor law's von Mises limit and the hardness cap come from the elastic body, the softer
    by definition; with no hardness there, the cap is refused naming the elastic body's key."""
    d = rigid_dict("sphere", n=32)
    d["friction"] = {"law": "tabor", "k_tau": 0.8, "hardness_cap": True}
    with pytest.raises(InputError) as e:
        case_from_dict(copy.deepcopy(d))
    assert e.value.key == "friction.hardness_cap" and "set flat.hardness" in e.value.problem, e.value
    d["flat"]["hardness"] = 6.2e9
    case = case_from_dict(d)
    assert case.pair.softer is case.pair.flat and case.pair.softer.yield_strength == 500e6


def test_stress_command_with_a_rigid_flat(tmp_path, capsys):
    """``warpcontact stress`` on an elastic sphere on a rigid flat: stress.json gives the sphere's
    maximum and first yield, the flat rigid (yielded null, the reason), stress.npz holds the
    sphere's fields alone, and both figures are drawn (the flat's panel says it is rigid)."""
    import json

    from warpcontact.cli import main

    f = tmp_path / "rigid_flat.toml"
    f.write_text(to_toml(rigid_dict("flat", n=32)), encoding="utf-8")
    out = tmp_path / "out"
    assert main(["stress", str(f), "--out", str(out), "--layers", "4"]) == 0
    assert "flat: rigid, no stress field" in capsys.readouterr().err
    s = json.loads((out / "stress.json").read_text())
    assert s["flat"]["rigid"] is True and s["flat"]["yielded"] is None and "von_mises_max" not in s["flat"]
    assert s["sphere"]["von_mises_max"]["value"] > 0 and s["sphere"]["first_yield"]["reached"] is False
    assert s["case"]["flat"] == {"rigid": True}
    z = np.load(out / "stress.npz")
    assert "sphere_axis_sigma_zz" in z.files and not any(k.startswith("flat_") for k in z.files)
    assert (out / "stress_section.png").stat().st_size > 0 and (out / "stress_profiles.png").stat().st_size > 0


def test_a_soft_flat_under_a_rigid_lens_is_no_unit_slip():
    """Rubber (E = 1 MPa) under a rigid lens with an adhesive stress above E*: the stress is
    refused, not the modulus (against a rigid body there is no other modulus to suspect a unit
    slip by; between two elastic bodies the softer one's E would be named)."""
    d = {"sphere": {"radius": 1e-6, "rigid": True}, "flat": {"E": 1e6, "nu": 0.45},
         "grid": {"n": 64, "size": 1e-7}, "load": {"delta_z": 1e-9},
         "adhesion": {"law": "smc", "sigma_max": 1e7, "tau_max": 1e4, "delta_n": 1e-9, "delta_t": 1e-9}}
    with pytest.raises(InputError) as e:
        case_from_dict(d)
    assert e.value.key == "adhesion.sigma_max" and "E* = 1.254e6 Pa" in e.value.problem, e.value

"""The nested start of a step (SolverSettings.nested): the step solved first on the grid of half
the cells per side, its tractions and statuses starting the fine step. The answer is the fine
step's own (its tolerances decide it); only the start changes.

The problem of bench/scaling.py (copper on steel, R = 10 um, Tabor k_tau = 0.8, delta_z = 1e-10 m then
delta_x = 2e-11 m, domain 4 sqrt(R delta_z)) on 128 cells (2 CPU cores, a few seconds).
"""

import math

import numpy as np
import pytest

from warpcontact.physics.friction import TaborVonMises
from warpcontact.physics.geometry import Grid, Sphere
from warpcontact.physics.materials import PAPER_PAIR
from warpcontact.numerics.model import ContactModel
from warpcontact.solvers.contact import ContactSolver
from warpcontact.numerics.state import ContactState

R, DZ, DX = 10e-6, 1.0e-10, 2.0e-11
STEPS = [(0.0, 0.0, DZ), (DX, 0.0, DZ)]


def run(n, nested, dtype="float64", **choices):
    model = ContactModel(PAPER_PAIR, Sphere(R), Grid(n, 4 * math.sqrt(R * DZ)), dtype=dtype)
    solver = ContactSolver(model, TaborVonMises(0.8, PAPER_PAIR.softer.yield_strength), nested=nested, **choices)
    state = ContactState(model)
    infos, coarse = [], []
    for approach in STEPS:
        infos.append(solver.step(state, approach))
        coarse.append(solver.nested_iterations)
    return state.to_numpy_si(), infos, coarse, np.array(state.status.numpy())


@pytest.fixture(scope="module")
def both():
    return run(128, False), run(128, True)


def test_nested_start_gives_the_same_state(both):
    """Tractions within 1e-7 of their largest value (the turns stop at a relative change of
    1e-8 = 100 x the inner tolerance: two converged answers differ by that order), the same stick
    and slip cells."""
    (plain, _, _, st_plain), (nested, _, _, st_nested) = both
    for name in ("pressure", "shear_x", "shear_y"):
        scale = np.abs(plain[name]).max()
        assert np.abs(nested[name] - plain[name]).max() < 1e-7 * scale, name
    assert np.array_equal(st_plain, st_nested)


def test_nested_start_takes_fewer_fine_iterations(both):
    """Step 2 (the slip front moves through the annulus): 60 inner iterations on 128 cells without,
    51 with (30 more on 64 cells, a quarter of the cost each); every step converges."""
    (_, plain, coarse_plain, _), (_, nested, coarse_nested, _) = both
    assert all(i.converged for i in plain + nested)
    assert coarse_plain == [0, 0] and all(c > 0 for c in coarse_nested)
    assert nested[1].iterations < plain[1].iterations


def test_float32_coarse_grids_give_the_same_state(both):
    """The coarse grids in float32 (``nested_float32``) only start the fine float64 step: the
    same tolerances as the plain start's above (tractions within 1e-7 of their largest, the same
    stick and slip cells), and the float32 start saves as many fine iterations as the float64 one
    within a few (the coarse tolerance, 1e-6, is the same; measured 52 against 51 in step 2, 60
    without; the tractions 2.5e-8 of their largest from the plain start's, as the float64 start's)."""
    (plain, infos_plain, _, st_plain), (_, infos_nested, _, _) = both
    start32, infos, coarse, st = run(128, True, nested_float32=True)
    assert all(i.converged for i in infos) and all(c > 0 for c in coarse)
    for name in ("pressure", "shear_x", "shear_y"):
        scale = np.abs(plain[name]).max()
        assert np.abs(start32[name] - plain[name]).max() < 1e-7 * scale, name
    assert np.array_equal(st_plain, st)
    assert infos[1].iterations < infos_plain[1].iterations
    assert abs(infos[1].iterations - infos_nested[1].iterations) <= 5


def test_float32_coarse_grids_chosen_by_the_fine_grid(monkeypatch):
    """nested_float32 = "auto": float32 coarse grids from NESTED_FLOAT32_AUTO cells per side of the
    fine grid (by device kind) on, the whole coarse chain then float32; float64 coarse grids
    under it or where forced off; a float32 model's coarse grids are float32 either way."""
    from warpcontact.solvers import settings as settings_module
    from warpcontact.solvers.turns import NestedStart

    monkeypatch.setitem(settings_module.NESTED_FLOAT32_AUTO, "cpu", 256)

    def coarse_of(solver):
        return next(s for s in solver.strategies if isinstance(s, NestedStart))._coarse_pair()[0]

    def solver(n, dtype="float64", **choices):
        model = ContactModel(PAPER_PAIR, Sphere(R), Grid(n, 4 * math.sqrt(R * DZ)), dtype=dtype)
        return ContactSolver(model, TaborVonMises(0.8, PAPER_PAIR.softer.yield_strength), nested=True, **choices)

    fine = solver(256)
    assert fine.settings.nested_float32 == "auto"
    assert coarse_of(fine).model.dtype_name == "float32"
    assert coarse_of(coarse_of(fine)).model.dtype_name == "float32"  # the chain on from there
    assert coarse_of(solver(128)).model.dtype_name == "float64"
    assert coarse_of(solver(256, nested_float32=False)).model.dtype_name == "float64"
    assert coarse_of(solver(128, nested_float32=True)).model.dtype_name == "float32"
    assert coarse_of(solver(128, "float32", nested_float32=False)).model.dtype_name == "float32"


def test_nested_start_needs_a_grid_that_halves():
    """An odd n (or n / 2 under 64 cells) starts the step as without: no coarse iterations."""
    _, infos, coarse, _ = run(101, True)
    assert coarse == [0, 0] and all(i.converged for i in infos)


def test_nested_start_in_float32():
    """float32: the turns stop at a relative change of 1e-3 (100 x its tolerance 1e-5), so two
    converged float32 answers differ by that order: with and without the nested start within
    3e-3 of the largest traction (measured 0.7e-3 pressure, 1.3e-3 shear_x), as float32 against
    float64 is (measured 0.5e-3, 0.9e-3)."""
    a, infos_a, _, _ = run(128, False, "float32")
    b, infos_b, coarse, _ = run(128, True, "float32")
    assert all(i.converged for i in infos_a + infos_b) and all(c > 0 for c in coarse)
    for name in ("pressure", "shear_x"):
        assert np.abs(a[name] - b[name]).max() < 3e-3 * np.abs(a[name]).max(), name


def test_case_file_setting(tmp_path):
    """[solver] nested = true reaches the solver through the case; a non-boolean is refused
    naming the key."""
    from pathlib import Path

    import tomllib

    from warpcontact.records.case import case_from_dict
    from warpcontact.errors import InputError
    from warpcontact.studies.runner import build

    data = tomllib.loads((Path(__file__).resolve().parents[1] / "examples" / "table2_k080_dz5e-5.toml").read_text())
    data["grid"]["n"] = 128
    data.setdefault("solver", {})["nested"] = True
    case = case_from_dict(data)
    assert case.solver.nested is True and case.to_dict()["solver"]["nested"] is True
    _, solver, _ = build(case)
    assert solver.settings.nested is True
    data["solver"]["nested"] = 1
    with pytest.raises(InputError) as e:
        case_from_dict(data)
    assert e.value.key == "solver.nested"
    data["solver"].update(nested=True, nested_float32=False)
    case = case_from_dict(data)
    assert case.to_dict()["solver"]["nested_float32"] is False
    assert build(case)[1].settings.nested_float32 is False
    data["solver"]["nested_float32"] = "no"
    with pytest.raises(InputError) as e:
        case_from_dict(data)
    assert e.value.key == "solver.nested_float32"


def test_auto_nests_from_the_measured_grid_of_each_device_kind():
    """nested = "auto" (the default of a case and of the solver): the nested start from
    NESTED_AUTO_N cells per side of the device's kind on, not below; the key takes true, false or
    "auto" and names itself for anything else."""
    import tomllib
    from pathlib import Path

    from warpcontact.records.case import case_from_dict
    from warpcontact.errors import InputError
    from warpcontact.solvers.contact import NESTED_AUTO_N

    def solver(n, nested="auto"):
        model = ContactModel(PAPER_PAIR, Sphere(R), Grid(n, 4 * math.sqrt(R * DZ)))
        return ContactSolver(model, TaborVonMises(0.8, PAPER_PAIR.softer.yield_strength), nested=nested)

    n = NESTED_AUTO_N["cpu"]
    assert solver(n).settings.nested == "auto" and solver(n).uses_nested
    assert not solver(n - 2).uses_nested
    assert not solver(n, nested=False).uses_nested and solver(64, nested=True).uses_nested
    data = tomllib.loads((Path(__file__).resolve().parents[1] / "examples" / "table2_k080_dz5e-5.toml").read_text())
    assert case_from_dict(data).solver.nested == "auto"
    data.setdefault("solver", {})["nested"] = "sometimes"
    with pytest.raises(InputError) as e:
        case_from_dict(data)
    assert e.value.key == "solver.nested" and "auto" in str(e.value)


def test_coarse_grids_start_nested_as_their_own_size_chooses(monkeypatch):
    """The half grid of a nested start chooses its own start: where the fine grid's choice is
    "auto", by its own size (NESTED_AUTO_N; under it a plain start, the coarse chain ends there);
    where forced on, nested all the way down to NESTED_MIN_N."""
    from warpcontact.solvers import contact
    from warpcontact.solvers.turns import NestedStart

    monkeypatch.setitem(contact.NESTED_AUTO_N, "cpu", 128)

    def coarse_of(solver):
        nested = [s for s in solver.strategies if isinstance(s, NestedStart)]
        assert nested, "the fine grid does not start nested"
        return nested[0]._coarse_pair()[0]

    def solver(n, nested="auto"):
        model = ContactModel(PAPER_PAIR, Sphere(R), Grid(n, 4 * math.sqrt(R * DZ)))
        return ContactSolver(model, TaborVonMises(0.8, PAPER_PAIR.softer.yield_strength), nested=nested)

    auto = coarse_of(solver(256))
    assert auto.model.grid.n == 128 and auto.settings.nested == "auto" and auto.uses_nested
    assert not coarse_of(auto).uses_nested  # 64 cells: under the threshold
    forced = coarse_of(solver(256, nested=True))
    assert forced.settings.nested is True and coarse_of(forced).uses_nested

"""The state summary reduced on the device (kernels/summary.py) against numpy sums of the same
quantities on the host.

Tolerances. The forces are sums over N = n^2 cells; any order of a float64 sum (the device's:
per thread, then the block and part sums; numpy's pairwise one) lies within (N - 1) u sum|x| of
the exact sum of the values (Higham, Accuracy and Stability of Numerical Algorithms, 2nd ed.,
section 4.2), u = 2^-53, and each side rounds a few more times (the SI scale per cell on the host,
the traction + adhesive addition, E* and dA once on the device): the two agree within
2 (N + 4) u sum|x|, sum|x| the sum of the terms' magnitudes. Float32 states are summed in float64
on both sides (each value converted exactly), so the same bound holds. The cell counts (areas)
and the maximum pressure are exact (counts; max commutes with the positive scale E*). The stick
centroid: the device sums the stick cells' centre offsets (half-integers, exact) and scales once;
numpy averages the rounded centres, within (N_st + 4) u max|X|.
"""

import math
from functools import lru_cache
from types import SimpleNamespace

import numpy as np
import pytest

from warpcontact.physics.adhesion import SMC, Dugdale
from warpcontact.physics.friction import Coulomb, TaborVonMises
from warpcontact.physics.geometry import Grid, Sphere
from warpcontact.kernels.tangential import SLIP, STICK
from warpcontact.physics.materials import PAPER_PAIR
from warpcontact.numerics.model import ContactModel
from warpcontact.records.results import state_summary
from warpcontact.solvers.contact import ContactSolver
from warpcontact.numerics.state import ContactState

R, DZ = 10e-6, 5e-11
A = math.sqrt(R * DZ)
U = 2.0**-53
N = 32

#: friction law, adhesion law, tangential displacement (delta_x, delta_y) [m] of the last step
CASES = {
    # stick (83 cells) and slip (125) cells, tangential load in x and y: a centroid off both axes
    "friction": (Coulomb(0.3), None, (1e-11, 0.4e-11)),
    # adhesive cells (246) beside stick (214) and slip (42) cells, adhesive shear
    "adhesion": (TaborVonMises(0.8, 200e6), SMC(2e7, 2e7, 2e-11, 2e-11), (1e-11, 0.4e-11)),
    # no stick cell (the centroid is None), adhesive cells (228)
    "frictionless": (None, Dugdale(2e7, 2e-11), None),
}


@lru_cache(maxsize=None)
def solved(case: str, device: str, dtype: str):
    friction, adhesion, tangential = CASES[case]
    model = ContactModel(PAPER_PAIR, Sphere(R), Grid(N, 4 * A), device=device, dtype=dtype)
    solver = ContactSolver(model, friction, adhesion=adhesion)
    state = ContactState(model)
    for k in (1, 2):
        assert solver.step(state, (0.0, 0.0, DZ * k / 2)).converged
    if tangential is not None:
        assert solver.step(state, (*tangential, DZ)).converged
    return model, state, adhesion


def host_reference(state, adhesion):
    """The summary's numbers from the SI fields on the host (numpy), with each force sum's
    scale sum|x| dA [N]."""
    m = state.model
    f = state.to_numpy_si()
    status = state.status.numpy()
    dA = m.grid.cell_area
    X, Y = m.grid.mesh()
    stick = status == STICK
    contact = f["pressure"] > 0
    adhesive = (f["pressure"] <= 0) & (f["gap"] <= adhesion.range) if adhesion is not None else np.zeros_like(contact)
    forces, scales = {}, {}
    for c, q in (("x", "shear_x"), ("y", "shear_y"), ("z", "pressure")):
        adh = f[q.replace("shear", "adhesive_shear") if c != "z" else "adhesive_pressure"]
        forces[("force", c)] = float((f[q] + adh).sum() * dA)
        scales[("force", c)] = float((np.abs(f[q]) + np.abs(adh)).sum() * dA)
        forces[("force_elastic", c)] = float(f[q].sum() * dA)
        scales[("force_elastic", c)] = float(np.abs(f[q]).sum() * dA)
    ref = {
        "forces": forces, "scales": scales,
        "contact_cells": int(contact.sum()), "stick_cells": int(stick.sum()), "adhesive_cells": int(adhesive.sum()),
        "max_pressure": float(f["pressure"].max()),
        "centroid": (float(X[stick].mean()), float(Y[stick].mean())) if stick.any() else None,
        "max_abs_x": float(np.abs(X).max()),
        "mean_gap": float(f["gap"].mean()), "mean_abs_gap": float(np.abs(f["gap"]).mean()),
    }
    return ref


def assert_matches(s: dict, ref: dict, model):
    dA = model.grid.cell_area
    n_cells = model.n_cells
    for (group, c), value in ref["forces"].items():
        tol = 2 * (n_cells + 4) * U * ref["scales"][(group, c)]
        assert abs(s[group][c] - value) <= tol, (group, c, s[group][c], value, tol)
    assert s["contact_area"] == ref["contact_cells"] * dA
    assert s["stick_area"] == ref["stick_cells"] * dA
    assert s["adhesive_area"] == ref["adhesive_cells"] * dA
    assert s["contact_radius"] == math.sqrt(ref["contact_cells"] * dA / math.pi)
    assert s["max_pressure"] == ref["max_pressure"]
    tol = 2 * (n_cells + 4) * U * ref["mean_abs_gap"]  # a sum's rounding, as the forces'
    assert abs(s["mean_gap"] - ref["mean_gap"]) <= tol, (s["mean_gap"], ref["mean_gap"], tol)
    if ref["centroid"] is None:
        assert s["stick_centroid"] is None
    else:
        tol = (ref["stick_cells"] + 4) * U * ref["max_abs_x"]
        for c, value in zip("xy", ref["centroid"]):
            assert abs(s["stick_centroid"][c] - value) <= tol, (c, s["stick_centroid"][c], value, tol)


@pytest.mark.parametrize("dtype", ["float64", "float32"])
@pytest.mark.parametrize("case", sorted(CASES))
def test_device_summary_equals_host_sums(case, dtype, device):
    """Friction (stick and slip cells), adhesion (adhesive cells, adhesive shear) and frictionless
    states, float64 and float32: the device summary equals the numpy sums within the rounding
    bounds of the module's docstring; the states have what the case is for."""
    model, state, adhesion = solved(case, device, dtype)
    ref = host_reference(state, adhesion)
    s = state_summary(state, adhesion)
    assert_matches(s, ref, model)
    friction, _, _ = CASES[case]
    assert ref["contact_cells"] > 0
    assert (ref["stick_cells"] > 0) == (friction is not None)
    assert (ref["adhesive_cells"] > 0) == (adhesion is not None)
    if friction is not None:  # partial slip: a stick zone off both axes (the load in x and y), by far more
        # than the centroid's tolerance (~1e-12 dx), so that its comparison above tells x from y and the sign
        assert 0 < ref["stick_cells"] < ref["contact_cells"]
        assert min(abs(v) for v in ref["centroid"]) > 1e-3 * model.grid.dx
    if adhesion is not None:
        assert s["force"]["z"] < s["force_elastic"]["z"]  # the adhesive tension is in the total


@pytest.mark.parametrize("workers", [2, 3])
def test_split_cpu_summary_equals_the_whole_launch(workers):
    """The CPU summary split by rows over threads (each part's sums merged on the host; the
    maximum pressure by max, not by sum) equals the whole launch: counts, maximum and centroid
    exactly (integer sums; max), forces within the float64 rounding bound."""
    model, state, adhesion = solved("adhesion", "cpu", "float64")
    whole = state_summary(state, adhesion)
    saved = model.launches.workers, model.launches.min_split_entries
    try:
        model.launches.workers = workers
        model.launches.min_split_entries = 0
        split = state_summary(state, adhesion)
        assert len(model.launches._splits) >= 1
    finally:
        model.launches.workers, model.launches.min_split_entries = saved
    for key in ("contact_area", "stick_area", "adhesive_area", "max_pressure", "stick_centroid"):
        assert split[key] == whole[key], key
    ref = host_reference(state, adhesion)
    for (group, c) in ref["forces"]:
        assert abs(split[group][c] - whole[group][c]) <= 2 * (model.n_cells + 4) * U * ref["scales"][(group, c)]


def planted_state(dtype: str):
    """A 16 x 16 state set by hand: stick cells at (row, column) (2, 11) and (3, 11) (off the
    diagonal: x and y differ), a slip cell at (12, 1), contact over rows 2-3 and 12; the gap of
    the cells out of contact below, at and above a range in row 6 (columns 0-2: gap 1, 2, 3
    cells) and small in the contact cells."""
    model = ContactModel(PAPER_PAIR, Sphere(R), Grid(16, 4 * A), device="cpu", dtype=dtype)
    state = ContactState(model)
    p = np.zeros((16, 16))
    p[2:4, :] = 1e-3
    p[12, :] = 5e-4
    p[3, 11] = 2e-3  # the peak, in a stick cell
    gap = np.full((16, 16), 10.0)  # out of range (cells)
    gap[2:4, :] = 0.0
    gap[12, :] = 0.0
    gap[6, 0:3] = (1.0, 2.0, 3.0)
    status = np.zeros((16, 16), dtype=np.int32)
    status[2:4, 11] = int(STICK)
    status[12, 1] = int(SLIP)
    state.pressure.assign(p.astype(model.np_dtype))
    state.gap.assign(gap.astype(model.np_dtype))
    state.status.assign(status)
    # the range: exactly the SI gap of the cell at 2 cells (float64(gap) x dx, as adhesive_mask sees it)
    law = SimpleNamespace(range=float(np.float64(model.np_dtype(2.0)) * model.length_scale))
    return model, state, law


@pytest.mark.parametrize("dtype", ["float64", "float32"])
def test_planted_centroid_areas_and_adhesive_cells(dtype):
    """Known answers: the stick centroid is the two stick cells' centres (Grid.mesh) averaged,
    exactly (x of column 11, y halfway between rows 2 and 3): a centroid from the wrong cell
    centre (half a cell off, rows and columns swapped, the slip cell counted) would fail. The
    adhesive cells are those out of contact with the gap at most the range, the cell at exactly
    the range included: 2 of the 3 planted ones (a wrong sign, or contact cells counted, gives
    another number). Contact: 2 rows and 1 row of 16 cells. Max: the peak planted."""
    model, state, law = planted_state(dtype)
    X, Y = model.grid.mesh()
    dA = model.grid.cell_area
    s = state_summary(state, law)
    assert s["stick_centroid"]["x"] == X[2, 11] == X[3, 11]
    assert s["stick_centroid"]["y"] == pytest.approx(0.5 * (Y[2, 11] + Y[3, 11]), rel=4 * U)
    assert s["stick_centroid"]["y"] != pytest.approx(Y[2, 11], rel=1e-6)
    assert s["stick_area"] == 2 * dA
    assert s["adhesive_area"] == 2 * dA
    assert s["contact_area"] == 48 * dA
    assert s["max_pressure"] == float(np.float64(model.np_dtype(2e-3)) * model.traction_scale)
    assert state_summary(state, None)["adhesive_area"] == 0.0


def test_empty_state_summary():
    """A state of zeros: no force, no area, maximum pressure 0 (the device's max starts from
    -inf, numpy's max of zeros is 0), no stick centroid."""
    model = ContactModel(PAPER_PAIR, Sphere(R), Grid(16, 4 * A), device="cpu")
    s = state_summary(ContactState(model), Dugdale(2e7, 2e-11))
    assert s["max_pressure"] == 0.0 and s["contact_area"] == 0.0 and s["stick_centroid"] is None
    assert all(s[g][c] == 0.0 for g in ("force", "force_elastic") for c in "xyz")
    # gap 0 <= range out of contact: every cell is adhesive (p = 0)
    assert s["adhesive_area"] == model.n_cells * model.grid.cell_area


@pytest.mark.parametrize("dtype", ["float64", "float32"])
@pytest.mark.parametrize("case", sorted(CASES))
def test_largest_tension_and_domain_edge_equal_numpy(case, dtype, device):
    """The checks' device reads (guards: the contact and the adhesive tension on the domain's
    edge) equal numpy on the whole field, exactly: a maximum and a gather round nothing."""
    import warp as wp

    from warpcontact.kernels.summary import S_MAX_TENSION
    from warpcontact.records.results import domain_edge, summary_sums

    model, state, adhesion = solved(case, device, dtype)
    tension = -state.adhesive_pressure.numpy().astype(np.float64)
    assert summary_sums(state, adhesion)[S_MAX_TENSION] == tension.max()
    if adhesion is not None:
        assert tension.max() > 0
    p = state.pressure.numpy()
    assert np.array_equal(domain_edge(state.pressure), np.concatenate([p[0], p[-1], p[:, 0], p[:, -1]]))
    # a field of another shape: rows and columns are not mixed up
    rng = np.random.default_rng(3)
    field = rng.standard_normal((5, 7)).astype(np.float32 if dtype == "float32" else np.float64)
    w = wp.array(field, device=device)
    assert np.array_equal(domain_edge(w), np.concatenate([field[0], field[-1], field[:, 0], field[:, -1]]))


@pytest.mark.parametrize("dtype", ["float64", "float32"])
def test_host_si_equals_astype_times_scale_and_leaves_the_field(dtype, device):
    """``state.host_si``: the same values as ``numpy().astype(float64) * scale`` (bit for bit), a
    new array each call, and the device field unchanged (on the CPU ``numpy()`` is a view of it)."""
    import warp as wp

    from warpcontact.numerics.state import host_si

    field = np.random.default_rng(5).standard_normal((6, 4)).astype(np.float32 if dtype == "float32" else np.float64)
    w = wp.array(field, device=device)
    scale = 7.8e10
    got = host_si(w, scale)
    assert got.dtype == np.float64
    assert np.array_equal(got, field.astype(np.float64) * scale)
    assert np.array_equal(w.numpy(), field)
    # a second field of the shape (on CUDA through the same page-locked stage) leaves the first
    # result as it was, and a strided view gives its own values
    again = host_si(wp.array(2 * field, device=device), scale)
    assert np.array_equal(again, 2 * field.astype(np.float64) * scale)
    assert np.array_equal(got, field.astype(np.float64) * scale)
    assert np.array_equal(host_si(w[:, 1:3], scale), field[:, 1:3].astype(np.float64) * scale)
    other = host_si(wp.array(field.T.copy(), device=device), scale)  # another shape: another stage
    assert np.array_equal(other, field.T.astype(np.float64) * scale)
    if str(device).startswith("cuda"):  # the stages kept: the newest two shapes
        from warpcontact.numerics import state

        assert list(state._PINNED_STAGES)[-2:] == [(str(w.device), s, w.dtype) for s in ((6, 4), (4, 6))]
        assert len(state._PINNED_STAGES) == state.PINNED_STAGES_KEPT

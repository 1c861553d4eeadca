"""Many cases solved together (``warpcontact.solve_batch``): each case's result is what
``warpcontact.solve`` gives it, whatever the batch around it."""

import warnings

import numpy as np
import pytest

import warp as wp

import warpcontact as wc
from warpcontact.errors import InputError

DEVICES = ["cpu", pytest.param("cuda", marks=pytest.mark.skipif(wp.get_cuda_device_count() == 0,
                                                                reason="no CUDA device here"))]

# a small Hertz case: 32 cells over 4 contact radii at the deepest approach
BASE = {
    "sphere": {"radius": 1e-6, "E": 200e9, "nu": 0.3, "yield_strength": 3e9},
    "flat": {"E": 70e9, "nu": 0.2, "yield_strength": 3e9},
    "grid": {"n": 32, "size": 1.6e-7},
    "load": {"delta_z": 1e-9, "steps": 1},
}


def case(**tables):
    out = {k: dict(v) for k, v in BASE.items()}
    for name, values in tables.items():
        if name == "load" and "path" in values:  # a path lists every state: no delta_z beside it
            out["load"] = {}
        out.setdefault(name, {}).update(values)
    return out


def quiet(function, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the coarse-grid warning of these small grids
        return function(*args, **kwargs)


def assert_same_path(batched, single, rel):
    """Every state's forces, areas, largest pressure and mean gap within ``rel`` of the single
    solve's; the contact areas (cell counts) identical."""
    assert len(batched.states) == len(single.states)
    for a, b in zip(batched.states, single.states):
        assert a["converged"] and b["converged"]
        assert a["delta"] == b["delta"]
        assert a["contact_area"] == b["contact_area"]
        for key in ("max_pressure", "mean_gap"):
            assert a[key] == pytest.approx(b[key], rel=rel), key
        assert a["force"]["z"] == pytest.approx(b["force"]["z"], rel=rel)
        assert a["force"]["x"] == b["force"]["x"] == 0.0


@pytest.mark.parametrize("device", DEVICES)
def test_a_batch_of_cases_gives_each_what_solve_gives(device):
    """Five normal-contact cases of one grid in one batch (other materials, radius, profile,
    load paths of 1 to 3 states, one of them unloading), float64: every state's forces, largest
    pressure and mean gap within 1e-8 of solve's, the contact areas identical. Both solves stop
    at a relative residual of 1e-10 and start from the same guess; their iterates differ only in
    how the gap is kept (carried or recomputed) and summed: measured 1e-15."""
    cases = [
        case(),
        case(load={"delta_z": 0.6e-9, "steps": 3}),
        case(sphere={"radius": 1.5e-6}, load={"delta_z": 0.7e-9}),
        case(flat={"E": 120e9, "nu": 0.35}, sphere={"profile": "sphere"}),
        case(load={"path": [[0, 0, 1e-9], [0, 0, 0.5e-9]]}),
    ]
    batched = quiet(wc.solve_batch, cases, device=device, batch=len(cases))
    for c, result in zip(cases, batched):
        assert str(result.model.device).startswith(device)
        assert_same_path(result, quiet(wc.solve, c, device=device, fields="none"), rel=1e-8)
        assert result.yield_check is not None and result.summary()["yielded"] is False


def test_other_shapes_in_one_batch(tmp_path):
    """A flat punch, a cone and a rough height map (non-Hertzian bodies: a model each, the
    punch's edge singularity, several contact patches) batched together: each within 1e-8 of
    solve, contact patches and areas identical."""
    rng = np.random.default_rng(5)
    heights = 2e-10 * rng.standard_normal((33, 33))
    heights -= heights.min()
    np.save(tmp_path / "rough.npy", heights)
    common = {"flat": {"E": 100e9, "nu": 0.3}, "grid": {"n": 32, "size": 2.5e-8}}
    cases = [
        {**common, "sphere": {"profile": "flat_punch", "radius": 1e-8, "E": 100e9, "nu": 0.3},
         "load": {"delta_z": 1e-10}},
        {**common, "sphere": {"profile": "cone", "half_angle": 80.0, "E": 100e9, "nu": 0.3},
         "load": {"delta_z": 1e-10, "steps": 2}},
        {**common, "sphere": {"profile": "height_map", "height_map": str(tmp_path / "rough.npy"),
                              "pixel_size": 2.5e-8 / 32, "E": 100e9, "nu": 0.3},
         "load": {"delta_z": 6e-10}},  # the cells' lowest gap is 3.5e-10 m (the map's lowest pixel between them)
    ]
    for c, result in zip(cases, quiet(wc.solve_batch, cases, batch=3)):
        single = quiet(wc.solve, c, fields="none")
        assert_same_path(result, single, rel=1e-8)
        assert result.states[-1]["contact_patches"] == single.states[-1]["contact_patches"]
    assert single.states[-1]["contact_patches"] > 1  # the rough map touches in several patches


def test_batches_smaller_than_the_cases_and_float32():
    """Three cases in batches of 2 (a full batch, then one case) give the results of one batch
    of 3; in float32 (tolerance 1e-5 on the relative residual) the forces are within 1e-4 of
    float64's (the residual's tolerance and float32's rounding of the sums, about 1e-6)."""
    cases = [case(load={"delta_z": dz}) for dz in (0.5e-9, 0.8e-9, 1e-9)]
    whole = quiet(wc.solve_batch, cases, batch=3)
    parts = quiet(wc.solve_batch, cases, batch=2)
    single32 = quiet(wc.solve_batch, cases, dtype="float32", batch=3)
    for a, b, c in zip(whole, parts, single32):
        assert a.states[-1]["force"]["z"] == pytest.approx(b.states[-1]["force"]["z"], rel=1e-12)
        assert c.states[-1]["force"]["z"] == pytest.approx(a.states[-1]["force"]["z"], rel=1e-4)
        assert c.model.dtype_name == "float32"


def test_friction_cases_go_one_at_a_time_and_a_failing_case_leaves_the_others(monkeypatch):
    """Without ``batch`` on the CPU, cases with friction and of normal contact are solved as solve
    solves them (the batched solve's own passes are not run); with it, a case of the batch whose
    state fails its check (here a contact check made to refuse its approach, as a contact past the
    domain's edge is refused) gets the InputError in its place, and the cases beside it their
    results."""
    from warpcontact.solvers.normal_batch import BatchNormalSolver
    from warpcontact.studies import batch_solve

    refused = 0.7e-9
    checked = batch_solve.check_contact_fits

    def check(state, *args, **kwargs):
        if state.approach[2] == refused:
            raise InputError("grid.size", "the contact reaches the domain's edge")
        checked(state, *args, **kwargs)

    batched = []
    solve = BatchNormalSolver.solve
    monkeypatch.setattr(BatchNormalSolver, "solve", lambda self, *a, **kw: batched.append(1) or solve(self, *a, **kw))
    monkeypatch.setattr(batch_solve, "check_contact_fits", check)
    friction = case(load={"delta_z": 1e-9, "delta_x": 2e-10, "steps": 2}, friction={"law": "coulomb", "mu": 0.3})
    failing = case(load={"delta_z": refused})
    normal = case()
    ended = []
    results = quiet(wc.solve_batch, [friction, normal], on_case=lambda i, r: ended.append(i))
    assert sorted(ended) == [0, 1] and not batched
    single = quiet(wc.solve, friction, fields="none")
    assert results[0].states[-1]["force"]["x"] == pytest.approx(single.states[-1]["force"]["x"], rel=1e-12)
    assert_same_path(results[1], quiet(wc.solve, normal, fields="none"), rel=1e-8)
    results = quiet(wc.solve_batch, [failing, normal], batch=2)
    assert batched
    assert isinstance(results[0], InputError) and "grid.size" in str(results[0])
    assert_same_path(results[1], quiet(wc.solve, normal, fields="none"), rel=1e-8)


def test_cases_solved_one_at_a_time_share_a_model_where_it_is_the_same(monkeypatch):
    """Cases solved one at a time (without ``batch`` on the CPU) build a model only where it
    differs from the case before's (materials, body, grid, device, float type): three cases on two
    models, in the order A A B, build two; each result is solve's."""
    from warpcontact.studies import batch_solve

    built = []
    build = batch_solve.build_model
    monkeypatch.setattr(batch_solve, "build_model", lambda c: built.append(c) or build(c))
    cases = [case(load={"delta_z": 0.8e-9}), case(), case(flat={"E": 120e9, "nu": 0.35})]
    results = quiet(wc.solve_batch, cases)
    assert len(built) == 2 and built[1].pair.flat.E == 120e9
    for c, result in zip(cases, results):
        assert_same_path(result, quiet(wc.solve, c, fields="none"), rel=1e-12)


@pytest.mark.parametrize("error", [RuntimeError("cuFFT refused the plan"),
                                   InputError("solver.fft", "CuPy is not installed")])
def test_a_batched_solve_that_fails_leaves_its_cases_to_solve(monkeypatch, error):
    """Where the batched solve itself fails (a device's refusal, a library's error or absence;
    here made to raise at its second state), one RuntimeWarning says so and the cases it had not
    ended are solved one at a time: every result is solve's, the one that had ended kept."""
    from warpcontact.solvers.normal_batch import BatchNormalSolver

    solve = BatchNormalSolver.solve
    calls = []

    def failing(self, *args, **kwargs):
        calls.append(1)
        if len(calls) == 2:
            raise error
        return solve(self, *args, **kwargs)

    monkeypatch.setattr(BatchNormalSolver, "solve", failing)
    cases = [case(), case(load={"delta_z": 0.6e-9, "steps": 3})]
    with pytest.warns(RuntimeWarning, match=str(error).split(":")[-1].strip()):  # (beside the coarse grid's)
        results = wc.solve_batch(cases, batch=2)
    for c, result in zip(cases, results):
        assert_same_path(result, quiet(wc.solve, c, fields="none"), rel=1e-8)


def test_fields_are_kept_as_solve_keeps_them():
    """fields="last": the last state's fields as solve keeps them (pressure within 1e-8 of its
    largest, as the forces)."""
    c = case(load={"delta_z": 1e-9, "steps": 2})
    (batched,) = quiet(wc.solve_batch, [c], fields="last", batch=1)
    single = quiet(wc.solve, c, fields="last")
    assert batched.field_states == single.field_states == [1]
    p, q = batched.fields[0]["pressure"], single.fields[0]["pressure"]
    assert np.abs(p - q).max() < 1e-8 * q.max()
    assert np.array_equal(batched.fields[0]["contact_mask"], single.fields[0]["contact_mask"])


def test_mistakes_are_input_errors():
    with pytest.raises(InputError, match="batch"):
        wc.solve_batch([case()], batch=0)
    with pytest.raises(InputError, match="fields"):
        wc.solve_batch([case()], fields="some")
    with pytest.raises(InputError, match="grid.n"):
        wc.solve_batch([case(), case(grid={"n": -4})])


@pytest.mark.parametrize("friction", [None, {"law": "coulomb", "mu": 0.3}])
def test_a_contact_past_the_domains_edge_is_its_cases_error_in_a_batch(friction):
    """The batch's edge check (the count of edge cells in contact, from the rows' summaries) refuses
    a case whose contact reaches the domain's edge with the error its own solve gives, at the same
    state, and leaves the case beside it its result. At delta_z = 1e-9 m the contact radius,
    sqrt(R delta_z) = 3.16e-8 m, is a fifth of the 1.6e-7 m side; on a 6.4e-8 m side (just over
    the diameter, which the case's check asks for) the edge cells' centres are 3.1e-8 m out."""
    extra = {} if friction is None else {"friction": friction, "load": {"delta_z": 1e-9, "delta_x": 2e-10, "steps": 2}}
    cut = case(grid={"n": 32, "size": 6.4e-8}, **extra)
    fits = case(**extra)
    with pytest.raises(InputError) as single:
        quiet(wc.solve, cut, fields="none")
    results = quiet(wc.solve_batch, [cut, fits], batch=2)
    assert isinstance(results[0], InputError) and str(results[0]) == str(single.value)
    assert "grid.size" in str(results[0])
    alone = quiet(wc.solve, fits, fields="none")
    for a, b in zip(results[1].states, alone.states, strict=True):
        assert a["force"]["z"] == pytest.approx(b["force"]["z"], rel=1e-8)

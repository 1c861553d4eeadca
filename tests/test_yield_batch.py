"""The yield check of many solved states at once (yielding.batch_yield_checks, numerics/stress_batch.py)
gives each state's own check depth by depth (yielding._own_yield_check, what state_yield_check
makes on the CPU): the same depths, half grid and refinement, the planes of every state evaluated
together by the plane kernels of kernels/stress.py."""

import warnings

import numpy as np
import pytest

import warpcontact as wc
from warpcontact.numerics import stress_batch, yielding
from warpcontact.numerics.stress import contact_radius
from warpcontact.studies import runner

PAIR = {"sphere": {"radius": 10e-6, "E": 106e9, "nu": 0.33, "yield_strength": 200e6},
        "flat": {"E": 205e9, "nu": 0.31, "yield_strength": 345e6}}


def final_states(cases, device, dtype="float64"):
    """Each case solved on ``device`` in ``dtype``, its last ``ContactState`` (the one a path's
    yield check reads)."""
    states = []
    finish = runner.PathRecorder.finish

    def keep(self, state, check=None):
        states.append(state)
        return finish(self, state, check)

    runner.PathRecorder.finish = keep
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            for d in cases:
                wc.solve({**d, "solver": {"device": device, "dtype": dtype}}, fields="none")
    finally:
        runner.PathRecorder.finish = finish
    return states


def case(n, size, delta_z, delta_x=0.0, friction=True, flat=None):
    d = {"sphere": dict(PAIR["sphere"]), "flat": dict(flat or PAIR["flat"]), "grid": {"n": n, "size": size},
         "load": {"delta_z": delta_z, "delta_x": delta_x, "steps": 2}}
    if friction:
        d["friction"] = {"law": "tabor", "k_tau": 0.8}
    return d


def assert_same(batch, alone, rel=1e-12, z_rel=1e-9):
    """Each body's maximum within ``rel`` of its own check's (the same sums, transformed by another
    FFT library: round-off, 1e-12 in float64), its depth within ``z_rel`` (the vertex of a parabola
    through three maxima that differ by about 1 %: it moves by the values' round-off over their
    relative differences, 1e-9 in float64), and the same verdicts."""
    assert batch.keys() == alone.keys()
    assert batch["yielded"] == alone["yielded"]
    for name in ("sphere", "flat"):
        b, a = batch[name], alone[name]
        if a.get("rigid"):
            assert b == a
            continue
        assert b["von_mises_max"] == pytest.approx(a["von_mises_max"], rel=rel)
        assert b["z"] == pytest.approx(a["z"], rel=z_rel)
        assert (b["yielded"], b["yield_strength"]) == (a["yielded"], a["yield_strength"])


def test_batched_checks_equal_each_states_own(device, monkeypatch):
    """Four states of one grid size: with friction and without, one whose deep depths go to the
    half grid (a contact radius of about 40 cells, more than COARSE_STRESS_MIN_RADIUS_CELLS) and
    one on a rigid flat; one check each, as each state's own check, made by the batched evaluation
(not its fallback). On CUDA the check leaves no
    free blocks in CuPy's memory pool (its transforms' work arrays handed back to the device)."""
    cases = [case(128, 3.2e-7, 1.5e-10, 3e-11), case(128, 3.2e-7, 1.0e-10, friction=False),
             case(128, 1.2e-7, 1.5e-10, 2e-11),
             case(128, 3.2e-7, 1.2e-10, friction=False, flat={"rigid": True})]
    states = final_states(cases, device)
    half = [yielding._has_half_grid(s.model.grid, yielding._state_totals(s, True, False)[1]) for s in states]
    assert half == [False, False, True, False]
    with monkeypatch.context() as m:  # the batched evaluation itself, not its fallback to each state's own
        m.setattr(yielding, "_own_yield_check", lambda *a: pytest.fail("the batched check fell back"))
        batch = yielding.batch_yield_checks(states, friction=True, adhesion=False)
    if device.startswith("cuda"):
        import cupy

        with cupy.cuda.Device(int(device.split(":")[1])):
            assert cupy.get_default_memory_pool().free_bytes() == 0
    for s, b in zip(states, batch):
        assert_same(b, yielding._own_yield_check(s, True, False))
    assert batch[3]["flat"]["rigid"] is True


def test_batched_checks_in_float32():
    """Float32 states: the maxima within 1e-6 of their own check's (float32 round-off, 6e-8 per
    operation, over transforms of 128 x 128 padded entries: 6.2e-8 measured), the depths within
    1e-5 (7.8e-7 measured), the verdicts equal."""
    states = final_states([case(64, 1.6e-7, 1.5e-10, 3e-11), case(64, 1.6e-7, 1.0e-10, friction=False)], "cpu",
                          "float32")
    for s, b in zip(states, yielding.batch_yield_checks(states)):
        assert_same(b, yielding._own_yield_check(s, True, True), rel=1e-6, z_rel=1e-5)


def test_cases_sharing_their_depths_share_the_basis_spectra(monkeypatch):
    """Two states at one approach and two shifts of elastically similar bodies (a sweep over
    delta_x: the shear does not move the pressure, so one contact radius and one set of depths):
    their planes' basis spectra are made once per depth (the first pass's as many as for one of
    the states alone), and each check equals its own."""
    similar = {"E": 106e9, "nu": 0.33, "yield_strength": 345e6}
    states = final_states([case(48, 1.6e-7, 1.5e-10, 1e-11, flat=similar),
                           case(48, 1.6e-7, 1.5e-10, 3e-11, flat=similar)], "cpu")
    radii = [yielding._state_totals(s, True, False)[1] for s in states]
    assert radii[0] == radii[1]
    forward = stress_batch.PlaneStress._forward

    def transformed(states):
        """The fields each transform of the checks of ``states`` took: (tractions, bases) a pass."""
        made = []

        def counted(self, fields, spectra):
            made.append(fields.shape[0])
            return forward(self, fields, spectra)

        with monkeypatch.context() as m:
            m.setattr(stress_batch.PlaneStress, "_forward", counted)
            m.setattr(yielding, "_own_yield_check", lambda *a: pytest.fail("the batched check fell back"))
            checks = yielding.batch_yield_checks(states, friction=True, adhesion=False)
        return checks, made[0::2], made[1::2]

    both, both_tractions, both_bases = transformed(states)
    _, one_tractions, one_bases = transformed(states[:1])
    assert both_tractions == [2 * t for t in one_tractions]
    # the first pass's depths come from the contact radius alone: shared whole; the refinement's
    # midpoints from each state's maxima: shared where they meet
    assert both_bases[0] == one_bases[0] > 0 and sum(both_bases) < 2 * sum(one_bases)
    for s, b in zip(states, both):
        assert_same(b, yielding._own_yield_check(s, True, False))


def test_batched_checks_in_chunks_of_planes(monkeypatch):
    """Chunks of 3 planes (a pass's planes split over several chunks) give the same checks."""
    states = final_states([case(48, 1.6e-7, 1.5e-10, 3e-11), case(48, 1.6e-7, 0.8e-10, 1e-11)], "cpu")
    whole = yielding.batch_yield_checks(states)
    three = 3 * stress_batch.PlaneStress.plane_bytes(48, states[0].model.dtype)
    monkeypatch.setattr(stress_batch, "CHUNK_BYTES", three)
    monkeypatch.setattr(stress_batch, "MAX_CHUNK_BYTES", three)
    for b, w in zip(yielding.batch_yield_checks(states), whole):
        assert_same(b, w)


def test_a_failing_batched_check_falls_back_to_each_states_own(monkeypatch):
    """An error of the batched evaluation (a device's refusal, say): each state is checked alone."""
    states = final_states([case(32, 1.6e-7, 1.5e-10, 3e-11)], "cpu")

    def refuse(self, *args, **kw):
        raise RuntimeError("out of memory")

    monkeypatch.setattr(stress_batch.PlaneStress, "maxima", refuse)
    (check,) = yielding.batch_yield_checks(states)
    assert_same(check, yielding._own_yield_check(states[0], True, True))
    assert np.isfinite(check["sphere"]["von_mises_max"])


def test_one_states_check_on_cuda_is_made_by_planes(monkeypatch):
    """state_yield_check takes the planes on CUDA where a plane fits a chunk, and depth by depth on
    the CPU or past that size."""
    calls = []
    monkeypatch.setattr(yielding, "batch_yield_checks", lambda states, f, a: calls.append(len(states)) or [{}])
    (state,) = final_states([case(32, 1.6e-7, 1.5e-10, 3e-11)], "cpu")
    yielding.state_yield_check(state)
    assert calls == []

    class Cuda:
        is_cuda = True

    class Model:
        device, dtype, grid = Cuda(), state.model.dtype, state.model.grid

    class Fake:
        model = Model()

    assert yielding.state_yield_check(Fake()) == {} and calls == [1]
    monkeypatch.setattr(stress_batch, "CHUNK_BYTES", stress_batch.PlaneStress.plane_bytes(32, Model.dtype) - 1)
    monkeypatch.setattr(yielding, "_own_yield_check", lambda s, f, a: {"own": True})
    assert yielding.state_yield_check(Fake()) == {"own": True} and calls == [1]


def test_solve_batch_makes_its_cases_checks_together(monkeypatch):
    """solve_batch with its checks by planes (as on CUDA; forced here on the CPU): each case's
    yield check as solve makes it depth by depth, and the planes made once for the cases that end
    at a state (a path of 1 state and two of 2: two evaluations, of 1 and 2 cases). The batched
    solve's fields agree with solve's within its tolerance, not to round-off (tests/test_solve_batch:
    1e-8), so the maxima within 1e-8 (3e-11 measured) and the depths within 1e-6 (the parabola's
    vertex amplifies the values' differences about a hundredfold)."""
    cases = [case(64, 1.6e-7, dz, friction=False) for dz in (1.5e-10, 1.0e-10, 0.6e-10)]
    cases[0]["load"]["steps"] = 1
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        alone = [wc.solve(d, fields="none") for d in cases]
        batches = []
        together = yielding.stacked_yield_checks
        monkeypatch.setattr(yielding, "checks_by_planes", lambda model: True)
        seen = []  # (radius given, radius counted from the pressure the batch gathered)

        def checks(pairs, grids, stack, loaded, radii):
            batches.append(len(pairs))
            seen.extend((r, contact_radius({"pressure": stack[3 * c].numpy()}, grids[c].cell_area))
                        for c, r in enumerate(radii))
            return together(pairs, grids, stack, loaded, radii)

        monkeypatch.setattr(yielding, "stacked_yield_checks", checks)
        batched = wc.solve_batch(cases, batch=3)
    assert batches == [1, 2]
    # the radii the batch gives (its summaries' contact_radius) are the pressure's own count
    assert len(seen) == 3 and all(given == counted > 0 for given, counted in seen), seen
    for b, a in zip(batched, alone):
        assert_same(b.yield_check, a.yield_check, rel=1e-8, z_rel=1e-6)


def test_solve_batch_checks_each_case_alone_where_the_evaluation_together_fails(monkeypatch):
    """solve_batch with its checks by planes (forced on the CPU) whose evaluation together raises:
    each case's rows are copied into its state at once and its own check made from them, the
    check solve makes (within the batched fields' tolerance, as above)."""
    cases = [case(64, 1.6e-7, dz, 2e-11) for dz in (1.5e-10, 1.0e-10)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        alone = [wc.solve(d, fields="none") for d in cases]
        monkeypatch.setattr(yielding, "checks_by_planes", lambda model: True)

        def refuse(*args):
            raise RuntimeError("refused")

        monkeypatch.setattr(yielding, "stacked_yield_checks", refuse)
        batched = wc.solve_batch(cases, batch=2)
    for b, a in zip(batched, alone):
        assert np.isfinite(b.yield_check["sphere"]["von_mises_max"])
        assert_same(b.yield_check, a.yield_check, rel=1e-8, z_rel=1e-6)

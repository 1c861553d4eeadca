"""Cases with friction solved together (``warpcontact.solve_batch``, the batched gross-slip
searches): each case's result is what ``warpcontact.solve`` (its own search) gives it, whatever
the batch around it."""

import warnings
from dataclasses import replace

import numpy as np
import pytest

import warp as wp

import warpcontact as wc
from conftest import NEEDS_FFTW
from test_solve_batch import DEVICES, quiet

# a small case: 32 cells over about 4 contact radii, steel on aluminium
BASE = {
    "sphere": {"radius": 1e-6, "E": 200e9, "nu": 0.3, "yield_strength": 3e9},
    "flat": {"E": 70e9, "nu": 0.2, "yield_strength": 1.5e9},
    "grid": {"n": 32, "size": 1.6e-7},
    "friction": {"law": "tabor", "k_tau": 0.8},
    "load": {"path": [[0, 0, 1e-9], [2e-10, 0, 1e-9], [4e-10, 0, 1e-9]]},
}


def case(**tables):
    out = {k: dict(v) for k, v in BASE.items()}
    for name, values in tables.items():
        if name == "friction":
            out[name] = dict(values)
        else:
            out.setdefault(name, {}).update(values)
    return out


#: the cases of one mixed batch: the Tabor law on a dissimilar pair (coupled turns), Coulomb on
#: another pair, identical materials (decoupled: one turn), the hardness cap (reached: the largest
#: pressure is the cap), a path that slides
#: along y and back, and one that unloads
MIXED = [
    case(),
    case(friction={"law": "coulomb", "mu": 0.3}, flat={"E": 120e9, "nu": 0.35}),
    case(flat={"E": 200e9, "nu": 0.3, "yield_strength": 3e9}),
    case(flat={"hardness": 1.2e9}, friction={"law": "tabor", "k_tau": 0.9, "hardness_cap": True},
         load={"path": [[0, 0, 1.5e-9], [3e-10, 0, 1.5e-9]]}),
    case(load={"path": [[0, 0, 1e-9], [0, 2e-10, 1e-9], [0, 0, 1e-9]]}),
    case(load={"path": [[0, 0, 1e-9], [2e-10, 0, 1e-9], [2e-10, 0, 0.6e-9]]}),
]


def assert_same_path(batched, single, rel, stress_rel=1e-8):
    """Every state's forces within ``rel`` of the single solve's (of |F_z|: the components that
    are zero by symmetry are rounding in both), its contact and stick areas (cell counts)
    identical, both converged; the last state's yield check (its largest von Mises stress in
    each body, from the pressure and the shear, and its depth) within ``stress_rel``: a local
    maximum, where the solves' differences (within their tolerance in norm over the contact) are
    not averaged as in a force (measured 1.3e-9)."""
    assert len(batched.states) == len(single.states)
    for body in ("sphere", "flat"):
        a, b = batched.yield_check[body], single.yield_check[body]
        assert a["von_mises_max"] == pytest.approx(b["von_mises_max"], rel=stress_rel)
        assert a["z"] == pytest.approx(b["z"], rel=stress_rel)
    for a, b in zip(batched.states, single.states):
        assert a["converged"] and b["converged"]
        assert a["delta"] == b["delta"]
        scale = abs(b["force"]["z"])
        for axis in ("x", "y", "z"):
            assert abs(a["force"][axis] - b["force"][axis]) <= rel * scale, axis
        assert a["contact_area"] == b["contact_area"]
        assert a["stick_area"] == b["stick_area"]


@pytest.mark.parametrize("device", DEVICES)
def test_a_batch_of_friction_cases_gives_each_what_solve_gives(device):
    """Six cases with friction in one batch (``MIXED``), float64: every state's forces within
    1e-9 of |F_z| of solve's, the contact and stick areas identical. Both solve each inner
    problem to a relative residual of 1e-10 and end their turns where the tractions change by
    less than 1e-8 a turn (the turns contract: what is left after the last is under that); the
    batch's tangential iteration makes its gradient exact at other iterations than the single
    solver's (every row's at once where any case asks), so their iterates differ, and the batch's
    run on windows of the contacts (the turns after a
    step's first wholly on them): measured 1.6e-10 at most. On CUDA the cases' yield checks are made
    together (``batch_yield_checks``), with their shear."""
    from warpcontact.studies import batch_solve

    own, place = batch_solve.run_path, batch_solve.BatchContactSolver._window
    windows = []

    def placed(self, turning):
        window = place(self, turning)
        windows.append(window.m)
        return window

    batch_solve.run_path = None  # a case handed back to be solved on its own would fail here
    batch_solve.BatchContactSolver._window = placed
    try:
        batched = quiet(wc.solve_batch, MIXED, device=device, batch=len(MIXED))
    finally:
        batch_solve.run_path, batch_solve.BatchContactSolver._window = own, place
    assert min(windows) < 32  # the tangential solves ran on windows of the grid
    for c, result in zip(MIXED, batched):
        assert not isinstance(result, Exception), result
        assert str(result.model.device).startswith(device)
        assert_same_path(result, quiet(wc.solve, c, device=device, fields="none"), rel=1e-9)


def test_batched_searches_that_fail_leave_their_cases_to_search_on_their_own(monkeypatch):
    """Where the batched steps themselves fail (a device's refusal, a library's error; here made
    to raise at the fifth step), one RuntimeWarning says so and the searches not ended run on their
    own: each result is the case's own search's."""
    from warpcontact.solvers.contact_batch import BatchContactSolver
    from warpcontact.studies.batch_solve import gross_slip_batch
    from warpcontact.studies.tasks import gross_slip_summary, prepare

    step, calls = BatchContactSolver.step, []

    def failing(self, *args, **kwargs):
        calls.append(1)
        if len(calls) == 5:
            raise RuntimeError("cuFFT refused the plan")
        return step(self, *args, **kwargs)

    monkeypatch.setattr(BatchContactSolver, "step", failing)
    cases = [prepare(wc.case_from_dict(c)) for c in MIXED[:2]]
    with pytest.warns(RuntimeWarning, match="refused the plan"):
        results = gross_slip_batch(cases, batch=2)
    assert len(calls) == 5
    for c, (summary, _) in zip(cases, results):
        own = quiet(gross_slip_summary, c)
        assert (summary["delta_x_max"], summary["mu"], len(summary["states"])) == \
            (own["delta_x_max"], own["mu"], len(own["states"]))


def test_an_error_of_the_callers_on_case_is_raised_as_it_was(monkeypatch):
    """An error raised by ``on_case`` (a caller's write that failed) ends the batched searches
    and is raised as it was, not taken for a failure of the batched steps (no search is run again
    on its own, no RuntimeWarning)."""
    from warpcontact.studies import batch_solve, tasks

    alone = []
    monkeypatch.setattr(tasks, "gross_slip_summary", lambda case, **kw: alone.append(case))

    def full(index, entry):
        raise OSError("no space left on device")

    cases = [tasks.prepare(wc.case_from_dict(c)) for c in MIXED[:2]]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with pytest.raises(OSError, match="no space left"):
            batch_solve.gross_slip_batch(cases, batch=2, on_case=full)
    assert alone == [] and not [w for w in caught if issubclass(w.category, RuntimeWarning)]


def handed_back(monkeypatch) -> list:
    """The cases a batched solve hands back to be solved on its own (``run_path``), listed as it
    solves them."""
    from warpcontact.studies import batch_solve

    alone, own = [], batch_solve.run_path

    def counted(c, **kwargs):
        alone.append(c)
        return own(c, **kwargs)

    monkeypatch.setattr(batch_solve, "run_path", counted)
    return alone


def test_a_case_whose_batched_step_does_not_converge_is_solved_on_its_own(monkeypatch):
    """A case whose inner solves cannot converge within their iteration limit (one iteration a
    solve to a relative residual of 1e-12: no state converges, in the batch or alone; at 1e-10
    the batch's turns converge, ending at 6e-11) is handed back and solved on its own: its
    result is solve's (the same unconverged states), and the case beside it is still solved in
    the batch."""
    alone = handed_back(monkeypatch)
    hard = case(solver={"max_iter": 1, "tol": 1e-12})
    results = quiet(wc.solve_batch, [MIXED[0], hard], batch=2)
    assert len(alone) == 1 and alone[0].solver.max_iter == 1
    single = quiet(wc.solve, hard, fields="none")
    assert [s["converged"] for s in results[1].states] == [s["converged"] for s in single.states]
    assert not results[1].converged
    assert results[1].states[0]["force"]["z"] == single.states[0]["force"]["z"]
    assert_same_path(results[0], quiet(wc.solve, MIXED[0], fields="none"), rel=1e-9)


def test_friction_cases_are_batched_by_default_only_where_it_pays(monkeypatch):
    """Without ``batch``, cases with friction are batched on CUDA from ``FRICTION_MIN_BATCH`` cases
    of one grid size on, never on the CPU (the batched step with friction is slower there, and
    with few cases anywhere): here on the CPU they go to the single solver."""
    from warpcontact.studies.batch_solve import FRICTION_MIN_BATCH, friction_batched

    assert friction_batched(FRICTION_MIN_BATCH, True, None) and not friction_batched(FRICTION_MIN_BATCH - 1, True, None)
    assert not friction_batched(1000, False, None) and friction_batched(2, False, 2) and not friction_batched(64, True, 0)
    from warpcontact.studies import batch_solve

    made = []
    monkeypatch.setattr(batch_solve.BatchContactSolver, "__init__",
                        lambda self, *a: made.append(a) or (_ for _ in ()).throw(AssertionError("batched")))
    results = quiet(wc.solve_batch, MIXED[:2], device="cpu")
    assert made == [] and all(r.converged for r in results)


@pytest.mark.parametrize("library", [pytest.param("fftw", marks=NEEDS_FFTW), "scipy"])
def test_the_batched_operator_is_the_single_operator(library, monkeypatch):
    """The batched tangential and coupling blocks of two pairs, one a row, applied to random
    fields, equal the single ``ElasticOperator``'s of each pair to rounding (1e-12 of the
    largest displacement: both are FFT products of the same coefficients in float64), with the
    batch's CPU transforms by FFTW's plans (pyFFTW installed) and by scipy.fft (without it): the
    separate products and the whole operator from one transform of each traction (``coupled``,
    with and without its K_zz block)."""
    from warpcontact.fft import fftw_backend
    from warpcontact.fft.batch import BatchElasticOperator

    if library == "scipy":
        monkeypatch.setattr(fftw_backend, "available", lambda: False)
    from warpcontact.numerics.model import ContactModel
    from warpcontact.records.case import case_from_dict

    n = 16
    cases = [case_from_dict(case(grid={"n": n})),
             case_from_dict(case(grid={"n": n}, flat={"E": 120e9, "nu": 0.35}))]
    op = BatchElasticOperator(n, 2, "cpu", wp.float64)
    assert (op.library._fftw is not None) == (library == "fftw")
    op.set_pairs([c.pair for c in cases])
    rng = np.random.default_rng(3)
    p, qx, qy = (rng.random((2, n * n)) for _ in range(3))

    def batch_field(a):
        return wp.array(a, dtype=wp.float64, device="cpu")

    u, uz = batch_field(np.zeros((2, 2, n * n))), batch_field(np.zeros((2, n * n)))
    op.tangential(batch_field(np.stack([qx, qy])), u, pressure=batch_field(p))
    op.cross_normal(batch_field(np.stack([qx, qy])), uz)
    ux, uy = u[0], u[1]
    whole, whole_z = batch_field(np.zeros((2, 2, n * n))), batch_field(np.zeros((2, n * n)))
    op.coupled(batch_field(p), batch_field(np.stack([qx, qy])), whole_z, whole)
    shear_z = batch_field(np.zeros((2, n * n)))
    op.coupled(batch_field(p), batch_field(np.stack([qx, qy])), shear_z, batch_field(np.zeros((2, 2, n * n))),
               normal_block=False)
    for row, c in enumerate(cases):
        m = ContactModel(c.pair, c.sphere, c.grid, device="cpu", dtype="float64")

        def field(a):
            return wp.array(a[row].reshape(n, n), dtype=wp.float64, device="cpu")

        sx, sy, sz = m.field(), m.field(), m.field()
        m.operator.coupled_apply(field(p), field(qx), field(qy), sz, sx, sy)
        zz = m.field()
        m.operator.cross_normal(field(qx), field(qy), zz)  # K_zt q alone
        for batched, single in ((ux, sx), (uy, sy), (uz, zz), (whole[0], sx), (whole[1], sy), (whole_z, sz),
                                (shear_z, zz)):
            expected = single.numpy().ravel()
            assert np.abs(batched.numpy()[row] - expected).max() < 1e-12 * np.abs(expected).max()


def test_float32_batches_agree_with_float64():
    """Three cases batched in float32 (tolerance 1e-5 on the relative residual): every state's
    forces within 1e-4 of |F_z| of float64's single solve (the residual's tolerance and float32's
    rounding of the sums; measured 2e-6) and the stick areas identical."""
    batched = quiet(wc.solve_batch, MIXED[:3], dtype="float32", batch=3)
    for c, result in zip(MIXED[:3], batched):
        assert result.model.dtype_name == "float32" and result.converged
        single = quiet(wc.solve, c, fields="none")
        for a, b in zip(result.states, single.states):
            for axis in ("x", "y", "z"):
                assert abs(a["force"][axis] - b["force"][axis]) <= 1e-4 * abs(b["force"]["z"]), axis
            assert a["stick_area"] == b["stick_area"]


SWEEP_BASE = """[sphere]
radius = 1e-6
E = 200e9
nu = 0.3
yield_strength = 3e9

[flat]
E = 70e9
nu = 0.2
yield_strength = 1.5e9

[grid]
n = 32
size = 1.6e-7

[friction]
law = "tabor"
k_tau = 0.8

[load]
path = [[0.0, 0.0, 1e-9], [2e-10, 0.0, 1e-9]]
"""


def sweep_both_ways(tmp_path, monkeypatch, task: str, counted: str):
    """The sweep of four cases of ``SWEEP_BASE`` (k_tau and the flat's modulus swept) with ``task``,
    one case at a time (``--batch 0``) and batched (``--batch 4``): (each case's record one at a
    time, batched, by case id) and the number of cases of each call of ``batch_solve.<counted>``."""
    import argparse
    import json

    from warpcontact.cli.sweep import add_parser, cmd_sweep
    from warpcontact.studies import batch_solve

    (tmp_path / "base.toml").write_text(SWEEP_BASE)
    sweep = tmp_path / "sweep.toml"
    sweep.write_text('base = "base.toml"\n[sweep]\n"friction.k_tau" = [0.8, 0.95]\n"flat.E" = [70e9, 120e9]\n'
                     f'[run]\ntask = "{task}"\n')
    calls, function = [], getattr(batch_solve, counted)
    monkeypatch.setattr(batch_solve, counted, lambda cases, **kw: calls.append(len(cases)) or function(cases, **kw))
    parser = argparse.ArgumentParser()
    add_parser(parser.add_subparsers(dest="command"))
    for out, batch in (("one", "0"), ("together", "4")):
        args = parser.parse_args(["sweep", str(sweep), "--out", str(tmp_path / out), "--quiet", "--batch", batch,
                                  "--workers", "1"])
        assert quiet(cmd_sweep, args) == 0
    ids = sorted(p.stem for p in (tmp_path / "one" / "cases").glob("*.json"))
    assert len(ids) == 4
    records = {i: tuple(json.loads((tmp_path / d / "cases" / f"{i}.json").read_text()) for d in ("one", "together"))
               for i in ids}
    return records, calls


def test_a_sweep_with_friction_batched_records_what_one_case_at_a_time_records(tmp_path, monkeypatch):
    """``warpcontact sweep --batch 4`` of four cases with friction: one batched solve of the four,
    each record as one case at a time writes it: statuses, stick and contact areas the same, the
    forces within 1e-9 of |F_z| (as the solves above)."""
    records, calls = sweep_both_ways(tmp_path, monkeypatch, "solve", "solve_batch")
    assert calls == [4]
    for x, y in records.values():
        assert (x["status"], x["converged"], x["params"]) == (y["status"], y["converged"], y["params"]) == \
            ("ok", True, x["params"])
        s, t = x["summary"], y["summary"]
        assert (s["contact_area"], s["stick_area"]) == (t["contact_area"], t["stick_area"])
        for axis in ("x", "y", "z"):
            assert abs(s["force"][axis] - t["force"][axis]) <= 1e-9 * abs(s["force"]["z"]), axis


def test_a_gross_slip_sweep_batched_records_what_one_case_at_a_time_records(tmp_path, monkeypatch):
    """``warpcontact sweep --batch 4`` with the task "gross-slip": the four searches walk together
    (each bisection trial from its own last stick state, batched), each record as one case at a
    time writes it: the same states, the same delta_x_max (the same bisection decisions), mu within
    2e-9 (F_x / F_z of forces within 1e-9 of |F_z|: (1 + mu) 1e-9; measured 1e-10)."""
    records, calls = sweep_both_ways(tmp_path, monkeypatch, "gross-slip", "gross_slip_batch")
    assert calls == [4]
    for x, y in records.values():
        assert (x["status"], x["converged"], sorted(x["warnings"])) == (y["status"], y["converged"], sorted(y["warnings"]))
        s, t = x["summary"], y["summary"]
        assert x["status"] == "ok" and s["n_states"] == t["n_states"]
        assert s["delta_x_max"] == t["delta_x_max"] and s["delta_x_gross"] == t["delta_x_gross"]
        assert abs(s["mu"] - t["mu"]) <= 2e-9
        assert s["yielded"] == t["yielded"]


def test_table2_cells_searched_together_record_what_one_at_a_time_records(tmp_path, monkeypatch):
    """``warpcontact table2 --no-adhesion --batch 4``: the four cells' searches walk together (one
    batch: cells of one n, each its own grid and k_tau); each record as one cell at a time writes
    it: the same states and delta_x_max, mu within 2e-9 (as the sweep above)."""
    import json

    from warpcontact.cli import main
    from warpcontact.studies import batch_solve

    searches, search = [], batch_solve.search_batch
    monkeypatch.setattr(batch_solve, "search_batch",
                        lambda entries, *a, **kw: searches.append(len(entries)) or search(entries, *a, **kw))
    sel = ["--no-adhesion", "--n", "24", "--k-tau", "0.8", "0.95", "--delta-z-um", "5e-5", "1e-5", "--quiet"]
    codes = [quiet(main, ["table2", *sel, "--batch", batch, "--out", str(tmp_path / batch)]) for batch in ("0", "4")]
    assert codes[0] == codes[1] and codes[0] in (0, 3)
    assert searches == [4]
    one, together = (json.loads((tmp_path / d / "table2.json").read_text())["cells"] for d in ("0", "4"))
    key = sorted
    assert key((c["k_tau"], c["delta_z_um"]) for c in one) == key((c["k_tau"], c["delta_z_um"]) for c in together)
    by_cell = {(c["k_tau"], c["delta_z_um"]): c for c in together}
    for a in one:
        b = by_cell[(a["k_tau"], a["delta_z_um"])]
        assert (a["converged"], a["states"], a["delta_x_max_um"]) == (b["converged"], b["states"], b["delta_x_max_um"])
        if a["mu"] is not None:
            assert abs(a["mu"] - b["mu"]) <= 2e-9


def test_turns_on_a_window_that_cuts_the_contact_are_judged_on_the_whole_grid(monkeypatch):
    """The turns after a step's first stay on the window of the first turn's contacts; a contact
    that passes it is found by the step's normal solve on the whole grid (the pressure moves by
    more than the turns' tolerance), and the case is solved again on its own. Forced here: a
    window of 8 cells over a contact about 16 wide (the whole grid's turns are what they were:
    only the window is forced). Each result is then solve's own (to 1e-9 of |F_z|, as above)."""
    from warpcontact.solvers import contact_batch
    from warpcontact.studies import batch_solve

    own = batch_solve.run_path
    alone = []

    def counted(case, **kw):
        alone.append(case)
        return own(case, **kw)

    monkeypatch.setattr(contact_batch, "window_cells", lambda extent, n: 8)
    monkeypatch.setattr(batch_solve, "run_path", counted)
    cases = MIXED[:2]
    batched = quiet(wc.solve_batch, cases, device="cpu", batch=len(cases))
    assert len(alone) == len(cases)
    monkeypatch.undo()
    for c, result in zip(cases, batched):
        assert_same_path(result, quiet(wc.solve, c, device="cpu", fields="none"), rel=1e-9)


def test_cases_judged_unconverged_on_their_exact_gradient_go_on_from_it(monkeypatch):
    """The batched tangential solve carries its gradient; a case stops where the carried one meets
    its tolerance and is judged on its exact one, going on from it where they disagree. Forced
    here: the first judgement of every solve says the first row has not converged, so every
    solve resumes from its exact gradient (one more launch each); the answers are unchanged (to
    1e-9 of |F_z|, as above) and every solve ends converged."""
    from warpcontact.solvers import tangential_batch

    judged = tangential_batch.row_infos
    calls = {"judged": 0, "resumed": 0}

    def once_unconverged(solver, active, tol):
        infos = judged(solver, active, tol)
        calls["judged"] += 1
        if calls["judged"] % 2 == 1 and active[0]:  # a solve's first judgement: row 0 said unconverged
            infos[0] = replace(infos[0], converged=False)
        return infos

    from warpcontact.numerics.launch import CapturedGraphs

    launch = CapturedGraphs.launch

    def counted(self, key, work, ready=None):
        calls["resumed"] += key == "resume"
        return launch(self, key, work, ready)

    monkeypatch.setattr(tangential_batch, "row_infos", once_unconverged)
    monkeypatch.setattr(CapturedGraphs, "launch", counted)
    cases = MIXED[:2]
    batched = quiet(wc.solve_batch, cases, device="cpu", batch=len(cases))
    assert calls["resumed"] > 0 and calls["judged"] == 2 * calls["resumed"]
    monkeypatch.undo()
    for c, result in zip(cases, batched):
        assert all(s["converged"] for s in result.states)
        assert_same_path(result, quiet(wc.solve, c, device="cpu", fields="none"), rel=1e-9)


def test_table2_batches_its_cells_by_default_only_on_cuda_grids_where_it_pays(tmp_path, monkeypatch):
    """Without ``--batch``, ``warpcontact table2`` searches its cells, those with adhesion too,
    together on CUDA for grids up to ``FEW_SEARCHES_MAX_N`` cells per side (where a column's 12
    searches pay batched), one at a time on larger grids and on the CPU; ``batch`` given, as
    asked. On workers the cells searched together go as one task a grid (``_batched_tasks``),
    ``batch`` cells at most, a lone cell a task of its own."""
    from types import SimpleNamespace

    from warpcontact.studies import batch_solve
    from warpcontact.studies.table2 import Table2Run, Table2Settings, run_cell, search_cells

    run = Table2Run(Table2Settings(n=128), tmp_path, ns=(128, 256, 512), k_tau=(0.8,), delta_z_um=(1e-4,))
    assert run._batched_cells(None) == ([], 0)  # the CPU
    monkeypatch.setattr(batch_solve, "resolve_device", lambda device: SimpleNamespace(is_cuda=True))
    cells, batch = run._batched_cells(None)
    assert [c for _, c in cells] == [(128, 0.8, 1e-4, False), (256, 0.8, 1e-4, False), (128, 0.8, 1e-4, True),
                                     (256, 0.8, 1e-4, True)] and batch == 4
    assert batch_solve.FEW_SEARCHES_MAX_N == 256
    assert run._batched_cells(0) == ([], 0)
    cells, batch = run._batched_cells(3)
    assert len(cells) == 6 and batch == 3
    # one grid a task: each cell here its own grid (its n, its column's domain), so each alone
    tasks, groups = run._batched_tasks(cells, batch)
    assert [t.fn for t in tasks] == [run_cell] * 6 and groups == {}
    wide = Table2Run(Table2Settings(n=32), tmp_path, k_tau=(0.5, 0.8, 0.95), delta_z_um=(1e-4,))
    cells, batch = wide._batched_cells(2)
    tasks, groups = wide._batched_tasks(cells, batch)
    # per column (its own grid), the three k_tau cells: a task of two searched together, one alone
    assert [(t.fn, t.cases) for t in tasks] == [(search_cells, 2), (run_cell, 1)] * 2
    assert sorted(int(c.key) for t in tasks for c in (groups[t.key] if t.cases > 1 else [t])) == list(range(6))
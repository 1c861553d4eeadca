"""The tangential solve on the window of the grid that holds the contact (``SolverSettings.window``):
its sizes and place, the same answer as on the whole grid, the coupled step with it."""

import math

import numpy as np
import pytest

from warpcontact.numerics.model import ContactModel
from warpcontact.numerics.state import ContactState
from warpcontact.physics.friction import TaborVonMises
from warpcontact.physics.geometry import Grid, Sphere
from warpcontact.physics.materials import PAPER_PAIR
from warpcontact.solvers.contact import ContactSolver
from warpcontact.solvers.normal import NormalSolver
from warpcontact.solvers.tangential import (
    WINDOW_MAX_SHARE, WINDOW_STEPS, TangentialSolver, window_cells, window_origin,
)

R, DZ, DX = 10e-6, 1.0e-10, 2.0e-11
A = math.sqrt(R * DZ)
LAW = TaborVonMises(0.8, PAPER_PAIR.softer.yield_strength)


def largest_prime_factor(m: int) -> int:
    p, largest = 2, 1
    while m > 1:
        while m % p == 0:
            m //= p
            largest = p
        p += 1
    return largest


def test_window_sizes_hold_the_support_and_transform_fast():
    """Every support from 1 to 5000 cells gets a window at least as wide, at most 20 % wider
    (the widest gap of the ladder, 10 -> 12; 8 cells at least), whose padded length 2m has no prime
    factor over 7; none past WINDOW_MAX_SHARE of the grid."""
    for extent in range(1, 5001):
        cells = window_cells(extent, 10**6)
        assert cells >= max(extent, WINDOW_STEPS[0]), extent
        assert cells <= max(1.2 * extent, WINDOW_STEPS[0]), (extent, cells)
        assert largest_prime_factor(2 * cells) <= 7, (extent, cells)
    assert window_cells(64, 128) == 64 and window_cells(65, 128) == 72
    assert window_cells(97, 128) is None  # 112 > 0.75 x 128
    assert window_cells(4098, 8192) == 4608  # a contact half the domain wide: 9/16 of the grid


def test_window_origin_holds_the_support_inside_the_grid():
    """The window covers rows first..last and stays on the grid, wherever the support lies."""
    n = 100
    for first in range(0, n):
        for last in range(first, min(n, first + 60)):
            cells = window_cells(last - first + 1, n)
            if cells is None:
                continue
            start = window_origin(first, last, cells, n)
            assert 0 <= start and start + cells <= n, (first, last, cells, start)
            assert start <= first and last < start + cells, (first, last, cells, start)


def hertz_state(n, device, dtype, size=4 * A, dz=DZ):
    model = ContactModel(PAPER_PAIR, Sphere(R), Grid(n, size), device=device, dtype=dtype)
    state = ContactState(model)
    assert NormalSolver(model).solve(state, dz).converged
    return model, state


def shear_problem(model, state, delta_x):
    """The tangential problem of the Hertz state at delta_x [m]: (target_x, target_y, q_max)."""
    f = model.field
    q_max = f()
    LAW.shear_limit(model, state.pressure.flatten(), q_max.flatten())
    target_x = f(np.full(model.grid.shape, delta_x / model.length_scale))
    return target_x, f(), q_max


def test_the_cpus_row_scan_finds_the_support_box_the_column_scan_finds():
    """``support_box_rows`` (the CPU's: a thread a row, scanning from each end) and ``support_box``
    (a thread a block of one column's rows) give the same box (first row, last row, first
    column, last column) of the cells > 0: no cell, every cell, one cell in a corner or on an
    edge, a disk off centre, a ring, negative values beside positive ones, on a grid whose rows
    are no multiple of the column scan's block; exactly (integers)."""
    import warp as wp

    from warpcontact.kernels import grids as gk

    n = 150
    y, x = np.mgrid[0:n, 0:n]
    r2 = (x - 97.3) ** 2 + (y - 40.1) ** 2
    fields = [np.zeros((n, n)), np.ones((n, n)), np.where(r2 < 30 ** 2, 1.0, 0.0),
              np.where((r2 > 20 ** 2) & (r2 < 25 ** 2), 2.0, -1.0), np.sin(0.3 * x) * np.cos(0.2 * y)]
    for i, j in ((0, 0), (n - 1, n - 1), (0, n - 1), (n - 1, 0), (77, 0), (0, 63)):
        one = np.zeros((n, n))
        one[i, j] = 1e-300
        fields.append(one)
    for field in fields:
        boxes = []
        for kernel, dim in ((gk.support_box, (-(-n // int(gk.SUPPORT_ROWS)), n)), (gk.support_box_rows, n)):
            box = wp.array(np.array([n, -1, n, -1], dtype=np.int32), device="cpu")
            wp.launch(kernel, dim, [wp.array(field, dtype=wp.float64, device="cpu")], [box], device="cpu")
            boxes.append(box.numpy())
        inside = np.argwhere(field > 0)
        expected = [n, -1, n, -1] if not len(inside) else [inside[:, 0].min(), inside[:, 0].max(),
                                                           inside[:, 1].min(), inside[:, 1].max()]
        assert boxes[0].tolist() == boxes[1].tolist() == expected


@pytest.mark.parametrize("dtype", ["float64", "float32"])
def test_window_solve_is_the_whole_grid_solve(device, dtype):
    """The tangential problem of a Hertz contact half the domain wide (n = 64, window 32) with the
    coupling of dissimilar materials (K_tp p made by the solver): on the window and on the whole
    grid. Both meet the solver's tolerance (1e-10 float64, 1e-5 float32); the shear differs by
    what two solutions within that relative residual may (the stick zone's conditioning: allowed
    1e-7 and 1e-3 of the largest shear; measured 3.0e-9 and 3.7e-5), the slip statuses agree except
    on cells at the stick-slip boundary (at most 2 of the 812 contact cells; measured none), and
    the displacements K_tt q on the whole grid likewise (1e-8 and 1e-4 of the largest; measured
    3.8e-10 and 4.5e-6). The known displacement the caller gets back is K_tp p on the whole grid
    either way."""
    n = 64
    out = {}
    for window in (False, True):
        model, state = hertz_state(n, device, dtype)
        solver = TangentialSolver(model, window=window)
        target_x, target_y, q_max = shear_problem(model, state, 0.5 * DX)
        known_x, known_y = model.field(), model.field()
        info = solver.solve(state, target_x, target_y, q_max, known_x, known_y, pressure=state.pressure)
        assert info.converged, (window, info)
        assert solver.last_window == (32 if window else None)
        out[window] = {k: getattr(state, k).numpy().copy() for k in ("shear_x", "shear_y", "disp_x", "disp_y", "status")}
        out[window]["known_x"] = known_x.numpy().copy()
    whole, win = out[False], out[True]
    tol_q, tol_u = (1e-7, 1e-8) if dtype == "float64" else (1e-3, 1e-4)
    scale_q = np.abs(whole["shear_x"]).max()
    for k in ("shear_x", "shear_y"):
        assert np.abs(win[k] - whole[k]).max() < tol_q * scale_q, (k, np.abs(win[k] - whole[k]).max() / scale_q)
    for k in ("disp_x", "disp_y", "known_x"):
        scale = np.abs(whole[k if k != "disp_y" else "disp_x"]).max()
        assert np.abs(win[k] - whole[k]).max() < tol_u * scale, (k, np.abs(win[k] - whole[k]).max() / scale)
    assert np.count_nonzero(win["status"] != whole["status"]) <= 2
    assert np.count_nonzero(whole["status"] == 2) > 0 and np.count_nonzero(whole["status"] == 1) > 0  # partial slip


def test_deferred_whole_displacement_is_the_window_solves_shear_convolved(device):
    """``whole=False``: after the solve on its window the whole grid's K_tt q and K_tp p are not
    made; ``whole_displacement`` makes them once (a second call changes nothing): the same bits as
    the operator applied to the solve's shear and pressure (the same transforms; the caller's
    zero known displacement plus K_tp p is K_tp p exactly). The shear outside the window is zero,
    its cells out of contact."""
    model, state = hertz_state(64, device, "float64")
    solver = TangentialSolver(model, window=True)
    target_x, target_y, q_max = shear_problem(model, state, 0.5 * DX)
    known_x, known_y = model.field(), model.field()
    solver.solve(state, target_x, target_y, q_max, known_x, known_y, pressure=state.pressure, whole=False)
    assert solver.last_window == 32
    assert not state.disp_x.numpy().any() and not known_x.numpy().any()  # not made yet
    solver.whole_displacement(state)
    solver.whole_displacement(state)  # nothing the second time
    f = model.field
    ref = [f() for _ in range(4)]
    model.operator.tangential(state.shear_x, state.shear_y, ref[0], ref[1])
    model.operator.cross_tangential(state.pressure, ref[2], ref[3])
    for name, got, want in zip(("disp_x", "disp_y", "known_x", "known_y"),
                               (state.disp_x, state.disp_y, known_x, known_y), ref):
        assert np.array_equal(got.numpy(), want.numpy()), name
    limit = q_max.numpy()
    assert not state.shear_x.numpy()[limit == 0].any() and not state.status.numpy()[limit == 0].any()


def test_contact_wider_than_the_largest_window_solves_on_the_whole_grid():
    """A domain only 1.25 times the contact's width: the window would pass WINDOW_MAX_SHARE of the
    grid, so the solve runs on the whole grid."""
    model, state = hertz_state(48, "cpu", "float64", size=2.5 * A)
    solver = TangentialSolver(model, window=True)
    target_x, target_y, q_max = shear_problem(model, state, 0.5 * DX)
    assert solver.solve(state, target_x, target_y, q_max).converged
    assert solver.last_window is None and WINDOW_MAX_SHARE < 1


def coupled_steps(n, device, window: bool):
    model = ContactModel(PAPER_PAIR, Sphere(R), Grid(n, 4 * A), device=device)
    solver = ContactSolver(model, LAW, window=window)
    state = ContactState(model)
    windows = []
    for approach in ((0.0, 0.0, DZ), (DX, 0.0, DZ)):
        info = solver.step(state, approach)
        assert info.converged, (window, approach, info)
        windows.append(solver.tangential.last_window)
    return state.to_numpy_si(), windows


def test_coupled_step_on_the_window_is_the_whole_grid_step(device):
    """The coupled problem of bench/scaling.py (Tabor k_tau 0.8, delta_z then delta_x) at n = 64, the
    tangential solves on the window and on the whole grid. The turns end at a relative change of
    1e-8 (100 x tol, 2-norm) and the two runs' iterates differ in rounding, so they may stop a
    turn apart: the tractions agree within 1e-6 of their largest value (measured: 1.7e-8 for the
    small shear_y, 2.7e-9 for shear_x, 4.4e-10 for the pressure), the displacements, gap and slip
    within 1e-8 (measured 5.3e-10 at most)."""
    whole, _ = coupled_steps(64, device, False)
    win, windows = coupled_steps(64, device, True)
    assert windows == [32, 32] or all(w is not None and w <= 40 for w in windows), windows
    for k, tol in (("pressure", 1e-6), ("shear_x", 1e-6), ("shear_y", 1e-6), ("disp_x", 1e-8), ("slip_x", 1e-8),
                   ("gap", 1e-8), ("disp_z", 1e-8)):
        scale = np.abs(whole[k]).max()
        assert np.abs(win[k] - whole[k]).max() < tol * scale, (k, np.abs(win[k] - whole[k]).max() / scale)


def test_auto_window_from_the_measured_grids_on():
    """``window = "auto"``: on the CPU from WINDOW_AUTO_N["cpu"] cells per side on (where it was
    measured to pay), on the whole grid below; True and False force it."""
    from warpcontact.solvers.tangential import WINDOW_AUTO_N

    n = WINDOW_AUTO_N["cpu"]
    for cells, expected in ((n // 2, None), (n, n // 2)):
        model, state = hertz_state(cells, "cpu", "float64")
        solver = TangentialSolver(model)
        assert solver.settings.window == "auto"
        target_x, target_y, q_max = shear_problem(model, state, 0.5 * DX)
        assert solver.solve(state, target_x, target_y, q_max).converged
        assert solver.last_window == expected, (cells, solver.last_window)


def test_case_files_set_the_window():
    """``[solver] window`` of a case file reaches the tangential solver (true, false, "auto" by
    default); anything else is refused with a message naming the key."""
    from warpcontact.errors import InputError
    from warpcontact.records.case import case_from_dict
    from warpcontact.studies.runner import build

    def material(m):
        return {"E": m.E, "nu": m.nu, "yield_strength": m.yield_strength}

    def case(**solver):
        return case_from_dict({"sphere": {"radius": R, **material(PAPER_PAIR.sphere)},
                               "flat": material(PAPER_PAIR.flat), "grid": {"n": 32, "size": 4 * A},
                               "load": {"delta_z": DZ, "delta_x": DX, "steps": 1},
                               "friction": {"law": "tabor", "k_tau": 0.8}, "solver": solver})

    assert case().solver.window == "auto"
    for value in (True, False, "auto"):
        _, solver, _ = build(case(window=value))
        assert solver.tangential.settings.window == value
        assert case(window=value).solver.to_dict()["window"] == value
    with pytest.raises(InputError, match="solver.window"):
        case(window="sometimes")


@pytest.mark.parametrize("turns, outer_tol", [("lagged", 1e-10), ("minimised", None)])
def test_adhesive_coupled_steps_on_the_window(turns, outer_tol):
    """An adhesive Table 2 cell's law (SMC, k_tau 0.8, delta_z 1e-4 um, n = 48: a grid of 60
    cells with the law's tail, window 32) with both kinds of turns, delta_z then delta_x = 2e-11 m,
    the tangential solves on the window and on the whole grid (where the adhesive tractions'
    displacements are known displacements on the whole grid, cut out for the window). The two
    runs' iterates differ in rounding and each stops where its turns' change falls under the
    outer tolerance: the contact tractions, slip and gap agree within 1e-7 of their largest
    (measured 2e-8 at most), the adhesive tractions within 1e-5. The adhesive tractions are the
    law at the last turn's gap, and on the cells just outside the contact (gap 1e-14 m against
    delta_n = 5e-12 m, where the law's slope e sigma_max / delta_n is steepest) the lagged fixed
    point's last step is largest: stopped at the default 1e-8 the two runs' lagged adhesive
    pressures differ there by 1.2e-5 of the largest, hence the lagged turns run to 1e-10 here
    (measured 8.8e-7); the minimised turns at the default 1e-8 (measured 9.4e-7 for the adhesive
    shear). Both runs precondition on the padded grid: the periodic circulants of a 32- and a
    60-cell grid (``preconditioner_grid``'s default) take paths different by more than rounding,
    and the lagged fixed point's edge cells keep their path (test_preconditioner_grid.py)."""
    from warpcontact.studies import table2 as t2

    settings = t2.Table2Settings(n=48)
    law = settings.adhesion_law()
    dz = 1e-4 * t2.UM
    out = {}
    for window in (False, True):
        model = ContactModel(PAPER_PAIR, Sphere(t2.RADIUS), t2.cell_grid(dz, settings, law))
        solver = ContactSolver(model, LAW, adhesion=law, turns=turns, window=window, outer_tol=outer_tol,
                               preconditioner_grid="padded")
        state = ContactState(model)
        for approach in ((0.0, 0.0, dz), (DX, 0.0, dz)):
            info = solver.step(state, approach)
            assert info.converged, (window, approach, info)
        assert solver.tangential.last_window == (32 if window else None)
        out[window] = state.to_numpy_si()
    for k, tol in (("pressure", 1e-7), ("shear_x", 1e-7), ("shear_y", 1e-7), ("slip_x", 1e-7), ("gap", 1e-7),
                   ("adhesive_pressure", 1e-5), ("adhesive_shear_x", 1e-5)):
        scale = np.abs(out[False][k]).max()
        assert np.abs(out[True][k] - out[False][k]).max() < tol * scale, (k, np.abs(out[True][k] - out[False][k]).max() / scale)


def test_a_turns_slip_and_shear_displacement_from_shared_transforms(monkeypatch):
    """The lagged adhesive turns of the test above on the window, their slip and the shear's
    normal displacement made from one forward transform of each traction
    (``ContactSolver.shared_transforms``, ``ElasticOperator.coupled_shear``) and from the separate
    products: the same problem and products equal to rounding, so the same turns and inner
    iterations (measured 33 turns either way) and states within 1e-8 of each field's largest
    (rounding carried through the solves' stopping tests; measured 2.0e-9); the shared products
    replace the next normal solve's ``cross_normal`` at every turn but a step's first (measured 2
    calls against 35). The law without its touching segment
    (``adhesion.TOUCHING`` = 0): with it a touching cell may keep any traction on the segment,
    and rounding alone can end the two on different points of it (one CI run: shear_y 1.2e-8
    apart; docs/limits.md); without it the fixed point is unique."""
    import warpcontact.physics.adhesion as adhesion_laws
    from warpcontact.studies import table2 as t2

    monkeypatch.setattr(adhesion_laws, "TOUCHING", 0.0)

    settings = t2.Table2Settings(n=48)
    law = settings.adhesion_law()
    dz = 1e-4 * t2.UM
    out, calls = {}, {}
    for shared in (False, True):
        monkeypatch.setattr(ContactSolver, "shared_transforms", shared)
        model = ContactModel(PAPER_PAIR, Sphere(t2.RADIUS), t2.cell_grid(dz, settings, law))
        op = model.operator
        count = {"cross_normal": 0, "coupled_shear": 0}
        for name in count:
            def counted(*a, _name=name, _f=getattr(op, name), **k):
                count[_name] += 1
                return _f(*a, **k)
            monkeypatch.setattr(op, name, counted)
        solver = ContactSolver(model, LAW, adhesion=law, turns="lagged", window=True, outer_tol=1e-10,
                               preconditioner_grid="padded")
        state = ContactState(model)
        turns = 0
        for approach in ((0.0, 0.0, dz), (DX, 0.0, dz)):
            info = solver.step(state, approach)
            assert info.converged, (shared, approach, info)
            turns += info.outer_iterations
        out[shared], calls[shared] = state.to_numpy_si(), (dict(count), turns)
    (separate, turns_separate), (together, turns_together) = calls[False], calls[True]
    assert separate["coupled_shear"] == 0 and together["coupled_shear"] >= turns_together - 2, calls
    assert together["cross_normal"] <= 4, calls  # each step's first turn and its final normal solve at most
    assert separate["cross_normal"] >= turns_separate, calls
    for k in ("pressure", "shear_x", "shear_y", "slip_x", "gap", "adhesive_pressure", "adhesive_shear_x"):
        scale = np.abs(out[False][k]).max()
        assert np.abs(out[True][k] - out[False][k]).max() < 1e-8 * scale, (k, np.abs(out[True][k] - out[False][k]).max() / scale)


def test_a_steps_final_slip_from_shared_transforms(monkeypatch):
    """Friction without adhesion, the tangential solves on the window: a step's final slip makes
    K_tt q + K_tp p on the whole grid from one forward transform of each traction
    (``ElasticOperator.coupled_shear`` without the shear's normal displacement), where the separate
    products add K_tp p to the known displacements and then make K_tt q: the same sum in another
    order. The first step's final slip is the second step's slip history, whose rounding changes
    that step's start, and its turns stop at a relative change of 1e-8: as on the window against
    the whole grid, the tractions within 1e-6 of their largest (measured 1.4e-8, shear_y), the
    slip and displacements within 1e-8 (measured 2.5e-9). One shared product a step, and two
    inverse transforms of the whole grid fewer a step (counted: the backend's inverse passes)."""
    out, counts = {}, {}
    for shared in (False, True):
        monkeypatch.setattr(ContactSolver, "shared_transforms", shared)
        model = ContactModel(PAPER_PAIR, Sphere(R), Grid(64, 4 * A))
        op = model.operator
        count = {"coupled_shear": 0, "inverse": 0}
        coupled, inverse = op.coupled_shear, op.fft.inverse

        def counted_coupled(*a, **k):
            count["coupled_shear"] += 1
            return coupled(*a, **k)

        def counted_inverse(*a, **k):
            count["inverse"] += 1
            return inverse(*a, **k)

        monkeypatch.setattr(op, "coupled_shear", counted_coupled)
        monkeypatch.setattr(op.fft, "inverse", counted_inverse)
        solver = ContactSolver(model, LAW, window=True)
        state = ContactState(model)
        for approach in ((0.0, 0.0, DZ), (DX, 0.0, DZ)):
            assert solver.step(state, approach).converged
            assert solver.tangential.last_window is not None
        out[shared], counts[shared] = state.to_numpy_si(), count
    assert counts[False]["coupled_shear"] == 0 and counts[True]["coupled_shear"] == 2, counts
    assert counts[False]["inverse"] - counts[True]["inverse"] == 4, counts
    for k, tol in (("pressure", 1e-6), ("shear_x", 1e-6), ("shear_y", 1e-6), ("slip_x", 1e-8), ("slip_y", 1e-8),
                   ("disp_x", 1e-8), ("disp_y", 1e-8)):
        scale = np.abs(out[False][k]).max()
        assert np.abs(out[True][k] - out[False][k]).max() < tol * scale, (k, np.abs(out[True][k] - out[False][k]).max() / scale)


def test_a_non_finite_value_in_a_window_names_the_whole_grids_cell():
    """A NaN in the shear a solve starts from, at a contact cell: the solve on the window stops
    with NonFiniteError naming the field and the cell by its row and column on the whole grid (the
    window's own indices plus its place), as the solve on the whole grid does."""
    from warpcontact.errors import NonFiniteError

    for window in (False, True):
        model, state = hertz_state(64, "cpu", "float64")
        solver = TangentialSolver(model, window=window)
        target_x, target_y, q_max = shear_problem(model, state, 0.5 * DX)
        values = state.shear_x.numpy().copy()
        values[30, 35] = np.nan  # inside the contact (cells 16..47 each way)
        state.shear_x.assign(values)
        with pytest.raises(NonFiniteError, match=r"shear_x .*row 30, column 35"):
            solver.solve(state, target_x, target_y, q_max)
        assert solver.last_window == (32 if window else None)

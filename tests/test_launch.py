"""Launches split over the CPU's threads by rows (warpcontact.numerics.launch: Rows, Sums, LaunchCache.split)."""

import math

import numpy as np
import pytest
import warp as wp

from warpcontact.physics.friction import TaborVonMises
from warpcontact.physics.geometry import Grid, Sphere
from warpcontact.kernels import normal as nk
from warpcontact.kernels import spectral
from warpcontact.kernels import tangential as tk
from warpcontact.numerics.launch import LaunchCache, ReductionLaunch, Rows, Sums
from warpcontact.physics.materials import PAPER_PAIR
from warpcontact.numerics.model import ContactModel
from warpcontact.solvers import NormalSolver
from warpcontact.studies.slip_search import estimate_delta_x_max
from warpcontact.solvers.contact import ContactSolver
from warpcontact.numerics.state import ContactState

R = 10e-6
DELTA_Z = 1.0e-10
A = math.sqrt(R * DELTA_Z)


def _cache(workers):
    """A CPU launch cache of ``workers`` threads that splits every launch with Rows arguments."""
    cache = LaunchCache(wp.get_device("cpu"), workers=workers)
    cache.min_split_entries = 0
    return cache


@pytest.mark.parametrize("workers", [2, 3])
def test_split_reduction_equals_the_whole_launch(workers):
    """normal_step_sums and normal_update over a (37, 29) grid, rows split over 2 and 3 threads
    (37 rows: parts of unequal size; parts after the first run copies of the kernel compiled in
    modules of their own, ``launch.part_kernel``), against the same launches whole: the fields
    written equal bit for bit, the sums (added onto values already there, as the solver's are)
    within the rounding of summing in another order (1e-13 relative; the sums are of order
    1e2-1e3)."""
    rng = np.random.default_rng(3)
    ny, nx = 37, 29
    n = ny * nx
    data = [rng.random(n) - 0.3 for _ in range(4)]
    padded_data = rng.random((ny, 2 * nx))
    results = []
    for cache in (_cache(1), _cache(workers)):
        g, t, p, b = (wp.array(a, dtype=wp.float64, device="cpu") for a in data)
        padded = wp.array(padded_data, dtype=wp.float64, device="cpu")
        # slots 0-4 of the update's sums give its step: tau = g.t / t.Kt = 4 / 5
        initial = np.arange(nk.N_SUMS, dtype=np.float64) + 1.0
        step_sums, update_sums = (wp.array(initial, dtype=wp.float64, device="cpu") for _ in range(2))
        settings = wp.zeros(nk.N_PARAMETERS, dtype=wp.float64, device="cpu")
        shape = ReductionLaunch.for_cells(n, cache.device)
        output = [Rows(padded), wp.float64(0.5), nx]
        # no cap, passed as the solver passes it (finite: the kernels take their 0 as cap - cap)
        cap = wp.float64(np.finfo(np.float64).max)
        cache.launch_reduce(nk.normal_step_sums, shape, n, [Rows(g), Rows(t), *output], [Sums(step_sums)],
                            rows=(ny, nx))
        cache.launch_reduce(nk.normal_update, shape, n, [Rows(t), *output, Rows(b), cap, settings],
                            [Rows(p), Rows(g), Sums(update_sums)], rows=(ny, nx))
        results.append((p.numpy(), g.numpy(), step_sums.numpy(), update_sums.numpy()))
        if cache.workers > 1:
            assert len(cache._splits) == 2  # both launches ran split
    (p1, g1, *sums1), (p2, g2, *sums2) = results
    assert all(np.isfinite(a).all() for a in (p1, g1, *sums1))
    assert np.array_equal(p1, p2) and np.array_equal(g1, g2)
    assert not np.array_equal(g1, data[0])  # the update moved the gap
    for s1, s2 in zip(sums1, sums2):
        assert not np.array_equal(s1, initial)  # the launches added something
        np.testing.assert_allclose(s2, s1, rtol=1e-13, atol=0)


def test_split_rows_of_a_stack_and_of_a_spectrum():
    """The spectral product (one row of the spectrum per thread) split by rows of the influence
    stack (axis 1) and of the spectrum equals the whole launch bit for bit."""
    rng = np.random.default_rng(5)
    rows, cols = 22, 13
    influence = rng.random((6, rows, cols))
    spectrum = rng.random((rows, cols, 2))
    out = []
    for cache in (_cache(1), _cache(2)):
        inf = wp.array(influence, dtype=wp.float64, device="cpu")
        spec = wp.array(spectrum, dtype=wp.vec2d, device="cpu")
        cache.launch_rows(spectral.spectral_normal, (rows, cols), [Rows(inf, axis=1), Rows(spec)])
        out.append(spec.numpy())
    assert np.array_equal(out[0], out[1])
    assert not np.array_equal(out[0], spectrum)


@pytest.mark.parametrize("workers", [2, 3])
def test_split_cells_equal_the_whole_launch(workers):
    """An elementwise kernel of one thread per cell (the tangential direction: stick, slip and
    out-of-contact cells, a non-zero conjugation factor) split by rows of a (23, 17) grid equals
    the whole launch bit for bit."""
    rng = np.random.default_rng(11)
    ny, nx = 23, 17
    n = ny * nx
    fields = [rng.standard_normal(n) for _ in range(6)]  # grad x/y, shear x/y, old direction x/y
    limit = rng.random(n) + 0.5
    status = rng.integers(0, 3, n).astype(np.int32)  # OUT, STICK, SLIP
    sums = np.arange(tk.N_SUMS, dtype=np.float64) + 1.0
    scalars = np.arange(tk.N_SCALARS, dtype=np.float64) + 1.0
    out = []
    for cache in (_cache(1), _cache(workers)):
        gx, gy, qx, qy, tx, ty = (wp.array(a, dtype=wp.float64, device="cpu") for a in fields)
        inputs = [Rows(gx), Rows(gy), Rows(qx), Rows(qy), Rows(wp.array(limit, dtype=wp.float64, device="cpu")),
                  Rows(wp.array(status, dtype=wp.int32, device="cpu")), wp.float64(2.0),
                  wp.array(sums, dtype=wp.float64, device="cpu"), wp.array(scalars, dtype=wp.float64, device="cpu")]
        cache.launch_cells(tk.tangential_direction, (ny, nx), inputs, [Rows(tx), Rows(ty)])
        out.append((tx.numpy(), ty.numpy()))
        if cache.workers > 1:
            assert len(cache._splits) == 1
    assert np.array_equal(out[0][0], out[1][0]) and np.array_equal(out[0][1], out[1][1])
    assert not np.array_equal(out[0][0], fields[4])


def test_small_launches_run_whole():
    """Under ``min_split_entries`` a launch is not split (no plan recorded)."""
    cache = LaunchCache(wp.get_device("cpu"), workers=2)
    field = wp.zeros(64, dtype=wp.float64, device="cpu")
    sums = wp.zeros(nk.N_SUMS, dtype=wp.float64, device="cpu")
    shape = ReductionLaunch.for_cells(64, cache.device)
    cache.launch_reduce(nk.count_positive, shape, 64, [Rows(field)], [Sums(sums)], rows=(8, 8))
    assert len(cache._splits) == 0


def test_rows_must_hold_the_entries():
    cache = _cache(2)
    field = wp.zeros(64, dtype=wp.float64, device="cpu")
    sums = wp.zeros(nk.N_SUMS, dtype=wp.float64, device="cpu")
    with pytest.raises(ValueError, match="do not hold"):
        cache.launch_reduce(nk.count_positive, ReductionLaunch.for_cells(64, cache.device), 64, [Rows(field)],
                            [Sums(sums)], rows=(8, 7))


def _threaded_model(n, workers):
    model = ContactModel(PAPER_PAIR, Sphere(R, "paraboloid"), Grid(n, 4 * A), device="cpu")
    for cache in (model.launches, model.operator.launches):
        cache.workers = workers
        cache.min_split_entries = 0
    return model


def test_solves_on_two_threads_equal_one():
    """A Hertz solve and a coupled load step (normal and tangential CG, Tabor + von Mises) with
    their passes split over two threads against one thread, n = 64. The block sums add in another
    order, which moves the iterates by rounding only. The Hertz pressures agree to 1e-9 of their
    peak (the solve's tolerance is 1e-10 on the residual) in iteration counts within 2. The step
    ends its turns once the tractions change by less than ``outer_tol`` (1e-8, relative 2-norm)
    from one turn to the next, so two runs may end that far apart and more, by the contraction's
    factor: 10 outer_tol bounds it (measured 2.8e-9 of the peak shear)."""
    out = []
    for workers in (1, 2):
        model = _threaded_model(64, workers)
        state = ContactState(model)
        info = NormalSolver(model).solve(state, DELTA_Z)
        hertz_pressure = state.to_numpy_si()["pressure"]
        law = TaborVonMises(0.8, PAPER_PAIR.softer.yield_strength)
        solver = ContactSolver(model, law)
        step = solver.step(state, (0.5 * estimate_delta_x_max(PAPER_PAIR, R, DELTA_Z, law), 0.0, DELTA_Z))
        out.append((info, hertz_pressure, step, state.to_numpy_si(), solver.outer_tol))
        if workers == 2:
            assert len(model.launches._splits) >= 5 and len(model.operator.launches._splits) >= 2
    (i1, h1, s1, f1, outer_tol), (i2, h2, s2, f2, _) = out
    assert i1.converged and i2.converged and abs(i1.iterations - i2.iterations) <= 2
    assert np.abs(h2 - h1).max() < 1e-9 * h1.max()
    assert s1.converged and s2.converged
    for name in ("pressure", "shear_x"):
        norm = np.linalg.norm(f1[name])
        assert norm > 0 and np.linalg.norm(f2[name] - f1[name]) < 10 * outer_tol * norm, name


def _counted_splits(monkeypatch):
    """Count the split launches planned from now on (``LaunchCache._split_plan``), by kernel."""
    planned = []
    plan = LaunchCache._split_plan

    def counted(self, kernel, *args, **kwargs):
        planned.append(kernel.key)
        return plan(self, kernel, *args, **kwargs)

    monkeypatch.setattr(LaunchCache, "_split_plan", counted)
    return planned


def test_batched_launches_split_over_the_cases_equal_one_thread(monkeypatch):
    """A batch of three cases with friction (a dissimilar pair's coupled turns, Coulomb on another
    pair, the hardness cap) solved with its elementwise and reducing launches split over the
    cases on two threads, against one thread: each case's sums are one thread's sweep over its
    cells either way, so every state's forces and areas are the same to the last bit."""
    import warpcontact as wc
    from test_solve_batch_friction import MIXED

    out = []
    for threads in (1, 2):
        monkeypatch.setattr(LaunchCache, "threads", threads)
        monkeypatch.setattr(LaunchCache, "min_split_entries", 0)
        planned = _counted_splits(monkeypatch)
        results = wc.solve_batch(MIXED[:4], batch=4)
        assert all(not isinstance(r, Exception) and r.converged for r in results)
        out.append([[(s["force"], s["contact_area"], s["stick_area"]) for s in r.states] for r in results])
        if threads == 2:  # the batched solvers' kernels were split (their names start batch_)
            assert {"batch_tangential_carried_update", "batch_update"} <= set(planned)
    assert out[0] == out[1]


def test_a_launch_with_an_array_of_another_length_runs_whole(monkeypatch):
    """A batched launch given an array whose first axis is not the cases' (here one row longer)
    runs whole: its kernel would index that array by case in a part's own numbering. The same
    launch with an array of a row a case is split, and counts each case's cells."""
    from warpcontact.kernels import normal_batch as bk
    from warpcontact.numerics.launch import BatchLaunches

    monkeypatch.setattr(LaunchCache, "min_split_entries", 0)
    planned = _counted_splits(monkeypatch)
    launches = BatchLaunches(4, 16, wp.get_device("cpu"))
    launches.cache.workers = 2
    values = wp.array(np.arange(64, dtype=np.float64).reshape(4, 16) - 20.0, dtype=wp.float64, device="cpu")
    sums = wp.zeros((4, 8), dtype=wp.float64, device="cpu")
    longer = wp.zeros((5, 8), dtype=wp.float64, device="cpu")
    launches.reduce(bk.batch_count_positive, [values], [longer])
    assert planned == []
    launches.reduce(bk.batch_count_positive, [values], [sums])
    assert planned == ["batch_count_positive"]
    assert np.array_equal(sums.numpy()[:, bk.G_POSITIVE], (values.numpy() > 0).sum(axis=1))
    assert np.array_equal(longer.numpy()[:4], sums.numpy())


def test_the_stress_spectra_split_from_fewer_entries_by_their_work(monkeypatch):
    """A yield check's stress spectra (31 complex numbers read and 6 written an entry) are split
    over two threads from ``min_split_entries`` / ``STRESS_SPECTRA_WORK`` entries: at n = 128
    (33,024 entries, a pressure and a shear along x) they are, where a pass of one field in and
    one out would not be, and the largest von Mises stresses equal one thread's to the last bit
    (each entry is one thread's sum either way)."""
    from warpcontact.numerics.stress import STRESS_SPECTRA_WORK, SubsurfaceStress

    n = 128
    assert LaunchCache.min_split_entries / STRESS_SPECTRA_WORK <= 2 * n * (n + 1) < LaunchCache.min_split_entries
    grid = Grid(n, 4 * A)
    x = (np.arange(n) - n / 2 + 0.5) * grid.dx
    r2 = x[:, None] ** 2 + x[None, :] ** 2
    pressure = 1e9 * np.sqrt(np.clip(1 - r2 / (A * A), 0, None))
    shear = 0.3 * pressure
    out = []
    for workers in (1, 2):
        planned = _counted_splits(monkeypatch)
        stress = SubsurfaceStress(PAPER_PAIR, grid, [0.5 * A], device="cpu")
        stress.launches.workers = workers
        out.append(stress.von_mises_maxima(pressure, shear, None, [0.5 * A]))
        assert ("stress_spectra" in planned) == (workers == 2)
    for body in out[0]:
        assert np.array_equal(out[0][body], out[1][body])


def test_anderson_mixing_split_over_two_threads_equals_one(monkeypatch):
    """The adhesive turns' Anderson mixing (``AndersonMixing``: its residual and history pass, the
    Gram matrix's dot products, the update) split by rows over two threads, against one thread,
    on a contracting linear map of three fields: the split passes are each a part of the cells
    (the history columns cut with them, ``FlatRows``) and their sums are merged, so the iterates
    agree to the merged sums' rounding as the least-squares solve carries it: 2.8e-14 of their
    size after three steps (two history columns; 1e-12 allowed). Later steps amplify it with the
    Gram matrix's condition (8e-10 after six, its columns nearly parallel near the fixed point),
    as the GPU's other order of sums does."""
    from warpcontact.solvers.fixed_point import AndersonMixing

    n = 48
    rng = np.random.default_rng(3)
    offsets = [rng.normal(size=(n, n)) for _ in range(3)]

    def image(fields):  # G(x) = b + 0.6 x + 0.2 (x's neighbour along the rows) of the next field
        return [b + 0.6 * x + 0.2 * np.roll(fields[(k + 1) % 3], 1, axis=1)
                for k, (b, x) in enumerate(zip(offsets, fields))]

    out = []
    for threads in (1, 2):
        monkeypatch.setattr(LaunchCache, "threads", threads)
        monkeypatch.setattr(LaunchCache, "min_split_entries", 0)
        planned = _counted_splits(monkeypatch)
        model = ContactModel(PAPER_PAIR, Sphere(R), Grid(n, 4 * A), device="cpu")
        mixing = AndersonMixing(model, 3)
        x = [model.field() for _ in range(3)]
        for _ in range(3):
            for r, g in zip(mixing.residual, image([a.numpy() for a in x])):
                r.assign(g.ravel())
            mixing.step([a.flatten() for a in x])
        out.append(np.stack([a.numpy() for a in x]))
        if threads == 2:
            assert {"anderson_residual", "sums_of_products", "anderson_update"} <= set(planned)
    assert np.abs(out[1] - out[0]).max() <= 1e-12 * np.abs(out[0]).max()


def test_window_transfers_split_over_two_threads(monkeypatch):
    """A window's crop from the whole grid and its embedding back (``Windows.transfer``, a row a
    thread on the CPU) split by the window's rows over two threads: each part takes its rows of
    the window at the whole grid's rows from the window's origin plus the part's first row
    (``FirstRow``), so the copies are exact."""
    from types import SimpleNamespace

    from warpcontact.kernels import grids as gk
    from warpcontact.solvers.tangential import Windows

    monkeypatch.setattr(LaunchCache, "threads", 2)
    monkeypatch.setattr(LaunchCache, "min_split_entries", 0)
    planned = _counted_splits(monkeypatch)
    n, cells, row0, col0 = 40, 24, 9, 5
    whole = ContactModel(PAPER_PAIR, Sphere(R), Grid(n, 4 * A), device="cpu")
    window = SimpleNamespace(solver=SimpleNamespace(model=whole.window_model(cells)), row0=row0, col0=col0)
    values = np.random.default_rng(5).normal(size=(n, n))
    full, part = whole.field(values), window.solver.model.field()
    Windows.transfer(window, gk.crop, [(full, part)])
    assert np.array_equal(part.numpy(), values[row0:row0 + cells, col0:col0 + cells])
    back = whole.field()
    Windows.transfer(window, gk.embed, [(part, back)])
    expected = np.zeros((n, n))
    expected[row0:row0 + cells, col0:col0 + cells] = values[row0:row0 + cells, col0:col0 + cells]
    assert np.array_equal(back.numpy(), expected)
    assert planned.count("crop") == 1 and planned.count("embed") == 1

"""The normal solve on a window of the grid (``SolverSettings.window``): the window holds the
contact and the cells the approach closes, the answer is judged on the whole grid, and a contact
that grows past the window is finished there."""

import math

import numpy as np

from warpcontact.numerics.model import ContactModel
from warpcontact.numerics.state import ContactState
from warpcontact.physics.geometry import Grid, Sphere
from warpcontact.physics.materials import PAPER_PAIR
from warpcontact.solvers import normal as normal_module
from warpcontact.solvers.normal import NormalSolver

R, DZ = 10e-6, 1.5e-10
N = 128
#: a domain of 5 final Hertz radii: the contact is under half the grid wide, so it has a window
SIZE = 5 * math.sqrt(R * DZ)
APPROACHES = [DZ * k / 4 for k in range(1, 5)]


def path(window, device, approaches=APPROACHES):
    model = ContactModel(PAPER_PAIR, Sphere(R), Grid(N, SIZE), device=device)
    solver = NormalSolver(model, window=window)
    state = ContactState(model)
    infos, windows = [], []
    for dz in approaches:
        infos.append(solver.solve(state, dz))
        windows.append(solver.last_window)
    return state.to_numpy_si(), infos, windows, solver


def test_a_path_on_windows_is_the_path_on_the_whole_grid(device):
    """Frictionless loading from rest in four steps (the contact radius grows by 2x): every solve
    runs on a window (the first from rest too: the rigid interference's box holds the contact),
    smaller than the grid, and meets the tolerance on the whole grid. Pressure and gap agree with
    the whole grid's path within 1e-8 of their largest: both solves stop at a relative residual
    of 1e-10 of the gap's misfit, and a pressure error is that misfit times K's inverse, whose
    conditioning on a contact some 60 cells wide is of order 100 (measured 3e-9 for the pressure,
    2e-11 for the gap). The contact cells are the same, and the warm-started steps on windows take
    at most 3 iterations more than on the whole grid: the problem is the same, and the window's
    preconditioner (its own circulant) is no worse a one (measured 16, 17, 14 on the window
    against 16, 19, 18 with T. Chan's circulants, 18, 19, 14 against 17, 19, 14 padded)."""
    whole, infos_whole, windows_whole, _ = path(False, device)
    on, infos_on, windows_on, _ = path(True, device)
    assert windows_whole == [None] * 4
    assert all(w is not None and w < N for w in windows_on), windows_on
    assert all(i.converged for i in infos_on + infos_whole)
    for key in ("pressure", "gap"):
        scale = np.abs(whole[key]).max()
        assert np.abs(on[key] - whole[key]).max() < 1e-8 * scale, (key, np.abs(on[key] - whole[key]).max() / scale)
    assert np.array_equal(on["pressure"] > 0, whole["pressure"] > 0)
    for a, b in zip(infos_on[1:], infos_whole[1:]):
        assert a.iterations <= b.iterations + 3, ([i.iterations for i in infos_on], [i.iterations for i in infos_whole])


def test_a_contact_grown_past_its_window_is_finished_on_the_whole_grid(device, monkeypatch, small_normal_windows):
    """The window chosen as if the approach were a sixth of the step's (so the contact outgrows
    it): the solve on the window holds the pressure at zero outside, the whole grid's residual
    misses the tolerance there, and the whole grid's solve goes on from the window's pressure to
    the same answer as the whole grid alone (within 1e-8 of the largest pressure, as above), with
    pressure on cells outside the window."""
    chosen = small_normal_windows
    on, infos, _, _ = path(True, device, [DZ])
    monkeypatch.undo()
    whole, _, _, _ = path(False, device, [DZ])
    (row0, col0, cells), = chosen
    outside = np.ones((N, N), dtype=bool)
    outside[row0:row0 + cells, col0:col0 + cells] = False
    assert (on["pressure"][outside] > 0).any(), "the contact did not outgrow the window"
    assert infos[0].converged
    scale = np.abs(whole["pressure"]).max()
    assert np.abs(on["pressure"] - whole["pressure"]).max() < 1e-8 * scale


def test_no_window_where_it_would_cover_most_of_the_grid(device):
    """A contact whose window would be over WINDOW_MAX_SHARE of the grid per side is solved on
    the whole grid (the domain of 2.2 contact radii: the contact and its closing cells span most
    of it)."""
    model = ContactModel(PAPER_PAIR, Sphere(R), Grid(64, 2.2 * math.sqrt(R * DZ)), device=device)
    solver = NormalSolver(model, window=True)
    state = ContactState(model)
    assert solver.solve(state, DZ).converged
    assert solver.last_window is None


def test_auto_takes_the_normal_windows_own_threshold(monkeypatch):
    """``window = "auto"``: the normal solves on windows from ``NORMAL_WINDOW_AUTO_N`` cells per
    side on (by device kind), the tangential solves from ``WINDOW_AUTO_N``, each measured to pay
    from there; true and false force both."""
    from warpcontact.solvers import tangential as tangential_module
    from warpcontact.solvers.tangential import TangentialSolver

    model = ContactModel(PAPER_PAIR, Sphere(R), Grid(64, SIZE))
    for normal_from, tangential_from in ((64, 128), (128, 64)):
        monkeypatch.setattr(normal_module, "NORMAL_WINDOW_AUTO_N", {"cpu": normal_from, "cuda": normal_from})
        monkeypatch.setattr(tangential_module, "WINDOW_AUTO_N", {"cpu": tangential_from, "cuda": tangential_from})
        assert NormalSolver(model).uses_window == (normal_from <= 64)
        assert TangentialSolver(model).uses_window == (tangential_from <= 64)
    for forced in (True, False):
        assert NormalSolver(model, window=forced).uses_window is forced
        assert TangentialSolver(model, window=forced).uses_window is forced

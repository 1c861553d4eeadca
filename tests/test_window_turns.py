"""The window turns of a coupled step (``SolverSettings.window_turns``): with the pressure solved
on windows, the turns after the first solve it on the first turn's window alone (the shear's
K_zt q made there) and the step judges it on the whole grid once, at its end. The answer is the
answer of turns judged one by one; a contact that grows past the window during the turns is
found by that judgement and the turns go again, judged.

The problem of ``test_nested_start.py`` (copper on steel, R = 10 um, Tabor k_tau = 0.8; a load
step, a tangential step, a second tangential step) on 96 cells with windows forced (the domain of
5 contact radii: the contact's window is under the grid), a few seconds on 2 CPU cores.
"""

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

R, DZ, DX = 10e-6, 1.0e-10, 2.0e-11
STEPS = [(0.0, 0.0, DZ), (DX, 0.0, DZ), (2 * DX, 0.0, DZ)]
N = 96


def run(window_turns, device, steps=STEPS):
    """The steps' states (SI), infos, and the normal solves judged on the whole grid per step."""
    model = ContactModel(PAPER_PAIR, Sphere(R), Grid(N, 5 * math.sqrt(R * DZ)), device=device)
    solver = ContactSolver(model, TaborVonMises(0.8, PAPER_PAIR.softer.yield_strength), window=True,
                           window_turns=window_turns)
    state = ContactState(model)
    judged = []
    whole = NormalSolver._solve_whole

    def counted(self, *args, **kw):
        judged[-1] += self.model is model  # (a window's own solver solves its grid whole too)
        return whole(self, *args, **kw)

    NormalSolver._solve_whole = counted
    try:
        infos = []
        for approach in steps:
            judged.append(0)
            infos.append(solver.step(state, approach))
    finally:
        NormalSolver._solve_whole = whole
    return state.to_numpy_si(), infos, judged, np.array(state.status.numpy())


def test_window_turns_give_the_answer_of_turns_judged_one_by_one(device):
    """The same state within 1e-7 of each traction's largest value (the turns of either stop at
    a relative change of 1e-8 = 100 x the inner tolerance: two converged answers differ by that
    order; measured 2e-10 on Figure 2c's path at n = 256), the same stick, slip and contact cells,
    every step converged; a step of window turns judges its pressure on the whole grid twice
    (its first turn and its end), turns judged one by one once a turn and once more at the end."""
    (judged_state, judged_infos, judged_counts, judged_status) = run(False, device)
    (state, infos, counts, status) = run(True, device)
    assert all(i.converged for i in infos + judged_infos)
    for name in ("pressure", "shear_x", "shear_y", "gap"):
        scale = np.abs(judged_state[name]).max()
        assert np.abs(state[name] - judged_state[name]).max() < 1e-7 * scale, name
    assert np.array_equal(status, judged_status)
    assert counts == [2] * len(STEPS), counts
    assert judged_counts == [i.outer_iterations + 1 for i in judged_infos], (judged_counts, judged_infos)


def test_a_contact_grown_past_the_turns_window_is_turned_again_judged(device, monkeypatch, small_normal_windows):
    """The window placed as if the approach were a sixth of the step's, with no margin: the first
    turn's judgement on the whole grid finishes the pressure past the window, the window turns
    then hold it at zero there, the step's judgement moves it back, and the turns go again, each
    judged: the answer is that of turns judged one by one (within 1e-7 of the largest traction,
    as above), with pressure outside the window."""
    chosen = small_normal_windows
    state, infos, counts, status = run(True, device, STEPS[:1])
    monkeypatch.undo()
    judged_state, _, _, judged_status = run(False, device, STEPS[:1])
    row0, col0, cells = chosen[0]
    outside = np.ones((N, N), dtype=bool)
    outside[row0:row0 + cells, col0:col0 + cells] = False
    assert (state["pressure"][outside] > 0).any(), "the contact did not outgrow the window"
    assert infos[0].converged and counts[0] > 2, counts  # the turns went again, judged
    for name in ("pressure", "shear_x", "shear_y"):
        scale = np.abs(judged_state[name]).max()
        assert np.abs(state[name] - judged_state[name]).max() < 1e-7 * scale, name
    assert np.array_equal(status, judged_status)


def test_window_turns_are_a_setting():
    """On by default; a bool (anything else is refused, naming it)."""
    from warpcontact.solvers.settings import SolverSettings

    assert SolverSettings().window_turns is True
    with pytest.raises(ValueError, match="window_turns"):
        SolverSettings(window_turns="yes")

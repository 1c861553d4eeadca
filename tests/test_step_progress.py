"""Progress inside a long step: the solver's per-turn callback, the turn on the
progress line, and a contact far past the domain's edge stopped at the first turn of a step.

The case is the AFM tip of tests/test_first_hour.py (Si3N4 on Si: dissimilar, so the normal and tangential problems
are coupled and every step turns), on n = 32 cells; the domains that cut the contact are made
directly (``ContactModel``), since a case's own check refuses a domain under the Hertz contact
diameter before any solve.
"""

from __future__ import annotations

import io
import math

import numpy as np
import pytest
from test_first_hour import afm_dict

import warpcontact.solvers.turns as turns_module
from warpcontact.records.case import case_from_dict
from warpcontact.errors import InputError
from warpcontact.physics.geometry import Grid
from warpcontact.records.guards import EDGE_SHARE_AT_FIRST_TURN
from warpcontact.numerics.model import ContactModel
from warpcontact.records.progress import Progress
from warpcontact.solvers.turns import MinimisedTurns
from warpcontact.studies.runner import build, run_path


class Terminal(io.StringIO):
    """A stream that says it is a terminal."""

    def isatty(self):
        return True


def afm_case(n=32, adhesion=False):
    return case_from_dict(afm_dict(n=n, adhesion=adhesion))


def built(case, size=None, **choices):
    """(model, solver, state) of ``case``, on a domain of side ``size`` [m] if given, with the
    solver settings ``choices``."""
    model = None if size is None else ContactModel(case.pair, case.sphere, Grid(case.grid.n, size))
    return build(case, model, **choices)


def edge_share(state) -> float:
    p = state.pressure.numpy()
    return float(np.mean(np.concatenate([p[0], p[-1], p[:, 0], p[:, -1]]) > 0))


@pytest.mark.parametrize("adhesion", [False, True], ids=["lagged turns", "minimised turns"])
def test_on_turn_counts_every_turn_of_a_step_with_its_change(adhesion):
    """on_turn(turn, change) after every turn: turns 1, 2, ... up to the step's turn count, each
    change finite, and the last one under outer_tol (it is the number the turns stop on)."""
    case = afm_case(adhesion=adhesion)
    _, solver, state = built(case, turns="minimised")  # with adhesion (the law is on the DMT side: lagged by default)
    assert solver.coupled
    seen = []
    solver.on_turn = lambda turn, change: seen[-1].append((turn, change))
    for approach in case.load.path()[:3]:  # two normal steps and the first tangential one
        seen.append([])
        info = solver.step(state, approach)
        assert info.converged, info
        turns = [t for t, _ in seen[-1]]
        assert turns == list(range(1, info.outer_iterations + 1)), (turns, info.outer_iterations)
        assert len(turns) >= 2  # a coupled step turns: a test of one call would test little
        changes = [c for _, c in seen[-1]]
        assert all(math.isfinite(c) and c >= 0.0 for c in changes), changes
        assert changes[-1] < solver.outer_tol, (changes[-1], solver.outer_tol)


def test_without_a_callback_the_step_is_the_same():
    """on_turn = None (the default of a ContactSolver) changes nothing: the same turns and the
    same pressure to the last bit as with a callback."""
    case = afm_case()
    results = []
    for callback in (None, lambda turn, change: None):
        _, solver, state = built(case)
        solver.on_turn = callback
        infos = [solver.step(state, approach) for approach in case.load.path()[:3]]
        results.append(([i.outer_iterations for i in infos], state.pressure.numpy().copy()))
    assert results[0][0] == results[1][0]
    assert np.array_equal(results[0][1], results[1][1])


@pytest.mark.filterwarnings("ignore::UserWarning")  # the coarse n = 32 grid and the yield warning: not judged here
def test_progress_line_shows_the_turn_while_a_step_runs():
    """On a terminal the line is redrawn with ``turn K, change X`` during each step of a path
    (runner.build wires the solver to the bar open now); the turns shown count up within a step."""
    case = afm_case()
    term = Terminal()
    bar = Progress("solve", total=len(case.load.path()), stream=term)
    bar.turn_redraw_s = 0.0  # every turn (the default throttle would skip the fast turns of n = 32)
    try:
        result = run_path(case, fields="none",
                          on_state=lambda k, total, s, r: bar.update(k + 1, s["iterations"], s["residual"]))
    finally:
        bar.close()
    assert result.converged
    redraws = term.getvalue().split("\r")
    turns = [r for r in redraws if "turn " in r]
    # each state's turns, and its bar drawn after them: a turn shown with the states finished before
    assert len(turns) == sum(s["outer_iterations"] for s in result.states), turns[:3]
    assert turns[0].startswith("solve [") and " 0/4  " in turns[0] and "  turn 1, change " in turns[0], turns[0]
    first_step = [int(r.split("turn ")[1].split(",")[0]) for r in turns if " 0/4  " in r]
    assert first_step == list(range(1, result.states[0]["outer_iterations"] + 1))
    assert any(" 3/4  " in r and "turn 1, change " in r for r in turns)  # the last (tangential) step too


def test_turns_on_a_log_only_once_a_step_has_run_long():
    """In a log (not a terminal) a turn gets a whole line only once TURN_LOG_S has passed since the
    last line: none in a fast run; with the interval at 0 one per turn, each a whole line."""
    for interval, expect_turns in ((None, False), (0.0, True)):
        log = io.StringIO()
        bar = Progress("gross-slip", stream=log)
        if interval is not None:
            bar.turn_log_s = interval
        bar.update(2, 10, 1e-9)
        bar.turn(7, 3.1e-5)
        bar.close()
        lines = log.getvalue().splitlines()
        assert "\r" not in log.getvalue()
        assert (len(lines) == 2 and lines[1].startswith("gross-slip 2/?  turn 7, change 3.1e-05  0:00 elapsed")
                ) if expect_turns else len(lines) == 1, lines


def test_turns_are_throttled_and_quiet_is_quiet():
    term = Terminal()
    bar = Progress("pull-off", total=5, stream=term)  # the default throttle: TURN_REDRAW_S
    bar.update(1)
    bar.turn(1, 0.5)  # right after a redraw: skipped
    assert "turn" not in term.getvalue()
    bar.shown_at -= bar.turn_redraw_s
    bar.turn(2, 0.25)
    assert "] 1/5  turn 2, change 2.5e-01  0:00" in term.getvalue().split("\r")[-1]  # (cut at the width)
    bar.close()
    quiet = Terminal()
    bar = Progress("solve", total=2, stream=quiet, quiet=True)
    bar.turn_redraw_s = 0.0
    bar.turn(1, 0.5)
    bar.close()
    assert quiet.getvalue() == ""


def test_no_bar_open_no_output(capsys):
    """The Python API (no bar open): the wired callback writes nothing."""
    buf = io.StringIO()
    bar = Progress("solve", total=1, stream=buf)
    bar.turn_redraw_s = bar.turn_log_s = 0.0
    bar.close()  # closed: no longer the open bar
    case = afm_case()
    _, solver, state = built(case)
    solver.step(state, case.load.path()[0])
    assert buf.getvalue() == "" and capsys.readouterr().err == ""


def count_turn_solves(solver, adhesion):
    """Wrap the normal solve each turn makes once (the adhesive one in the minimised turns); returns
    the list whose length counts them."""
    calls = []
    name = "_adhesive_normal" if adhesion else "solve"
    owner = next(s for s in solver.strategies if isinstance(s, MinimisedTurns)) if adhesion else solver.normal
    inner = getattr(owner, name)

    def counted(*a, **kw):
        calls.append(1)
        return inner(*a, **kw)

    setattr(owner, name, counted)
    return calls


@pytest.mark.parametrize("adhesion", [False, True], ids=["lagged turns", "minimised turns"])
def test_contact_far_past_the_edge_stops_at_the_first_turn(adhesion, monkeypatch):
    """A domain of 1.6e-9 m against a Hertz contact diameter of 2.8e-9 m: the first step's first
    turn already covers more than EDGE_SHARE_AT_FIRST_TURN of the edge, and the step stops there
    with the grid.size error made after a step. Without the first-turn check the same step makes
    13 turns (8 with adhesion) and its final solve before the same error (the control below), so
    one turn is the check's doing."""
    case = afm_case(adhesion=adhesion)
    _, solver, state = built(case, size=1.6e-9, turns="minimised")  # with adhesion (lagged by default: DMT side)
    calls = count_turn_solves(solver, adhesion)
    approach = case.load.path()[0]
    with pytest.raises(InputError) as e:
        solver.step(state, approach)
    assert len(calls) == 1, len(calls)
    assert edge_share(state) > EDGE_SHARE_AT_FIRST_TURN
    assert e.value.key == "grid.size"
    assert "the contact reaches the edge of the 1.6e-09 m domain at delta = (0, 0, 5e-11) m" in str(e.value)
    assert "\n" not in str(e.value)

    # the control: the check after the step only
    monkeypatch.setattr(turns_module, "check_contact_fits", lambda *a, **k: None)  # (the turns' check: at the first turn)
    _, solver, state = built(case, size=1.6e-9, turns="minimised")
    calls = count_turn_solves(solver, adhesion)
    with pytest.raises(InputError) as late:
        solver.step(state, approach)
    assert len(calls) > 2, len(calls)
    assert str(late.value) == str(e.value)


def test_a_contact_that_only_touches_the_edge_at_the_first_turn_is_judged_at_the_step_end():
    """The first turn solves loosely against the last state's shear, and its contact can pass the
    converged one's: at n = 64 on a 2.875e-9 m domain the second normal step's first turn puts
    cells of the edge in contact and its converged state none. The step must not stop there: it
    converges, as it did before the first-turn check."""
    case = afm_case(n=64)
    _, solver, state = built(case, size=2.875e-9)
    solver.step(state, case.load.path()[0])
    shares = []
    solver.on_turn = lambda turn, change: shares.append(edge_share(state)) if turn == 1 else None
    info = solver.step(state, case.load.path()[1])
    assert info.converged
    assert 0.0 < shares[0] <= EDGE_SHARE_AT_FIRST_TURN, shares
    assert edge_share(state) == 0.0

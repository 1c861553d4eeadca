"""The lagged turns' stall: where the plain turns stop converging, the shear is mixed by
Anderson's method, and the mixed turns end on the same state as the plain ones.

Near the von Mises crossover (p -> S_Y) the shear limit k_VM sqrt(S_Y^2 - p^2) has an unbounded
slope: on Figure 2a's pair at 4 times its approach, n = 1024 on a GPU, a few cells on the ring
where p passes S_Y held the plain turns in a cycle of 4 turns for the whole limit of 1000 turns
(their change 7.0e-5 to 7.6e-5, the state not converged); with the mixing from the stall on
(``LocalAndersonMixing``), every state of the path converges at n = 1024-4096
(``bench/path_parts.py --path hardness``; docs/performance.md).
"""

from pathlib import Path

import pytest

import warpcontact as wc
from warpcontact.records.case import tomllib
from warpcontact.records.guards import YieldWarning
from warpcontact.solvers import turns
from warpcontact.solvers.turns import STALL_TURNS, LaggedTurns, stalled

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def test_a_cycle_is_a_stall_and_a_linear_decrease_is_not():
    cycle = [7.02e-5, 7.61e-5, 6.99e-5, 7.38e-5] * 5
    assert stalled(cycle)
    linear = [0.7**k for k in range(STALL_TURNS + 10)]  # halves in 2 turns: converging
    assert not stalled(linear)
    slow = [0.95**k for k in range(STALL_TURNS + 10)]  # 0.60 in 10 turns: not halved, a stall
    assert stalled(slow)
    assert not stalled(cycle[: STALL_TURNS + 3])  # too few turns to judge


def heavy_path(n: int) -> dict:
    """Figure 2a's path at 4 times its approach and shift on twice its domain: the pressure
    passes S_Y in the middle of the contact."""
    with open(EXAMPLES / "figure2a.toml", "rb") as f:
        case = tomllib.load(f)
    case["load"]["delta_z"] *= 4.0
    case["load"]["delta_x"] *= 4.0
    case["grid"]["size"] *= 2.0
    case["grid"]["n"] = n
    case["solver"]["device"] = "cpu"
    return case


@pytest.fixture(scope="module")
def plain_and_mixed():
    case = heavy_path(64)
    with pytest.warns(YieldWarning):  # p passes S_Y: the point of this path
        plain = wc.solve(case, fields="last")
    mixed_turns = []
    original = LaggedTurns._mixed_change

    def counted(self, state, mixing):
        mixed_turns.append(1)
        return original(self, state, mixing)

    with pytest.MonkeyPatch.context() as mp:  # the mixing from the third turn of every step on
        mp.setattr(turns, "stalled", lambda changes: len(changes) >= 3)
        mp.setattr(LaggedTurns, "_mixed_change", counted)
        with pytest.warns(YieldWarning):
            mixed = wc.solve(case, fields="last")
    assert len(mixed_turns) >= len(mixed.states), "the mixing was not used"
    return plain, mixed


def test_mixed_turns_end_on_the_plain_turns_state(plain_and_mixed):
    """Every state converges both ways, to the same forces within 1e-6 relative (the turns stop
    at a relative change of 1e-8 and the solves at 1e-10: the two iterates agree far closer
    than 1e-6 unless the mixing ended somewhere else) and the same stick area within one cell."""
    plain, mixed = plain_and_mixed
    cell = plain.model.grid.cell_area
    for k, (a, b) in enumerate(zip(plain.states, mixed.states)):
        assert a["converged"] and b["converged"], f"state {k}: plain {a['converged']}, mixed {b['converged']}"
        for axis in ("x", "z"):
            fa, fb = a["force"][axis], b["force"][axis]
            assert fb == pytest.approx(fa, rel=1e-6), f"state {k}: F_{axis} {fb} mixed against {fa} plain"
        assert abs(b["stick_area"] - a["stick_area"]) <= 1.01 * cell, f"state {k}: stick areas differ"


def test_a_stall_the_plain_turns_do_not_leave_is_left_by_the_mixing():
    """The stall on a grid CI can afford. Its gain grows with k_VM (the limit's slope near S_Y is
    k_VM p / sqrt(S_Y^2 - p^2)) as with refinement (about sqrt(n): the cells next to the crossover
    come closer to S_Y), so Figure 2a's heavy path with the hardness cap and k_VM = 2.3 (four
    times von Mises's 1/sqrt(3)) stalls at n = 128 as the shipped k_VM does from about n = 1024:
    its first tangential state takes the plain turns past 300 turns unconverged (4,242 inner
    iterations, measured on 2 CPU cores). There the stall is detected and the mixed turns
    converge within the 300 (68 turns, 726 inner iterations, measured; the count follows the
    turns' rounding: 129 turns and 1,303 inner iterations with earlier code)."""
    case = heavy_path(128)
    case["friction"].update(hardness_cap=True, k_vm=2.3)
    dz, dx = case["load"]["delta_z"], case["load"]["delta_x"]
    case["load"] = {"path": [[0.0, 0.0, dz * k / 8] for k in range(1, 9)] + [[dx / 8, 0.0, dz]]}
    case["solver"]["max_turns"] = 300
    mixed_turns = []
    original = LaggedTurns._mixed_change

    def counted(self, state, mixing):
        mixed_turns.append(1)
        return original(self, state, mixing)

    with pytest.MonkeyPatch.context() as mp, pytest.warns(YieldWarning):
        mp.setattr(LaggedTurns, "_mixed_change", counted)
        result = wc.solve(case, fields="none")
    last = result.states[-1]
    assert mixed_turns, "no stall was detected"
    assert last["converged"] and last["outer_iterations"] <= 300, (last["outer_iterations"], last["iterations"])
    assert all(s["converged"] for s in result.states)

"""The solvers' settings (warpcontact.solvers.settings) and the strategies a step runs
(warpcontact.solvers.turns): one frozen, checked settings object given at construction and shared
by every solver of a step; the order of strategies by the physics and the settings."""

from __future__ import annotations

import dataclasses
import math

import pytest

from warpcontact.numerics.model import ContactModel
from warpcontact.physics.adhesion import SMC
from warpcontact.physics.friction import TaborVonMises
from warpcontact.physics.geometry import Grid, Sphere
from warpcontact.physics.materials import PAPER_PAIR
from warpcontact.solvers.contact import ContactSolver
from warpcontact.solvers.normal import NormalSolver
from warpcontact.solvers.settings import SolverSettings
from warpcontact.solvers.tangential import TangentialSolver
from warpcontact.solvers.turns import AdhesiveSolve, LaggedTurns, MinimisedTurns, NestedStart

R, DZ = 10e-6, 1e-10
LAW = TaborVonMises(0.8, PAPER_PAIR.softer.yield_strength)


def model(n: int = 32) -> ContactModel:
    return ContactModel(PAPER_PAIR, Sphere(R), Grid(n, 4 * math.sqrt(R * DZ)))


@pytest.mark.parametrize("name, value", [
    ("tol", 0.0), ("tol", 1.5), ("outer_tol", -1e-8), ("max_iter", -1), ("max_iter", 2.5), ("max_turns", 0),
    ("exact_every", 0), ("iterations_per_launch", True), ("deferral", 1.5), ("relax", 0.0),
    ("normal_preconditioner", "yes"), ("fourier_step_sums", 1), ("turn_tolerance", "loose"), ("turns", "mixed"),
    ("nested", "sometimes"), ("window", 1), ("use_graphs", "auto"), ("response_float32", "sometimes"),
])
def test_a_bad_value_is_refused_naming_its_setting(name, value):
    with pytest.raises(ValueError, match=rf"^settings\.{name}: "):
        SolverSettings(**{name: value})


def test_an_unknown_name_is_refused_with_the_closest_one():
    with pytest.raises(TypeError, match=r"'turn_tol' is not a solver setting \(did you mean 'turn_tolerance'\?\)"):
        ContactSolver(model(), LAW, turn_tol="exact")
    with pytest.raises(TypeError, match="settings must be a SolverSettings"):
        SolverSettings.of({"tol": 1e-8})


def test_settings_are_frozen_and_shared_by_every_solver_of_a_step():
    """Given at construction, read by the inner solvers; a choice cannot change afterwards (the
    captured graphs are built from it): a new solver takes other settings."""
    settings = SolverSettings(tol=1e-9, window=False, turn_tolerance="exact", max_iter=300)
    solver = ContactSolver(model(), LAW, settings=settings)
    assert solver.settings is settings and solver.normal.settings is settings and solver.tangential.settings is settings
    assert solver.tol == solver.normal.tol == solver.tangential.tol == 1e-9
    assert solver.outer_tol == pytest.approx(1e-7)  # 100 tol by default
    assert solver.normal.max_iter == 300 and not solver.tangential.uses_window
    with pytest.raises(dataclasses.FrozenInstanceError):
        settings.window = True
    other = ContactSolver(model(), LAW, settings=settings, window=True)  # choices by name on top of settings
    assert other.settings.window is True and other.settings.tol == 1e-9 and settings.window is False


def test_defaults_by_float_type_and_device():
    m32 = ContactModel(PAPER_PAIR, Sphere(R), Grid(32, 4 * math.sqrt(R * DZ)), dtype="float32")
    assert NormalSolver(m32).tol == 1e-5 and NormalSolver(model()).tol == 1e-10
    cpu = NormalSolver(model())
    assert cpu.fourier_step_sums is False and cpu.use_graphs is False  # the CPU's choices
    assert TangentialSolver(model(), window=True).uses_window


def test_the_strategies_of_a_step_by_the_physics_and_the_settings():
    """Adhesion alone: the minimisation, then the lagged turns (a law with a fixed point). With
    friction: the DMT side's lagged turns first, the minimised ones as their fallback, and the other
    way round towards JKR, or as asked (``turns``); a hardness cap: the lagged turns alone (the
    minimisation does not know it). Friction without adhesion: the lagged turns, wrapped by the
    nested start where it is asked for."""
    dmt, towards_jkr = SMC(1e6, 1e6, 5e-12, 5e-12), SMC(2e8, 2e8, 2.5e-14, 2.5e-14)

    def kinds(solver):
        return [type(s) for s in solver.strategies]

    assert kinds(ContactSolver(model(), None, dmt)) == [AdhesiveSolve, LaggedTurns]
    assert kinds(ContactSolver(model(), LAW, dmt)) == [LaggedTurns, MinimisedTurns]
    assert kinds(ContactSolver(model(), LAW, towards_jkr)) == [MinimisedTurns, LaggedTurns]
    assert kinds(ContactSolver(model(), LAW, dmt, turns="minimised")) == [MinimisedTurns, LaggedTurns]
    assert kinds(ContactSolver(model(), LAW, towards_jkr, pressure_cap=1e9)) == [LaggedTurns]
    assert kinds(ContactSolver(model(), LAW)) == [LaggedTurns]  # n = 32: the nested start's "auto" is off
    nested = ContactSolver(model(128), LAW, nested=True)
    assert kinds(nested) == [NestedStart] and isinstance(nested.strategies[0].inner, LaggedTurns)


def test_the_nested_start_solves_its_coarse_grid_with_the_same_settings_but_its_tolerance():
    """The coarse grid's solver takes the fine one's settings, its tolerance no finer than
    NESTED_COARSE_TOL, and is nested itself."""
    from warpcontact.numerics.state import ContactState
    from warpcontact.solvers.turns import NESTED_COARSE_TOL

    solver = ContactSolver(model(128), LAW, nested=True, window=False, turn_tolerance="exact")
    state = ContactState(solver.model)
    info = solver.step(state, (0.0, 0.0, DZ))
    assert info.converged and solver.nested_iterations > 0
    coarse, _ = solver.strategies[0]._coarse
    assert coarse.model.grid.n == 64 and coarse.tol == max(solver.tol, NESTED_COARSE_TOL)
    assert coarse.settings.window is False and coarse.settings.turn_tolerance == "exact" and coarse.settings.nested

"""The solvers capture a CUDA graph of an iteration only after every conditional part of it (the
loop body, the prelude, the refresh) has run eagerly once: a generic kernel's overload made for
the first time inside a capture is a module load there, which fails the capture (seen on an H100:
a float32 tangential solve that starts at its solution runs zero iterations, so its body's
kernels were first launched inside the capture; CUDA error 901). The capture itself needs a GPU;
here the bookkeeping that decides it is checked on the CPU, and _launch with a stand-in capture."""

import math
from types import SimpleNamespace

import warp as wp

from warpcontact.physics.friction import Coulomb
from warpcontact.physics.geometry import Grid, Sphere
from warpcontact.physics.materials import COPPER, MaterialPair
from warpcontact.numerics.launch import CapturedGraphs
from warpcontact.numerics.model import ContactModel
from warpcontact.solvers.base import ProjectedCG
from warpcontact.solvers.contact import ContactSolver
from warpcontact.numerics.state import ContactState

R, DZ = 10e-6, 1e-10


def ran_eagerly(tangential) -> set:
    """The parts that ran eagerly in the tangential solver and in its windows' solvers (where its
    solves run: ``SolverSettings.window``)."""
    solvers = [tangential, *(w.solver for w in tangential._windows.kept())]
    return {getattr(c, "co_name", c) for s in solvers for c in s._ran_eagerly}


def test_a_solve_of_zero_iterations_leaves_its_body_unmarked():
    # like materials: no coupling, so the normal approach leaves the shear at zero (its solution)
    model = ContactModel(MaterialPair(COPPER, COPPER), Sphere(R), Grid(32, 4 * math.sqrt(R * DZ)))
    solver = ContactSolver(model, Coulomb(0.3))
    tangential = solver.tangential
    state = ContactState(model)
    solver.step(state, (0.0, 0.0, DZ))  # no tangential load: the shear solve starts at its solution
    codes = ran_eagerly(tangential)
    assert "body" not in codes, codes  # the loop body has not run: no capture may be made yet
    solver.step(state, (2e-11, 0.0, DZ))  # partial slip: the shear iterates
    codes = ran_eagerly(tangential)
    assert "body" in codes, codes


def test_launch_captures_only_once_every_part_ran(monkeypatch):
    captures = []

    class FakeCapture:  # stands for wp.ScopedCapture: records, runs nothing
        def __init__(self, **kwargs):
            self.graph = object()

        def __enter__(self):
            captures.append(self)
            return self

        def __exit__(self, *exc):
            return False

    monkeypatch.setattr(wp, "ScopedCapture", FakeCapture)
    solver = SimpleNamespace(graphs=CapturedGraphs("cuda:0", True, "solver", max_graphs=4), _ran_eagerly=set())
    runs = []
    ProjectedCG._launch(solver, "k", lambda: runs.append(1), needs=("body",))
    assert len(runs) == 1 and not captures and "k" not in solver.graphs.graphs  # body never ran: eager only
    solver._ran_eagerly.add("body")
    ProjectedCG._launch(solver, "k", lambda: runs.append(1), needs=("body",))
    assert len(captures) == 1 and "k" in solver.graphs.graphs


def test_a_failed_capture_leaves_the_solve_to_eager_launches(monkeypatch):
    """A capture that fails (CUDA error 901 from its first operation) after the work ran eagerly:
    the solve goes on with its result, the solver launches eagerly from then on (no graph kept,
    ``capture_failure`` says why) and warns once. A Hertz solve made so on the CPU (its launches
    are the same kernels either way) equals the plain solve to the last bit."""
    import numpy as np
    import pytest

    from warpcontact.solvers.normal import NormalSolver

    class FailingCapture:  # stands for wp.ScopedCapture: the capture is invalid from its start
        def __init__(self, **kwargs):
            self.graph = None

        def __enter__(self):
            raise RuntimeError("Warp CUDA error 901: operation failed due to a previous error during capture")

        def __exit__(self, *exc):
            return False

    model = ContactModel(MaterialPair(COPPER, COPPER), Sphere(R), Grid(32, 4 * math.sqrt(R * DZ)))
    plain_state = ContactState(model)
    plain = NormalSolver(model).solve(plain_state, DZ)
    solver = NormalSolver(model)
    solver.use_graphs = True  # as on CUDA; every part marked as run, so the first launch captures
    monkeypatch.setattr(ProjectedCG, "_run", _run_marking_everything(ProjectedCG._run))
    monkeypatch.setattr(wp, "ScopedCapture", FailingCapture)
    state = ContactState(model)
    with pytest.warns(RuntimeWarning, match="graph capture failed") as seen:
        info = solver.solve(state, DZ)
    assert len(seen) == 1
    assert not solver.use_graphs and not solver.graphs.graphs and "901" in solver.capture_failure
    assert info.converged and info.iterations == plain.iterations
    np.testing.assert_array_equal(state.pressure.numpy(), plain_state.pressure.numpy())


def _run_marking_everything(run):
    """ProjectedCG._run with every part of the iteration counted as run before (so that the first
    launch tries a capture at once)."""

    def marked(self, key, start, exact, body, *args, **kwargs):
        self._ran_eagerly.add(getattr(body, "__code__", body))
        return run(self, key, start, exact, body, *args, **kwargs)

    return marked

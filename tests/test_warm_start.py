"""Warm-started normal solves along a load path: the iterations stay bounded as the grid is refined.

A step of a path starts from the last state's pressure. Where the approach grows, a band of cells
around the old contact penetrates and must enter it. The preconditioned solve steps those cells
with the free set (their step -tau M g, ``kernels/normal.py``, ``conjugate_direction``). Polonsky
and Keer's re-entry p = -tau g, at the preconditioned step length (about 1), entered a band w cells
wide at about w times its pressure: the paper's Figure 2c pair, frictionless, delta_z in three
steps, took up to 42 iterations a step at n = 256, 92 at 384 and 95 at 512 (2 CPU cores; on an
H100 such solves diverged at n = 2048), against 15-23 at every n from 128 to 1024 now.
"""

import math

import numpy as np
import pytest

from warpcontact.numerics.model import ContactModel
from warpcontact.numerics.state import ContactState
from warpcontact.physics.geometry import Grid, Sphere
from warpcontact.physics.materials import PAPER_PAIR
from warpcontact.solvers.normal import NormalSolver
from warpcontact.physics.reference import hertz

R, DZ = 10e-6, 1.5e-10
#: the domain of examples/figure2c.toml: 3.52 Hertz radii at the last step
SIZE = 3.52 * math.sqrt(R * DZ)
STEPS = 3


def warm_path(n, device):
    """Iterations of each normal step (frictionless, DZ in STEPS steps) and the last state."""
    model = ContactModel(PAPER_PAIR, Sphere(R), Grid(n, SIZE), device=device)
    solver = NormalSolver(model)
    state = ContactState(model)
    infos = [solver.solve(state, DZ * k / STEPS) for k in range(1, STEPS + 1)]
    return infos, model, state


@pytest.fixture(scope="module")
def paths():
    return {n: warm_path(n, "cpu") for n in (128, 384)}


def test_warm_started_steps_do_not_grow_with_the_grid(paths):
    """Every step converges; the warm-started ones (all but the first, from rest) take at most 30
    iterations and at most 8 more at n = 384 than at 128 (measured 15-17 and 20; with the re-entry
    p = -tau g, 54 at 384: the band of entering cells is three times as many cells wide there)."""
    for n, (infos, _, _) in paths.items():
        assert all(i.converged for i in infos), f"n = {n}: a step did not converge"
    coarse = max(i.iterations for i in paths[128][0][1:])
    fine = [i.iterations for i in paths[384][0][1:]]
    assert max(fine) <= 30, f"warm-started steps at n = 384 took {fine} iterations (at most 30 expected)"
    assert max(fine) <= coarse + 8, f"warm-started steps took {fine} at n = 384 against at most {coarse} at 128"


def test_warm_started_path_ends_on_hertz(paths):
    """The last state of the warm-started path is the Hertz contact: the force within 2 % (the
    grid's discretisation at n = 384 on 3.52 contact radii; the solve itself to 1e-10)."""
    infos, model, state = paths[384]
    force = float(np.sum(state.to_numpy_si()["pressure"])) * model.grid.cell_area
    expected = hertz(PAPER_PAIR, R, DZ)["force"]
    assert force == pytest.approx(expected, rel=0.02), f"F_z {force:.4e} N against Hertz {expected:.4e} N"

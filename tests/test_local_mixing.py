"""Anderson mixing with each cell's own coefficients (``LocalAndersonMixing``) against one set for
the whole field, on a fixed point whose unstable modes are many small clusters far apart.

The map: on a 32 x 32 field of two components, 25 pairs of neighbouring cells, 6 cells apart,
each a rotation with its own gain mu in 2-6 (x_a <- b_a + mu x_b, x_b <- b_b - mu x_a: the lagged
turns' cycle of two cells at the von Mises crossover, docs/model.md "The turns' stall"), every
other cell contracting by 0.5 (x) or 0.3 (y). The plain iteration diverges (|eigenvalues| = mu);
one set of Anderson coefficients (depth 5) cannot cancel 25 distinct rotations and diverges too;
the local coefficients solve each pair on its own patch.
"""

import numpy as np
import pytest

from warpcontact.numerics.model import ContactModel
from warpcontact.physics.geometry import Grid, Sphere
from warpcontact.physics.materials import PAPER_PAIR
from warpcontact.solvers.fixed_point import AndersonMixing, LocalAndersonMixing

N = 32
TURNS = 40


def rotation_clusters():
    rng = np.random.default_rng(1)
    bx, by = rng.normal(size=(N, N)), rng.normal(size=(N, N))
    pairs = [(r, c) for r in range(2, N - 2, 6) for c in range(2, N - 3, 6)]
    gains = rng.uniform(2.0, 6.0, len(pairs))

    def image(x, y):
        gx, gy = bx + 0.5 * x, by + 0.3 * y
        for (r, c), mu in zip(pairs, gains):
            gx[r, c] = bx[r, c] + mu * x[r, c + 1]
            gx[r, c + 1] = bx[r, c + 1] - mu * x[r, c]
        return gx, gy

    fixed_x, fixed_y = bx / 0.5, by / 0.7
    for (r, c), mu in zip(pairs, gains):
        fixed_x[r, c], fixed_x[r, c + 1] = np.linalg.solve([[1.0, -mu], [mu, 1.0]], [bx[r, c], bx[r, c + 1]])
    return image, fixed_x, fixed_y


def mixed_error(mixing, model, image, fixed_x, fixed_y) -> float:
    """The largest distance from the fixed point after TURNS mixed turns from zero."""
    x = [model.field(), model.field()]
    for _ in range(TURNS):
        gx, gy = image(x[0].numpy(), x[1].numpy())
        mixing.residual[0].assign(gx.ravel().astype(model.np_dtype))
        mixing.residual[1].assign(gy.ravel().astype(model.np_dtype))
        mixing.step([a.flatten() for a in x])
    return max(np.abs(x[0].numpy() - fixed_x).max(), np.abs(x[1].numpy() - fixed_y).max())


def test_local_coefficients_solve_many_rotations_one_set_does_not(device):
    model = ContactModel(PAPER_PAIR, Sphere(1e-6), Grid(N, 1e-7), device=device)
    image, fixed_x, fixed_y = rotation_clusters()
    scale = max(np.abs(fixed_x).max(), np.abs(fixed_y).max())  # about 5
    # 40 turns reach 6e-11 (float64 on the CPU); 1e-8 of the fixed point's size leaves room for
    # the GPU's other order of sums
    local = mixed_error(LocalAndersonMixing(model), model, image, fixed_x, fixed_y)
    assert local < 1e-8 * scale
    # the same turns with one set of coefficients end farther away than they started
    whole = mixed_error(AndersonMixing(model, 2, beta=1.0, depth=5), model, image, fixed_x, fixed_y)
    assert whole > scale


@pytest.mark.parametrize("dtype, bound", [("float64", 1e-8), ("float32", 1e-4)])
def test_local_mixing_at_the_scale_of_shears(device, dtype, bound):
    """The same map scaled by 1e-3 (shears in units of E* are 1e-3 to 1e-2): the Gram entries of
    a cell's patch are then 1e-12 and smaller, whose determinant underflows float32 unless the
    kernel scales them (it gave NaN). Bounds: 1e-8 of the fixed point in float64 (7e-12
    measured); in float32 the mixing ends at rounding's floor and wanders there (the history's
    differences are then rounding noise: 2.2e-6 measured on the CPU, 1.4e-5 on an H200), so the
    bound is what the float32 turns need: an order under their tolerance on the change, 1e-3
    (100 x the float32 solves' 1e-5)."""
    model = ContactModel(PAPER_PAIR, Sphere(1e-6), Grid(N, 1e-7), device=device, dtype=dtype)
    image, fixed_x, fixed_y = rotation_clusters()
    k = 1e-3

    def scaled(x, y):
        return tuple(k * a for a in image(x / k, y / k))

    error = mixed_error(LocalAndersonMixing(model), model, scaled, k * fixed_x, k * fixed_y)
    assert error < bound * k * max(np.abs(fixed_x).max(), np.abs(fixed_y).max())


def test_local_mixing_needs_beta_one():
    model = ContactModel(PAPER_PAIR, Sphere(1e-6), Grid(8, 1e-7), device="cpu")
    with pytest.raises(ValueError, match="beta"):
        LocalAndersonMixing(model).step([model.field().flatten(), model.field().flatten()], beta=0.5)

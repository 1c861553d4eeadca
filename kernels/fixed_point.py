"""Anderson mixing of a fixed point x = G(x) (Walker & Ni 2011), one vector component at a time.

The vector is split into components (the adhesive pressure and shears), each a flat field; the
history of the last ``depth`` differences of residuals (dF) and iterates (dX) of a component is a
(depth, n) array. Per turn: ``anderson_residual`` turns G into f = G - x, writes the new history
column and sums the norms and the dot products that the host's small least-squares problem needs;
``anderson_update`` applies x <- x + beta f - sum_j gamma_j (dX_j + beta dF_j).
"""

from typing import Any

import warp as wp

from .overloads import register_float_overloads
from .reduce import Cells, block_add, cell_index

# no adjoints: nothing differentiates these kernels, and compiling them doubles the build
wp.set_module_options({"enable_backward": False})

# slots of the sums: then GRAM_SLOTS + j: dF_new . dF_j, then GRAM_SLOTS + depth + j: dF_j . f
S_RESIDUAL = wp.constant(0)  # |f|^2
S_IMAGE = wp.constant(1)  # |G(x)|^2
GRAM_SLOTS = 2


@wp.kernel
def anderson_residual(
    iterate: wp.array(dtype=Any),
    column: int,
    has_previous: int,
    depth: int,
    cells: Cells,
    residual: wp.array(dtype=Any),
    previous_residual: wp.array(dtype=Any),
    previous_iterate: wp.array(dtype=Any),
    residual_diff: wp.array2d(dtype=Any),
    iterate_diff: wp.array2d(dtype=Any),
    sums: wp.array(dtype=Any),
):
    """``residual`` holds G(x) on entry and f = G(x) - x on exit. With ``has_previous`` the
    history column ``column`` gets dF = f - f_prev, dX = x - x_prev (then its dot products with
    every column and with f are summed). f_prev, x_prev <- f, x."""
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = iterate[0] - iterate[0]
    s_res = zero
    s_img = zero
    for k in range(cells.per):
        i = cell_index(thread, cells, k)
        if i < cells.n:
            g = residual[i]
            x = iterate[i]
            f = g - x
            residual[i] = f
            s_res += f * f
            s_img += g * g
            if has_previous != 0:
                residual_diff[column, i] = f - previous_residual[i]
                iterate_diff[column, i] = x - previous_iterate[i]
            previous_residual[i] = f
            previous_iterate[i] = x
    block_add(sums, S_RESIDUAL, s_res)
    block_add(sums, S_IMAGE, s_img)


@wp.kernel
def anderson_update(
    residual: wp.array(dtype=Any),
    residual_diff: wp.array2d(dtype=Any),
    iterate_diff: wp.array2d(dtype=Any),
    gamma: wp.array(dtype=Any),
    depth: int,
    beta: Any,
    iterate: wp.array(dtype=Any),
):
    """x <- x + beta f - sum_j gamma_j (dX_j + beta dF_j) (gamma_j = 0 for unused columns)."""
    i = wp.tid()
    x = iterate[i] + beta * residual[i]
    for j in range(depth):
        x = x - gamma[j] * (iterate_diff[j, i] + beta * residual_diff[j, i])
    iterate[i] = x


for _k in (anderson_residual, anderson_update):
    register_float_overloads(_k)

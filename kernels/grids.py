"""Transfers between a grid and the grid of half its cells per side over the same domain
(cell (I, J) of the coarse grid covers cells (2I..2I+1, 2J..2J+1) of the fine one): the nested
start of a step (``ContactSolver.nested``)."""

from typing import Any

import warp as wp

from .overloads import register_float_overloads

wp.set_module_options({"enable_backward": False})


@wp.kernel
def restrict_mean(fine: wp.array2d(dtype=Any), scale: Any, coarse: wp.array2d(dtype=Any)):
    """coarse[I, J] <- scale x the mean of the four fine cells it covers (a traction: scale 1; a
    length in cells, slip: scale 1/2, the coarse cell being twice as wide)."""
    i, j = wp.tid()
    total = fine[2 * i, 2 * j] + fine[2 * i, 2 * j + 1] + fine[2 * i + 1, 2 * j] + fine[2 * i + 1, 2 * j + 1]
    coarse[i, j] = scale * total / type(scale)(4.0)


@wp.kernel
def restrict_status(fine: wp.array2d(dtype=wp.int32), coarse: wp.array2d(dtype=wp.int32)):
    """coarse[I, J] <- the largest status of the four fine cells (slip 2 over stick 1 over out of
    contact 0: a coarse cell slips where any of its cells slips)."""
    i, j = wp.tid()
    a = wp.max(fine[2 * i, 2 * j], fine[2 * i, 2 * j + 1])
    b = wp.max(fine[2 * i + 1, 2 * j], fine[2 * i + 1, 2 * j + 1])
    coarse[i, j] = wp.max(a, b)


@wp.kernel
def prolong_constant(coarse: wp.array2d(dtype=Any), fine: wp.array2d(dtype=Any)):
    """fine[i, j] <- coarse[i // 2, j // 2]: a traction or a status, constant over the coarse cell."""
    i, j = wp.tid()
    fine[i, j] = coarse[i // 2, j // 2]


for _k in (restrict_mean, prolong_constant):
    register_float_overloads(_k)
wp.overload(prolong_constant, {"coarse": wp.array2d(dtype=wp.int32), "fine": wp.array2d(dtype=wp.int32)})

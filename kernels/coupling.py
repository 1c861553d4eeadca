"""Bookkeeping of the coupled normal-tangential solution: stick targets, slip, changes."""

from typing import Any

import warp as wp

from .overloads import register_float_overloads
from .reduce import Cells, block_add, cell_index

# no adjoints: nothing differentiates these kernels, and compiling them doubles the build
wp.set_module_options({"enable_backward": False})


@wp.kernel
def stick_target(
    slip_x: wp.array(dtype=Any),
    slip_y: wp.array(dtype=Any),
    shift_x: Any,
    shift_y: Any,
    target_x: wp.array(dtype=Any),
    target_y: wp.array(dtype=Any),
):
    """target = delta - s_prev: the tangential displacement u_t that keeps a cell stuck."""
    i = wp.tid()
    target_x[i] = shift_x - slip_x[i]
    target_y[i] = shift_y - slip_y[i]


@wp.kernel
def accumulate_slip(
    disp_x: wp.array(dtype=Any),
    disp_y: wp.array(dtype=Any),
    known_x: wp.array(dtype=Any),
    known_y: wp.array(dtype=Any),
    shift_x: Any,
    shift_y: Any,
    slip_x: wp.array(dtype=Any),
    slip_y: wp.array(dtype=Any),
    total_x: wp.array(dtype=Any),
    total_y: wp.array(dtype=Any),
):
    """u_t = K_tt q + K_tp p and the slip s = delta - u_t of the sphere relative to the flat."""
    i = wp.tid()
    ux = disp_x[i] + known_x[i]
    uy = disp_y[i] + known_y[i]
    total_x[i] = ux
    total_y[i] = uy
    slip_x[i] = shift_x - ux
    slip_y[i] = shift_y - uy


# slots of the turns' ``change`` sums (``change_sums`` adds |current - previous|^2 at a slot and
# |current|^2 at the next): the pressure's pair, the shear's (x; the minimised turns add every
# shear component there) and the shear's y pair
CHANGE_PRESSURE = 0
CHANGE_SHEAR_X = 2
CHANGE_SHEAR_Y = 4
N_CHANGE_SUMS = 6


@wp.kernel
def change_sums(
    current: wp.array(dtype=Any),
    slot: int,
    cells: Cells,
    previous: wp.array(dtype=Any),
    sums: wp.array(dtype=Any),
):
    """sums[slot] += |current - previous|^2, sums[slot + 1] += |current|^2; previous <- current."""
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = current[0] - current[0]
    s_change = zero
    s_norm = zero
    for k in range(cells.per):
        i = cell_index(thread, cells, k)
        if i < cells.n:
            c = current[i]
            d = c - previous[i]
            s_change += d * d
            s_norm += c * c
            previous[i] = c
    block_add(sums, slot, s_change)
    block_add(sums, slot + 1, s_norm)


for _k in (stick_target, accumulate_slip, change_sums):
    register_float_overloads(_k)

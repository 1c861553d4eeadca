"""Bookkeeping of the coupled normal-tangential solution: stick targets, slip, changes."""

from typing import Any

import warp as wp

from .overloads import register_float_overloads
from .reduce import Cells, block_add, block_add_vector, cell_index

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


@wp.kernel
def batch_stick_target(slip_x: wp.array2d(dtype=Any), slip_y: wp.array2d(dtype=Any),
                       shifts: wp.array2d(dtype=Any), target_x: wp.array2d(dtype=Any),
                       target_y: wp.array2d(dtype=Any)):
    """``stick_target`` of B cases, each at its shifts (``shifts[case]``: delta_x, delta_y, scaled)."""
    case, i = wp.tid()
    target_x[case, i] = shifts[case, 0] - slip_x[case, i]
    target_y[case, i] = shifts[case, 1] - slip_y[case, i]


@wp.kernel
def batch_accumulate_slip(disp_x: wp.array2d(dtype=Any), disp_y: wp.array2d(dtype=Any),
                          shifts: wp.array2d(dtype=Any), slip_x: wp.array2d(dtype=Any),
                          slip_y: wp.array2d(dtype=Any)):
    """s = delta - u_t of B cases, ``disp`` holding each case's whole u_t (K_tt q + K_tp p)."""
    case, i = wp.tid()
    slip_x[case, i] = shifts[case, 0] - disp_x[case, i]
    slip_y[case, i] = shifts[case, 1] - disp_y[case, i]


@wp.kernel
def batch_change_sums(pressure: wp.array2d(dtype=Any), shear_x: wp.array2d(dtype=Any),
                      shear_y: wp.array2d(dtype=Any), cells: Cells, previous_p: wp.array2d(dtype=Any),
                      previous_x: wp.array2d(dtype=Any), previous_y: wp.array2d(dtype=Any),
                      sums: wp.array2d(dtype=Any)):
    """``change_sums`` of the pressure (slots CHANGE_PRESSURE, + 1) and the shear (both
    components at CHANGE_SHEAR_X, + 1) of B cases; the previous copies take the current fields."""
    case, block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = sums[case, 0] - sums[case, 0]
    change = wp.vector(zero, zero, zero, zero)
    for k in range(cells.per):
        i = cell_index(thread, cells, k)
        if i < cells.n:
            p = pressure[case, i]
            qx = shear_x[case, i]
            qy = shear_y[case, i]
            dp = p - previous_p[case, i]
            dx = qx - previous_x[case, i]
            dy = qy - previous_y[case, i]
            change += wp.vector(dp * dp, p * p, dx * dx + dy * dy, qx * qx + qy * qy)
            previous_p[case, i] = p
            previous_x[case, i] = qx
            previous_y[case, i] = qy
    block_add_vector(sums[case], 0, change, lane)  # slots CHANGE_PRESSURE, + 1, CHANGE_SHEAR_X, + 1


for _k in (stick_target, accumulate_slip, change_sums, batch_stick_target, batch_accumulate_slip, batch_change_sums):
    register_float_overloads(_k)

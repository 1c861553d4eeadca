"""The summary of one solved state, reduced on the device in one pass (``results.state_summary``).

``summary_sums`` reads the tractions, the gap and the cell status of every cell once and adds
to ``sums`` (slots below): the force sums, the cell counts of the contact, stick and adhesive
areas, the stick cells' centre offsets (their centroid), the largest contact pressure and the
largest adhesive tension. The host multiplies by the scales (E*, the cell area, the cell size)
and reads the whole array in one transfer per state. ``domain_edge`` gathers a field's edge
cells for the domain-edge checks (``guards``).

The sums are float64 for float32 and float64 fields alike: each value is converted exactly to
float64 before it is added, so a float32 state's sums carry the rounding of a float64 sum (about
n_cells x 1.1e-16 of the sum of magnitudes at worst), not of a float32 one (n_cells x 6e-8).
Counts and the centre offsets (half-integers) are whole multiples of 1/2 below 2^52: their sums
are exact in any order. ``sums`` is set before the launch: 0 in every slot, -inf in
S_MAX_PRESSURE and S_MAX_TENSION.
"""

from typing import Any

import warp as wp

from .reduce import Cells, block_add, block_add_vector, block_max, cell_index
from .tangential import STICK

# no adjoints: nothing differentiates these kernels, and compiling them doubles the build
wp.set_module_options({"enable_backward": False})

# slots of ``sums``, in units of the state's scaled fields (tractions / E*, lengths / dx) and cells
S_FORCE_Z = wp.constant(0)  # sum of p + p_adh: the normal force / (E* dA), adhesion included
S_FORCE_X = wp.constant(1)  # sum of q_x + q_adh,x
S_FORCE_Y = wp.constant(2)  # sum of q_y + q_adh,y
S_ELASTIC_Z = wp.constant(3)  # sum of p: the contact tractions alone
S_ELASTIC_X = wp.constant(4)  # sum of q_x
S_ELASTIC_Y = wp.constant(5)  # sum of q_y
S_CONTACT_CELLS = wp.constant(6)  # cells with p > 0 (A_c / dA)
S_STICK_CELLS = wp.constant(7)  # cells whose status is STICK (A_st / dA)
S_ADHESIVE_CELLS = wp.constant(8)  # cells with p <= 0 and the gap within the law's range (A_adh / dA)
S_STICK_X = wp.constant(9)  # sum over stick cells of the centre's x offset in cells, j - (n_x - 1) / 2
S_STICK_Y = wp.constant(10)  # sum over stick cells of the centre's y offset in cells, i - (n_y - 1) / 2
S_MAX_PRESSURE = wp.constant(11)  # the largest p (max, not a sum)
S_MAX_TENSION = wp.constant(12)  # the largest adhesive tension -p_adh (max, not a sum)
S_GAP = wp.constant(13)  # sum of the gap g (in cells): the mean separation of the surfaces x n_cells
N_SUMMARY = 14


@wp.func
def centre_offset(index: int, count: int, zero: Any):
    """The centre of cell ``index`` of ``count`` along an axis, in cells from the grid's centre:
    index - (count - 1) / 2 (``Grid.x`` before its multiplication by dx); a half-integer, exact."""
    return type(zero)(index) - type(zero)(0.5) * type(zero)(count - 1)


@wp.kernel
def summary_sums(
    pressure: wp.array(dtype=Any),
    adhesive_pressure: wp.array(dtype=Any),
    shear_x: wp.array(dtype=Any),
    adhesive_shear_x: wp.array(dtype=Any),
    shear_y: wp.array(dtype=Any),
    adhesive_shear_y: wp.array(dtype=Any),
    gap: wp.array(dtype=Any),
    status: wp.array(dtype=wp.int32),
    columns: int,
    rows: int,
    first_row: int,
    length_scale: wp.float64,
    adhesive_range: wp.float64,
    adhesive: int,
    cells: Cells,
    sums: wp.array(dtype=Any),
):
    """Adds one state's summary to ``sums`` (slots S_*). Fields flattened row-major from
    (rows, columns) grids, scaled (tractions / E*, gap / dx); ``first_row``: the grid row of entry
    0 (a part of a split CPU launch). A cell is adhesive (``adhesive`` = 1 only) where p <= 0 and
    the gap in metres, gap x ``length_scale`` (dx [m]) in float64, is at most ``adhesive_range``
    [m]: the same product and comparison as ``results.adhesive_mask`` on the SI fields."""
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = sums[0] - sums[0]
    one = type(zero)(1.0)
    force_z = zero
    force_x = zero
    force_y = zero
    elastic_z = zero
    elastic_x = zero
    elastic_y = zero
    contact_cells = zero
    stick_cells = zero
    adhesive_cells = zero
    stick_x = zero
    stick_y = zero
    gap_sum = zero
    largest = type(zero)(-wp.inf)
    largest_tension = type(zero)(-wp.inf)
    for k in range(cells.per):
        i = cell_index(thread, cells, k)
        if i < cells.n:
            p = type(zero)(pressure[i])
            qx = type(zero)(shear_x[i])
            qy = type(zero)(shear_y[i])
            force_z += p + type(zero)(adhesive_pressure[i])
            force_x += qx + type(zero)(adhesive_shear_x[i])
            force_y += qy + type(zero)(adhesive_shear_y[i])
            elastic_z += p
            elastic_x += qx
            elastic_y += qy
            gap_sum += type(zero)(gap[i])
            largest = wp.max(largest, p)
            largest_tension = wp.max(largest_tension, -type(zero)(adhesive_pressure[i]))
            if p > zero:
                contact_cells += one
            elif adhesive != 0 and p <= zero:
                if wp.float64(gap[i]) * length_scale <= adhesive_range:
                    adhesive_cells += one
            if status[i] == STICK:
                stick_cells += one
                stick_x += centre_offset(i % columns, columns, zero)
                stick_y += centre_offset(first_row + i // columns, rows, zero)
    block_add_vector(sums, S_FORCE_Z, wp.vector(force_z, force_x, force_y, elastic_z, elastic_x, elastic_y,
                                                contact_cells, stick_cells, adhesive_cells, stick_x, stick_y), lane)
    block_add(sums, S_GAP, gap_sum)
    block_max(sums, S_MAX_PRESSURE, largest, lane)
    block_max(sums, S_MAX_TENSION, largest_tension, lane)


@wp.kernel
def domain_edge(field: wp.array2d(dtype=Any), edge: wp.array(dtype=Any)):
    """``edge`` = the cells of ``field`` on the domain's edge, in the order of numpy's
    ``concatenate([f[0], f[-1], f[:, 0], f[:, -1]])`` (2 columns + 2 rows entries; the corners
    twice): what the domain-edge checks read, without the whole field leaving the device."""
    k = wp.tid()
    rows = field.shape[0]
    columns = field.shape[1]
    if k < columns:
        edge[k] = field[0, k]
    elif k < 2 * columns:
        edge[k] = field[rows - 1, k - columns]
    elif k < 2 * columns + rows:
        edge[k] = field[k - 2 * columns, 0]
    else:
        edge[k] = field[k - 2 * columns - rows, columns - 1]


for _fields in (wp.float32, wp.float64):
    wp.overload(summary_sums, {
        **{name: wp.array(dtype=_fields) for name in (
            "pressure", "adhesive_pressure", "shear_x", "adhesive_shear_x", "shear_y", "adhesive_shear_y", "gap")},
        "sums": wp.array(dtype=wp.float64),
    })
    wp.overload(domain_edge, {"field": wp.array2d(dtype=_fields), "edge": wp.array(dtype=_fields)})

"""The summary of one solved state, reduced on the device in one pass (``results.state_summary``).

``summary_sums`` reads the tractions, the gap and the cell status of every cell once and adds
to ``sums`` (slots below): the force sums, the cell counts of the contact, stick and adhesive
areas, the stick cells' centre offsets (their centroid), the contact cells on the domain's edge,
the largest contact pressure and the largest adhesive tension (one cell's terms:
``cell_summary``). The host multiplies by the scales (E*, the cell area, the cell size) and reads
the whole array in one transfer per state. ``batch_summary_sums`` does the same for every case
of a batch at once, one row of sums a case (``studies/batch_solve.py``). ``domain_edge`` gathers
a field's edge cells for the domain-edge checks (``guards``).

The sums are float64 for float32 and float64 fields alike: each value is converted exactly to
float64 before it is added, so a float32 state's sums carry the rounding of a float64 sum (about
n_cells x 1.1e-16 of the sum of magnitudes at worst), not of a float32 one (n_cells x 6e-8).
Counts and the centre offsets (half-integers) are whole multiples of 1/2 below 2^52: their sums
are exact in any order. ``sums`` is set before the launch: 0 in every slot, -inf in
S_MAX_PRESSURE and S_MAX_TENSION.
"""

from typing import Any

import warp as wp

from .reduce import Cells, block_add_vector, block_max, cell_index
from .tangential import OUT, STICK

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
S_GAP = wp.constant(11)  # sum of the gap g (in cells): the mean separation of the surfaces x n_cells
S_EDGE_CONTACT = wp.constant(12)  # cells with p > 0 on the domain's edge (``check_contact_fits``)
S_MAX_PRESSURE = wp.constant(13)  # the largest p (max, not a sum)
S_MAX_TENSION = wp.constant(14)  # the largest adhesive tension -p_adh (max, not a sum)
N_SUMMARY = 15

#: a cell's terms of the summed slots, S_FORCE_Z to S_EDGE_CONTACT in order (``cell_summary``)
summed = wp.types.vector(length=13, dtype=wp.float64)


@wp.func
def centre_offset(index: int, count: int, zero: Any):
    """The centre of cell ``index`` of ``count`` along an axis, in cells from the grid's centre:
    index - (count - 1) / 2 (``Grid.x`` before its multiplication by dx); a half-integer, exact."""
    return type(zero)(index) - type(zero)(0.5) * type(zero)(count - 1)


@wp.func
def cell_summary(p: wp.float64, adhesive_p: wp.float64, qx: wp.float64, adhesive_qx: wp.float64, qy: wp.float64,
                 adhesive_qy: wp.float64, gap: wp.float64, status: int, column: int, row: int, columns: int,
                 rows: int, length_scale: wp.float64, adhesive_range: wp.float64, adhesive: int):
    """The terms of one cell (``row``, ``column`` of a (rows, columns) grid) in the summed slots,
    S_FORCE_Z to S_EDGE_CONTACT in order (``summed``). A cell is adhesive (``adhesive`` = 1 only)
    where p <= 0 and the gap in metres, gap x ``length_scale`` (dx [m]), is at most
    ``adhesive_range`` [m]: the same product and comparison as ``results.adhesive_mask`` on the SI
    fields."""
    zero = wp.float64(0.0)
    one = wp.float64(1.0)
    contact = zero
    edge = zero
    adhesive_cell = zero
    stick = zero
    stick_x = zero
    stick_y = zero
    if p > zero:
        contact = one
        if row == 0 or row == rows - 1 or column == 0 or column == columns - 1:
            edge = one
    elif adhesive != 0 and p <= zero:
        if gap * length_scale <= adhesive_range:
            adhesive_cell = one
    if status == STICK:
        stick = one
        stick_x = centre_offset(column, columns, zero)
        stick_y = centre_offset(row, rows, zero)
    return summed(p + adhesive_p, qx + adhesive_qx, qy + adhesive_qy, p, qx, qy, contact, stick, adhesive_cell,
                  stick_x, stick_y, gap, edge)


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
    sums: wp.array(dtype=wp.float64),
):
    """Adds one state's summary to ``sums`` (slots S_*). Fields flattened row-major from
    (rows, columns) grids, scaled (tractions / E*, gap / dx); ``first_row``: the grid row of entry
    0 (a part of a split CPU launch); the adhesive cells as ``cell_summary``'s."""
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    terms = summed()
    largest = wp.float64(-wp.inf)
    largest_tension = wp.float64(-wp.inf)
    for k in range(cells.per):
        i = cell_index(thread, cells, k)
        if i < cells.n:
            p = wp.float64(pressure[i])
            adhesive_p = wp.float64(adhesive_pressure[i])
            terms += cell_summary(p, adhesive_p, wp.float64(shear_x[i]), wp.float64(adhesive_shear_x[i]),
                                  wp.float64(shear_y[i]), wp.float64(adhesive_shear_y[i]), wp.float64(gap[i]),
                                  status[i], i % columns, first_row + i // columns, columns, rows, length_scale,
                                  adhesive_range, adhesive)
            largest = wp.max(largest, p)
            largest_tension = wp.max(largest_tension, -adhesive_p)
    block_add_vector(sums, S_FORCE_Z, terms, lane)
    block_max(sums, S_MAX_PRESSURE, largest, lane)
    block_max(sums, S_MAX_TENSION, largest_tension, lane)


@wp.kernel
def batch_summary_sums(
    pressure: wp.array2d(dtype=Any),
    shear_x: wp.array2d(dtype=Any),
    shear_y: wp.array2d(dtype=Any),
    gap: wp.array2d(dtype=Any),
    status: wp.array2d(dtype=wp.int32),
    adhesive_pressure: wp.array2d(dtype=Any),
    adhesive_shear_x: wp.array2d(dtype=Any),
    adhesive_shear_y: wp.array2d(dtype=Any),
    length_scale: wp.array(dtype=wp.float64),
    adhesive_range: wp.array(dtype=wp.float64),
    friction: int,
    adhesion: int,
    columns: int,
    rows: int,
    cells: Cells,
    sums: wp.array2d(dtype=wp.float64),
):
    """Adds each case's summary to its row of ``sums`` (slots S_*): the fields of a batch, (B,
    cells) arrays of (rows, columns) grids flattened row-major; ``friction`` = 0: no shear and
    every cell's status OUT (``shear_*`` and ``status`` not read); ``adhesion`` = 0: no adhesive
    tractions (``adhesive_*``, ``length_scale`` and ``adhesive_range`` not read), else each case's
    adhesive cells as ``cell_summary``'s, with its cell size ``length_scale[case]`` [m] and its
    law's range ``adhesive_range[case]`` [m] (0: a case without adhesion). S_MAX_TENSION is left
    as it was set where there is no adhesion."""
    case, block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = wp.float64(0.0)
    terms = summed()
    largest = wp.float64(-wp.inf)
    largest_tension = wp.float64(-wp.inf)
    scale = wp.float64(1.0)
    reach = zero
    adhesive = int(0)
    if adhesion != 0:
        scale = length_scale[case]
        reach = adhesive_range[case]
        if reach > zero:
            adhesive = 1
    for k in range(cells.per):
        i = cell_index(thread, cells, k)
        if i < cells.n:
            p = wp.float64(pressure[case, i])
            qx = zero
            qy = zero
            adhesive_p = zero
            adhesive_qx = zero
            adhesive_qy = zero
            cell_status = int(OUT)
            if friction != 0:
                qx = wp.float64(shear_x[case, i])
                qy = wp.float64(shear_y[case, i])
                cell_status = status[case, i]
            if adhesive != 0:
                adhesive_p = wp.float64(adhesive_pressure[case, i])
                adhesive_qx = wp.float64(adhesive_shear_x[case, i])
                adhesive_qy = wp.float64(adhesive_shear_y[case, i])
            terms += cell_summary(p, adhesive_p, qx, adhesive_qx, qy, adhesive_qy, wp.float64(gap[case, i]),
                                  cell_status, i % columns, i // columns, columns, rows, scale, reach, adhesive)
            largest = wp.max(largest, p)
            largest_tension = wp.max(largest_tension, -adhesive_p)
    block_add_vector(sums[case], S_FORCE_Z, terms, lane)
    block_max(sums[case], S_MAX_PRESSURE, largest, lane)
    if adhesion != 0:
        block_max(sums[case], S_MAX_TENSION, largest_tension, lane)


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
    })
    wp.overload(batch_summary_sums, {name: wp.array2d(dtype=_fields) for name in (
        "pressure", "shear_x", "shear_y", "gap", "adhesive_pressure", "adhesive_shear_x", "adhesive_shear_y")})
    wp.overload(domain_edge, {"field": wp.array2d(dtype=_fields), "edge": wp.array(dtype=_fields)})

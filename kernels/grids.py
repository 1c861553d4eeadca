"""Transfers between grids: a grid and the grid of half its cells per side over the same domain
(cell (I, J) of the coarse grid covers cells (2I..2I+1, 2J..2J+1) of the fine one), for the nested
start of a step (``SolverSettings.nested``); a square window of a grid cut out and put back, for
the normal and tangential solves on the contact's cells (``SolverSettings.window``)."""

from typing import Any

import warp as wp

from .overloads import mixed_float_overloads, register_float_overloads

wp.set_module_options({"enable_backward": False})


@wp.kernel
def restrict_mean(fine: wp.array2d(dtype=Any), scale: Any, coarse: wp.array2d(dtype=Any)):
    """coarse[I, J] <- scale x the mean of the four fine cells it covers (a traction: scale 1; a
    length in cells, slip: scale 1/2, the coarse cell being twice as wide), in the coarse grid's
    float type (``scale``'s)."""
    i, j = wp.tid()
    total = fine[2 * i, 2 * j] + fine[2 * i, 2 * j + 1] + fine[2 * i + 1, 2 * j] + fine[2 * i + 1, 2 * j + 1]
    coarse[i, j] = scale * type(scale)(total) / type(scale)(4.0)


@wp.kernel
def restrict_mean_stack(fine: wp.array3d(dtype=Any), coarse: wp.array3d(dtype=Any)):
    """coarse[k, I, J] <- the mean of the four fine cells it covers, layer by layer (``restrict_mean``
    of a traction, for a stack of fields)."""
    k, i, j = wp.tid()
    total = fine[k, 2 * i, 2 * j] + fine[k, 2 * i, 2 * j + 1] + fine[k, 2 * i + 1, 2 * j] + fine[k, 2 * i + 1, 2 * j + 1]
    coarse[k, i, j] = total / type(total)(4.0)


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
    """fine[i, j] <- coarse[i // 2, j // 2]: a traction or a status, constant over the coarse cell,
    in the fine grid's type."""
    i, j = wp.tid()
    fine[i, j] = type(fine[i, j])(coarse[i // 2, j // 2])


for _k in (restrict_mean, prolong_constant):
    register_float_overloads(_k)
# a float64 grid's nested start on a float32 coarse grid (``SolverSettings.nested_float32``)
mixed_float_overloads(restrict_mean, ("scale", "coarse"))
mixed_float_overloads(prolong_constant, ("coarse",))
wp.overload(prolong_constant, {"coarse": wp.array2d(dtype=wp.int32), "fine": wp.array2d(dtype=wp.int32)})


# --- a square window of the grid (the tangential solve on the cells that can carry shear) ---


@wp.kernel
def crop(full: wp.array2d(dtype=Any), row0: int, col0: int, first: int, per: int, window: wp.array2d(dtype=Any)):
    """window[i, j] <- full[row0 + first + i, col0 + j], thread (i, c) the columns j from c per to
    (c + 1) per (``LaunchCache.launch_rows``; ``first``: the first row of a split CPU launch's
    part, whose ``window`` is its rows)."""
    i, c = wp.tid()
    for j in range(c * per, wp.min((c + 1) * per, window.shape[1])):
        window[i, j] = full[row0 + first + i, col0 + j]


@wp.kernel
def embed(window: wp.array2d(dtype=Any), row0: int, col0: int, first: int, per: int, full: wp.array2d(dtype=Any)):
    """full[row0 + first + i, col0 + j] <- window[i, j] (the cells outside the window are left as
    they are), launched as ``crop``."""
    i, c = wp.tid()
    for j in range(c * per, wp.min((c + 1) * per, window.shape[1])):
        full[row0 + first + i, col0 + j] = window[i, j]


#: rows of one column that a thread of ``support_box`` scans
SUPPORT_ROWS = wp.constant(64)


@wp.func
def add_to_box(first: int, last: int, column: int, box: wp.array(dtype=wp.int32)):
    """Widen ``box`` (first row, last row, first column, last column) to rows ``first`` ..
    ``last`` of ``column``; nothing where ``last`` < 0 (no cell)."""
    if last >= 0:
        wp.atomic_min(box, 0, first)
        wp.atomic_max(box, 1, last)
        wp.atomic_min(box, 2, column)
        wp.atomic_max(box, 3, column)


@wp.kernel
def support_box(field: wp.array2d(dtype=Any), box: wp.array(dtype=wp.int32)):
    """The bounding box of the cells where ``field`` > 0: box <- (first row, last row, first
    column, last column), from box = (n, -1, n, -1). A thread scans SUPPORT_ROWS rows of one
    column (neighbouring threads read neighbouring cells) and adds its bounds by atomics, once."""
    block, j = wp.tid()
    n = field.shape[0]
    zero = field[0, 0] - field[0, 0]
    first = n
    last = int(-1)
    start = block * SUPPORT_ROWS
    end = wp.min(start + SUPPORT_ROWS, n)
    for i in range(start, end):
        if field[i, j] > zero:
            first = wp.min(first, i)
            last = i
    add_to_box(first, last, j, box)


@wp.kernel
def support_box_rows(field: wp.array2d(dtype=Any), box: wp.array(dtype=wp.int32)):
    """``support_box`` for the CPU, which runs the threads one after another: a thread a row,
    scanning it from each end to its first and to its last cell where ``field`` > 0 (neighbouring
    reads in memory order, and a row in contact read only outside its support: at n = 1024, a
    contact 582 cells wide, 2.2-2.7 ms against 4.5 ms for the threads of one column each)."""
    i = wp.tid()
    n = field.shape[1]
    zero = field[0, 0] - field[0, 0]
    first = int(-1)
    for j in range(n):
        if field[i, j] > zero:
            first = j
            break
    if first >= 0:
        last = first
        for j in range(n - 1, first, -1):
            if field[i, j] > zero:
                last = j
                break
        wp.atomic_min(box, 0, i)
        wp.atomic_max(box, 1, i)
        wp.atomic_min(box, 2, first)
        wp.atomic_max(box, 3, last)


@wp.kernel
def closing_box(pressure: wp.array2d(dtype=Any), initial_gap: wp.array2d(dtype=Any), disp_z: wp.array2d(dtype=Any),
                known: wp.array2d(dtype=Any), approach: Any, box: wp.array(dtype=wp.int32)):
    """As ``support_box``, the box of the cells in contact (``pressure`` > 0) or closed at the
    rigid ``approach`` with the displacements held (h0 - approach + u_z + u_known < 0, scaled):
    where a normal solve at that approach starts from (the window of ``NormalSolver``; the
    contact of a growing load stays inside it, as the displacements only grow)."""
    block, j = wp.tid()
    n = pressure.shape[0]
    zero = approach - approach
    first = n
    last = int(-1)
    start = block * SUPPORT_ROWS
    end = wp.min(start + SUPPORT_ROWS, n)
    for i in range(start, end):
        if pressure[i, j] > zero or initial_gap[i, j] - approach + disp_z[i, j] + known[i, j] < zero:
            first = wp.min(first, i)
            last = i
    add_to_box(first, last, j, box)


# --- the windows of B cases at once (rows (B, n^2), row-major cells; ``solvers/contact_batch.py``) ---


@wp.kernel
def batch_support_box(field: wp.array2d(dtype=Any), width: int, boxes: wp.array2d(dtype=wp.int32)):
    """Each case's bounding box of its cells where ``field`` > 0: ``boxes[case]`` <- (first row,
    last row, first column, last column), from (n, -1, n, -1). A thread scans one column of
    one case (``support_box``'s scan, the whole column)."""
    case, j = wp.tid()
    zero = field[case, 0] - field[case, 0]
    first = width
    last = int(-1)
    for i in range(width):
        if field[case, i * width + j] > zero:
            first = wp.min(first, i)
            last = i
    add_to_box(first, last, j, boxes[case])


@wp.kernel
def batch_crop(whole: wp.array2d(dtype=Any), width: int, origins: wp.array2d(dtype=wp.int32), cells: int,
               window: wp.array2d(dtype=Any)):
    """Each case's window of ``cells`` per side at its origin (``origins[case]``: first row,
    first column) cut out of its whole grid (``width`` per side)."""
    case, k = wp.tid()
    i = k // cells
    j = k - i * cells
    window[case, k] = whole[case, (origins[case, 0] + i) * width + origins[case, 1] + j]


@wp.kernel
def batch_put_back(window: wp.array2d(dtype=Any), cells: int, origins: wp.array2d(dtype=wp.int32),
                   active: wp.array(dtype=wp.int32), width: int, whole: wp.array2d(dtype=Any)):
    """Each active case's whole grid <- its window at its origin, zero outside it (the other
    cases are left as they are)."""
    case, k = wp.tid()
    if active[case] != 0:
        i = k // width - origins[case, 0]
        j = k - (k // width) * width - origins[case, 1]
        value = window[case, 0] - window[case, 0]
        if i >= 0 and i < cells and j >= 0 and j < cells:
            value = window[case, i * cells + j]
        whole[case, k] = value


@wp.kernel
def batch_copy_rows(source: wp.array2d(dtype=Any), rows: wp.array(dtype=wp.int32), dest: wp.array2d(dtype=Any)):
    """dest[case] <- source[case] for the cases where ``rows[case]`` != 0."""
    case, k = wp.tid()
    if rows[case] != 0:
        dest[case, k] = source[case, k]


@wp.kernel
def gather_rows(source: wp.array2d(dtype=Any), rows: wp.array(dtype=wp.int32), layer: int, layers: int,
                accumulate: int, stack: wp.array2d(dtype=Any)):
    """stack[layers c + layer] <- source[rows[c]] (``accumulate``: += it): case rows of a batch's
    field into every ``layers``-th layer of a stack (a yield check's tractions, contact and
    adhesive, ``yielding.stacked_yield_checks``)."""
    c, k = wp.tid()
    value = source[rows[c], k]
    if accumulate != 0:
        value = stack[layers * c + layer, k] + value
    stack[layers * c + layer, k] = value


for _k in (crop, embed, support_box, support_box_rows, closing_box, batch_support_box, batch_crop, batch_put_back,
           batch_copy_rows, restrict_mean_stack, gather_rows):
    register_float_overloads(_k)
for _k in (crop, embed):
    wp.overload(_k, [wp.array2d(dtype=wp.int32), int, int, int, int, wp.array2d(dtype=wp.int32)])
wp.overload(batch_crop, [wp.array2d(dtype=wp.int32), int, wp.array2d(dtype=wp.int32), int, wp.array2d(dtype=wp.int32)])
wp.overload(batch_copy_rows, [wp.array2d(dtype=wp.int32), wp.array(dtype=wp.int32), wp.array2d(dtype=wp.int32)])
wp.overload(batch_put_back, [wp.array2d(dtype=wp.int32), int, wp.array2d(dtype=wp.int32), wp.array(dtype=wp.int32), int,
                             wp.array2d(dtype=wp.int32)])

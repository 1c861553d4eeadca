"""Anderson mixing of a fixed point x = G(x) (Walker & Ni 2011), one vector component at a time.

The vector is split into components (the adhesive pressure and shears), each a flat field; the
history of the last ``depth`` differences of residuals (dF) and iterates (dX) of a component is a
(depth, n) array. Per turn: ``anderson_residual`` turns G into f = G - x, writes the new history
column and sums the norms and the dot products that the host's small least-squares problem needs;
``anderson_update`` applies x <- x + beta f - sum_j gamma_j (dX_j + beta dF_j).
``local_anderson_update`` does the same with each cell's own gamma, from the cells around it.
"""

from typing import Any

import warp as wp

from .overloads import register_float_overloads
from .reduce import Cells, block_add, block_add_vector, cell_index

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


@wp.kernel
def batch_anderson_residual(
    iterate: wp.array3d(dtype=Any),
    columns: wp.array(dtype=wp.int32),
    turning: wp.array(dtype=wp.int32),
    cells: Cells,
    residual: wp.array3d(dtype=Any),
    previous_residual: wp.array3d(dtype=Any),
    previous_iterate: wp.array3d(dtype=Any),
    residual_diff: wp.array4d(dtype=Any),
    iterate_diff: wp.array4d(dtype=Any),
    sums: wp.array2d(dtype=Any),
):
    """``anderson_residual`` of B fixed points at once, each ``turning`` case's vector of
    components (component, case, cell): f = G(x) - x into ``residual`` (G(x) on entry), with
    ``columns[case]`` >= 0 its history column (component, case) gets dF, dX; its |f|^2 and
    |G(x)|^2 into ``sums[case]`` (slots S_RESIDUAL, S_IMAGE). Other cases are left as they are."""
    case, block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = sums[case, 0] - sums[case, 0]
    terms = wp.vector(zero, zero)
    column = columns[case]
    if turning[case] != 0:
        for k in range(cells.per):
            i = cell_index(thread, cells, k)
            if i < cells.n:
                for c in range(iterate.shape[0]):
                    g = residual[c, case, i]
                    x = iterate[c, case, i]
                    f = g - x
                    residual[c, case, i] = f
                    terms += wp.vector(f * f, g * g)
                    if column >= 0:
                        residual_diff[column, c, case, i] = f - previous_residual[c, case, i]
                        iterate_diff[column, c, case, i] = x - previous_iterate[c, case, i]
                    previous_residual[c, case, i] = f
                    previous_iterate[c, case, i] = x
    block_add_vector(sums[case], S_RESIDUAL, terms, lane)


@wp.kernel
def batch_anderson_products(
    residual: wp.array3d(dtype=Any),
    residual_diff: wp.array4d(dtype=Any),
    columns: wp.array(dtype=wp.int32),
    used: wp.array2d(dtype=wp.int32),
    cells: Cells,
    sums: wp.array2d(dtype=Any),
):
    """Each case's dot products of its newest history column (``columns[case]``, >= 0) with each
    column j it uses (``used[case, j]`` != 0), dF_new . dF_j, and of dF_j with f, into
    ``sums[case]``'s slots GRAM_SLOTS + 2 j and GRAM_SLOTS + 2 j + 1."""
    case, block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = sums[case, 0] - sums[case, 0]
    column = columns[case]
    for j in range(used.shape[1]):
        terms = wp.vector(zero, zero)
        if column >= 0 and used[case, j] != 0:
            for k in range(cells.per):
                i = cell_index(thread, cells, k)
                if i < cells.n:
                    for c in range(residual.shape[0]):
                        d = residual_diff[j, c, case, i]
                        terms += wp.vector(residual_diff[column, c, case, i] * d, d * residual[c, case, i])
        block_add_vector(sums[case], GRAM_SLOTS + 2 * j, terms, lane)


@wp.kernel
def batch_anderson_update(
    residual: wp.array3d(dtype=Any),
    residual_diff: wp.array4d(dtype=Any),
    iterate_diff: wp.array4d(dtype=Any),
    gamma: wp.array2d(dtype=Any),
    beta: Any,
    turning: wp.array(dtype=wp.int32),
    iterate: wp.array3d(dtype=Any),
):
    """``anderson_update`` of each ``turning`` case with its own ``gamma[case]`` (0 for the
    columns it does not use)."""
    case, i = wp.tid()
    if turning[case] == 0:
        return
    for c in range(iterate.shape[0]):
        x = iterate[c, case, i] + beta * residual[c, case, i]
        for j in range(gamma.shape[1]):
            x = x - gamma[case, j] * (iterate_diff[j, c, case, i] + beta * residual_diff[j, c, case, i])
        iterate[c, case, i] = x


for _k in (anderson_residual, anderson_update, batch_anderson_residual, batch_anderson_products,
           batch_anderson_update):
    register_float_overloads(_k)


@wp.kernel
def local_anderson_update(
    residual_x: wp.array(dtype=Any),
    residual_y: wp.array(dtype=Any),
    residual_diff_x: wp.array2d(dtype=Any),
    residual_diff_y: wp.array2d(dtype=Any),
    iterate_diff_x: wp.array2d(dtype=Any),
    iterate_diff_y: wp.array2d(dtype=Any),
    use: wp.array(dtype=Any),
    n: int,
    radius: int,
    iterate_x: wp.array(dtype=Any),
    iterate_y: wp.array(dtype=Any),
):
    """Anderson's step of a two-component field with coefficients of each cell's own: gamma of
    the cell (r, c) minimises |f - sum_j gamma_j dF_j|^2 over the (2 radius + 1)^2 cells around it
    (history columns 0-2, ``use[j]`` 1 or 0), then x <- x + f - sum_j gamma_j (dX_j + dF_j). The
    least squares carry a Tikhonov term of 1e-10 of the Gram matrix's trace. A cell whose own f,
    dF and dX (in the used columns) are zero keeps its x whatever its gamma (most cells outside the
    contact): no patch."""
    r, c = wp.tid()
    i = r * n + c
    u0 = use[0]
    u1 = use[1]
    u2 = use[2]
    zero = u0 - u0
    own = wp.abs(residual_x[i]) + wp.abs(residual_y[i])
    for k in range(3):
        own += use[k] * (wp.abs(residual_diff_x[k, i]) + wp.abs(residual_diff_y[k, i])
                         + wp.abs(iterate_diff_x[k, i]) + wp.abs(iterate_diff_y[k, i]))
    if own == zero:
        return
    g00 = zero
    g01 = zero
    g02 = zero
    g11 = zero
    g12 = zero
    g22 = zero
    b0 = zero
    b1 = zero
    b2 = zero
    for dr in range(-radius, radius + 1):
        rr = r + dr
        if rr >= 0 and rr < n:
            for dc in range(-radius, radius + 1):
                cc = c + dc
                if cc >= 0 and cc < n:
                    j = rr * n + cc
                    fx = residual_x[j]
                    fy = residual_y[j]
                    ax0 = u0 * residual_diff_x[0, j]
                    ax1 = u1 * residual_diff_x[1, j]
                    ax2 = u2 * residual_diff_x[2, j]
                    ay0 = u0 * residual_diff_y[0, j]
                    ay1 = u1 * residual_diff_y[1, j]
                    ay2 = u2 * residual_diff_y[2, j]
                    g00 += ax0 * ax0 + ay0 * ay0
                    g01 += ax0 * ax1 + ay0 * ay1
                    g02 += ax0 * ax2 + ay0 * ay2
                    g11 += ax1 * ax1 + ay1 * ay1
                    g12 += ax1 * ax2 + ay1 * ay2
                    g22 += ax2 * ax2 + ay2 * ay2
                    b0 += ax0 * fx + ay0 * fy
                    b1 += ax1 * fx + ay1 * fy
                    b2 += ax2 * fx + ay2 * fy
    one = zero + type(zero)(1.0)
    trace = g00 + g11 + g22
    fx = residual_x[i]
    fy = residual_y[i]
    x = iterate_x[i] + fx
    y = iterate_y[i] + fy
    if trace > zero:
        # the Gram matrix and its right side over the trace (gamma unchanged): entries of order 1,
        # whose determinant neither underflows (shears of 1e-3 in units of E* moving by 1e-5 make
        # entries of 1e-16) nor overflows, in float32 too
        w = one / trace
        eps = type(zero)(1.0e-10)
        # an unused column: its row and column zero, its diagonal one (gamma_j = 0)
        m = wp.matrix(w * g00 + eps + (one - u0), w * g01, w * g02,
                      w * g01, w * g11 + eps + (one - u1), w * g12,
                      w * g02, w * g12, w * g22 + eps + (one - u2), shape=(3, 3))
        det = wp.determinant(m)
        if det > zero:
            gamma = wp.inverse(m) * wp.vector(w * b0, w * b1, w * b2)
            for k in range(3):
                x = x - gamma[k] * (iterate_diff_x[k, i] + residual_diff_x[k, i])
                y = y - gamma[k] * (iterate_diff_y[k, i] + residual_diff_y[k, i])
    iterate_x[i] = x
    iterate_y[i] = y


register_float_overloads(local_anderson_update)

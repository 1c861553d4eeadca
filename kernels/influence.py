"""Influence coefficients of the Boussinesq-Cerruti kernels, computed on the device.

The antiderivatives at the cell corners, and each cell's four-corner difference
(``warpcontact/physics/influence.py`` orchestrates, and its module docstring gives the formulas; this is
the same arithmetic as its numpy path).

Always float64, whatever the model's float type: a far cell's integral [m / Pa, or m per unit
force times length^2] is the difference of four antiderivatives about (2 n)^2 times larger than
itself, so float32 would leave nothing of it. Lengths are in metres (the cell sizes dx, dy), the
antiderivatives in m^2 (m^2 per unit kernel), coefficients in the units of ``coefficient`` times
m.

The corner grid: (rows + 1) x (cols + 1) points at x = (j - first_x - 1/2) dx, y = (i - first_y -
1/2) dy, the corners between cells whose natural offsets are -first ... count - first - 1. The
shared terms are computed once per corner in three groups (``corner_asinh_terms``: x asinh(y/|x|)
and y asinh(x/|y|), which 1/r, x^2/r^3 and y^2/r^3 use; ``corner_radius``: r, for x y / r^3;
``corner_atan_log_terms``: the antiderivatives of x/r^2 and y/r^2, which share ln r^2), so that at
most two corner arrays are held at a time.
"""

import warp as wp

# no adjoints: nothing differentiates these kernels, and compiling them doubles the build
wp.set_module_options({"enable_backward": False})

#: ``pick`` of ``boussinesq_cerruti_cells``: the corner value of an elementary kernel from the
#: group's two corner arrays (a, b): a + b, a, b or -a
PICK_SUM = wp.constant(0)
PICK_A = wp.constant(1)
PICK_B = wp.constant(2)
PICK_MINUS_A = wp.constant(3)

#: above this, asinh(t) = ln(2 t) to float64 rounding (the next term, 1 / (4 t^2), is below
#: 2^-54 of it)
ASINH_LARGE = wp.constant(wp.float64(67108864.0))  # 2^26
LN2 = wp.constant(wp.float64(0.6931471805599453))


@wp.func
def asinh_f64(t: wp.float64) -> wp.float64:
    """asinh(t), dimensionless, float64 (Warp has no asinh): with the sign of t,
    log1p(|t| + t^2 / (1 + sqrt(1 + t^2))), log1p(u) taken as ln(1 + u) u / ((1 + u) - 1)
    (Goldberg 1991: the rounding of 1 + u compensated, a few ulp), ln(2 |t|) past 2^26."""
    a = wp.abs(t)
    v = wp.float64(0.0)
    if a > ASINH_LARGE:
        v = wp.log(a) + LN2
    else:
        u = a + a * a / (wp.float64(1.0) + wp.sqrt(wp.float64(1.0) + a * a))
        w = wp.float64(1.0) + u
        if w == wp.float64(1.0):
            v = u
        else:
            v = wp.log(w) * (u / (w - wp.float64(1.0)))
    if t < wp.float64(0.0):
        v = -v
    return v


@wp.func
def x_asinh_y_over_abs_x(x: wp.float64, y: wp.float64) -> wp.float64:
    """x asinh(y / |x|) [m], 0 where x = 0 (its limit)."""
    if x == wp.float64(0.0):
        return wp.float64(0.0)
    return x * asinh_f64(y / wp.abs(x))


@wp.func
def corner_coordinate(index: int, first: int, spacing: wp.float64) -> wp.float64:
    """Position [m] of corner ``index`` on an axis whose cell ``first`` (natural order) is the
    offset 0: (index - first - 1/2) spacing, rounded as numpy's (arange - first - 0.5) * spacing."""
    return (wp.float64(index) - wp.float64(first) - wp.float64(0.5)) * spacing


@wp.kernel
def corner_asinh_terms(first_y: int, first_x: int, dy: wp.float64, dx: wp.float64,
                       x_asinh: wp.array2d(dtype=wp.float64), y_asinh: wp.array2d(dtype=wp.float64)):
    """At corner (i, j) [m]: x asinh(y/|x|) and y asinh(x/|y|), each 0 on the axis where its
    factor is 0 (1/r's antiderivative is their sum, x^2/r^3's the second, y^2/r^3's the first)."""
    i, j = wp.tid()
    y = corner_coordinate(i, first_y, dy)
    x = corner_coordinate(j, first_x, dx)
    x_asinh[i, j] = x_asinh_y_over_abs_x(x, y)
    y_asinh[i, j] = x_asinh_y_over_abs_x(y, x)


@wp.kernel
def corner_radius(first_y: int, first_x: int, dy: wp.float64, dx: wp.float64, radius: wp.array2d(dtype=wp.float64)):
    """At corner (i, j): r = sqrt(x^2 + y^2) [m] (x y / r^3's antiderivative is -r)."""
    i, j = wp.tid()
    y = corner_coordinate(i, first_y, dy)
    x = corner_coordinate(j, first_x, dx)
    radius[i, j] = wp.sqrt(x * x + y * y)


@wp.kernel
def corner_atan_log_terms(first_y: int, first_x: int, dy: wp.float64, dx: wp.float64,
                          x_over_r2: wp.array2d(dtype=wp.float64), y_over_r2: wp.array2d(dtype=wp.float64)):
    """At corner (i, j) [m, with ln of r in m]: the antiderivatives of x/r^2, x atan(y/x) + y ln r,
    and of y/r^2, y atan(x/y) + x ln r; a term is 0 where its factor (x or y) is 0, so both are 0
    at the origin."""
    i, j = wp.tid()
    y = corner_coordinate(i, first_y, dy)
    x = corner_coordinate(j, first_x, dx)
    zero = wp.float64(0.0)
    log_r2 = zero
    if x != zero or y != zero:
        log_r2 = wp.log(x * x + y * y)
    x_atan = zero
    y_atan = zero
    x_log = zero
    y_log = zero
    if x != zero:
        x_atan = x * wp.atan(y / x)
        x_log = wp.float64(0.5) * x * log_r2
    if y != zero:
        y_atan = y * wp.atan(x / y)
        y_log = wp.float64(0.5) * y * log_r2
    x_over_r2[i, j] = x_atan + y_log
    y_over_r2[i, j] = y_atan + x_log


@wp.func
def corner_value(pick: int, a: wp.array2d(dtype=wp.float64), b: wp.array2d(dtype=wp.float64), i: int, j: int):
    """An elementary kernel's antiderivative at corner (i, j) from its group's corner arrays."""
    if pick == PICK_SUM:
        return a[i, j] + b[i, j]
    if pick == PICK_B:
        return b[i, j]
    if pick == PICK_MINUS_A:
        return -a[i, j]
    return a[i, j]


@wp.func
def cell_difference(pick: int, a: wp.array2d(dtype=wp.float64), b: wp.array2d(dtype=wp.float64), row: int, col: int):
    """The integral of an elementary kernel over the cell of natural index (row, col): its
    antiderivative at the corners F(+,+) - F(-,+) - F(+,-) + F(-,-) (x right, y up), in that
    order."""
    return (corner_value(pick, a, b, row + 1, col + 1) - corner_value(pick, a, b, row, col + 1)
            - corner_value(pick, a, b, row + 1, col) + corner_value(pick, a, b, row, col))


@wp.kernel
def boussinesq_cerruti_cells(a: wp.array2d(dtype=wp.float64), b: wp.array2d(dtype=wp.float64),
                             coefficient_0: wp.float64, pick_0: int, coefficient_1: wp.float64, pick_1: int,
                             scale: wp.float64, shift_y: int, shift_x: int, zero_row: int, zero_col: int,
                             out: wp.array2d(dtype=wp.float64)):
    """One influence kernel's coefficient at every entry of ``out``: (coefficient_0 cell_0 +
    coefficient_1 cell_1) scale, cell_k the integral of the elementary kernel ``pick_k`` over the
    cell (``pick_1`` < 0: one term); in the units of the coefficients times m times ``scale``.

    Entry (i, j) is the cell of natural index ((i + shift_y) mod rows, (j + shift_x) mod cols):
    shifts of n give the DC-FFT's wrap-around order (offset k at index k mod 2 n), 0 the natural
    one; row ``zero_row`` and column ``zero_col`` (offsets +-n of the padded grid; -1: none) are 0.
    """
    i, j = wp.tid()
    if i == zero_row or j == zero_col:
        out[i, j] = wp.float64(0.0)
        return
    row = (i + shift_y) % out.shape[0]
    col = (j + shift_x) % out.shape[1]
    v = coefficient_0 * cell_difference(pick_0, a, b, row, col)
    if pick_1 >= 0:
        v = v + coefficient_1 * cell_difference(pick_1, a, b, row, col)
    out[i, j] = v * scale


@wp.kernel
def chan_circulant(padded: wp.array2d(dtype=wp.float64), circulant: wp.array2d(dtype=wp.float64)):
    """T. Chan's optimal circulant of a kernel on the (ny, nx) grid, from its DC-FFT coefficients
    (``padded``: (2 ny, 2 nx), wrap-around order): the entry of offset (i, j), 0 <= i < ny,
    0 <= j < nx, is its four images (i - a ny, j - b nx), a, b in {0, 1}, weighted by the share
    of the grid's cell pairs each offset has: (ny - i) / ny for a = 0, i / ny for a = 1 (and
    likewise along x). Launched over the (ny, nx) grid."""
    i, j = wp.tid()
    ny = circulant.shape[0]
    nx = circulant.shape[1]
    one = wp.float64(1.0)
    wy = wp.float64(ny - i) / wp.float64(ny)
    wx = wp.float64(nx - j) / wp.float64(nx)
    circulant[i, j] = (wy * (wx * padded[i, j] + (one - wx) * padded[i, j + nx])
                       + (one - wy) * (wx * padded[i + ny, j] + (one - wx) * padded[i + ny, j + nx]))

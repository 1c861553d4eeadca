"""The adhesive normal problem as one energy minimisation (warpcontact/solvers/adhesive.py).

Unknown: the normal relative displacement u on the padded (2 n, 2 n) grid of the DC-FFT
operator C (scaled units: lengths / dx, tractions / E*). Its traction is p = C^-1 u; minimising

    E(u) = 1/2 u . C^-1 u + sum over the physical (n, n) cells of phi(h),  h = offset + u >= 0,

gives p = 0 on the padding (the DC-FFT's zero padding, so the non-periodic solution) and, on the
physical cells, p = -t(h) where h > 0 (the law's tension t = phi') and p >= -t(0) where h = 0
(contact). ``offset`` = h0 - delta_z + u_known is the gap at u = 0. Non-penetration is the bound
u >= -offset, one per cell.

A law is chosen by ``law`` (the LAW_* constants) with three scaled parameters (a, b, c); each
returns its potential phi (phi -> 0 as h -> infinity), tension t = d phi / dh (> 0: attraction)
and stiffness k = dt / dh at a gap h >= 0. ``opening_t`` is the SMC law's tangential opening
|s| / delta_t of the cell (0 for the others).

Reductions follow kernels/reduce.py (``cell_index``, ``block_add``): the padded grid is visited
as a flat array of 4 n^2 entries, entry i at row i / (2 n), column i % (2 n).
"""

from typing import Any

import warp as wp

from .overloads import register_float_overloads
from .reduce import Cells, block_add, cell_index

# no adjoints: nothing differentiates these kernels, and compiling them doubles the build
wp.set_module_options({"enable_backward": False})

LAW_SMC = wp.constant(0)  # McGarry et al. (2014) at a fixed tangential opening: a = sigma_max, b = delta_n
LAW_DUGDALE = wp.constant(1)  # Dugdale-Maugis with linear ramps: a = sigma_0, b = h_0, c = ramp width
LAW_EXPONENTIAL = wp.constant(2)  # t = (w / rho) exp(-h / rho): a = w, b = rho
LAW_LJ93 = wp.constant(3)  # Lennard-Jones 9-3 from its equilibrium distance: a = w, b = z0
LAW_DUGDALE_CENTRED = wp.constant(4)  # Dugdale-Maugis, one ramp centred on h_0: a = sigma_0, b = h_0, c = ramp width

# slots of the sums array
S_ENERGY = wp.constant(0)  # energy change of a trial step (trial kernel) or energy (evaluate)
S_PG = wp.constant(1)  # squared projected gradient
S_TRACTION = wp.constant(2)  # squared traction on the physical cells
S_CLIPPED = wp.constant(3)  # cells a trial step put against the bound
S_SLOPE = wp.constant(4)  # g . s of a trial step
S_DOT = wp.constant(5)  # a dot product (two-loop recursion)
S_FORCE = wp.constant(6)  # sum of the traction over the physical cells
S_SY = wp.constant(7)  # s . y of a new L-BFGS pair (``reduce.sums_of_products``)
S_SS = wp.constant(8)  # s . s
S_YY = wp.constant(9)  # y . y
N_SUMS = 10


@wp.func
def law_values(law: int, h: Any, opening_t: Any, a: Any, b: Any, c: Any):
    """(phi, t, k) of the law at gap h >= 0: potential, tension phi', stiffness phi''."""
    zero = h - h
    one = zero + type(h)(1.0)
    phi = zero
    t = zero
    k = zero
    if law == LAW_SMC:
        xn = h / b
        m = wp.sqrt(xn * xn + opening_t * opening_t)
        e = wp.exp(one - m)
        phi = -a * b * (one + m) * e
        t = a * xn * e
        if m > zero:
            k = a / b * e * (one - xn * xn / m)
        else:
            k = a / b * e
    elif law == LAW_DUGDALE:
        # rising ramp [0, c], plateau to b, falling ramp [b, b + c]; w = a b
        if c > zero:
            r = wp.min(h, c)
            p = wp.min(wp.max(h - c, zero), b - c)
            f = wp.min(wp.max(h - b, zero), c)
            phi = a * (r * r / (type(h)(2.0) * c) + p + f - f * f / (type(h)(2.0) * c)) - a * b
            t = a * wp.max(wp.min(wp.min(h / c, (b + c - h) / c), one), zero)
            if h < c:
                k = a / c
            elif h >= b and h < b + c:
                k = -a / c
        else:
            phi = a * wp.min(h, b) - a * b
            t = wp.where(h <= b, a, zero)
    elif law == LAW_DUGDALE_CENTRED:
        # tension a from contact (h = 0) to b - c / 2, falling linearly to 0 at b + c / 2; w = a b and
        # the law's centroid (its first moment) are the sharp law's
        lo = b - type(h)(0.5) * c
        if c > zero:
            f = wp.min(wp.max(h - lo, zero), c)
            phi = a * (wp.min(h, lo) + f - f * f / (type(h)(2.0) * c)) - a * b
            t = a * wp.max(wp.min((b + type(h)(0.5) * c - h) / c, one), zero)
            if h >= lo and h < b + type(h)(0.5) * c:
                k = -a / c
        else:
            phi = a * wp.min(h, b) - a * b
            t = wp.where(h <= b, a, zero)
    elif law == LAW_EXPONENTIAL:
        e = wp.exp(-h / b)
        phi = -a * e
        t = a / b * e
        k = -a / (b * b) * e
    else:  # LAW_LJ93
        r = b / (h + b)
        r2 = r * r
        r4 = r2 * r2
        r8 = r4 * r4
        three = type(h)(3.0)  # (4 / 3 written as a literal would be rounded to float32)
        phi = -a * type(h)(4.0) / three * (r2 - type(h)(0.25) * r8)
        t = a * type(h)(8.0) / three / b * (r2 * r - r8 * r)
        k = a * type(h)(8.0) / three / (b * b) * (type(h)(9.0) * r8 * r2 - three * r4)
    return phi, t, k


@wp.func
def physical_cell(i: int, n: int):
    """Row-major index of padded entry i in the physical (n, n) grid, or -1 in the padding."""
    row = i / (2 * n)
    col = i - row * (2 * n)
    if row < n and col < n:
        return row * n + col
    return -1


@wp.func
def padded_entry(j: int, n_side: int):
    """Index in the padded (2 n, 2 n) grid of physical cell j (row-major in the (n, n) grid)."""
    row = j / n_side
    return row * (2 * n_side) + (j - row * n_side)


@wp.func
def is_bound(h: Any, g: Any, eps: Any):
    """A cell held at the bound: touching (h <= eps) and pushed into contact (g > 0)."""
    return h <= eps and g > h - h


@wp.func
def cell_energy_change(ui: Any, ut: Any, pi: Any, pt: Any, j: int, offset: wp.array(dtype=Any),
                       opening_t: wp.array(dtype=Any), law: int, a: Any, b: Any, c: Any):
    """A padded entry's share of the energy change from (u, p) to (u_trial, p_trial):
    s (p + p_trial) / 2, plus phi(h_trial) - phi(h) on a physical cell (j >= 0). Summed from
    differences, so that float32 keeps its digits."""
    zero = a - a
    change = type(a)(0.5) * (ut - ui) * (pi + pt)
    if j >= 0:
        o = offset[j]
        phi_new, t_new, k_new = law_values(law, wp.max(o + ut, zero), opening_t[j], a, b, c)
        phi_old, t_old, k_old = law_values(law, wp.max(o + ui, zero), opening_t[j], a, b, c)
        change += phi_new - phi_old
    return change


@wp.kernel
def adhesive_evaluate(
    u: wp.array(dtype=Any),
    p: wp.array(dtype=Any),
    offset: wp.array(dtype=Any),
    opening_t: wp.array(dtype=Any),
    law: int,
    a: Any,
    b: Any,
    c: Any,
    eps: Any,
    n_side: int,
    cells: Cells,
    grad: wp.array(dtype=Any),
    sums: wp.array(dtype=Any),
):
    """grad <- dE/du = p + t(h) (p on the padding); sums: energy, squared projected gradient,
    squared physical traction, force (sum of p over the physical cells)."""
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = a - a
    s_energy = zero
    s_pg = zero
    s_traction = zero
    s_force = zero
    for k in range(cells.per):
        i = cell_index(thread, cells, k)
        if i < cells.n:
            ui = u[i]
            pi = p[i]
            g = pi
            energy = type(a)(0.5) * ui * pi
            j = physical_cell(i, n_side)
            if j >= 0:
                h = wp.max(offset[j] + ui, zero)
                phi, t, kk = law_values(law, h, opening_t[j], a, b, c)
                g = pi + t
                energy += phi
                s_traction += pi * pi
                s_force += pi
                if is_bound(h, g, eps):
                    g = zero
            grad[i] = g
            s_energy += energy
            s_pg += g * g
    block_add(sums, S_ENERGY, s_energy)
    block_add(sums, S_PG, s_pg)
    block_add(sums, S_TRACTION, s_traction)
    block_add(sums, S_FORCE, s_force)


@wp.kernel
def adhesive_free(
    u: wp.array(dtype=Any),
    grad: wp.array(dtype=Any),
    offset: wp.array(dtype=Any),
    eps: Any,
    n_side: int,
    field: wp.array(dtype=Any),
):
    """field <- 0 on the cells held at the bound (the projection onto the free set)."""
    i = wp.tid()
    j = physical_cell(i, n_side)
    if j >= 0:
        h = wp.max(offset[j] + u[i], u[i] - u[i])
        # grad is 0 on bound cells already (adhesive_evaluate); a bound cell is touching with grad 0
        if h <= eps and grad[i] == h - h:
            field[i] = h - h


@wp.kernel
def adhesive_scale(
    u: wp.array(dtype=Any),
    grad: wp.array(dtype=Any),
    offset: wp.array(dtype=Any),
    opening_t: wp.array(dtype=Any),
    law: int,
    a: Any,
    b: Any,
    c: Any,
    eps: Any,
    self_compliance: Any,
    n_side: int,
    field: wp.array(dtype=Any),
):
    """The preconditioner's diagonal part: field <- field / sqrt(1 + max(k, 0) c0) on the physical
    cells (the law's stiffness k against a cell's own compliance c0), 0 on bound cells. Applied
    before and after C, so that the preconditioner J^-1/2 C J^-1/2 stays symmetric positive
    definite (a descent direction for the recursion)."""
    i = wp.tid()
    j = physical_cell(i, n_side)
    if j >= 0:
        zero = a - a
        h = wp.max(offset[j] + u[i], zero)
        if h <= eps and grad[i] == zero:
            field[i] = zero
        else:
            phi, t, kk = law_values(law, h, opening_t[j], a, b, c)
            field[i] = field[i] / wp.sqrt(type(a)(1.0) + wp.max(kk, zero) * self_compliance)


@wp.kernel
def pair_curvature(sums: wp.array(dtype=Any), one: Any, slot: int, rho: wp.array(dtype=Any)):
    """rho[slot] <- 1 / (s . y) of the pair just kept (one thread; ``one``: 1 in the float type)."""
    rho[slot] = one / sums[S_SY]


@wp.kernel
def two_loop_first(dots: wp.array(dtype=Any), k: int, rho: wp.array(dtype=Any), slot: int, y: wp.array(dtype=Any),
                   q: wp.array(dtype=Any)):
    """The two-loop recursion's first loop, pair k (stored in ``slot``): alpha_k = rho (s . q)
    with s . q in dots[k]; q <- q - alpha_k y. On the device: no read on the host."""
    i = wp.tid()
    q[i] = q[i] - (rho[slot] * dots[k]) * y[i]


@wp.kernel
def two_loop_second(dots: wp.array(dtype=Any), k: int, memory: int, rho: wp.array(dtype=Any), slot: int,
                    s: wp.array(dtype=Any), d: wp.array(dtype=Any)):
    """The second loop, pair k: beta = rho (y . d) with y . d in dots[memory + k]; d <- d +
    (alpha_k - beta) s, alpha_k = rho dots[k] from the first loop."""
    i = wp.tid()
    r = rho[slot]
    d[i] = d[i] + (r * dots[k] - r * dots[memory + k]) * s[i]


@wp.kernel
def difference(x_new: wp.array(dtype=Any), x_old: wp.array(dtype=Any), out: wp.array(dtype=Any)):
    """out <- x_new - x_old"""
    i = wp.tid()
    out[i] = x_new[i] - x_old[i]


@wp.kernel
def scaled_copy(alpha: Any, x: wp.array(dtype=Any), out: wp.array(dtype=Any)):
    """out <- alpha x"""
    i = wp.tid()
    out[i] = alpha * x[i]


@wp.kernel
def adhesive_trial(
    u: wp.array(dtype=Any),
    p: wp.array(dtype=Any),
    grad: wp.array(dtype=Any),
    direction: wp.array(dtype=Any),
    direction_traction: wp.array(dtype=Any),
    offset: wp.array(dtype=Any),
    opening_t: wp.array(dtype=Any),
    law: int,
    a: Any,
    b: Any,
    c: Any,
    step: Any,
    n_side: int,
    cells: Cells,
    u_trial: wp.array(dtype=Any),
    p_trial: wp.array(dtype=Any),
    sums: wp.array(dtype=Any),
):
    """u_trial <- max(u + step d, bound), p_trial <- p + step C^-1 d (exact where no cell was
    clipped); sums: the energy change s . (p + p_trial) / 2 + sum (phi(h_trial) - phi(h)) (from
    differences, so float32 keeps its digits), the slope g . s and the clipped cells."""
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = a - a
    s_change = zero
    s_slope = zero
    s_clipped = zero
    for k in range(cells.per):
        i = cell_index(thread, cells, k)
        if i < cells.n:
            ui = u[i]
            ut = ui + step * direction[i]
            pt = p[i] + step * direction_traction[i]
            j = physical_cell(i, n_side)
            if j >= 0 and offset[j] + ut < zero:
                ut = -offset[j]
                s_clipped += type(a)(1.0)
            s_change += cell_energy_change(ui, ut, p[i], pt, j, offset, opening_t, law, a, b, c)
            s_slope += grad[i] * (ut - ui)
            u_trial[i] = ut
            p_trial[i] = pt
    block_add(sums, S_ENERGY, s_change)
    block_add(sums, S_SLOPE, s_slope)
    block_add(sums, S_CLIPPED, s_clipped)


@wp.kernel
def adhesive_change(
    u: wp.array(dtype=Any),
    p: wp.array(dtype=Any),
    u_trial: wp.array(dtype=Any),
    p_trial: wp.array(dtype=Any),
    offset: wp.array(dtype=Any),
    opening_t: wp.array(dtype=Any),
    law: int,
    a: Any,
    b: Any,
    c: Any,
    n_side: int,
    cells: Cells,
    sums: wp.array(dtype=Any),
):
    """sums[S_ENERGY] += the energy change from (u, p) to (u_trial, p_trial) (a trial whose
    traction was made exactly)."""
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = a - a
    s_change = zero
    for k in range(cells.per):
        i = cell_index(thread, cells, k)
        if i < cells.n:
            s_change += cell_energy_change(u[i], u_trial[i], p[i], p_trial[i], physical_cell(i, n_side), offset,
                                           opening_t, law, a, b, c)
    block_add(sums, S_ENERGY, s_change)


@wp.kernel
def adhesive_state(
    u: wp.array(dtype=Any),
    p: wp.array(dtype=Any),
    offset: wp.array(dtype=Any),
    opening_t: wp.array(dtype=Any),
    law: int,
    a: Any,
    b: Any,
    c: Any,
    n_side: int,
    pressure: wp.array(dtype=Any),
    adhesive_pressure: wp.array(dtype=Any),
    gap: wp.array(dtype=Any),
    displacement: wp.array(dtype=Any),
):
    """The state's fields from the solution (one thread per physical cell): gap h, displacement
    u, adhesive pressure -t(h), contact pressure p + t(0) >= 0 on touching cells (h = 0: at the
    bound), 0 elsewhere."""
    j = wp.tid()
    i = padded_entry(j, n_side)
    zero = a - a
    ui = u[i]
    h = wp.max(offset[j] + ui, zero)
    phi, t, k = law_values(law, h, opening_t[j], a, b, c)
    gap[j] = h
    displacement[j] = ui
    adhesive_pressure[j] = -t
    if h == zero:
        pressure[j] = wp.max(p[i] + t, zero)
    else:
        pressure[j] = zero


@wp.kernel
def adhesive_start(
    pressure: wp.array(dtype=Any),
    adhesive_pressure: wp.array(dtype=Any),
    n_side: int,
    traction: wp.array(dtype=Any),
):
    """traction (padded, zero outside the physical corner) <- pressure + adhesive pressure:
    the state's total normal traction, whose displacement C traction starts the solve."""
    j = wp.tid()
    i = padded_entry(j, n_side)
    traction[i] = pressure[j] + adhesive_pressure[j]


@wp.kernel
def adhesive_offset(
    initial_gap: wp.array(dtype=Any),
    known: wp.array(dtype=Any),
    approach: Any,
    offset: wp.array(dtype=Any),
):
    """offset <- h0 - delta_z + u_known: the gap at u = 0."""
    i = wp.tid()
    offset[i] = initial_gap[i] - approach + known[i]


@wp.kernel
def project_to_bound(u: wp.array(dtype=Any), offset: wp.array(dtype=Any), contact_pressure: wp.array(dtype=Any),
                     n_side: int):
    """u <- max(u, -offset) on the physical cells (one thread per physical cell), and u <- -offset
    (h = 0 exactly) where the contact pressure of the start is positive: a touching cell stays at
    the bound rather than a rounding error above it (where it would count as out of contact)."""
    j = wp.tid()
    i = padded_entry(j, n_side)
    if contact_pressure[j] > contact_pressure[j] - contact_pressure[j]:
        u[i] = -offset[j]
    else:
        u[i] = wp.max(u[i], -offset[j])


@wp.kernel
def smc_opening(
    slip_x: wp.array(dtype=Any), slip_y: wp.array(dtype=Any), delta_t: Any, opening_t: wp.array(dtype=Any)
):
    """opening_t <- |s| / delta_t (SMC's tangential opening of a cell)."""
    i = wp.tid()
    opening_t[i] = wp.sqrt(slip_x[i] * slip_x[i] + slip_y[i] * slip_y[i]) / delta_t


@wp.kernel
def spectral_scale(spectrum: wp.array2d(dtype=Any), influence: wp.array2d(dtype=Any), inverse: int):
    """spectrum *= K(k) (or / K(k) with ``inverse``): the circulant C on the padded grid, or its
    inverse, on a real-to-complex spectrum (a 2-vector per entry)."""
    r, q = wp.tid()
    kval = influence[r, q]
    if inverse != 0:
        spectrum[r, q] = spectrum[r, q] / kval
    else:
        spectrum[r, q] = spectrum[r, q] * kval


for _k in (adhesive_evaluate, adhesive_free, adhesive_scale, pair_curvature, two_loop_first,
           two_loop_second, difference, scaled_copy, adhesive_trial, adhesive_change, adhesive_state,
           adhesive_start, adhesive_offset, project_to_bound, smc_opening):
    register_float_overloads(_k)
for _vec, _real in ((wp.vec2f, wp.float32), (wp.vec2d, wp.float64)):
    wp.overload(spectral_scale, [wp.array2d(dtype=_vec), wp.array2d(dtype=_real), int])

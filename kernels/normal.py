"""Polonsky & Keer (1999) projected conjugate gradients for the contact pressure.

Displacement-driven form (no force constraint, MODEL.md section 4): minimise the complementary
energy over p >= 0 with the rigid approach delta_z given. Quantities are in the model's scaled
units (tractions / E*, lengths / cell size). Fields are flattened (n_cells,) arrays.

Polonsky, I. A. & Keer, L. M. (1999), "A numerical method for solving rough contact problems
based on the multi-level multi-summation and conjugate gradient techniques", Wear 231, 206-219.

Per iteration: ``normal_gap`` -> ``normal_direction`` -> (r = K t) -> ``normal_step_sums`` ->
``normal_update`` -> ``reduce.cg_advance``. Scalars live in two device arrays: ``sums`` (zeroed at
the start of each iteration) and ``scalars`` (carried: G_old, delta, iteration count).
"""

from typing import Any

import warp as wp

from .overloads import register_float_overloads
from .reduce import (  # noqa: F401  (shared slots)
    C_DELTA, C_G_OLD, C_ITER, N_SCALARS, N_SETTINGS, P_APPROACH, P_TOL, S_G, S_GT, S_RHS, S_RT, S_VIOL, block_add, block_max,
    cell_index, cg_converged, cg_step_length,
)
from .reduce import S_RESTART as S_IOL  # cells that re-enter contact (or leave the cap)

# no adjoints: nothing differentiates these kernels, and compiling them doubles the build
wp.set_module_options({"enable_backward": False})

# slots of ``sums`` (0-2 and 5 shared with kernels/reduce.py: g^2 on the free set, violation,
# right-hand side, re-entries)
S_CORRECTION = wp.constant(6)  # sum |p - (p_old - tau t)|: what the projection changed, which K t misses
N_SUMS = 7


@wp.kernel
def normal_gap(
    initial_gap: wp.array(dtype=Any),
    displacement: wp.array(dtype=Any),
    known_displacement: wp.array(dtype=Any),
    pressure: wp.array(dtype=Any),
    settings: wp.array(dtype=Any),
    pressure_cap: Any,
    n: int,
    outer: int,
    inner: int,
    per: int,
    gap: wp.array(dtype=Any),
    sums: wp.array(dtype=Any),
):
    """gap = h0 - delta_z + u_z + u_known, and the residual sums of the current pressure.

    Free cells (0 < p < cap) must close (g = 0); cells at p = 0 must not penetrate (g >= 0);
    cells at the cap (the hardness: a perfectly plastic surface) must not open (g <= 0). The
    approach delta_z is ``settings[P_APPROACH]``.
    """
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    approach = settings[P_APPROACH]
    zero = approach - approach
    s_g = zero
    s_viol = zero
    s_rhs = zero
    for k in range(per):
        i = cell_index(thread, outer, inner, k)
        if i < n:
            rhs = approach - initial_gap[i] - known_displacement[i]
            g = displacement[i] - rhs
            gap[i] = g
            p = pressure[i]
            # 0 while g and p are finite, NaN once either is not: the residual turns non-finite,
            # which stops the solve (cheaper than two isfinite branches: 2.5 -> 1.5 ms at n = 512 on
            # the CPU)
            s_viol += (g - g) + (p - p)
            if p >= pressure_cap:
                s_rhs += rhs * rhs
                if g > zero:
                    s_viol += g * g
            elif p > zero:
                s_g += g * g
                s_viol += g * g
                s_rhs += rhs * rhs
            elif g < zero:
                s_viol += g * g
    block_add(sums, S_G, s_g)
    block_add(sums, S_VIOL, s_viol)
    block_add(sums, S_RHS, s_rhs)


@wp.kernel
def normal_direction(
    gap: wp.array(dtype=Any),
    pressure: wp.array(dtype=Any),
    pressure_cap: Any,
    sums: wp.array(dtype=Any),
    scalars: wp.array(dtype=Any),
    direction: wp.array(dtype=Any),
):
    """Conjugate direction t = g + delta (G / G_old) t on the free set 0 < p < cap, 0 elsewhere."""
    i = wp.tid()
    zero = sums[S_G] - sums[S_G]
    beta = zero
    if scalars[C_G_OLD] > zero:
        beta = scalars[C_DELTA] * sums[S_G] / scalars[C_G_OLD]
    if pressure[i] > zero and pressure[i] < pressure_cap:
        direction[i] = gap[i] + beta * direction[i]
    else:
        direction[i] = zero


@wp.kernel
def normal_step_sums(
    gap: wp.array(dtype=Any),
    direction: wp.array(dtype=Any),
    response: wp.array(dtype=Any),
    pressure: wp.array(dtype=Any),
    pressure_cap: Any,
    n: int,
    outer: int,
    inner: int,
    per: int,
    sums: wp.array(dtype=Any),
):
    """Sums of g t and (K t) t over the contact set, for the step length."""
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = gap[0] - gap[0]
    s_gt = zero
    s_rt = zero
    for k in range(per):
        i = cell_index(thread, outer, inner, k)
        if i < n:
            if pressure[i] > zero and pressure[i] < pressure_cap:
                t = direction[i]
                s_gt += gap[i] * t
                s_rt += response[i] * t
    block_add(sums, S_GT, s_gt)
    block_add(sums, S_RT, s_rt)


@wp.kernel
def normal_update(
    gap: wp.array(dtype=Any),
    direction: wp.array(dtype=Any),
    pressure_cap: Any,
    settings: wp.array(dtype=Any),
    n: int,
    outer: int,
    inner: int,
    per: int,
    pressure: wp.array(dtype=Any),
    sums: wp.array(dtype=Any),
):
    """p <- clip(p - tau t, 0, cap); penetrating cells with p = 0 re-enter with p = -tau g, and
    opening cells at the cap leave it with p = cap - tau g (Polonsky-Keer's re-entry rule).

    An iterate whose relative residual is already under ``settings[P_TOL]`` is left as it is.
    """
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = gap[0] - gap[0]
    tau = cg_step_length(sums)
    count = zero
    corrected = zero
    done = cg_converged(sums, settings[P_TOL])
    for k in range(per):
        i = cell_index(thread, outer, inner, k)
        if i < n and not done:
            p = pressure[i]
            unprojected = p - tau * direction[i]  # what K t accounts for (t = 0 off the free set)
            if p >= pressure_cap:
                if gap[i] > zero:
                    p = wp.max(pressure_cap - tau * gap[i], zero)
                    count += type(zero)(1.0)
            elif p > zero:
                p = wp.min(wp.max(p - tau * direction[i], zero), pressure_cap)
            elif gap[i] < zero:
                p = wp.min(-tau * gap[i], pressure_cap)
                count += type(zero)(1.0)
            corrected += wp.abs(p - unprojected)
            pressure[i] = p
    block_add(sums, S_IOL, count)
    block_add(sums, S_CORRECTION, corrected)



@wp.kernel
def normal_displacement_step(response: wp.array(dtype=Any), sums: wp.array(dtype=Any), settings: wp.array(dtype=Any),
                             displacement: wp.array(dtype=Any)):
    """u <- u - tau K t: the displacement of the updated pressure when no cell was projected
    (the same tau, and the same converged-iterate rule, as ``normal_update``)."""
    i = wp.tid()
    if cg_converged(sums, settings[P_TOL]):
        return
    displacement[i] = displacement[i] - cg_step_length(sums) * response[i]


@wp.kernel
def normal_recompute_flag(sums: wp.array(dtype=Any), scalars: wp.array(dtype=Any), settings: wp.array(dtype=Any),
                          exact_every: int, column_norm: Any, deferral: Any, deferred: wp.array(dtype=Any),
                          recompute: wp.array(dtype=wp.int32)):
    """One thread, end of an iteration that carried u = K p (as u - tau K t): whether to recompute
    K p at the start of the next iteration (``recompute[0] = 1``).

    The carried u misses K c, c the changes the projections made since the last recompute; their
    L1 norms add up in ``deferred[0]``, and ||K c||_2 <= ``column_norm`` * that (the 2-norm of
    one column of K bounds each cell's share). Recompute when that bound exceeds ``deferral``
    times the violation the iteration started from (the carried gap's error stays a fraction of
    what the iteration corrects), when a change comes near convergence (relative residual under
    4 tol: a converged iterate must be judged on the exact gap), and every ``exact_every``
    iterations (rounding).
    """
    zero = sums[S_VIOL] - sums[S_VIOL]
    missed = deferred[0] + sums[S_CORRECTION]
    bound = column_norm * missed
    tol = settings[P_TOL]
    near = sums[S_VIOL] <= type(zero)(16.0) * tol * tol * sums[S_RHS]
    if (bound * bound > deferral * deferral * sums[S_VIOL] or (near and missed > zero)
            or int(scalars[C_ITER]) % exact_every == 0):
        recompute[0] = 1
        deferred[0] = zero
    else:
        recompute[0] = 0
        deferred[0] = missed


# slots of the first guess's sums (NormalSolver.guess_sums)
G_POSITIVE = wp.constant(0)  # cells with p > 0
G_UB = wp.constant(1)  # sum of (K s) b over the guess's support s > 0
G_UU = wp.constant(2)  # sum of (K s)^2 over it
G_BMAX = wp.constant(3)  # the largest interference b
N_GUESS_SUMS = 4


@wp.kernel
def count_positive(pressure: wp.array(dtype=Any), n: int, outer: int, inner: int, per: int, guess_sums: wp.array(dtype=Any)):
    """guess_sums[G_POSITIVE] += the number of cells with p > 0."""
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = pressure[0] - pressure[0]
    count = zero
    for k in range(per):
        i = cell_index(thread, outer, inner, k)
        if i < n and pressure[i] > zero:
            count += type(zero)(1.0)
    block_add(guess_sums, G_POSITIVE, count)


@wp.func
def interference(initial_gap: wp.array(dtype=Any), known_displacement: wp.array(dtype=Any), approach: Any, i: int):
    """b = max(delta_z - h0 - u_known, 0): how far the rigid surfaces overlap at cell i."""
    return wp.max(approach - initial_gap[i] - known_displacement[i], approach - approach)


@wp.kernel
def guess_max_interference(initial_gap: wp.array(dtype=Any), known_displacement: wp.array(dtype=Any),
                           settings: wp.array(dtype=Any), n: int, outer: int, inner: int, per: int,
                           guess_sums: wp.array(dtype=Any)):
    """guess_sums[G_BMAX] <- max(guess_sums[G_BMAX], the largest interference b) (zeroed before:
    b >= 0)."""
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    approach = settings[P_APPROACH]
    largest = approach - approach
    for k in range(per):
        i = cell_index(thread, outer, inner, k)
        if i < n:
            largest = wp.max(largest, interference(initial_gap, known_displacement, approach, i))
    block_max(guess_sums, G_BMAX, largest, lane)


@wp.kernel
def guess_shape(initial_gap: wp.array(dtype=Any), known_displacement: wp.array(dtype=Any),
                settings: wp.array(dtype=Any), guess_sums: wp.array(dtype=Any), pressure: wp.array(dtype=Any)):
    """p <- s = sqrt(max(b - b_max / 2, 0)), the shape of the first guess: for a paraboloid on a
    flat, b - b_max / 2 = (a^2 - r^2) / 2R on the Hertz contact radius a^2 = R delta_z (the
    elastic contact closes half the rigid interference), so s is the Hertz pressure's shape."""
    i = wp.tid()
    b = interference(initial_gap, known_displacement, settings[P_APPROACH], i)
    half = type(b)(0.5) * guess_sums[G_BMAX]
    pressure[i] = wp.sqrt(wp.max(b - half, b - b))


@wp.kernel
def guess_fit_sums(initial_gap: wp.array(dtype=Any), known_displacement: wp.array(dtype=Any),
                   settings: wp.array(dtype=Any), shape: wp.array(dtype=Any), response: wp.array(dtype=Any),
                   n: int, outer: int, inner: int, per: int, guess_sums: wp.array(dtype=Any)):
    """Sums of (K s) b and (K s)^2 over the support s > 0, for the least-squares scale of the
    first guess (``response`` = K s)."""
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    approach = settings[P_APPROACH]
    zero = approach - approach
    s_ub = zero
    s_uu = zero
    for k in range(per):
        i = cell_index(thread, outer, inner, k)
        if i < n and shape[i] > zero:
            b = interference(initial_gap, known_displacement, approach, i)
            s_ub += response[i] * b
            s_uu += response[i] * response[i]
    block_add(guess_sums, G_UB, s_ub)
    block_add(guess_sums, G_UU, s_uu)


@wp.kernel
def guess_scale(guess_sums: wp.array(dtype=Any), pressure_cap: Any, pressure: wp.array(dtype=Any)):
    """p <- min(c s, cap), c = sum (K s) b / sum (K s)^2: K p fits the interference best on the
    support."""
    i = wp.tid()
    zero = pressure_cap - pressure_cap
    c = wp.where(guess_sums[G_UU] > zero, guess_sums[G_UB] / guess_sums[G_UU], zero)
    pressure[i] = wp.min(c * pressure[i], pressure_cap)


for _k in (normal_gap, normal_direction, normal_step_sums, normal_update, normal_displacement_step, normal_recompute_flag,
           count_positive, guess_max_interference, guess_shape, guess_fit_sums, guess_scale):
    register_float_overloads(_k)

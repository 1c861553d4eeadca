"""Polonsky & Keer (1999) projected conjugate gradients for the contact pressure.

Displacement-driven form (no force constraint, MODEL.md section 4): minimise the complementary
energy over p >= 0 with the rigid approach delta_z given. Quantities are in the model's scaled
units (tractions / E*, lengths / cell size). Fields are (ny, nx) arrays, flattened to (n_cells,)
for the reductions.

Polonsky, I. A. & Keer, L. M. (1999), "A numerical method for solving rough contact problems
based on the multi-level multi-summation and conjugate gradient techniques", Wear 231, 206-219.

One iteration, four passes over the grid around one convolution (three on CUDA) (``solvers/normal.py``):

1. ``normal_direction``: the conjugate direction t, written also into the FFT backend's padded
   input (the zero padding of the DC-FFT stays zero);
2. the transforms and the spectral product: K t in the backend's padded output;
3. ``normal_step_sums``: g . t and (K t) . t over the free set, read from the padded output;
   on CUDA instead ``normal_direction_sum`` sums g . t and the spectral product (K t) . t, in
   Fourier space (Parseval; ``kernels/spectral.py``, ``spectral_normal_energy``), one pass less;
4. ``normal_update``: the projected step on p, the carried gap g <- g - tau K t, and the residual
   sums of the new iterate; ``normal_advance`` (one thread) then carries the scalars, decides
   whether the next iteration starts from an exact gap (``normal_gap`` after a convolution of p),
   and sets the device loop's flag.

Preconditioned (``SolverSettings.normal_preconditioner``, the default), the iteration starts with
``normal_free_gap`` (the gap on the free set into the padded input), a transform pair whose
spectral product is the operator's inverse (``spectral_normal_energy`` with ``inverse``, which
also sums g . M g into slot S_G), and the direction's pass reads z = M g from the padded output
in place of g.

Scalars live in device arrays: ``sums`` (the reductions of one iteration; slots below),
``scalars`` (carried: G_old, delta, iteration count, why the loop stopped) and ``parameters`` (the
values of one solve).
"""

from typing import Any

import warp as wp

from .overloads import mixed_float_overloads, register_float_overloads
from .reduce import (  # noqa: F401  (shared slots)
    Cells, C_DELTA, C_G_OLD, C_ITER, N_SCALARS, N_PARAMETERS, N_SHARED_SUMS, P_APPROACH, P_CHUNK, P_EXACT, P_MAX_ITER, P_TOL, S_G, S_GT, S_RHS,
    S_RT, S_VIOL, advance, residual_of, stop_loop,
    block_add, block_add_vector, block_max, cell_index, cg_converged, cg_step_length, conjugacy,
)
from .reduce import S_RESTART as S_IOL  # cells that re-enter contact (or leave the cap)

# no adjoints: nothing differentiates these kernels, and compiling them doubles the build
wp.set_module_options({"enable_backward": False})

# the normal solver's own slots of ``sums``, after the shared ones of kernels/reduce.py (whose
# S_G, S_VIOL, S_RHS describe the iterate the iteration starts from); S_IOL and these four are
# consecutive (``normal_update`` adds them as one vector)
S_CORRECTION = wp.constant(N_SHARED_SUMS + 0)  # sum |p - (p_old - tau t)|: what the projection changed, which K t misses
S_NEXT_G = wp.constant(N_SHARED_SUMS + 1)  # S_G, S_VIOL, S_RHS of the updated iterate, with the carried gap
S_NEXT_VIOL = wp.constant(N_SHARED_SUMS + 2)
S_NEXT_RHS = wp.constant(N_SHARED_SUMS + 3)
N_SUMS = wp.constant(N_SHARED_SUMS + 4)


@wp.func
def residual_terms(pressure: Any, gap: Any, interference: Any, pressure_cap: Any):
    """One cell's shares of the residual sums (S_G, S_VIOL, S_RHS): free cells (0 < p < cap)
    must close (g = 0), cells at p = 0 must not penetrate (g >= 0), cells at the cap (the
    hardness: a perfectly plastic surface) must not open (g <= 0); the right-hand side is the
    interference b = delta_z - h0 - u_known on the active cells (p > 0). ``interference`` is
    read only there. The violation is NaN once p or g is not finite, which stops the solve."""
    zero = type(pressure)(0.0)
    s_g = zero
    # 0 while g and p are finite, NaN once either is not (cheaper than two isfinite branches:
    # 2.5 -> 1.5 ms at n = 512 on the CPU)
    s_viol = (gap - gap) + (pressure - pressure)
    s_rhs = zero
    if pressure >= pressure_cap:
        s_rhs = interference * interference
        if gap > zero:
            s_viol += gap * gap
    elif pressure > zero:
        s_g = gap * gap
        s_viol += gap * gap
        s_rhs = interference * interference
    elif gap < zero:
        s_viol += gap * gap
    return s_g, s_viol, s_rhs


@wp.func
def padded_entry(padded: wp.array2d(dtype=Any), cell: int, width: int):
    """Entry of cell ``cell`` (row-major in a field ``width`` wide) in a padded 2-D buffer whose
    top-left corner holds the field."""
    row = cell // width
    return padded[row, cell - row * width]


@wp.kernel
def normal_interference(initial_gap: wp.array(dtype=Any), known_displacement: wp.array(dtype=Any),
                        parameters: wp.array(dtype=Any), interference: wp.array(dtype=Any)):
    """b = delta_z - h0 - u_known: how far the rigid surfaces overlap (negative where they do
    not), once per solve; the gap is g = K p - b."""
    i = wp.tid()
    interference[i] = parameters[P_APPROACH] - initial_gap[i] - known_displacement[i]


@wp.kernel
def normal_gap(
    displacement: wp.array(dtype=Any),
    interference: wp.array(dtype=Any),
    pressure: wp.array(dtype=Any),
    pressure_cap: Any,
    cells: Cells,
    gap: wp.array(dtype=Any),
    sums: wp.array(dtype=Any),
):
    """The exact gap g = u_z - b of the current pressure (``displacement`` = K p) and its residual
    sums into slots S_G, S_VIOL, S_RHS."""
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = pressure_cap - pressure_cap
    s_g = zero
    s_viol = zero
    s_rhs = zero
    for k in range(cells.per):
        i = cell_index(thread, cells, k)
        if i < cells.n:
            b = interference[i]
            g = displacement[i] - b
            gap[i] = g
            dg, dv, dr = residual_terms(pressure[i], g, b, pressure_cap)
            s_g += dg
            s_viol += dv
            s_rhs += dr
    block_add_vector(sums, S_G, wp.vector(s_g, s_viol, s_rhs), lane)  # slots S_G, S_VIOL, S_RHS


@wp.func
def is_free(pressure: Any, pressure_cap: Any):
    """Whether a cell is in the free set 0 < p < cap, where the gap must close."""
    return pressure > type(pressure)(0.0) and pressure < pressure_cap


@wp.func
def is_entering(pressure: Any, gap: Any):
    """Whether a cell out of contact penetrates (p = 0, g < 0): the preconditioned iteration
    steps it with the free set (``conjugate_direction``)."""
    zero = type(pressure)(0.0)
    return pressure <= zero and gap < zero


@wp.func
def is_leaving(pressure: Any, gap: Any, pressure_cap: Any):
    """Whether a cell at the cap opens (p >= cap, g > 0): the preconditioned iteration steps it
    with the free set as it does a penetrating cell (:func:`is_entering`)."""
    return pressure >= pressure_cap and gap > type(pressure)(0.0)


@wp.func
def is_stepped(pressure: Any, gap: Any, pressure_cap: Any, precondition: int):
    """Whether a cell takes part in the conjugate direction: the free set, and with
    ``precondition`` the cells that would leave their bound (:func:`is_entering`,
    :func:`is_leaving`)."""
    if is_free(pressure, pressure_cap):
        return True
    if precondition != 0:
        return is_entering(pressure, gap) or is_leaving(pressure, gap, pressure_cap)
    return False


@wp.kernel
def normal_free_gap(gap: wp.array(dtype=Any), pressure: wp.array(dtype=Any), pressure_cap: Any, width: int, per: int,
                    padded_input: wp.array2d(dtype=Any)):
    """The gap on the stepped cells (:func:`is_stepped`), 0 elsewhere, into the FFT backend's
    ``padded_input``: what the preconditioner transforms (``SolverSettings.normal_preconditioner``). Launched over (rows, chunks)
    (``LaunchCache.launch_rows``)."""
    i, c = wp.tid()
    for j in range(c * per, wp.min((c + 1) * per, width)):
        cell = i * width + j
        g = pressure_cap - pressure_cap
        p = pressure[cell]
        if is_stepped(p, gap[cell], pressure_cap, 1):
            g = gap[cell]
        padded_input[i, j] = padded_input.dtype(g)


@wp.func
def conjugate_direction(pressure: wp.array(dtype=Any), gap: wp.array(dtype=Any),
                        preconditioned: wp.array2d(dtype=Any), output_scale: Any, precondition: int,
                        direction: wp.array(dtype=Any), cell: int, width: int, beta: Any, pressure_cap: Any):
    """(t, g t) of a cell: t = z + beta t_last on the free set 0 < p < cap, 0 elsewhere, with
    z = g, or with ``precondition`` z = M g, the preconditioned gap, read from ``preconditioned``
    (the FFT backend's padded output, times ``output_scale``); g, z and t_last are read only there.
    With ``precondition`` the penetrating cells out of contact (:func:`is_entering`) and the
    opening cells at the cap (:func:`is_leaving`) take part as well: M g is a pressure, and their
    step -tau z (``projected_step``) moves them off their bound by the pressure the
    preconditioner gives them, in the step whose length the line search chose for all. Polonsky
    and Keer's rules, p = -tau g to re-enter and p = cap - tau g to leave the cap, take a gap for
    a pressure: with the plain iteration's tau (about 1 / K's largest eigenvalue) a small move;
    with the preconditioned one's (about 1) a band of w cells moves by about w times its pressure,
    and the residual of a warm start jumped 10-50 fold at its first iteration and took hundreds of
    iterations to recover, more the wider the band (the grid finer, the load step longer).

    t_last is read only on cells of the working set now; when beta != 0 those were in it then
    too, or had t = 0 (a cell that entered the contact sets delta = 0), so t there is the last
    iteration's direction."""
    zero = pressure_cap - pressure_cap
    t = zero
    gt = zero
    p = pressure[cell]
    if is_stepped(p, gap[cell], pressure_cap, precondition):
        g = gap[cell]
        z = g
        if precondition != 0:
            z = type(g)(output_scale * padded_entry(preconditioned, cell, width))
        t = z + beta * direction[cell]
        gt = g * t
    return t, gt


@wp.kernel
def normal_direction(
    gap: wp.array(dtype=Any),
    pressure: wp.array(dtype=Any),
    pressure_cap: Any,
    sums: wp.array(dtype=Any),
    scalars: wp.array(dtype=Any),
    preconditioned: wp.array2d(dtype=Any),
    output_scale: Any,
    precondition: int,
    width: int,
    per: int,
    direction: wp.array(dtype=Any),
    padded_input: wp.array2d(dtype=Any),
):
    """Conjugate direction t (:func:`conjugate_direction`) written to ``direction`` and to the
    FFT backend's ``padded_input`` (the field's corner of the padded grid). Launched over (rows,
    chunks) (``LaunchCache.launch_rows``): the CPU's path, where ``normal_step_sums`` follows the
    convolution."""
    i, c = wp.tid()
    beta = conjugacy(sums, scalars)
    for j in range(c * per, wp.min((c + 1) * per, width)):
        t, gt = conjugate_direction(pressure, gap, preconditioned, output_scale, precondition, direction,
                                    i * width + j, width, beta, pressure_cap)
        direction[i * width + j] = t
        padded_input[i, j] = t


@wp.kernel
def normal_direction_sum(
    gap: wp.array(dtype=Any),
    pressure: wp.array(dtype=Any),
    pressure_cap: Any,
    sums: wp.array(dtype=Any),
    scalars: wp.array(dtype=Any),
    preconditioned: wp.array2d(dtype=Any),
    output_scale: Any,
    precondition: int,
    width: int,
    cells: Cells,
    direction: wp.array(dtype=Any),
    padded_input: wp.array2d(dtype=Any),
):
    """``normal_direction``, and the sum of g t into slot S_GT: a reducing kernel. The CUDA path,
    where the spectral product sums (K t) . t (``spectral_normal_energy``) and
    ``normal_step_sums`` does not run."""
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    beta = conjugacy(sums, scalars)
    s_gt = beta - beta
    for k in range(cells.per):
        i = cell_index(thread, cells, k)
        if i < cells.n:
            t, gt = conjugate_direction(pressure, gap, preconditioned, output_scale, precondition, direction, i,
                                        width, beta, pressure_cap)
            s_gt += gt
            direction[i] = t
            row = i // width
            padded_input[row, i - row * width] = t
    block_add(sums, S_GT, s_gt)


@wp.kernel
def normal_step_sums(
    gap: wp.array(dtype=Any),
    direction: wp.array(dtype=Any),
    padded_output: wp.array2d(dtype=Any),
    output_scale: Any,
    width: int,
    cells: Cells,
    sums: wp.array(dtype=Any),
):
    """Sums of g t and (K t) t over the free set (where t can be non-zero), K t read from the FFT
    backend's padded output (times ``output_scale``)."""
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = output_scale - output_scale
    s_gt = zero
    s_rt = zero
    for k in range(cells.per):
        i = cell_index(thread, cells, k)
        if i < cells.n:
            t = direction[i]
            if t != zero:
                s_gt += gap[i] * t
                s_rt += output_scale * padded_entry(padded_output, i, width) * t
    block_add(sums, S_GT, s_gt)
    block_add(sums, S_RT, s_rt)


@wp.func
def projected_step(pressure: Any, gap: Any, direction: Any, response: Any, tau: Any, pressure_cap: Any):
    """One cell of the step (``normal_update``): returns the new pressure and carried gap, 1 where
    the cell re-entered (or left the cap), and |p - (p_old - tau t)|, what the projection changed."""
    zero = pressure_cap - pressure_cap
    p = pressure
    g = gap
    count = zero
    unprojected = p - tau * direction  # what K t accounts for (t = 0 off the free set)
    if p >= pressure_cap:
        if g > zero:
            if direction != zero:  # stepped with the free set (preconditioned)
                p = wp.min(wp.max(unprojected, zero), pressure_cap)
                count = wp.where(p < pressure_cap, type(zero)(1.0), zero)
            else:  # Polonsky and Keer's rule
                p = wp.max(pressure_cap - tau * g, zero)
                count = type(zero)(1.0)
    elif p > zero:
        p = wp.min(wp.max(unprojected, zero), pressure_cap)
    elif g < zero:
        if direction != zero:  # stepped with the free set (preconditioned: ``conjugate_direction``)
            p = wp.min(wp.max(unprojected, zero), pressure_cap)
            count = wp.where(p > zero, type(zero)(1.0), zero)
        else:  # Polonsky and Keer's re-entry
            p = wp.min(-tau * g, pressure_cap)
            count = type(zero)(1.0)
    return p, g - tau * response, count, wp.abs(p - unprojected)


@wp.kernel
def normal_update(
    direction: wp.array(dtype=Any),
    padded_output: wp.array2d(dtype=Any),
    output_scale: Any,
    width: int,
    interference: wp.array(dtype=Any),
    pressure_cap: Any,
    parameters: wp.array(dtype=Any),
    cells: Cells,
    pressure: wp.array(dtype=Any),
    gap: wp.array(dtype=Any),
    sums: wp.array(dtype=Any),
):
    """p <- clip(p - tau t, 0, cap); without the preconditioner, penetrating cells with p = 0
    re-enter with p = -tau g, and opening cells at the cap leave it with p = cap - tau g
    (Polonsky-Keer's rules; preconditioned, they step with the free set). The
    gap is carried, g <- g - tau K t (K t from the padded output): exact where no cell was
    projected; what the projections changed (their L1 norm, slot S_CORRECTION) it misses until
    the next exact gap. The residual sums of the new iterate with that gap go to the S_NEXT_*
    slots.

    An iterate whose relative residual is already under ``parameters[P_TOL]`` is left as it is.
    """
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = pressure_cap - pressure_cap
    tau = cg_step_length(sums)
    count = zero
    corrected = zero
    s_g = zero
    s_viol = zero
    s_rhs = zero
    done = cg_converged(sums, parameters[P_TOL])
    for k in range(cells.per):
        i = cell_index(thread, cells, k)
        if i < cells.n:
            # every load before any store: the compiler may not move a load above a store to
            # another array (they might alias), which would serialise the memory round trips
            p = pressure[i]
            g = gap[i]
            t = direction[i]
            r = output_scale * padded_entry(padded_output, i, width)
            if not done:
                old = p
                p, g, entered, changed = projected_step(p, g, t, r, tau, pressure_cap)
                count += entered
                corrected += changed
                if p != old:
                    pressure[i] = p
                gap[i] = g
            b = zero
            if p > zero:
                b = interference[i]
            dg, dv, dr = residual_terms(p, g, b, pressure_cap)
            s_g += dg
            s_viol += dv
            s_rhs += dr
    # slots S_IOL, S_CORRECTION, S_NEXT_G, S_NEXT_VIOL, S_NEXT_RHS (consecutive)
    block_add_vector(sums, S_IOL, wp.vector(count, corrected, s_g, s_viol, s_rhs), lane)


@wp.kernel
def normal_advance(sums: wp.array(dtype=Any), parameters: wp.array(dtype=Any), exact_every: int, column_norm: Any,
                   deferral: Any, scalars: wp.array(dtype=Any), residual_history: wp.array(dtype=Any),
                   deferred: wp.array(dtype=Any), recompute: wp.array(dtype=wp.int32), loop: wp.array(dtype=wp.int32),
                   refresh: wp.array(dtype=wp.int32), inner_loop: wp.array(dtype=wp.int32)):
    """One thread, end of an iteration: the shared :func:`~warpcontact.kernels.reduce.advance`
    (residual history, G_old, delta, the loop flag), then whether the next iteration starts
    from an exact gap (``recompute[0] = 1``: a convolution of p and ``normal_gap``), then the
    sums of the new iterate moved into slots 0-2 and the other slots zeroed for the next
    iteration.

    The carried gap misses K c, c the changes the projections made since the last exact gap;
    their L1 norms add up in ``deferred[0]``, and ||K c||_2 <= ``column_norm`` * that (the
    2-norm of one column of K bounds each cell's share). Recompute when that bound exceeds
    ``deferral`` times the violation the iteration started from (the carried gap's error stays
    a fraction of what the iteration corrects), when a change comes near convergence (relative
    residual under 4 tol: a converged iterate must be judged on the exact gap), every
    ``exact_every`` iterations (rounding), and always when ``parameters[P_EXACT]`` is 1.

    The loop also stops (settled) when the new iterate's residual, from the update's sums, is
    under the tolerance and no cell was projected since the last exact gap. ``inner_loop[0]``: 1
    while the loop goes on without a recompute (the solver's inner device loop, see
    ``ProjectedCG._run``).
    """
    # every load before the first store (see advance): one round trip to memory, not one per load
    tol = parameters[P_TOL]
    exact = parameters[P_EXACT]
    viol = sums[S_VIOL]
    rhs = sums[S_RHS]
    missed = deferred[0] + sums[S_CORRECTION]
    next_g = sums[S_NEXT_G]
    next_viol = sums[S_NEXT_VIOL]
    next_rhs = sums[S_NEXT_RHS]
    done, stopped = advance(sums, parameters, 0, scalars, residual_history, loop, refresh)
    zero = type(tol)(0.0)
    bound = column_norm * missed
    near = viol <= type(zero)(16.0) * tol * tol * rhs
    again = (exact > zero or bound * bound > deferral * deferral * viol or (near and missed > zero)
             or done % exact_every == 0)
    recompute[0] = wp.where(again, 1, 0)
    deferred[0] = wp.where(again, zero, missed)
    sums[S_G] = next_g
    sums[S_VIOL] = next_viol
    sums[S_RHS] = next_rhs
    for slot in range(S_GT, N_SUMS):
        sums[slot] = zero
    # the new iterate converged, and no projection changed since the last exact gap, so its carried
    # gap is exact but for rounding: stop here rather than in an iteration that only observes it
    res, finite = residual_of(next_viol, next_rhs)
    if not finite or (missed == zero and res < tol):
        stop_loop(scalars, loop, refresh, True)
        stopped = True
    inner_loop[0] = wp.where(stopped or again, 0, 1)


# slots of the first guess's sums (NormalSolver.guess_sums)
G_POSITIVE = wp.constant(0)  # cells with p > 0
G_UB = wp.constant(1)  # sum of (K s) b over the guess's support s > 0
G_UU = wp.constant(2)  # sum of (K s)^2 over it
G_BMAX = wp.constant(3)  # the largest interference b
N_GUESS_SUMS = 4


@wp.kernel
def count_positive(pressure: wp.array(dtype=Any), cells: Cells, guess_sums: wp.array(dtype=Any)):
    """guess_sums[G_POSITIVE] += the number of cells with p > 0."""
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = type(guess_sums[0])(0.0)
    count = zero
    for k in range(cells.per):
        i = cell_index(thread, cells, k)
        if i < cells.n and pressure[i] > zero:
            count += type(zero)(1.0)
    block_add(guess_sums, G_POSITIVE, count)


@wp.kernel
def guess_needed(guess_sums: wp.array(dtype=Any), flag: wp.array(dtype=wp.int32)):
    """One thread: ``flag[0]`` = 1 when no cell has p > 0 (a solve from rest: make the first
    guess), 0 for a warm start."""
    flag[0] = wp.where(guess_sums[G_POSITIVE] > type(guess_sums[0])(0.0), 0, 1)


@wp.func
def overlap(interference: Any):
    """max(b, 0): how far the rigid surfaces overlap; 0 where b is not finite (``wp.max`` returns
    its second argument when the first is NaN), so that a NaN stays in its own cell, where the
    residual names it, instead of spreading through the guess."""
    return wp.max(interference, type(interference)(0.0))


@wp.kernel
def guess_max_interference(interference: wp.array(dtype=Any), cells: Cells,
                           guess_sums: wp.array(dtype=Any)):
    """guess_sums[G_BMAX] <- max(guess_sums[G_BMAX], the largest overlap max(b, 0)) (zeroed
    before)."""
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    largest = type(guess_sums[0])(0.0)
    for k in range(cells.per):
        i = cell_index(thread, cells, k)
        if i < cells.n:
            largest = wp.max(largest, overlap(interference[i]))
    block_max(guess_sums, G_BMAX, largest, lane)


@wp.kernel
def guess_shape(interference: wp.array(dtype=Any), guess_sums: wp.array(dtype=Any), pressure: wp.array(dtype=Any)):
    """p <- s = sqrt(max(b - b_max / 2, 0)), the shape of the first guess: for a paraboloid on a
    flat, b - b_max / 2 = (a^2 - r^2) / 2R on the Hertz contact radius a^2 = R delta_z (the
    elastic contact closes half the rigid interference), so s is the Hertz pressure's shape."""
    i = wp.tid()
    b = overlap(interference[i])
    half = type(b)(0.5) * guess_sums[G_BMAX]
    pressure[i] = wp.sqrt(wp.max(b - half, type(b)(0.0)))


@wp.kernel
def guess_fit_sums(interference: wp.array(dtype=Any), shape: wp.array(dtype=Any), response: wp.array(dtype=Any),
                   cells: Cells, guess_sums: wp.array(dtype=Any)):
    """Sums of (K s) b and (K s)^2 over the support s > 0, for the least-squares scale of the
    first guess (``response`` = K s; b > 0 there)."""
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = type(guess_sums[0])(0.0)
    s_ub = zero
    s_uu = zero
    for k in range(cells.per):
        i = cell_index(thread, cells, k)
        if i < cells.n and shape[i] > zero:
            s_ub += response[i] * interference[i]
            s_uu += response[i] * response[i]
    block_add(guess_sums, G_UB, s_ub)
    block_add(guess_sums, G_UU, s_uu)


@wp.kernel
def guess_scale(guess_sums: wp.array(dtype=Any), pressure_cap: Any, response: wp.array(dtype=Any),
                pressure: wp.array(dtype=Any), displacement: wp.array(dtype=Any)):
    """p <- min(c s, cap), c = sum (K s) b / sum (K s)^2: K p fits the interference best on the
    support; and ``displacement`` <- c K s (``response`` = K s), which is K p where no cell
    reached the cap."""
    i = wp.tid()
    zero = pressure_cap - pressure_cap
    c = wp.where(guess_sums[G_UU] > zero, guess_sums[G_UB] / guess_sums[G_UU], zero)
    pressure[i] = wp.min(c * pressure[i], pressure_cap)
    displacement[i] = c * response[i]


for _k in (normal_interference, normal_gap, normal_free_gap, normal_direction, normal_direction_sum, normal_step_sums,
           normal_update, normal_advance, count_positive, guess_needed, guess_max_interference, guess_shape,
           guess_fit_sums, guess_scale):
    register_float_overloads(_k)

# the preconditioner's transforms in float32 beside float64 fields (SolverSettings.preconditioner_float32)
mixed_float_overloads(normal_free_gap, ("padded_input",))
mixed_float_overloads(normal_direction, ("preconditioned", "output_scale"))
mixed_float_overloads(normal_direction_sum, ("preconditioned", "output_scale"))

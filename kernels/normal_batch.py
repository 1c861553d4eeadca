"""Batched normal contact: the projected conjugate gradients of ``kernels/normal.py`` for B cases
of one grid size at once, each kernel launched once for all of them.

Fields are (B, n_cells) arrays, one row a case (row-major cells); the transforms' buffers are
each case's zero-padded (2 n, 2 n) grid, (B, 2 n, 2 n), whose (n, n) corner the kernels write and
read (``corner``: ``fft/batch.py``'s ``BatchConvolution``). Each case has its own row of
``sums``, ``scalars`` and ``parameters`` (the slots of ``kernels/reduce.py`` and
``kernels/normal.py``) and its own convergence: a case whose residual is under its tolerance, or
that reached the iteration limit, or whose fields are not finite, stops changing (``active`` = 0)
while the others go on. The per-cell physics is the single solver's (``residual_terms``,
``is_stepped``, ``projected_step``, ``overlap``); what differs is the case axis of the launch.

Reducing kernels are launched with ``wp.launch_tiled`` over (B, blocks): thread (case, block,
lane) visits the case's cells as in ``kernels/reduce.py`` and adds its block's sum to the case's
row of ``sums``. Elementwise kernels are launched over (B, n_cells).

An iteration (``solvers/normal_batch.py``): the exact gap of p (a convolution) and its residual
sums; the preconditioned gap M g on the stepped cells (a transform pair with 1 / K(k)) and
G = g . M g; the conjugate direction t; K t (a convolution) and the step sums g . t, (K t) . t;
the projected step; ``batch_advance`` carries each case's scalars and says whether it goes on.
"""

from typing import Any

import warp as wp

from .normal import G_BMAX, G_POSITIVE, G_UB, G_UU, is_stepped, overlap, projected_step, residual_terms
from .overloads import register_float_overloads
from .reduce import (
    Cells, C_DELTA, C_G_OLD, C_ITER, N_SHARED_SUMS, P_APPROACH, P_MAX_ITER, P_TOL, S_G, S_GT, S_RESTART,
    S_RHS, S_VIOL,
    block_add, block_add_vector, block_max, cell_index, cg_converged, cg_step_length, conjugacy, residual_of,
)

wp.set_module_options({"enable_backward": False})

# slots of the batched solve's ``sums`` rows: the shared ones of kernels/reduce.py, then (as the
# single solver's S_CORRECTION and S_NEXT_*) what the step's projections changed and the residual
# sums of the stepped iterate with its carried gap (consecutive: ``batch_update`` adds them as one)
B_CORRECTION = wp.constant(N_SHARED_SUMS + 0)
B_NEXT_VIOL = wp.constant(N_SHARED_SUMS + 1)
B_NEXT_RHS = wp.constant(N_SHARED_SUMS + 2)
N_BATCH_SUMS = wp.constant(N_SHARED_SUMS + 3)
#: ``batch_advance``'s counts (``flags``): cases still active, and those whose next iteration needs
#: an exact gap
F_ACTIVE = wp.constant(0)
F_EXACT = wp.constant(1)


@wp.func
def corner(buffer: wp.array3d(dtype=Any), case: int, cell: int, width: int):
    """Entry of cell ``cell`` (row-major, ``width`` wide) of case ``case`` in a (B, 2 n, 2 n)
    transform buffer."""
    row = cell // width
    return buffer[case, row, cell - row * width]


@wp.kernel
def batch_interference(initial_gap: wp.array2d(dtype=Any), known: wp.array2d(dtype=Any),
                       parameters: wp.array2d(dtype=Any), interference: wp.array2d(dtype=Any)):
    """b = delta_z - h0 - u_known of each case (u_known: the normal displacement of tractions held
    fixed, the shear's with friction; zero without)."""
    case, i = wp.tid()
    interference[case, i] = parameters[case, P_APPROACH] - initial_gap[case, i] - known[case, i]


@wp.kernel
def batch_gap(displacement: wp.array3d(dtype=Any), interference: wp.array2d(dtype=Any),
              pressure: wp.array2d(dtype=Any), pressure_cap: wp.array(dtype=Any), width: int, cells: Cells, gap: wp.array2d(dtype=Any), displacement_field: wp.array2d(dtype=Any),
              sums: wp.array2d(dtype=Any)):
    """The exact gap g = K p - b (K p read from ``displacement``, the transform's result, and
    kept in ``displacement_field``) and the residual sums S_VIOL, S_RHS of each case
    (``residual_terms``); S_G comes from the preconditioner (``batch_free_gap_sum``)."""
    case, block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    cap = pressure_cap[case]
    zero = cap - cap
    s_viol = zero
    s_rhs = zero
    for k in range(cells.per):
        i = cell_index(thread, cells, k)
        if i < cells.n:
            b = interference[case, i]
            u = corner(displacement, case, i, width)
            g = u - b
            gap[case, i] = g
            displacement_field[case, i] = u
            dg, dv, dr = residual_terms(pressure[case, i], g, b, cap)
            s_viol += dv
            s_rhs += dr
    block_add_vector(sums[case], S_VIOL, wp.vector(s_viol, s_rhs), lane)  # slots S_VIOL, S_RHS


@wp.kernel
def batch_free_gap(gap: wp.array2d(dtype=Any), pressure: wp.array2d(dtype=Any), pressure_cap: wp.array(dtype=Any),
                   width: int, buffer: wp.array3d(dtype=Any)):
    """The gap on the stepped cells (``is_stepped``, preconditioned), 0 elsewhere, into the
    each case's transform buffer: what the preconditioner transforms."""
    case, i = wp.tid()
    cap = pressure_cap[case]
    g = cap - cap
    if is_stepped(pressure[case, i], gap[case, i], cap, 1):
        g = gap[case, i]
    row = i // width
    buffer[case, row, i - row * width] = g


@wp.kernel
def batch_free_gap_sum(gap: wp.array2d(dtype=Any), pressure: wp.array2d(dtype=Any),
                       pressure_cap: wp.array(dtype=Any), preconditioned: wp.array3d(dtype=Any), width: int, cells: Cells, sums: wp.array2d(dtype=Any)):
    """G = g . M g over the stepped cells of each case into slot S_G (M g read from
    ``preconditioned``, the transform's result): the preconditioned squared gradient the conjugacy uses."""
    case, block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    cap = pressure_cap[case]
    total = cap - cap
    for k in range(cells.per):
        i = cell_index(thread, cells, k)
        if i < cells.n:
            g = gap[case, i]
            if is_stepped(pressure[case, i], g, cap, 1):
                total += g * corner(preconditioned, case, i, width)
    block_add(sums[case], S_G, total)


@wp.kernel
def batch_direction(gap: wp.array2d(dtype=Any), pressure: wp.array2d(dtype=Any), pressure_cap: wp.array(dtype=Any),
                    preconditioned: wp.array3d(dtype=Any), sums: wp.array2d(dtype=Any),
                    scalars: wp.array2d(dtype=Any), width: int, direction: wp.array2d(dtype=Any),
                    buffer: wp.array3d(dtype=Any)):
    """t = M g + beta t_last on the stepped cells, 0 elsewhere (``conjugate_direction`` of
    ``kernels/normal.py``, preconditioned), into ``direction`` and the transform ``buffer``."""
    case, i = wp.tid()
    cap = pressure_cap[case]
    t = cap - cap
    if is_stepped(pressure[case, i], gap[case, i], cap, 1):
        beta = conjugacy(sums[case], scalars[case])
        t = corner(preconditioned, case, i, width) + beta * direction[case, i]
    direction[case, i] = t
    row = i // width
    buffer[case, row, i - row * width] = t


@wp.kernel
def batch_step_sums(gap: wp.array2d(dtype=Any), direction: wp.array2d(dtype=Any), response: wp.array3d(dtype=Any),
                    width: int, cells: Cells, sums: wp.array2d(dtype=Any)):
    """g . t and (K t) . t of each case (K t read from ``response``, the transform's result)
    into slots S_GT, S_RT."""
    case, block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = gap[0, 0] - gap[0, 0]
    s_gt = zero
    s_rt = zero
    for k in range(cells.per):
        i = cell_index(thread, cells, k)
        if i < cells.n:
            t = direction[case, i]
            if t != zero:
                s_gt += gap[case, i] * t
                s_rt += corner(response, case, i, width) * t
    block_add_vector(sums[case], S_GT, wp.vector(s_gt, s_rt), lane)  # slots S_GT, S_RT


@wp.kernel
def batch_update(direction: wp.array2d(dtype=Any), response: wp.array3d(dtype=Any), width: int,
                 interference: wp.array2d(dtype=Any), pressure_cap: wp.array(dtype=Any),
                 parameters: wp.array2d(dtype=Any), active: wp.array(dtype=wp.int32),
                 cells: Cells, pressure: wp.array2d(dtype=Any), gap: wp.array2d(dtype=Any),
                 sums: wp.array2d(dtype=Any)):
    """The projected step of each active case (``projected_step``: p <- clip(p - tau t, 0, cap),
    the carried gap g <- g - tau K t), cells re-entering the free set counted into S_RESTART, what
    the projections changed (L1) into B_CORRECTION and the residual sums of the stepped iterate
    with its carried gap into B_NEXT_VIOL, B_NEXT_RHS. A case that is not active, or whose
    iterate already meets its tolerance, is left as it is."""
    case, block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    row = sums[case]
    cap = pressure_cap[case]
    zero = cap - cap
    count = zero
    corrected = zero
    s_viol = zero
    s_rhs = zero
    if active[case] != 0 and not cg_converged(row, parameters[case, P_TOL]):
        tau = cg_step_length(row)
        for k in range(cells.per):
            i = cell_index(thread, cells, k)
            if i < cells.n:
                p, g, entered, changed = projected_step(pressure[case, i], gap[case, i], direction[case, i],
                                                        corner(response, case, i, width), tau, cap)
                pressure[case, i] = p
                gap[case, i] = g
                count += entered
                corrected += changed
                b = zero
                if p > zero:
                    b = interference[case, i]
                dg, dv, dr = residual_terms(p, g, b, cap)
                s_viol += dv
                s_rhs += dr
    block_add(row, S_RESTART, count)
    block_add_vector(row, B_CORRECTION, wp.vector(corrected, s_viol, s_rhs), lane)  # B_CORRECTION, B_NEXT_*


@wp.func
def case_ended(sums: wp.array(dtype=Any), parameters: wp.array(dtype=Any), scalars: wp.array(dtype=Any)):
    """Whether a case of a batched solve stops at this iteration: its iterate (the one the
    iteration started from) meets its tolerance or is not finite, or it reached its iteration
    limit (its rows of ``sums``, ``parameters`` and ``scalars``)."""
    res, finite = residual_of(sums[S_VIOL], sums[S_RHS])
    return (not finite) or res < parameters[P_TOL] or int(scalars[C_ITER]) >= int(parameters[P_MAX_ITER])


@wp.kernel
def batch_advance(sums: wp.array2d(dtype=Any), parameters: wp.array2d(dtype=Any), exact_every: int,
                  column_norm: Any, deferral: Any, scalars: wp.array2d(dtype=Any), active: wp.array(dtype=wp.int32),
                  deferred: wp.array(dtype=Any), flags: wp.array(dtype=wp.int32)):
    """One thread a case, end of an iteration: a case whose iterate (the one the iteration
    started from) meets its tolerance, reached its iteration limit or is not finite stops
    (``active`` = 0); an active one counts the iteration and carries
    G_old and delta (0 after a cell re-entered: the conjugacy restarts). The stepped iterate's
    residual sums with its carried gap become the next iteration's; an active case counts in
    ``flags[F_EXACT]`` (zeroed before) when its next iteration must start from an exact gap, as
    the single solver's ``normal_advance`` decides: the carried gap misses K c, c what the
    projections changed since the last exact gap (their L1 norm adds up in ``deferred``), and
    ||K c||_2 <= ``column_norm`` x that; an exact gap when that bound passes ``deferral`` times
    the violation the iteration started from, when a change comes near the tolerance (a case
    stops on its exact residual), and every ``exact_every`` iterations (rounding). A case that has
    made its last iteration (its limit) stops there; active cases count in ``flags[F_ACTIVE]``
    (the device loop's condition: ``BatchNormalSolver.solve``). The other sums are zeroed."""
    case = wp.tid()
    zero = sums[case, S_G] - sums[case, S_G]
    viol = sums[case, S_VIOL]
    missed = deferred[case] + sums[case, B_CORRECTION]
    next_viol = sums[case, B_NEXT_VIOL]
    next_rhs = sums[case, B_NEXT_RHS]
    if active[case] != 0:
        it = int(scalars[case, C_ITER])
        if case_ended(sums[case], parameters[case], scalars[case]):
            active[case] = 0
        else:
            scalars[case, C_G_OLD] = sums[case, S_G]
            scalars[case, C_DELTA] = wp.where(sums[case, S_RESTART] > zero, zero, type(zero)(1.0))
            scalars[case, C_ITER] = type(zero)(it + 1)
            tol = parameters[case, P_TOL]
            near = next_viol <= type(zero)(16.0) * tol * tol * next_rhs
            bound = column_norm * missed
            deferred[case] = missed
            if it + 1 >= int(parameters[case, P_MAX_ITER]):
                active[case] = 0  # its last iteration: its residual is the solve's final exact gap's
            else:
                if bound * bound > deferral * deferral * viol or (near and missed > zero) or (it + 1) % exact_every == 0:
                    wp.atomic_add(flags, F_EXACT, 1)
                wp.atomic_add(flags, F_ACTIVE, 1)
    for slot in range(N_BATCH_SUMS):
        sums[case, slot] = zero
    sums[case, S_VIOL] = next_viol
    sums[case, S_RHS] = next_rhs


@wp.kernel
def batch_clear_residual(sums: wp.array2d(dtype=Any), deferred: wp.array(dtype=Any)):
    """S_VIOL and S_RHS of every case zeroed, and what its carried gap missed: an exact gap and its
    sums (``batch_gap``) come next."""
    case = wp.tid()
    zero = sums[case, S_VIOL] - sums[case, S_VIOL]
    sums[case, S_VIOL] = zero
    sums[case, S_RHS] = zero
    deferred[case] = zero


@wp.kernel
def batch_residual(sums: wp.array2d(dtype=Any), residual: wp.array(dtype=Any)):
    """The relative residual of each case's iterate from its sums (``residual_of``)."""
    case = wp.tid()
    res, finite = residual_of(sums[case, S_VIOL], sums[case, S_RHS])
    residual[case] = res


@wp.kernel
def batch_count_positive(pressure: wp.array2d(dtype=Any), cells: Cells,
                         guess_sums: wp.array2d(dtype=Any)):
    """Cells with p > 0 of each case into G_POSITIVE (zeroed before): whether a case starts from
    rest (``batch_guess_shape``)."""
    case, block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = pressure[0, 0] - pressure[0, 0]
    count = zero
    for k in range(cells.per):
        i = cell_index(thread, cells, k)
        if i < cells.n and pressure[case, i] > zero:
            count += type(zero)(1.0)
    block_add(guess_sums[case], G_POSITIVE, count)


@wp.kernel
def batch_max_interference(interference: wp.array2d(dtype=Any), cells: Cells,
                           guess_sums: wp.array2d(dtype=Any)):
    """Each case's largest overlap max(b, 0) into G_BMAX (``guess_max_interference``)."""
    case, block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    largest = interference[0, 0] - interference[0, 0]
    for k in range(cells.per):
        i = cell_index(thread, cells, k)
        if i < cells.n:
            largest = wp.max(largest, overlap(interference[case, i]))
    block_max(guess_sums[case], G_BMAX, largest, lane)


@wp.kernel
def batch_guess_shape(interference: wp.array2d(dtype=Any), guess_sums: wp.array2d(dtype=Any), width: int,
                      shape: wp.array2d(dtype=Any), buffer: wp.array3d(dtype=Any)):
    """s = sqrt(max(b - b_max / 2, 0)) of each case starting from rest (``guess_shape``: the
    Hertz pressure's shape), 0 for the others, into ``shape`` and the transform ``buffer``."""
    case, i = wp.tid()
    b = overlap(interference[case, i])
    zero = b - b
    s = zero
    if guess_sums[case, G_POSITIVE] <= zero:
        s = wp.sqrt(wp.max(b - type(b)(0.5) * guess_sums[case, G_BMAX], zero))
    shape[case, i] = s
    row = i // width
    buffer[case, row, i - row * width] = s


@wp.kernel
def batch_guess_fit_sums(interference: wp.array2d(dtype=Any), shape: wp.array2d(dtype=Any),
                         response: wp.array3d(dtype=Any), width: int, cells: Cells,
                         guess_sums: wp.array2d(dtype=Any)):
    """Sums of (K s) b and (K s)^2 over each case's support s > 0 (``guess_fit_sums``)."""
    case, block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = shape[0, 0] - shape[0, 0]
    s_ub = zero
    s_uu = zero
    for k in range(cells.per):
        i = cell_index(thread, cells, k)
        if i < cells.n and shape[case, i] > zero:
            u = corner(response, case, i, width)
            s_ub += u * interference[case, i]
            s_uu += u * u
    block_add_vector(guess_sums[case], G_UB, wp.vector(s_ub, s_uu), lane)  # slots G_UB, G_UU


@wp.kernel
def batch_guess_scale(guess_sums: wp.array2d(dtype=Any), shape: wp.array2d(dtype=Any),
                      pressure_cap: wp.array(dtype=Any), pressure: wp.array2d(dtype=Any)):
    """p <- min(c s, cap), c = sum (K s) b / sum (K s)^2, for each case starting from rest
    (``guess_scale``); the others keep their pressure (a warm start)."""
    case, i = wp.tid()
    zero = pressure_cap[case] - pressure_cap[case]
    if guess_sums[case, G_POSITIVE] <= zero:
        uu = guess_sums[case, G_UU]
        c = wp.where(uu > zero, guess_sums[case, G_UB] / uu, zero)
        pressure[case, i] = wp.min(c * shape[case, i], pressure_cap[case])


for _k in (batch_interference, batch_gap, batch_free_gap, batch_free_gap_sum, batch_direction,
           batch_step_sums, batch_update, batch_advance, batch_clear_residual, batch_residual, batch_count_positive,
           batch_max_interference, batch_guess_shape, batch_guess_fit_sums, batch_guess_scale):
    register_float_overloads(_k)


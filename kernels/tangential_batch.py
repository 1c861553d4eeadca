"""Batched partial slip: the plain bounded conjugate gradients of ``kernels/tangential.py`` (Chen
& Wang's iteration, Jacobi-scaled) for B cases of one grid size at once, each kernel launched
once for all of them.

Fields are (B, n_cells) arrays, one row a case; each case has its own row of ``sums``,
``scalars`` and ``parameters`` (the slots of ``kernels/reduce.py`` and ``kernels/tangential.py``),
its own self-influence ``stiffness`` (its material pair's) and its own convergence: a case whose
residual is under its tolerance, that reached its iteration limit or whose fields are not finite
stops changing (``active`` = 0) while the others go on. The per-cell rules are the single
solver's (``classify_cell``, ``gradient_cell``, ``plain_direction``, ``step_terms``,
``disk_step``, ``may_release``); what differs is the case axis of the launch.

Reducing kernels are launched with ``wp.launch_tiled`` over (B, blocks) as in
``kernels/normal_batch.py``; elementwise kernels over (B, n_cells).

An iteration (``solvers/tangential_batch.py``): K q of every case (batched transforms), the exact
g and the residual sums (``batch_tangential_residual``), the direction, K t, the step sums, the
projected step, and ``batch_tangential_advance``, which carries each case's scalars and says
whether it goes on.
"""

from typing import Any

import warp as wp

from .normal_batch import case_ended
from .overloads import register_float_overloads
from .reduce import (
    Cells, C_DELTA, C_G_OLD, C_ITER, P_MAX_ITER, P_TOL, S_G, S_GT, S_RESTART, S_RHS, S_VIOL,
    block_add, block_add_vector, cell_index, cg_converged, cg_step_length, conjugacy,
)
from .tangential import (
    N_SUMS, N_SUMS_PRECONDITIONED, OUT, S_CORRECTION, S_NEXT_G, S_NEXT_REVERSAL, S_NEXT_VIOL, S_REVERSAL, S_STICK,
    SLIP, STICK, carried_cell, classify_cell, disk_step, gradient_cell, may_release, plain_direction, residual_terms,
    slip_direction, step_terms,
)

wp.set_module_options({"enable_backward": False})

#: ``batch_tangential_advance``'s counts (``flags``): cases still active, cases whose next
#: iteration must start from an exact g (``batch_tangential_carried_advance``)
F_ACTIVE = wp.constant(0)
F_EXACT = wp.constant(1)


@wp.kernel
def batch_tangential_classify(shear_limit: wp.array2d(dtype=Any), active: wp.array(dtype=wp.int32),
                              keep_slip: int, shear_x: wp.array2d(dtype=Any), shear_y: wp.array2d(dtype=Any),
                              status: wp.array2d(dtype=wp.int32)):
    """The start of each active case's solve (``tangential_classify``: with ``keep_slip`` 1, the
    preconditioned iteration, the cells that slipped stay slip on their new circle; 0, the plain
    iteration, reclassifies every cell)."""
    case, i = wp.tid()
    if active[case] != 0:
        qx, qy, st = classify_cell(shear_limit[case, i], shear_x[case, i], shear_y[case, i], status[case, i],
                                   keep_slip)
        shear_x[case, i] = qx
        shear_y[case, i] = qy
        status[case, i] = st


@wp.kernel
def batch_tangential_residual(disp_x: wp.array2d(dtype=Any), disp_y: wp.array2d(dtype=Any),
                              known_x: wp.array2d(dtype=Any), known_y: wp.array2d(dtype=Any),
                              target_x: wp.array2d(dtype=Any), target_y: wp.array2d(dtype=Any),
                              shear_x: wp.array2d(dtype=Any), shear_y: wp.array2d(dtype=Any),
                              shear_limit: wp.array2d(dtype=Any), status: wp.array2d(dtype=wp.int32),
                              stiffness: wp.array(dtype=Any), jacobi_stick: int, cells: Cells,
                              grad_x: wp.array2d(dtype=Any), grad_y: wp.array2d(dtype=Any),
                              sums: wp.array2d(dtype=Any)):
    """Each case's exact g = K q + u_known - target from ``disp`` = K q, and its residual sums
    (slots S_G, S_VIOL, S_RHS, S_STICK, S_REVERSAL: the single solver's ``tangential_residual``;
    ``jacobi_stick`` = 1, the plain iteration: S_G with the stick cells' Jacobi part; 0: their
    part comes from ``batch_stick_energy``)."""
    case, block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    k_self = stiffness[case]
    zero = k_self - k_self
    first = wp.vector(zero, zero, zero)
    second = wp.vector(zero, zero)
    for k in range(cells.per):
        i = cell_index(thread, cells, k)
        if i < cells.n:
            gx, gy, a, b = gradient_cell(disp_x[case, i], disp_y[case, i], known_x[case, i], known_y[case, i],
                                         target_x[case, i], target_y[case, i], shear_x[case, i], shear_y[case, i],
                                         shear_limit[case, i], status[case, i], k_self, jacobi_stick)
            grad_x[case, i] = gx
            grad_y[case, i] = gy
            first += a
            second += b
    row = sums[case]
    block_add_vector(row, S_G, first, lane)  # slots S_G, S_VIOL, S_RHS
    block_add_vector(row, S_STICK, second, lane)  # slots S_STICK, S_REVERSAL


@wp.kernel
def batch_tangential_direction(grad_x: wp.array2d(dtype=Any), grad_y: wp.array2d(dtype=Any),
                               shear_x: wp.array2d(dtype=Any), shear_y: wp.array2d(dtype=Any),
                               shear_limit: wp.array2d(dtype=Any), status: wp.array2d(dtype=wp.int32),
                               stiffness: wp.array(dtype=Any), sums: wp.array2d(dtype=Any),
                               scalars: wp.array2d(dtype=Any), dir_x: wp.array2d(dtype=Any),
                               dir_y: wp.array2d(dtype=Any)):
    """Each case's conjugate direction (``tangential_direction``)."""
    case, i = wp.tid()
    t = plain_direction(grad_x[case, i], grad_y[case, i], shear_x[case, i], shear_y[case, i], shear_limit[case, i],
                        status[case, i], dir_x[case, i], dir_y[case, i], stiffness[case],
                        conjugacy(sums[case], scalars[case]))
    dir_x[case, i] = t[0]
    dir_y[case, i] = t[1]


@wp.kernel
def batch_stick_gradient(grad_x: wp.array2d(dtype=Any), grad_y: wp.array2d(dtype=Any),
                         status: wp.array2d(dtype=wp.int32), stick_x: wp.array2d(dtype=Any),
                         stick_y: wp.array2d(dtype=Any)):
    """g on each case's stick cells, 0 elsewhere: what the preconditioner transforms
    (``tangential_stick_gradient``)."""
    case, i = wp.tid()
    stick = status[case, i] == STICK
    zero = grad_x[case, i] - grad_x[case, i]
    stick_x[case, i] = wp.where(stick, grad_x[case, i], zero)
    stick_y[case, i] = wp.where(stick, grad_y[case, i], zero)


@wp.kernel
def batch_stick_energy(grad_x: wp.array2d(dtype=Any), grad_y: wp.array2d(dtype=Any),
                       precond_x: wp.array2d(dtype=Any), precond_y: wp.array2d(dtype=Any),
                       status: wp.array2d(dtype=wp.int32), cells: Cells, sums: wp.array2d(dtype=Any)):
    """Each case's g . M g over its stick cells (z = M g in ``precond``) added to slot S_G, where
    ``batch_tangential_residual`` put the slip cells' part."""
    case, block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = sums[case, S_G] - sums[case, S_G]
    energy = zero
    for k in range(cells.per):
        i = cell_index(thread, cells, k)
        if i < cells.n:
            if status[case, i] == STICK:
                energy += grad_x[case, i] * precond_x[case, i] + grad_y[case, i] * precond_y[case, i]
    block_add(sums[case], S_G, energy)


@wp.kernel
def batch_tangential_direction_preconditioned(grad_x: wp.array2d(dtype=Any), grad_y: wp.array2d(dtype=Any),
                                              precond_x: wp.array2d(dtype=Any), precond_y: wp.array2d(dtype=Any),
                                              shear_x: wp.array2d(dtype=Any), shear_y: wp.array2d(dtype=Any),
                                              shear_limit: wp.array2d(dtype=Any),
                                              status: wp.array2d(dtype=wp.int32), stiffness: wp.array(dtype=Any),
                                              sums: wp.array2d(dtype=Any), scalars: wp.array2d(dtype=Any),
                                              dir_x: wp.array2d(dtype=Any), dir_y: wp.array2d(dtype=Any)):
    """Each case's preconditioned conjugate direction: t = z + beta t_last on stick cells with
    z = M g from ``precond``, the Jacobi-scaled tangent part on slip cells (``slip_direction``), 0
    out of contact (``tangential_direction_stick`` and ``tangential_direction_rest``)."""
    case, i = wp.tid()
    beta = conjugacy(sums[case], scalars[case])
    st = status[case, i]
    tx = beta - beta
    ty = tx
    if st == STICK:
        tx = precond_x[case, i] + beta * dir_x[case, i]
        ty = precond_y[case, i] + beta * dir_y[case, i]
    elif st == SLIP:
        t = slip_direction(grad_x[case, i], grad_y[case, i], shear_x[case, i], shear_y[case, i], shear_limit[case, i],
                           dir_x[case, i], dir_y[case, i], stiffness[case], beta)
        tx = t[0]
        ty = t[1]
    dir_x[case, i] = tx
    dir_y[case, i] = ty


@wp.kernel
def batch_tangential_step_sums(grad_x: wp.array2d(dtype=Any), grad_y: wp.array2d(dtype=Any),
                               dir_x: wp.array2d(dtype=Any), dir_y: wp.array2d(dtype=Any),
                               resp_x: wp.array2d(dtype=Any), resp_y: wp.array2d(dtype=Any),
                               shear_x: wp.array2d(dtype=Any), shear_y: wp.array2d(dtype=Any),
                               shear_limit: wp.array2d(dtype=Any), status: wp.array2d(dtype=wp.int32),
                               cells: Cells, sums: wp.array2d(dtype=Any)):
    """Each case's g.t and t.(K t) + the slip cells' curvature term into slots S_GT, S_RT
    (``tangential_step_sums``)."""
    case, block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = sums[case, S_GT] - sums[case, S_GT]
    s_gt = zero
    s_rt = zero
    for k in range(cells.per):
        i = cell_index(thread, cells, k)
        if i < cells.n:
            gt, rt = step_terms(grad_x[case, i], grad_y[case, i], dir_x[case, i], dir_y[case, i], resp_x[case, i],
                                resp_y[case, i], shear_x[case, i], shear_y[case, i], shear_limit[case, i],
                                status[case, i])
            s_gt += gt
            s_rt += rt
    block_add_vector(sums[case], S_GT, wp.vector(s_gt, s_rt), lane)  # slots S_GT, S_RT


@wp.kernel
def batch_tangential_update(grad_x: wp.array2d(dtype=Any), grad_y: wp.array2d(dtype=Any),
                            dir_x: wp.array2d(dtype=Any), dir_y: wp.array2d(dtype=Any),
                            shear_limit: wp.array2d(dtype=Any), stiffness: wp.array(dtype=Any),
                            parameters: wp.array2d(dtype=Any), active: wp.array(dtype=wp.int32), cells: Cells,
                            shear_x: wp.array2d(dtype=Any), shear_y: wp.array2d(dtype=Any),
                            status: wp.array2d(dtype=wp.int32), sums: wp.array2d(dtype=Any)):
    """The projected step of each active case (``tangential_update``: ``disk_step`` with the
    proportioning test, the released cells counted into S_RESTART); a case that is not active,
    or whose iterate already meets its tolerance, is left as it is."""
    case, block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    row = sums[case]
    tol = parameters[case, P_TOL]
    zero = tol - tol
    released = zero
    if active[case] != 0 and not cg_converged(row, tol):
        tau = cg_step_length(row)
        tau_release = wp.where(tau > zero, tau, type(zero)(1.0) / stiffness[case])
        release = may_release(row, tol)
        for k in range(cells.per):
            i = cell_index(thread, cells, k)
            if i < cells.n:
                st = status[case, i]
                if st != OUT:
                    q, new, change = disk_step(st, shear_x[case, i], shear_y[case, i], grad_x[case, i],
                                               grad_y[case, i], dir_x[case, i], dir_y[case, i], shear_limit[case, i],
                                               tau, tau_release, release)
                    if new != st:
                        status[case, i] = new
                        if new == STICK:
                            released += type(zero)(1.0)
                    shear_x[case, i] = q[0]
                    shear_y[case, i] = q[1]
    block_add(row, S_RESTART, released)


@wp.kernel
def batch_tangential_advance(sums: wp.array2d(dtype=Any), parameters: wp.array2d(dtype=Any), restart_every: int,
                             scalars: wp.array2d(dtype=Any), active: wp.array(dtype=wp.int32),
                             flags: wp.array(dtype=wp.int32)):
    """One thread a case, end of an iteration (``reduce.advance`` per case): a case whose iterate
    (the one the iteration started from) meets its tolerance, reached its iteration limit or is
    not finite stops (``active`` = 0); an active one counts the iteration, carries G_old (0 every
    ``restart_every`` iterations) and delta (0 after a released cell: the conjugacy restarts),
    and counts in ``flags[F_ACTIVE]`` (zeroed before: the device loop's condition); a case that
    has made its last iteration (its limit) stops there. Every sum is zeroed: the next iteration
    makes them anew from its exact g."""
    case = wp.tid()
    zero = sums[case, S_G] - sums[case, S_G]
    if active[case] != 0:
        if case_ended(sums[case], parameters[case], scalars[case]):
            active[case] = 0
        else:
            done = int(scalars[case, C_ITER]) + 1
            scalars[case, C_G_OLD] = wp.where(restart_every > 0 and done % restart_every == 0, zero,
                                              sums[case, S_G])
            scalars[case, C_DELTA] = wp.where(sums[case, S_RESTART] > zero, zero, type(zero)(1.0))
            scalars[case, C_ITER] = type(zero)(done)
            if done >= int(parameters[case, P_MAX_ITER]):
                active[case] = 0  # its last iteration: its residual is the solve's final gradient's
            else:
                wp.atomic_add(flags, F_ACTIVE, 1)
    for slot in range(N_SUMS):
        sums[case, slot] = zero


@wp.kernel
def batch_tangential_carried_update(dir_x: wp.array2d(dtype=Any), dir_y: wp.array2d(dtype=Any),
                                    resp_x: wp.array2d(dtype=Any), resp_y: wp.array2d(dtype=Any),
                                    shear_limit: wp.array2d(dtype=Any), stiffness: wp.array(dtype=Any),
                                    parameters: wp.array2d(dtype=Any), active: wp.array(dtype=wp.int32),
                                    cells: Cells, shear_x: wp.array2d(dtype=Any), shear_y: wp.array2d(dtype=Any),
                                    status: wp.array2d(dtype=wp.int32), grad_x: wp.array2d(dtype=Any),
                                    grad_y: wp.array2d(dtype=Any), sums: wp.array2d(dtype=Any)):
    """The projected step of each active case with g carried (the single solver's
    ``tangential_carried_update``, ``carried_cell`` a cell): g <- g - tau K t, what the
    projections changed into S_CORRECTION, the new iterate's S_G, S_VIOL and S_REVERSAL into
    S_NEXT_G, S_NEXT_VIOL and S_NEXT_REVERSAL, the released cells into S_RESTART. A case whose
    iterate already meets its tolerance is not stepped (its sums are its iterate's); a case not
    active is left as it is."""
    case, block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    row = sums[case]
    tol = parameters[case, P_TOL]
    zero = tol - tol
    if active[case] != 0:
        k_self = stiffness[case]
        tau = cg_step_length(row)
        tau_release = wp.where(tau > zero, tau, type(zero)(1.0) / k_self)
        done = cg_converged(row, tol)
        release = may_release(row, tol)
        released = zero
        terms = wp.vector(zero, zero, zero, zero)  # S_CORRECTION, S_NEXT_G, S_NEXT_VIOL, S_NEXT_REVERSAL
        for k in range(cells.per):
            i = cell_index(thread, cells, k)
            if i < cells.n:
                st = status[case, i]
                if st != OUT:
                    q_max = shear_limit[case, i]
                    qx = shear_x[case, i]
                    qy = shear_y[case, i]
                    gx = grad_x[case, i]
                    gy = grad_y[case, i]
                    if done:
                        dg, dv, dr = residual_terms(gx, gy, qx, qy, q_max, st, k_self)
                        terms += wp.vector(zero, dg, dv, dr)
                    else:
                        fields, new, cell = carried_cell(st, q_max, qx, qy, gx, gy, dir_x[case, i], dir_y[case, i],
                                                         resp_x[case, i], resp_y[case, i], tau, tau_release, release,
                                                         k_self)
                        shear_x[case, i] = fields[0]
                        shear_y[case, i] = fields[1]
                        grad_x[case, i] = fields[2]
                        grad_y[case, i] = fields[3]
                        if new != st:
                            status[case, i] = new
                            if new == STICK:
                                released += type(zero)(1.0)
                        terms += cell
        block_add(row, S_RESTART, released)
        block_add_vector(row, S_CORRECTION, terms, lane)


@wp.kernel
def batch_tangential_carried_advance(sums: wp.array2d(dtype=Any), parameters: wp.array2d(dtype=Any),
                                     restart_every: int, exact_every: int, column_norm: wp.array(dtype=Any),
                                     deferral: Any, scalars: wp.array2d(dtype=Any), active: wp.array(dtype=wp.int32),
                                     deferred: wp.array(dtype=Any), flags: wp.array(dtype=wp.int32)):
    """One thread a case, end of an iteration with g carried: as ``batch_tangential_advance``
    (a case whose iterate, the one the iteration started from, meets its tolerance, reached its
    limit or is not finite stops; the conjugacy carried or restarted), then the stepped iterate's
    sums with the carried g become the next iteration's (S_NEXT_G, S_NEXT_VIOL, S_NEXT_REVERSAL
    into S_G, S_VIOL, S_REVERSAL; S_RHS kept; the rest zeroed), and an active case counts in
    ``flags[F_EXACT]`` (zeroed before) where its next iteration must start from an exact g, as
    the single solver's ``tangential_advance`` decides: after a released cell, every
    ``exact_every`` iterations, and where ``column_norm`` (the row's bound on ||K c||_2 /
    ||c||_1) times what the projections changed since the last exact g (``deferred``) passes
    ``deferral`` times the violation the iteration started from. A case stops on its carried
    residual; the solver judges it on its exact g (``BatchTangentialSolver.solve``)."""
    case = wp.tid()
    zero = sums[case, S_G] - sums[case, S_G]
    viol = sums[case, S_VIOL]
    released = sums[case, S_RESTART]
    missed = deferred[case] + sums[case, S_CORRECTION]
    next_g = sums[case, S_NEXT_G]
    next_viol = sums[case, S_NEXT_VIOL]
    next_reversal = sums[case, S_NEXT_REVERSAL]
    if active[case] != 0:
        if case_ended(sums[case], parameters[case], scalars[case]):
            active[case] = 0
        else:
            done = int(scalars[case, C_ITER]) + 1
            scalars[case, C_G_OLD] = wp.where(restart_every > 0 and done % restart_every == 0, zero, sums[case, S_G])
            scalars[case, C_DELTA] = wp.where(released > zero, zero, type(zero)(1.0))
            scalars[case, C_ITER] = type(zero)(done)
            bound = column_norm[case] * missed
            deferred[case] = missed
            if done >= int(parameters[case, P_MAX_ITER]):
                active[case] = 0  # its last iteration: its residual is the solve's final exact g's
            else:
                if released > zero or bound * bound > deferral * deferral * viol or done % exact_every == 0:
                    wp.atomic_add(flags, F_EXACT, 1)
                wp.atomic_add(flags, F_ACTIVE, 1)
    for slot in range(N_SUMS_PRECONDITIONED):
        if slot != S_RHS:
            sums[case, slot] = zero
    sums[case, S_G] = next_g
    sums[case, S_VIOL] = next_viol
    sums[case, S_REVERSAL] = next_reversal


for _k in (batch_tangential_classify, batch_tangential_residual, batch_tangential_direction,
           batch_stick_gradient, batch_stick_energy, batch_tangential_direction_preconditioned,
           batch_tangential_step_sums, batch_tangential_update, batch_tangential_advance,
           batch_tangential_carried_update, batch_tangential_carried_advance):
    register_float_overloads(_k)

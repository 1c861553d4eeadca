"""Bounded conjugate gradients for the shear traction under a disk bound |q| <= q_max.

After Chen, W. W. & Wang, Q. J. (2008), "A numerical model for the point contact of dissimilar
materials considering tangential tractions", Mech. Mater. 40, 936-948, with the disk bound of
MODEL.md section 5 in place of their Coulomb limit. Scaled units (tractions / E*, lengths / dx),
vector fields as separate x and y arrays of shape (n_cells,).

The problem per load step is the convex quadratic programme
    min 1/2 q.K q - q.b  subject to |q_i| <= q_max_i,   b = delta - s_prev - u_known,
whose optimality conditions are the stick/slip conditions: with g = K q + u_known - (delta -
s_prev) = -(slip increment), stick cells (|q| < q_max) have g = 0 and slip cells (|q| = q_max)
have the slip increment -g along q (q is the traction on the flat; on the sphere it opposes the
slip). The conjugate directions span the stick cells' two components and the slip cells'
tangent to their circle (the rotation of q), where the Hessian gains the constraint's curvature
lambda / q_max (lambda = |slip increment|): an active-set Newton-CG on the product of disks.
After each step slip cells are retracted onto their circle; stick cells that cross it are
projected onto it and become slip; slip cells whose slip would reverse (g.q > 0) are released
into stick with the step P(q - tau g) (the disk analogue of Polonsky-Keer's re-entry rule), and
the conjugacy restarts; releases wait for the proportioning test (``may_release``: the reversal
a large share of the violation, or the iterate near the tolerance).

Cell status: 0 out of contact (q_max = 0), 1 stick, 2 slip.

Two iterations share these rules (``TangentialSolver.preconditioned``):

- plain (Chen & Wang): ``tangential_residual`` (the exact g from K q) and ``tangential_direction``
  (Jacobi scaling by the self-influence, plus lambda / q_max on slip cells), then K t,
  ``tangential_step_sums``, ``tangential_update`` and ``reduce.cg_advance``: two applications of
  K_tt per iteration;
- preconditioned (the default): g is carried (``tangential_carried_update``: g <- g - tau K t)
  and made exact (``tangential_residual`` after K q) where ``tangential_advance`` asks for it;
  the direction is built from z = M g, M the circulant inverse of K_tt
  (``spectral.spectral_tangential_inverse_energy``) applied to g on the stick cells
  (``tangential_stick_gradient`` writes it into the FFT backend's padded input) and read there
  (``tangential_direction_stick`` for x, ``tangential_direction_rest`` for y and the slip
  cells, which keep the Jacobi scaling): one application of K_tt and one of M per iteration.
"""

from typing import Any

import warp as wp

from .overloads import mixed_float_overloads, register_float_overloads
from .reduce import (  # noqa: F401  (shared slots)
    Cells, C_DELTA, C_G_OLD, N_SCALARS, N_PARAMETERS, N_SHARED_SUMS, P_EXACT, P_TOL, S_G, S_GT, S_RHS, S_RT, S_VIOL, advance, block_add,
    block_add_vector, cell_index, cg_converged, cg_step_length, conjugacy, residual_of, stop_loop,
)
from .reduce import S_RESTART as S_RELEASED  # slip cells released into stick by the last step

# no adjoints: nothing differentiates these kernels, and compiling them doubles the build
wp.set_module_options({"enable_backward": False})

# the tangential solver's own slots of ``sums``, after the shared ones of kernels/reduce.py (S_G
# holds g . z, z = M^-1 P g)
S_STICK = wp.constant(N_SHARED_SUMS + 0)  # count of stick cells
S_REVERSAL = wp.constant(N_SHARED_SUMS + 1)  # the iterate's reversing slip: sum over slip cells of max(g.e, 0)^2
N_SUMS = N_SHARED_SUMS + 2

#: the proportioning test (after Dostal's MPRGP): slip cells whose slip would reverse are released
#: into stick only where the squared reversal (slot S_REVERSAL) exceeds RELEASE_RATIO^2 times the
#: rest of the squared violation, or where the relative residual is within RELEASE_NEAR times the
#: tolerance (there the rest sits near the iteration's rounding floor and may not fall under the
#: reversal); until then they stay on their circle and the conjugate directions go on over the
#: unchanged sets (a release restarts the conjugacy)
RELEASE_RATIO = wp.constant(1.0)
RELEASE_NEAR = wp.constant(100.0)

OUT = wp.constant(0)
STICK = wp.constant(1)
SLIP = wp.constant(2)


@wp.func
def project_disk(qx: Any, qy: Any, q_max: Any):
    """Projection of (qx, qy) onto the disk of radius q_max."""
    norm = wp.sqrt(qx * qx + qy * qy)
    scale = wp.where(norm > q_max, q_max / wp.max(norm, q_max + q_max * type(qx)(1e-30)), type(qx)(1.0))
    return wp.vector(qx * scale, qy * scale)


@wp.func
def slip_frame(qx: Any, qy: Any):
    """Unit vector along q (the outward normal of the circle at q)."""
    qn = wp.sqrt(qx * qx + qy * qy)
    inv = wp.where(qn > type(qx)(0.0), type(qx)(1.0) / qn, type(qx)(0.0))
    return wp.vector(qx * inv, qy * inv)


@wp.func
def classify_cell(q_max: Any, qx: Any, qy: Any, status: int, keep_slip: int):
    """One cell's start of a solve (``tangential_classify``): its shear and status."""
    zero = q_max - q_max
    new = STICK
    if q_max <= zero:
        qx = zero
        qy = zero
        new = OUT
    elif qx * qx + qy * qy >= q_max * q_max:
        q = project_disk(qx, qy, q_max)
        qx = q[0]
        qy = q[1]
        new = SLIP
    elif keep_slip != 0 and status == SLIP and qx * qx + qy * qy > zero:
        e = slip_frame(qx, qy)
        qx = q_max * e[0]
        qy = q_max * e[1]
        new = SLIP
    return qx, qy, new


@wp.kernel
def tangential_classify(
    shear_limit: wp.array(dtype=Any),
    keep_slip: int,
    shear_x: wp.array(dtype=Any),
    shear_y: wp.array(dtype=Any),
    status: wp.array(dtype=wp.int32),
):
    """At the start of a solve: project q onto the current disks and set each cell's status.
    ``keep_slip`` = 1: a cell that slipped when the last solve ended (status 2) and has q != 0
    stays slip, its q scaled onto the new circle, also where q_max grew (the preconditioned
    solve: such a cell left inside its disk by a grown q_max, or by rounding, would start as a
    stick cell with the whole slip increment as its residual; the release rule returns it to
    stick when its slip reverses)."""
    i = wp.tid()
    qx, qy, st = classify_cell(shear_limit[i], shear_x[i], shear_y[i], status[i], keep_slip)
    shear_x[i] = qx
    shear_y[i] = qy
    status[i] = st


@wp.func
def residual_terms(gx: Any, gy: Any, qx: Any, qy: Any, q_max: Any, status: int, stiffness: Any):
    """One cell's shares of the sums S_G and S_VIOL: on slip cells g_t . g_t / (``stiffness`` +
    lambda / q_max) (the Jacobi part of g . M g) and the violation |g_t|^2 + max(g.e, 0)^2; on
    stick cells the violation |g|^2 and no share of S_G (the plain iteration adds their Jacobi
    share, ``tangential_residual``; the preconditioned one takes it from the spectral product);
    and the slip cell's reversal max(g.e, 0)^2 (its share of S_REVERSAL, also in S_VIOL)."""
    zero = type(gx)(0.0)
    s_g = zero
    s_viol = zero
    s_reversal = zero
    if status == STICK:
        s_viol = gx * gx + gy * gy
    elif status == SLIP:
        e = slip_frame(qx, qy)
        normal = gx * e[0] + gy * e[1]
        tx = gx - normal * e[0]
        ty = gy - normal * e[1]
        s_g = (tx * tx + ty * ty) / (stiffness + wp.max(-normal, zero) / q_max)
        s_reversal = wp.max(normal, zero) * wp.max(normal, zero)
        s_viol = tx * tx + ty * ty + s_reversal
    return s_g, s_viol, s_reversal


@wp.func
def gradient_cell(disp_x: Any, disp_y: Any, known_x: Any, known_y: Any, target_x: Any, target_y: Any,
                  qx: Any, qy: Any, q_max: Any, status: int, stiffness: Any, jacobi_stick: int):
    """One cell of ``tangential_residual``: g = K q + u_known - target, and its shares of the
    slots S_G, S_VIOL, S_RHS, S_STICK and S_REVERSAL (0 out of contact)."""
    zero = stiffness - stiffness
    rx = target_x - known_x
    ry = target_y - known_y
    gx = disp_x - rx
    gy = disp_y - ry
    s_g = zero
    s_viol = zero
    s_rhs = zero
    s_stick = zero
    s_reversal = zero
    if status != OUT:
        s_rhs = rx * rx + ry * ry
        s_g, s_viol, s_reversal = residual_terms(gx, gy, qx, qy, q_max, status, stiffness)
        if status == STICK:
            s_stick = type(zero)(1.0)
            if jacobi_stick != 0:
                s_g = (gx * gx + gy * gy) / stiffness
    return gx, gy, wp.vector(s_g, s_viol, s_rhs), wp.vector(s_stick, s_reversal)


@wp.kernel
def tangential_residual(
    disp_x: wp.array(dtype=Any),
    disp_y: wp.array(dtype=Any),
    known_x: wp.array(dtype=Any),
    known_y: wp.array(dtype=Any),
    target_x: wp.array(dtype=Any),
    target_y: wp.array(dtype=Any),
    shear_x: wp.array(dtype=Any),
    shear_y: wp.array(dtype=Any),
    shear_limit: wp.array(dtype=Any),
    status: wp.array(dtype=wp.int32),
    stiffness: Any,
    jacobi_stick: int,
    cells: Cells,
    grad_x: wp.array(dtype=Any),
    grad_y: wp.array(dtype=Any),
    sums: wp.array(dtype=Any),
):
    """The exact g = K q + u_known - target (= minus the slip increment) from ``disp`` = K q, and
    the iterate's residual sums: slots S_VIOL, S_RHS, S_STICK (the stick cells), S_REVERSAL and S_G, the slip
    cells' part (:func:`residual_terms`) plus, with ``jacobi_stick`` = 1 (the plain iteration),
    the stick cells' Jacobi part |g|^2 / ``stiffness``; with 0 (the preconditioned iteration) the
    spectral product adds theirs."""
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = stiffness - stiffness
    first = wp.vector(zero, zero, zero)
    second = wp.vector(zero, zero)
    for k in range(cells.per):
        i = cell_index(thread, cells, k)
        if i < cells.n:
            gx, gy, a, b = gradient_cell(disp_x[i], disp_y[i], known_x[i], known_y[i], target_x[i], target_y[i],
                                         shear_x[i], shear_y[i], shear_limit[i], status[i], stiffness, jacobi_stick)
            grad_x[i] = gx
            grad_y[i] = gy
            first += a
            second += b
    block_add_vector(sums, S_G, first, lane)  # slots S_G, S_VIOL, S_RHS
    block_add_vector(sums, S_STICK, second, lane)  # slots S_STICK, S_REVERSAL


@wp.func
def slip_direction(gx: Any, gy: Any, qx: Any, qy: Any, q_max: Any, last_x: Any, last_y: Any, stiffness: Any,
                   beta: Any):
    """The conjugate direction of a slip cell: the tangent part of g scaled by 1 / (``stiffness``
    + lambda / q_max), lambda = max(-g.q/|q|, 0) the constraint's curvature, plus beta times the
    tangent part of the last direction."""
    zero = type(gx)(0.0)
    e = slip_frame(qx, qy)
    gn = gx * e[0] + gy * e[1]
    inv_m = type(zero)(1.0) / (stiffness + wp.max(-gn, zero) / q_max)
    tgx = (gx - gn * e[0]) * inv_m
    tgy = (gy - gn * e[1]) * inv_m
    pn = last_x * e[0] + last_y * e[1]
    return wp.vector(tgx + beta * (last_x - pn * e[0]), tgy + beta * (last_y - pn * e[1]))


@wp.func
def plain_direction(gx: Any, gy: Any, qx: Any, qy: Any, q_max: Any, status: int, last_x: Any, last_y: Any,
                    stiffness: Any, beta: Any):
    """One cell of ``tangential_direction``: the Jacobi-scaled g plus beta times the last
    direction on stick cells, :func:`slip_direction` on slip cells, 0 out of contact."""
    t = wp.vector(gx / stiffness + beta * last_x, gy / stiffness + beta * last_y)
    if status == SLIP:
        t = slip_direction(gx, gy, qx, qy, q_max, last_x, last_y, stiffness, beta)
    elif status != STICK:
        t = wp.vector(stiffness - stiffness, stiffness - stiffness)
    return t


@wp.kernel
def tangential_direction(
    grad_x: wp.array(dtype=Any),
    grad_y: wp.array(dtype=Any),
    shear_x: wp.array(dtype=Any),
    shear_y: wp.array(dtype=Any),
    shear_limit: wp.array(dtype=Any),
    status: wp.array(dtype=wp.int32),
    stiffness: Any,
    sums: wp.array(dtype=Any),
    scalars: wp.array(dtype=Any),
    dir_x: wp.array(dtype=Any),
    dir_y: wp.array(dtype=Any),
):
    """t = M^-1 P g + delta (G / G_old) P t: P is the identity on stick cells, the tangent
    projector on slip cells, 0 out of contact; M the Jacobi preconditioner, the self-influence
    ``stiffness`` plus, on slip cells, the curvature lambda / q_max."""
    i = wp.tid()
    t = plain_direction(grad_x[i], grad_y[i], shear_x[i], shear_y[i], shear_limit[i], status[i], dir_x[i], dir_y[i],
                        stiffness, conjugacy(sums, scalars))
    dir_x[i] = t[0]
    dir_y[i] = t[1]


@wp.func
def step_terms(gx: Any, gy: Any, tx: Any, ty: Any, rx: Any, ry: Any, qx: Any, qy: Any, q_max: Any, status: int):
    """One cell's shares of g.t and t.(K t) + (lambda / q_max) |t|^2 (slip cells), 0 out of contact.

    On a slip cell g.t is taken with g's tangent part g_t: t is tangent there but for rounding,
    and g's normal part (minus the slip increment lambda) is up to 1e9 times g_t near a solution,
    so lambda times t's rounded normal part (lambda |t| eps) would swamp g_t . t: the sums g.t
    and g.M g then disagree, the step tau changes sign and the iteration wanders from a relative
    residual near lambda eps / |g_t| (1e-10 on a fretting reversal) instead of converging."""
    zero = gx - gx
    s_gt = zero
    s_rt = zero
    if status != OUT:
        s_gt = gx * tx + gy * ty
        s_rt = rx * tx + ry * ty
        if status == SLIP:
            e = slip_frame(qx, qy)
            normal = gx * e[0] + gy * e[1]
            s_gt = (gx - normal * e[0]) * tx + (gy - normal * e[1]) * ty
            s_rt += wp.max(-normal, zero) / q_max * (tx * tx + ty * ty)
    return s_gt, s_rt


@wp.kernel
def tangential_step_sums(
    grad_x: wp.array(dtype=Any),
    grad_y: wp.array(dtype=Any),
    dir_x: wp.array(dtype=Any),
    dir_y: wp.array(dtype=Any),
    resp_x: wp.array(dtype=Any),
    resp_y: wp.array(dtype=Any),
    shear_x: wp.array(dtype=Any),
    shear_y: wp.array(dtype=Any),
    shear_limit: wp.array(dtype=Any),
    status: wp.array(dtype=wp.int32),
    cells: Cells,
    sums: wp.array(dtype=Any),
):
    """g.t and t.(K t) + sum over slip cells of (lambda / q_max) |t|^2, lambda = max(-g.q/|q|, 0)."""
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = grad_x[0] - grad_x[0]
    s_gt = zero
    s_rt = zero
    for k in range(cells.per):
        i = cell_index(thread, cells, k)
        if i < cells.n:
            gt, rt = step_terms(grad_x[i], grad_y[i], dir_x[i], dir_y[i], resp_x[i], resp_y[i], shear_x[i],
                                shear_y[i], shear_limit[i], status[i])
            s_gt += gt
            s_rt += rt
    block_add(sums, S_GT, s_gt)
    block_add(sums, S_RT, s_rt)


@wp.func
def disk_step(status: int, qx: Any, qy: Any, gx: Any, gy: Any, tx: Any, ty: Any, q_max: Any, tau: Any,
              tau_release: Any, release: bool):
    """One contact cell's step q <- q - tau t under the disk bound |q| <= q_max: a stick cell
    that leaves the disk is projected onto it and slips; a slip cell is retracted onto its circle,
    or, where ``release`` (the proportioning test, :func:`may_release`) and its slip would reverse
    (g.q > 0), leaves the circle inwards with P(q - tau_release g) and sticks where that lands
    inside. Returns the new q, the new status and |q - (q_old - tau
    t)|, what the projection changed (which K t misses)."""
    zero = type(qx)(0.0)
    fx = qx - tau * tx  # what K t accounts for
    fy = qy - tau * ty
    new = status
    q = wp.vector(fx, fy)
    if release and status == SLIP and gx * qx + gy * qy > zero:
        # the slip would reverse: leave the circle inwards
        q = project_disk(qx - tau_release * gx, qy - tau_release * gy, q_max)
        if q[0] * q[0] + q[1] * q[1] < q_max * q_max:
            new = STICK
    elif status == SLIP:
        e = slip_frame(fx, fy)
        q = wp.vector(q_max * e[0], q_max * e[1])
    elif fx * fx + fy * fy >= q_max * q_max:
        q = project_disk(fx, fy, q_max)
        new = SLIP
    return q, new, wp.sqrt((q[0] - fx) * (q[0] - fx) + (q[1] - fy) * (q[1] - fy))


@wp.func
def may_release(sums: wp.array(dtype=Any), tol: Any):
    """The proportioning test: whether this step releases the slip cells whose slip would reverse
    (their squared reversal, slot S_REVERSAL, over RELEASE_RATIO^2 times the rest of the squared
    violation, slot S_VIOL; or the relative residual under RELEASE_NEAR times ``tol``)."""
    reversal = sums[S_REVERSAL]
    viol = sums[S_VIOL]
    ratio = type(reversal)(RELEASE_RATIO)
    near = type(reversal)(RELEASE_NEAR) * tol
    return reversal > ratio * ratio * (viol - reversal) or viol < near * near * sums[S_RHS]


@wp.kernel
def tangential_update(
    grad_x: wp.array(dtype=Any),
    grad_y: wp.array(dtype=Any),
    dir_x: wp.array(dtype=Any),
    dir_y: wp.array(dtype=Any),
    shear_limit: wp.array(dtype=Any),
    slip_step: Any,
    parameters: wp.array(dtype=Any),
    cells: Cells,
    shear_x: wp.array(dtype=Any),
    shear_y: wp.array(dtype=Any),
    status: wp.array(dtype=wp.int32),
    sums: wp.array(dtype=Any),
):
    """q <- q - tau t, then: stick cells beyond the disk are projected (-> slip); slip cells are
    retracted onto their circle, or released into stick with P(q - tau g) when g.q > 0 and the
    proportioning test (:func:`may_release`) allows it.

    tau is the conjugate-gradient step; ``slip_step`` (about 1 / the self-influence coefficient)
    stands in for it when the free subspace is empty. An iterate whose relative residual is
    already under ``parameters[P_TOL]`` is left as it is (near the solution tau is a ratio of rounding
    noise).
    """
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = grad_x[0] - grad_x[0]
    tau = cg_step_length(sums)
    tau_release = wp.where(tau > zero, tau, slip_step)
    done = cg_converged(sums, parameters[P_TOL])
    release = may_release(sums, parameters[P_TOL])
    released = zero
    for k in range(cells.per):
        i = cell_index(thread, cells, k)
        if i < cells.n and not done:
            st = status[i]
            if st != OUT:
                q, new, change = disk_step(st, shear_x[i], shear_y[i], grad_x[i], grad_y[i], dir_x[i], dir_y[i],
                                           shear_limit[i], tau, tau_release, release)
                if new != st:
                    status[i] = new
                    if new == STICK:
                        released += type(zero)(1.0)
                shear_x[i] = q[0]
                shear_y[i] = q[1]
    block_add(sums, S_RELEASED, released)



# --- the preconditioned iteration (SolverSettings.tangential_preconditioner) ---
# slots of ``sums`` besides 0-5: what the projections changed (which the carried g misses), and
# slots S_G and S_VIOL of the updated iterate (S_RHS does not change within a solve)
S_CORRECTION = wp.constant(N_SUMS + 0)
S_NEXT_G = wp.constant(N_SUMS + 1)
S_NEXT_VIOL = wp.constant(N_SUMS + 2)
S_NEXT_REVERSAL = wp.constant(N_SUMS + 3)
N_SUMS_PRECONDITIONED = N_SUMS + 4


@wp.kernel
def tangential_stick_gradient(grad: wp.array(dtype=Any), status: wp.array(dtype=wp.int32), width: int, per: int,
                              padded_input: wp.array2d(dtype=Any)):
    """One component of g on the stick cells, 0 elsewhere, into the FFT backend's
    ``padded_input``: what the preconditioner transforms (in its backend's float type, which
    may be float32 beside float64 fields: ``SolverSettings.preconditioner_float32``). Launched
    over (rows, chunks) (``LaunchCache.launch_rows``)."""
    i, c = wp.tid()
    for j in range(c * per, wp.min((c + 1) * per, width)):
        cell = i * width + j
        padded_input[i, j] = padded_input.dtype(wp.where(status[cell] == STICK, grad[cell], type(grad[cell])(0.0)))


@wp.kernel
def tangential_direction_stick(
    preconditioned: wp.array2d(dtype=Any),
    output_scale: Any,
    status: wp.array(dtype=wp.int32),
    sums: wp.array(dtype=Any),
    scalars: wp.array(dtype=Any),
    width: int,
    per: int,
    direction: wp.array(dtype=Any),
):
    """One component of the conjugate direction on stick cells, t = z + beta t_last with z = M g
    read from ``preconditioned`` (the FFT backend's padded output, times ``output_scale``); 0 out
    of contact; slip cells left as they are (``tangential_direction_rest`` writes them). Launched
    over (rows, chunks)."""
    i, c = wp.tid()
    beta = conjugacy(sums, scalars)
    for j in range(c * per, wp.min((c + 1) * per, width)):
        cell = i * width + j
        st = status[cell]
        if st == STICK:
            direction[cell] = type(beta)(output_scale * preconditioned[i, j]) + beta * direction[cell]
        elif st == OUT:
            direction[cell] = beta - beta


@wp.kernel
def tangential_direction_rest(
    preconditioned: wp.array2d(dtype=Any),
    output_scale: Any,
    grad_x: wp.array(dtype=Any),
    grad_y: wp.array(dtype=Any),
    shear_x: wp.array(dtype=Any),
    shear_y: wp.array(dtype=Any),
    shear_limit: wp.array(dtype=Any),
    status: wp.array(dtype=wp.int32),
    stiffness: Any,
    sums: wp.array(dtype=Any),
    scalars: wp.array(dtype=Any),
    width: int,
    per: int,
    dir_x: wp.array(dtype=Any),
    dir_y: wp.array(dtype=Any),
):
    """The rest of the conjugate direction after ``tangential_direction_stick`` wrote the stick
    cells' x component: the y component on stick cells (z_y from ``preconditioned``), 0 out of
    contact, and both components on slip cells (:func:`slip_direction`, from the last direction,
    which the x pass left there). Launched over (rows, chunks)."""
    i, c = wp.tid()
    beta = conjugacy(sums, scalars)
    for j in range(c * per, wp.min((c + 1) * per, width)):
        cell = i * width + j
        st = status[cell]
        if st == STICK:
            dir_y[cell] = type(beta)(output_scale * preconditioned[i, j]) + beta * dir_y[cell]
        elif st == SLIP:
            t = slip_direction(grad_x[cell], grad_y[cell], shear_x[cell], shear_y[cell], shear_limit[cell],
                               dir_x[cell], dir_y[cell], stiffness, beta)
            dir_x[cell] = t[0]
            dir_y[cell] = t[1]
        else:
            dir_y[cell] = beta - beta


@wp.func
def carried_cell(status: int, q_max: Any, qx: Any, qy: Any, gx: Any, gy: Any, tx: Any, ty: Any, rx: Any, ry: Any,
                 tau: Any, tau_release: Any, release: bool, stiffness: Any):
    """One contact cell's step of the preconditioned iteration with g carried
    (``tangential_carried_update``): ``disk_step``, then g <- g - tau K t (K t: ``rx``, ``ry``),
    and the new iterate's shares of the sums (``residual_terms``). Returns (q_x, q_y, g_x, g_y),
    the new status, and (what the projection changed, the shares of S_G, S_VIOL and
    S_REVERSAL)."""
    q, new, change = disk_step(status, qx, qy, gx, gy, tx, ty, q_max, tau, tau_release, release)
    gx_new = gx - tau * rx
    gy_new = gy - tau * ry
    dg, dv, dr = residual_terms(gx_new, gy_new, q[0], q[1], q_max, new, stiffness)
    return wp.vector(q[0], q[1], gx_new, gy_new), new, wp.vector(change, dg, dv, dr)


@wp.kernel
def tangential_carried_update(
    dir_x: wp.array(dtype=Any),
    dir_y: wp.array(dtype=Any),
    resp_x: wp.array(dtype=Any),
    resp_y: wp.array(dtype=Any),
    shear_limit: wp.array(dtype=Any),
    slip_step: Any,
    stiffness: Any,
    parameters: wp.array(dtype=Any),
    cells: Cells,
    shear_x: wp.array(dtype=Any),
    shear_y: wp.array(dtype=Any),
    status: wp.array(dtype=wp.int32),
    grad_x: wp.array(dtype=Any),
    grad_y: wp.array(dtype=Any),
    sums: wp.array(dtype=Any),
):
    """``tangential_update``'s step on q and the statuses, with g carried: g <- g - tau K t (K t
    in ``resp``), exact where no cell was projected. What the projections changed, sum_i |q_i -
    (q_i - tau t_i)| (the slip cells' retraction onto their circle, stick cells projected onto
    it, released cells), goes to slot S_CORRECTION: the carried g misses K of it until the next
    exact g. Slots S_G and S_VIOL of the new iterate with the carried g go to S_NEXT_G and
    S_NEXT_VIOL, the released cells' count to S_RELEASED. An iterate whose relative residual is
    already under ``parameters[P_TOL]`` is left as it is."""
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = stiffness - stiffness
    tau = cg_step_length(sums)
    tau_release = wp.where(tau > zero, tau, slip_step)
    done = cg_converged(sums, parameters[P_TOL])
    release = may_release(sums, parameters[P_TOL])
    released = zero
    corrected = zero
    s_g = zero
    s_viol = zero
    s_reversal = zero
    for k in range(cells.per):
        i = cell_index(thread, cells, k)
        if i < cells.n:
            st = status[i]
            if st != OUT:
                # every load before any store (see kernels/normal.py, normal_update)
                q_max = shear_limit[i]
                qx = shear_x[i]
                qy = shear_y[i]
                gx = grad_x[i]
                gy = grad_y[i]
                tx = dir_x[i]
                ty = dir_y[i]
                rx = resp_x[i]
                ry = resp_y[i]
                if not done:
                    fields, new, terms = carried_cell(st, q_max, qx, qy, gx, gy, tx, ty, rx, ry, tau, tau_release,
                                                      release, stiffness)
                    shear_x[i] = fields[0]
                    shear_y[i] = fields[1]
                    grad_x[i] = fields[2]
                    grad_y[i] = fields[3]
                    if new != st:
                        status[i] = new
                        if new == STICK:
                            released += type(zero)(1.0)
                    corrected += terms[0]
                    s_g += terms[1]
                    s_viol += terms[2]
                    s_reversal += terms[3]
                else:
                    dg, dv, dr = residual_terms(gx, gy, qx, qy, q_max, st, stiffness)
                    s_g += dg
                    s_viol += dv
                    s_reversal += dr
    block_add(sums, S_RELEASED, released)
    # slots S_CORRECTION, S_NEXT_G, S_NEXT_VIOL, S_NEXT_REVERSAL (consecutive)
    block_add_vector(sums, S_CORRECTION, wp.vector(corrected, s_g, s_viol, s_reversal), lane)


@wp.kernel
def tangential_advance(sums: wp.array(dtype=Any), parameters: wp.array(dtype=Any), restart_every: int, exact_every: int,
                       column_norm: Any, deferral: Any, scalars: wp.array(dtype=Any),
                       residual_history: wp.array(dtype=Any), deferred: wp.array(dtype=Any),
                       recompute: wp.array(dtype=wp.int32), loop: wp.array(dtype=wp.int32),
                       refresh: wp.array(dtype=wp.int32), inner_loop: wp.array(dtype=wp.int32)):
    """One thread, end of a preconditioned iteration: the shared
    :func:`~warpcontact.kernels.reduce.advance` (residual history, G_old, delta: a released cell
    restarts the conjugacy; the loop flag), then whether the next iteration starts from an exact
    g (``recompute[0]`` = 1: K q and ``tangential_residual``), then the new iterate's sums moved
    into slots S_G and S_VIOL and slots S_GT on zeroed.

    The carried g misses K c, c the projections' changes since the last exact g; their norms add
    up in ``deferred[0]``, and ||K c||_2 <= ``column_norm`` * that. Recompute when that bound
    exceeds ``deferral`` times the norm of the violation the iteration started from, after a
    released cell (a restart), every ``exact_every`` iterations, and always when
    ``parameters[P_EXACT]`` is 1.

    The loop also stops (settled) where the new iterate meets the tolerance with the carried g:
    the launch then makes g exact (``ProjectedCG._run``'s refresh) and the host judges it, and
    launches the loop again where the exact g does not agree. ``inner_loop[0]``: 1 while the
    loop goes on without a recompute."""
    tol = parameters[P_TOL]
    exact = parameters[P_EXACT]
    viol = sums[S_VIOL]
    rhs = sums[S_RHS]
    released = sums[S_RELEASED]
    missed = deferred[0] + sums[S_CORRECTION]
    next_g = sums[S_NEXT_G]
    next_viol = sums[S_NEXT_VIOL]
    next_reversal = sums[S_NEXT_REVERSAL]
    done, stopped = advance(sums, parameters, restart_every, scalars, residual_history, loop, refresh)
    zero = type(tol)(0.0)
    bound = column_norm * missed
    again = (exact > zero or released > zero or bound * bound > deferral * deferral * viol
             or done % exact_every == 0)
    recompute[0] = wp.where(again, 1, 0)
    deferred[0] = wp.where(again, zero, missed)
    for slot in range(S_GT, N_SUMS_PRECONDITIONED):
        sums[slot] = zero
    sums[S_G] = next_g
    sums[S_VIOL] = next_viol
    sums[S_REVERSAL] = wp.where(again, zero, next_reversal)  # a recompute's residual adds it anew
    # converged with the carried g: settle (the launch then makes g exact and the host judges it)
    res, finite = residual_of(next_viol, rhs)
    if not finite or res < tol:
        stop_loop(scalars, loop, refresh, True)
        stopped = True
    inner_loop[0] = wp.where(stopped or again, 0, 1)


for _k in (
    tangential_classify,
    tangential_residual,
    tangential_direction,
    tangential_step_sums,
    tangential_update,
    tangential_stick_gradient,
    tangential_direction_stick,
    tangential_direction_rest,
    tangential_carried_update,
    tangential_advance,
):
    register_float_overloads(_k)

# the preconditioner's transforms in float32 beside float64 fields (SolverSettings.preconditioner_float32)
mixed_float_overloads(tangential_stick_gradient, ("padded_input",))
mixed_float_overloads(tangential_direction_stick, ("preconditioned", "output_scale"))
mixed_float_overloads(tangential_direction_rest, ("preconditioned", "output_scale"))

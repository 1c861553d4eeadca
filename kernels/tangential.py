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
slip). Stick cells move along conjugate directions; slip cells take the projected step
P(q - tau g) onto their disk, which turns them towards the slip direction and releases them
into stick when the slip would reverse (the disk analogue of Polonsky-Keer's re-entry rule).

Cell status: 0 out of contact (q_max = 0), 1 stick, 2 slip.
"""

from typing import Any

import warp as wp

from .overloads import register_float_overloads
from .reduce import block_add, cell_index

S_G = wp.constant(0)  # sum over stick cells of |g|^2
S_VIOL = wp.constant(1)  # squared optimality violation
S_RHS = wp.constant(2)  # squared right-hand side over contact cells
S_GT = wp.constant(3)
S_RT = wp.constant(4)
S_RELEASED = wp.constant(5)  # slip cells released into stick by the last step
S_STICK = wp.constant(6)  # count of stick cells
N_SUMS = 7
C_G_OLD = wp.constant(0)
C_DELTA = wp.constant(1)
C_ITER = wp.constant(2)
N_SCALARS = 3

OUT = wp.constant(0)
STICK = wp.constant(1)
SLIP = wp.constant(2)


@wp.func
def project_disk(qx: Any, qy: Any, q_max: Any):
    """Projection of (qx, qy) onto the disk of radius q_max."""
    norm = wp.sqrt(qx * qx + qy * qy)
    scale = wp.where(norm > q_max, q_max / wp.max(norm, q_max + q_max * type(qx)(1e-30)), type(qx)(1.0))
    return wp.vector(qx * scale, qy * scale)


@wp.kernel
def tangential_classify(
    shear_limit: wp.array(dtype=Any),
    shear_x: wp.array(dtype=Any),
    shear_y: wp.array(dtype=Any),
    status: wp.array(dtype=wp.int32),
):
    """At the start of a solve: project q onto the current disks and set each cell's status."""
    i = wp.tid()
    q_max = shear_limit[i]
    zero = q_max - q_max
    if q_max <= zero:
        shear_x[i] = zero
        shear_y[i] = zero
        status[i] = OUT
        return
    qx = shear_x[i]
    qy = shear_y[i]
    if qx * qx + qy * qy >= q_max * q_max:
        q = project_disk(qx, qy, q_max)
        shear_x[i] = q[0]
        shear_y[i] = q[1]
        status[i] = SLIP
    else:
        status[i] = STICK


@wp.kernel
def tangential_gradient(
    disp_x: wp.array(dtype=Any),
    disp_y: wp.array(dtype=Any),
    known_x: wp.array(dtype=Any),
    known_y: wp.array(dtype=Any),
    target_x: wp.array(dtype=Any),
    target_y: wp.array(dtype=Any),
    shear_x: wp.array(dtype=Any),
    shear_y: wp.array(dtype=Any),
    status: wp.array(dtype=wp.int32),
    n: int,
    outer: int,
    inner: int,
    per: int,
    grad_x: wp.array(dtype=Any),
    grad_y: wp.array(dtype=Any),
    sums: wp.array(dtype=Any),
):
    """g = K q + u_known - target (= minus the slip increment) and the residual sums."""
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = disp_x[0] - disp_x[0]
    s_g = zero
    s_viol = zero
    s_rhs = zero
    s_stick = zero
    for k in range(per):
        i = cell_index(thread, outer, inner, k)
        if i < n:
            rx = target_x[i] - known_x[i]
            ry = target_y[i] - known_y[i]
            gx = disp_x[i] - rx
            gy = disp_y[i] - ry
            grad_x[i] = gx
            grad_y[i] = gy
            st = status[i]
            if st != OUT:
                s_rhs += rx * rx + ry * ry
            if st == STICK:
                s_g += gx * gx + gy * gy
                s_viol += gx * gx + gy * gy
                s_stick += type(zero)(1.0)
            elif st == SLIP:
                qx = shear_x[i]
                qy = shear_y[i]
                qn = wp.sqrt(qx * qx + qy * qy)
                if qn > zero:
                    nx = qx / qn
                    ny = qy / qn
                    normal = gx * nx + gy * ny
                    tx = gx - normal * nx
                    ty = gy - normal * ny
                    s_viol += tx * tx + ty * ty + wp.max(normal, zero) * wp.max(normal, zero)
    block_add(sums, S_G, s_g)
    block_add(sums, S_VIOL, s_viol)
    block_add(sums, S_RHS, s_rhs)
    block_add(sums, S_STICK, s_stick)


@wp.kernel
def tangential_direction(
    grad_x: wp.array(dtype=Any),
    grad_y: wp.array(dtype=Any),
    status: wp.array(dtype=wp.int32),
    sums: wp.array(dtype=Any),
    scalars: wp.array(dtype=Any),
    dir_x: wp.array(dtype=Any),
    dir_y: wp.array(dtype=Any),
):
    """t = g + delta (G / G_old) t on stick cells, 0 elsewhere."""
    i = wp.tid()
    zero = sums[S_G] - sums[S_G]
    beta = zero
    if scalars[C_G_OLD] > zero:
        beta = scalars[C_DELTA] * sums[S_G] / scalars[C_G_OLD]
    if status[i] == STICK:
        dir_x[i] = grad_x[i] + beta * dir_x[i]
        dir_y[i] = grad_y[i] + beta * dir_y[i]
    else:
        dir_x[i] = zero
        dir_y[i] = zero


@wp.kernel
def tangential_step_sums(
    grad_x: wp.array(dtype=Any),
    grad_y: wp.array(dtype=Any),
    dir_x: wp.array(dtype=Any),
    dir_y: wp.array(dtype=Any),
    resp_x: wp.array(dtype=Any),
    resp_y: wp.array(dtype=Any),
    status: wp.array(dtype=wp.int32),
    n: int,
    outer: int,
    inner: int,
    per: int,
    sums: wp.array(dtype=Any),
):
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = grad_x[0] - grad_x[0]
    s_gt = zero
    s_rt = zero
    for k in range(per):
        i = cell_index(thread, outer, inner, k)
        if i < n:
            if status[i] == STICK:
                s_gt += grad_x[i] * dir_x[i] + grad_y[i] * dir_y[i]
                s_rt += resp_x[i] * dir_x[i] + resp_y[i] * dir_y[i]
    block_add(sums, S_GT, s_gt)
    block_add(sums, S_RT, s_rt)


@wp.kernel
def tangential_update(
    grad_x: wp.array(dtype=Any),
    grad_y: wp.array(dtype=Any),
    dir_x: wp.array(dtype=Any),
    dir_y: wp.array(dtype=Any),
    shear_limit: wp.array(dtype=Any),
    slip_step: Any,
    n: int,
    outer: int,
    inner: int,
    per: int,
    shear_x: wp.array(dtype=Any),
    shear_y: wp.array(dtype=Any),
    status: wp.array(dtype=wp.int32),
    sums: wp.array(dtype=Any),
):
    """Stick cells: q <- P(q - tau t); slip cells: q <- P(q - tau_s g); statuses follow.

    tau is the conjugate-gradient step of the stick cells; slip cells use it too, or
    ``slip_step`` (about 1 / the self-influence coefficient) when no cell sticks.
    """
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = grad_x[0] - grad_x[0]
    tau = zero
    if sums[S_RT] > zero:
        tau = sums[S_GT] / sums[S_RT]
    tau_slip = wp.where(tau > zero, tau, slip_step)
    released = zero
    for k in range(per):
        i = cell_index(thread, outer, inner, k)
        if i < n:
            st = status[i]
            if st != OUT:
                q_max = shear_limit[i]
                qx = shear_x[i]
                qy = shear_y[i]
                if st == STICK:
                    qx = qx - tau * dir_x[i]
                    qy = qy - tau * dir_y[i]
                else:
                    qx = qx - tau_slip * grad_x[i]
                    qy = qy - tau_slip * grad_y[i]
                if qx * qx + qy * qy >= q_max * q_max:
                    q = project_disk(qx, qy, q_max)
                    qx = q[0]
                    qy = q[1]
                    status[i] = SLIP
                else:
                    if st == SLIP:
                        released += type(zero)(1.0)
                    status[i] = STICK
                shear_x[i] = qx
                shear_y[i] = qy
    block_add(sums, S_RELEASED, released)


@wp.kernel
def tangential_advance(
    sums: wp.array(dtype=Any), scalars: wp.array(dtype=Any), residual_history: wp.array(dtype=Any)
):
    """One thread: G_old <- G, delta <- (no cell released), record the relative residual."""
    zero = sums[S_G] - sums[S_G]
    one = type(zero)(1.0)
    it = int(scalars[C_ITER])
    res = zero
    if sums[S_RHS] > zero:
        res = wp.sqrt(sums[S_VIOL] / sums[S_RHS])
    elif sums[S_VIOL] > zero:
        res = one
    if it < residual_history.shape[0]:
        residual_history[it] = res
    scalars[C_G_OLD] = sums[S_G]
    scalars[C_DELTA] = wp.where(sums[S_RELEASED] > zero, zero, one)
    scalars[C_ITER] = scalars[C_ITER] + one


for _k in (
    tangential_classify,
    tangential_gradient,
    tangential_direction,
    tangential_step_sums,
    tangential_update,
    tangential_advance,
):
    register_float_overloads(_k)

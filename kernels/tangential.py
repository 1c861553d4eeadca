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
the conjugacy restarts.

Cell status: 0 out of contact (q_max = 0), 1 stick, 2 slip.
"""

from typing import Any

import warp as wp

from .overloads import register_float_overloads
from .reduce import (  # noqa: F401  (shared slots)
    C_DELTA, C_G_OLD, N_SCALARS, N_SETTINGS, P_TOL, S_G, S_GT, S_RHS, S_RT, S_VIOL, block_add, cell_index, cg_converged,
    cg_step_length,
)
from .reduce import S_RESTART as S_RELEASED  # slip cells released into stick by the last step

# no adjoints: nothing differentiates these kernels, and compiling them doubles the build
wp.set_module_options({"enable_backward": False})

# slots of ``sums`` (0-2 and 5 shared with kernels/reduce.py; S_G holds g.z, z = M^-1 P g)
S_STICK = wp.constant(6)  # count of stick cells
N_SUMS = 7

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
    shear_limit: wp.array(dtype=Any),
    status: wp.array(dtype=wp.int32),
    stiffness: Any,
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
                s_g += (gx * gx + gy * gy) / stiffness
                s_viol += gx * gx + gy * gy
                s_stick += type(zero)(1.0)
            elif st == SLIP:
                e = slip_frame(shear_x[i], shear_y[i])
                normal = gx * e[0] + gy * e[1]
                tx = gx - normal * e[0]
                ty = gy - normal * e[1]
                s_g += (tx * tx + ty * ty) / (stiffness + wp.max(-normal, zero) / shear_limit[i])
                s_viol += tx * tx + ty * ty + wp.max(normal, zero) * wp.max(normal, zero)
    block_add(sums, S_G, s_g)
    block_add(sums, S_VIOL, s_viol)
    block_add(sums, S_RHS, s_rhs)
    block_add(sums, S_STICK, s_stick)


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
    zero = sums[S_G] - sums[S_G]
    beta = zero
    if scalars[C_G_OLD] > zero:
        beta = scalars[C_DELTA] * sums[S_G] / scalars[C_G_OLD]
    st = status[i]
    tx = grad_x[i] / stiffness + beta * dir_x[i]
    ty = grad_y[i] / stiffness + beta * dir_y[i]
    if st == SLIP:
        e = slip_frame(shear_x[i], shear_y[i])
        gn = grad_x[i] * e[0] + grad_y[i] * e[1]
        inv_m = type(zero)(1.0) / (stiffness + wp.max(-gn, zero) / shear_limit[i])
        tgx = (grad_x[i] - gn * e[0]) * inv_m
        tgy = (grad_y[i] - gn * e[1]) * inv_m
        px = dir_x[i]
        py = dir_y[i]
        pn = px * e[0] + py * e[1]
        tx = tgx + beta * (px - pn * e[0])
        ty = tgy + beta * (py - pn * e[1])
    elif st != STICK:
        tx = zero
        ty = zero
    dir_x[i] = tx
    dir_y[i] = ty


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
    n: int,
    outer: int,
    inner: int,
    per: int,
    sums: wp.array(dtype=Any),
):
    """g.t and t.(K t) + sum over slip cells of (lambda / q_max) |t|^2, lambda = max(-g.q/|q|, 0)."""
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = grad_x[0] - grad_x[0]
    s_gt = zero
    s_rt = zero
    for k in range(per):
        i = cell_index(thread, outer, inner, k)
        if i < n:
            st = status[i]
            if st != OUT:
                tx = dir_x[i]
                ty = dir_y[i]
                s_gt += grad_x[i] * tx + grad_y[i] * ty
                s_rt += resp_x[i] * tx + resp_y[i] * ty
                if st == SLIP:
                    e = slip_frame(shear_x[i], shear_y[i])
                    lam = wp.max(-(grad_x[i] * e[0] + grad_y[i] * e[1]), zero)
                    s_rt += lam / shear_limit[i] * (tx * tx + ty * ty)
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
    settings: wp.array(dtype=Any),
    n: int,
    outer: int,
    inner: int,
    per: int,
    shear_x: wp.array(dtype=Any),
    shear_y: wp.array(dtype=Any),
    status: wp.array(dtype=wp.int32),
    sums: wp.array(dtype=Any),
):
    """q <- q - tau t, then: stick cells beyond the disk are projected (-> slip); slip cells are
    retracted onto their circle, or released into stick with P(q - tau g) when g.q > 0.

    tau is the conjugate-gradient step; ``slip_step`` (about 1 / the self-influence coefficient)
    stands in for it when the free subspace is empty. An iterate whose relative residual is
    already under ``settings[P_TOL]`` is left as it is (near the solution tau is a ratio of rounding
    noise).
    """
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = grad_x[0] - grad_x[0]
    tau = cg_step_length(sums)
    tau_release = wp.where(tau > zero, tau, slip_step)
    done = cg_converged(sums, settings[P_TOL])
    released = zero
    for k in range(per):
        i = cell_index(thread, outer, inner, k)
        if i < n and not done:
            st = status[i]
            if st != OUT:
                q_max = shear_limit[i]
                qx = shear_x[i]
                qy = shear_y[i]
                if st == SLIP and grad_x[i] * qx + grad_y[i] * qy > zero:
                    # the slip would reverse: leave the circle inwards
                    q = project_disk(qx - tau_release * grad_x[i], qy - tau_release * grad_y[i], q_max)
                    qx = q[0]
                    qy = q[1]
                    if qx * qx + qy * qy < q_max * q_max:
                        status[i] = STICK
                        released += type(zero)(1.0)
                elif st == SLIP:
                    e = slip_frame(qx - tau * dir_x[i], qy - tau * dir_y[i])
                    qx = q_max * e[0]
                    qy = q_max * e[1]
                else:
                    qx = qx - tau * dir_x[i]
                    qy = qy - tau * dir_y[i]
                    if qx * qx + qy * qy >= q_max * q_max:
                        q = project_disk(qx, qy, q_max)
                        qx = q[0]
                        qy = q[1]
                        status[i] = SLIP
                shear_x[i] = qx
                shear_y[i] = qy
    block_add(sums, S_RELEASED, released)



for _k in (
    tangential_classify,
    tangential_gradient,
    tangential_direction,
    tangential_step_sums,
    tangential_update,
):
    register_float_overloads(_k)

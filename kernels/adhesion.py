"""Adhesion laws (MODEL.md section 6): adhesive tractions from the current gap and slip.

Scaled units (tractions / E*, lengths / dx). The adhesive tractions act outside the elastic
contact (cells with p_c = 0); inside it the SMC law gives no normal traction (h = 0) and the
total shear there is the tangential solver's unknown, bounded as a whole. Conventions as in
warpcontact/influence.py: the adhesive shear is the traction on the flat, along the slip s of
the sphere relative to the flat (on the sphere it opposes s).

Each update relaxes: t <- (1 - relax) t + relax law(h, s), and sums the squared change and the
squared new value for the fixed-point test.
"""

from typing import Any

import warp as wp

from .overloads import register_float_overloads
from .reduce import block_add, cell_index


@wp.func
def smc_normal(gap: Any, slip: Any, sigma_max: Any, delta_n: Any, delta_t: Any):
    """SMC (McGarry et al. 2014) normal traction: -sigma_max x_n exp(1 - m), m = |(x_n, x_t)|."""
    zero = type(gap)(0.0)
    xn = wp.max(gap, zero) / delta_n
    xt = slip / delta_t
    m = wp.sqrt(xn * xn + xt * xt)
    return -sigma_max * xn * wp.exp(type(gap)(1.0) - m)


@wp.func
def smc_shear(gap: Any, slip: Any, tau_max: Any, delta_n: Any, delta_t: Any):
    """SMC shear traction magnitude tau_max x_t exp(1 - m), along the slip."""
    zero = type(gap)(0.0)
    xn = wp.max(gap, zero) / delta_n
    xt = slip / delta_t
    m = wp.sqrt(xn * xn + xt * xt)
    return tau_max * xt * wp.exp(type(gap)(1.0) - m)


@wp.func
def dugdale_normal(gap: Any, sigma_0: Any, h_0: Any, ramp: Any):
    """Dugdale (Maugis 1992): tension sigma_0 for 0 < h <= h_0, none beyond; with ``ramp`` > 0 the
    two jumps become linear ramps of width ramp (rising over 0 < h < ramp, falling over h_0 < h <
    h_0 + ramp), which keeps the work of adhesion sigma_0 h_0 exact."""
    zero = type(gap)(0.0)
    one = type(gap)(1.0)
    if gap <= zero or gap >= h_0 + ramp:
        return zero
    if ramp <= zero:
        return wp.where(gap <= h_0, -sigma_0, zero)
    rise = wp.min(gap / ramp, one)
    fall = wp.min((h_0 + ramp - gap) / ramp, one)
    return -sigma_0 * wp.min(rise, fall)


@wp.kernel
def smc_update(
    gap: wp.array(dtype=Any),
    slip_x: wp.array(dtype=Any),
    slip_y: wp.array(dtype=Any),
    contact_pressure: wp.array(dtype=Any),
    sigma_max: Any,
    tau_max: Any,
    delta_n: Any,
    delta_t: Any,
    relax: Any,
    n: int,
    outer: int,
    inner: int,
    per: int,
    adhesive_pressure: wp.array(dtype=Any),
    adhesive_shear_x: wp.array(dtype=Any),
    adhesive_shear_y: wp.array(dtype=Any),
    sums: wp.array(dtype=Any),
):
    """Relaxed SMC update on cells out of contact (zero on contact cells); sums[0] += |change|^2,
    sums[1] += |new|^2."""
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = relax - relax
    one = zero + type(relax)(1.0)
    s_change = zero
    s_norm = zero
    for k in range(per):
        i = cell_index(thread, outer, inner, k)
        if i < n:
            p = zero
            qx = zero
            qy = zero
            if contact_pressure[i] <= zero:
                sx = slip_x[i]
                sy = slip_y[i]
                s = wp.sqrt(sx * sx + sy * sy)
                p = smc_normal(gap[i], s, sigma_max, delta_n, delta_t)
                if s > zero:
                    q = smc_shear(gap[i], s, tau_max, delta_n, delta_t)
                    qx = q * sx / s
                    qy = q * sy / s
            p = (one - relax) * adhesive_pressure[i] + relax * p
            qx = (one - relax) * adhesive_shear_x[i] + relax * qx
            qy = (one - relax) * adhesive_shear_y[i] + relax * qy
            dp = p - adhesive_pressure[i]
            dqx = qx - adhesive_shear_x[i]
            dqy = qy - adhesive_shear_y[i]
            s_change += dp * dp + dqx * dqx + dqy * dqy
            s_norm += p * p + qx * qx + qy * qy
            adhesive_pressure[i] = p
            adhesive_shear_x[i] = qx
            adhesive_shear_y[i] = qy
    block_add(sums, 0, s_change)
    block_add(sums, 1, s_norm)


@wp.kernel
def dugdale_update(
    gap: wp.array(dtype=Any),
    contact_pressure: wp.array(dtype=Any),
    sigma_0: Any,
    h_0: Any,
    ramp: Any,
    relax: Any,
    n: int,
    outer: int,
    inner: int,
    per: int,
    adhesive_pressure: wp.array(dtype=Any),
    sums: wp.array(dtype=Any),
):
    """Relaxed Dugdale update on cells out of contact; sums as in ``smc_update``."""
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = relax - relax
    one = zero + type(relax)(1.0)
    s_change = zero
    s_norm = zero
    for k in range(per):
        i = cell_index(thread, outer, inner, k)
        if i < n:
            p = zero
            if contact_pressure[i] <= zero:
                p = dugdale_normal(gap[i], sigma_0, h_0, ramp)
            p = (one - relax) * adhesive_pressure[i] + relax * p
            dp = p - adhesive_pressure[i]
            s_change += dp * dp
            s_norm += p * p
            adhesive_pressure[i] = p
    block_add(sums, 0, s_change)
    block_add(sums, 1, s_norm)


@wp.kernel
def add_to(source: wp.array(dtype=Any), target: wp.array(dtype=Any)):
    """target += source."""
    i = wp.tid()
    target[i] = target[i] + source[i]


for _k in (smc_update, dugdale_update, add_to):
    register_float_overloads(_k)

"""Adhesion laws (MODEL.md section 6): adhesive tractions from the current gap and slip.

Scaled units (tractions / E*, lengths / dx). The adhesive tractions act outside the elastic
contact (cells with p_c = 0); inside it the SMC law gives no normal traction (h = 0), and the
total shear there is the tangential solver's unknown, bounded as a whole, or (the SMC law's
``contact_shear = "added"``) the bounded contact shear plus the law's shear at the cell's slip. Conventions as in
warpcontact/physics/influence.py: the adhesive shear is the traction on the flat, along the slip s of
the sphere relative to the flat (on the sphere it opposes s).

The law kernels evaluate the tractions of the current gap and slip; the fixed point over them is
accelerated by kernels/fixed_point.py (Anderson mixing, driven from warpcontact/solvers/fixed_point.py).
"""

from typing import Any

import warp as wp

from .overloads import register_float_overloads

# no adjoints: nothing differentiates these kernels, and compiling them doubles the build
wp.set_module_options({"enable_backward": False})


@wp.func
def smc_law(gap: Any, slip: Any, sigma_max: Any, tau_max: Any, delta_n: Any, delta_t: Any):
    """SMC (McGarry et al. 2014) tractions at gap h and slip magnitude s: the normal traction
    -sigma_max x_n exp(1 - m) and the shear traction's magnitude tau_max x_t exp(1 - m), along the
    slip; x_n = max(h, 0) / delta_n, x_t = s / delta_t, m = |(x_n, x_t)|."""
    zero = type(gap)(0.0)
    xn = wp.max(gap, zero) / delta_n
    xt = slip / delta_t
    m = wp.sqrt(xn * xn + xt * xt)
    decay = wp.exp(type(gap)(1.0) - m)
    return -sigma_max * xn * decay, tau_max * xt * decay


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


@wp.func
def dugdale_centred_normal(gap: Any, sigma_0: Any, h_0: Any, ramp: Any):
    """Dugdale with one ramp centred on h_0: tension sigma_0 for 0 < h <= h_0 - ramp / 2, falling
    linearly to none at h_0 + ramp / 2 (the work of adhesion sigma_0 h_0 and the law's centroid
    are the sharp law's); ramp = 0 is the sharp law."""
    zero = type(gap)(0.0)
    one = type(gap)(1.0)
    half = type(gap)(0.5) * ramp
    if gap <= zero or gap >= h_0 + half:
        return zero
    if ramp <= zero:
        return wp.where(gap <= h_0, -sigma_0, zero)
    return -sigma_0 * wp.min((h_0 + half - gap) / ramp, one)


@wp.func
def touching_segment(t: Any, g: Any):
    """For a touching cell: the point of the segment [0, g] nearest to t (a scalar traction)."""
    zero = g - g
    if g == zero:
        return zero
    return wp.clamp(t / g, zero, type(g)(1.0)) * g


@wp.func
def smc_cell(gap: Any, slip_x: Any, slip_y: Any, contact_pressure: Any, adhesive_pressure: Any, adhesive_shear_x: Any,
             adhesive_shear_y: Any, sigma_max: Any, tau_max: Any, delta_n: Any, delta_t: Any, touching: Any,
             added_in_contact: int):
    """One cell's SMC tractions (p, q_x, q_y) of its gap and slip (``smc_tractions``)."""
    zero = sigma_max - sigma_max
    p = zero
    qx = zero
    qy = zero
    if contact_pressure <= zero:
        s = wp.sqrt(slip_x * slip_x + slip_y * slip_y)
        p, q = smc_law(gap, s, sigma_max, tau_max, delta_n, delta_t)
        if s > zero:
            qx = q * slip_x / s
            qy = q * slip_y / s
        if gap <= touching:
            p = touching_segment(adhesive_pressure, p)
            qq = qx * qx + qy * qy
            if qq > zero:
                lam = wp.clamp((adhesive_shear_x * qx + adhesive_shear_y * qy) / qq, zero, type(qq)(1.0))
                qx = lam * qx
                qy = lam * qy
    elif added_in_contact != 0:
        s = wp.sqrt(slip_x * slip_x + slip_y * slip_y)
        if s > zero:
            p_h0, q = smc_law(zero, s, sigma_max, tau_max, delta_n, delta_t)
            qx = q * slip_x / s
            qy = q * slip_y / s
    return p, qx, qy


@wp.kernel
def smc_tractions(
    gap: wp.array(dtype=Any),
    slip_x: wp.array(dtype=Any),
    slip_y: wp.array(dtype=Any),
    contact_pressure: wp.array(dtype=Any),
    adhesive_pressure: wp.array(dtype=Any),
    adhesive_shear_x: wp.array(dtype=Any),
    adhesive_shear_y: wp.array(dtype=Any),
    sigma_max: Any,
    tau_max: Any,
    delta_n: Any,
    delta_t: Any,
    touching: Any,
    added_in_contact: int,
    law_pressure: wp.array(dtype=Any),
    law_shear_x: wp.array(dtype=Any),
    law_shear_y: wp.array(dtype=Any),
):
    """The SMC tractions of the current gap and slip on cells out of contact; on contact cells
    zero, or with ``added_in_contact`` the law's shear at h = 0 and the cell's slip (its normal
    traction is zero there), added to the bounded contact shear (``SMC.contact_shear``). A cell
    out of contact with gap <= ``touching`` sits on the law's jump to the contact side (zero
    adhesive traction there): it may carry any traction on the segment between the two, so its
    current traction (``adhesive_*``) is kept where it lies on that segment and projected onto it
    otherwise."""
    i = wp.tid()
    p, qx, qy = smc_cell(gap[i], slip_x[i], slip_y[i], contact_pressure[i], adhesive_pressure[i], adhesive_shear_x[i],
                         adhesive_shear_y[i], sigma_max, tau_max, delta_n, delta_t, touching, added_in_contact)
    law_pressure[i] = p
    law_shear_x[i] = qx
    law_shear_y[i] = qy


#: a batch row's SMC law (``batch_smc_tractions``' ``laws``, scaled: tractions / E*, lengths / dx):
#: its slots; a row whose delta_n is 0 has no adhesion
SMC_SIGMA_MAX = wp.constant(0)
SMC_TAU_MAX = wp.constant(1)
SMC_DELTA_N = wp.constant(2)
SMC_DELTA_T = wp.constant(3)
SMC_TOUCHING = wp.constant(4)
N_SMC_PARAMETERS = 5


@wp.kernel
def batch_smc_tractions(
    gap: wp.array2d(dtype=Any),
    slip_x: wp.array2d(dtype=Any),
    slip_y: wp.array2d(dtype=Any),
    contact_pressure: wp.array2d(dtype=Any),
    adhesive_pressure: wp.array2d(dtype=Any),
    adhesive_shear_x: wp.array2d(dtype=Any),
    adhesive_shear_y: wp.array2d(dtype=Any),
    laws: wp.array2d(dtype=Any),
    law_pressure: wp.array2d(dtype=Any),
    law_shear_x: wp.array2d(dtype=Any),
    law_shear_y: wp.array2d(dtype=Any),
):
    """``smc_tractions`` of B cases (the contact shear "bounded"), each with its own law
    (``laws[case]``, slots SMC_*); zero on the rows without adhesion."""
    case, i = wp.tid()
    delta_n = laws[case, SMC_DELTA_N]
    zero = delta_n - delta_n
    p = zero
    qx = zero
    qy = zero
    if delta_n > zero:
        p, qx, qy = smc_cell(gap[case, i], slip_x[case, i], slip_y[case, i], contact_pressure[case, i],
                             adhesive_pressure[case, i], adhesive_shear_x[case, i], adhesive_shear_y[case, i],
                             laws[case, SMC_SIGMA_MAX], laws[case, SMC_TAU_MAX], delta_n, laws[case, SMC_DELTA_T],
                             laws[case, SMC_TOUCHING], 0)
    law_pressure[case, i] = p
    law_shear_x[case, i] = qx
    law_shear_y[case, i] = qy


@wp.kernel
def dugdale_tractions(
    gap: wp.array(dtype=Any),
    contact_pressure: wp.array(dtype=Any),
    adhesive_pressure: wp.array(dtype=Any),
    sigma_0: Any,
    h_0: Any,
    ramp: Any,
    touching: Any,
    centred: int,
    law_pressure: wp.array(dtype=Any),
):
    """The Dugdale tension of the current gap on cells out of contact (zero on contact cells);
    touching cells as in ``smc_tractions``. ``centred``: the one ramp centred on h_0
    (``dugdale_centred_normal``) instead of the two (``dugdale_normal``)."""
    i = wp.tid()
    zero = sigma_0 - sigma_0
    p = zero
    if contact_pressure[i] <= zero:
        if centred != 0:
            p = dugdale_centred_normal(gap[i], sigma_0, h_0, ramp)
        else:
            p = dugdale_normal(gap[i], sigma_0, h_0, ramp)
        if gap[i] <= touching:
            p = touching_segment(adhesive_pressure[i], p)
    law_pressure[i] = p


@wp.kernel
def add_to(source: wp.array(dtype=Any), target: wp.array(dtype=Any)):
    """target += source."""
    i = wp.tid()
    target[i] = target[i] + source[i]


for _k in (smc_tractions, dugdale_tractions, add_to, batch_smc_tractions):
    register_float_overloads(_k)

"""Shear limits (MODEL.md section 5): one kernel per law, writing q_max from the pressure.

Scaled units: pressures and strengths / E*. ``pressure`` is the total pressure that bounds the
shear (contact plus adhesive where adhesion is on); cells with p <= 0 get q_max = 0.
"""

from typing import Any

import warp as wp

from .overloads import register_float_overloads

# no adjoints: nothing differentiates these kernels, and compiling them doubles the build
wp.set_module_options({"enable_backward": False})


@wp.func
def coulomb_shear_limit(p: Any, mu: Any):
    """q_max = mu p for p > 0, else 0 (Coulomb, for validation against Cattaneo-Mindlin)."""
    return wp.where(p > type(p)(0.0), mu * p, type(p)(0.0))


@wp.func
def tabor_shear_limit(p: Any, mu_b: Any, k_vm: Any, yield_strength: Any):
    """q_max = min(mu_b p, k_VM sqrt(max(S_Y^2 - p^2, 0))) for p > 0, else 0.

    mu_b = k_VM / sqrt(k_tau^-2 - 1) is Tabor's bond-failure slope; the second term is the von
    Mises material failure p^2 + q^2 / k_VM^2 = S_Y^2 of the softer material.
    """
    zero = type(p)(0.0)
    bond = mu_b * p
    material = k_vm * wp.sqrt(wp.max(yield_strength * yield_strength - p * p, zero))
    return wp.where(p > zero, wp.min(bond, material), zero)


@wp.kernel
def coulomb_limit(pressure: wp.array(dtype=Any), mu: Any, shear_limit: wp.array(dtype=Any)):
    i = wp.tid()
    shear_limit[i] = coulomb_shear_limit(pressure[i], mu)


@wp.kernel
def tabor_limit(
    pressure: wp.array(dtype=Any), mu_b: Any, k_vm: Any, yield_strength: Any, shear_limit: wp.array(dtype=Any)
):
    i = wp.tid()
    shear_limit[i] = tabor_shear_limit(pressure[i], mu_b, k_vm, yield_strength)


#: the laws of ``batch_shear_limit``, by their code in a case's row of law parameters
LAW_COULOMB = wp.constant(0)
LAW_TABOR = wp.constant(1)
#: a row of law parameters: the law's code, then mu (Coulomb) or mu_b, k_VM, S_Y / E* (Tabor)
N_LAW_PARAMETERS = 4


@wp.kernel
def batch_shear_limit(pressure: wp.array2d(dtype=Any), laws: wp.array2d(dtype=Any),
                      shear_limit: wp.array2d(dtype=Any)):
    """q_max of B cases at once, each by its own law and parameters (a row of ``laws``)."""
    case, i = wp.tid()
    p = pressure[case, i]
    if int(laws[case, 0]) == LAW_COULOMB:
        shear_limit[case, i] = coulomb_shear_limit(p, laws[case, 1])
    else:
        shear_limit[case, i] = tabor_shear_limit(p, laws[case, 1], laws[case, 2], laws[case, 3])


for _k in (coulomb_limit, tabor_limit, batch_shear_limit):
    register_float_overloads(_k)

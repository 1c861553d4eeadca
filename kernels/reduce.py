"""Block reductions for the solver kernels.

The solver kernels that reduce are launched with ``wp.launch_tiled`` over ``num_blocks`` blocks.
Thread ``g`` of the launch visits the cells ``g * outer + k * inner`` for k < ``per``: contiguous
chunks on the CPU (outer = per, inner = 1; one thread per block there), a grid-stride loop on
CUDA (outer = 1, inner = total threads) so that loads coalesce. Each block sums its threads'
partial sums with ``tile_sum`` and adds them to the output with one atomic per block.
"""

from typing import Any

import warp as wp

from .overloads import register_float_overloads

# no adjoints: nothing differentiates these kernels, and compiling them doubles the build
wp.set_module_options({"enable_backward": False})

# slots shared by the conjugate-gradient solvers (kernels/normal.py, kernels/tangential.py)
S_G = wp.constant(0)  # the (preconditioned) squared gradient over the free set
S_VIOL = wp.constant(1)  # squared violation of the optimality conditions
S_RHS = wp.constant(2)  # squared right-hand side over the active cells
S_RESTART = wp.constant(5)  # cells that re-entered the free set: restart the conjugacy
C_G_OLD = wp.constant(0)
C_DELTA = wp.constant(1)
C_ITER = wp.constant(2)
N_SCALARS = 3
# slots of a solver's ``settings`` array: the values of one solve that its iteration reads on the
# device (so that a captured CUDA graph of the iteration serves every solve)
P_TOL = wp.constant(0)  # relative residual to reach
P_APPROACH = wp.constant(1)  # rigid approach delta_z, scaled (normal solver)
N_SETTINGS = 2


@wp.func
def cell_index(thread: int, outer: int, inner: int, k: int) -> int:
    """Index of the k-th cell visited by thread ``thread`` (= block * block_dim + lane)."""
    return thread * outer + k * inner


@wp.func
def block_add(sums: wp.array(dtype=Any), slot: int, value: Any):
    """sums[slot] += the sum of ``value`` over the threads of this block."""
    total = wp.tile_sum(wp.tile(value))
    wp.tile_atomic_add(sums, total, offset=slot)


@wp.func
def block_max(out: wp.array(dtype=Any), slot: int, value: Any, lane: int):
    """out[slot] = max(out[slot], the largest ``value`` of this block's threads): one atomic per
    block, by its lane 0."""
    largest = wp.tile_extract(wp.tile_max(wp.tile(value)), 0)
    if lane == 0:
        wp.atomic_max(out, slot, largest)


S_GT = wp.constant(3)  # g . t over the free set
S_RT = wp.constant(4)  # t . (K t) (+ curvature) over the free set


@wp.func
def cg_step_length(sums: wp.array(dtype=Any)):
    """The conjugate-gradient step tau = (g . t) / (t . H t), 0 when the denominator vanishes."""
    zero = sums[S_GT] - sums[S_GT]
    return wp.where(sums[S_RT] > zero, sums[S_GT] / sums[S_RT], zero)


@wp.func
def cg_converged(sums: wp.array(dtype=Any), tol: Any):
    """Whether the iterate this iteration started from already meets the relative tolerance:
    then it is left as it is (near the solution tau is a ratio of rounding noise)."""
    return sums[S_VIOL] <= tol * tol * sums[S_RHS]


@wp.kernel
def cg_advance(sums: wp.array(dtype=Any), scalars: wp.array(dtype=Any), residual_history: wp.array(dtype=Any)):
    """One thread, end of an iteration: G_old <- G, delta <- (no cell re-entered the free set),
    and the relative residual sqrt(S_VIOL / S_RHS) of the iterate the iteration started from."""
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
    scalars[C_DELTA] = wp.where(sums[S_RESTART] > zero, zero, one)
    scalars[C_ITER] = scalars[C_ITER] + one


register_float_overloads(cg_advance)

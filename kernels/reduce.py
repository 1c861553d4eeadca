"""Block reductions for the solver kernels.

The solver kernels that reduce are launched with ``wp.launch_tiled`` over ``num_blocks`` blocks.
Their ``cells`` argument (:class:`Cells`) says which entries each thread visits: thread ``g`` of
the launch visits the cells ``g * outer + k * inner`` for k < ``per``: contiguous
chunks on the CPU (outer = per, inner = 1; one thread per block there), a grid-stride loop on
CUDA (outer = 1, inner = total threads) so that loads coalesce. Each block sums its threads'
partial sums with ``tile_sum`` and adds them to the output with one atomic per block.
"""

from typing import Any

import warp as wp

from .overloads import register_float_overloads

# no adjoints: nothing differentiates these kernels, and compiling them doubles the build
wp.set_module_options({"enable_backward": False})

# slots of ``sums`` shared by the conjugate-gradient solvers (kernels/normal.py,
# kernels/tangential.py); a solver's own slots follow from N_SHARED_SUMS on
S_G = wp.constant(0)  # the (preconditioned) squared gradient over the free set
S_VIOL = wp.constant(1)  # squared violation of the optimality conditions
S_RHS = wp.constant(2)  # squared right-hand side over the active cells
S_GT = wp.constant(3)  # g . t over the free set
S_RT = wp.constant(4)  # t . (K t) (+ curvature) over the free set
S_RESTART = wp.constant(5)  # cells that re-entered the free set: restart the conjugacy
N_SHARED_SUMS = 6
# slots of a solver's ``scalars`` array, carried from one iteration to the next
C_G_OLD = wp.constant(0)  # S_G of the last iteration
C_DELTA = wp.constant(1)  # 0: restart the conjugacy in the next iteration
C_ITER = wp.constant(2)  # iterations done in this solve
C_STOP = wp.constant(3)  # 1: the loop stopped for convergence, the limit or a non-finite value; 0: at a launch's end
N_SCALARS = 4
# slots of a solver's ``parameters`` array: the values of one solve that its iteration reads on the
# device (so that a captured CUDA graph of the iteration serves every solve)
P_TOL = wp.constant(0)  # relative residual to reach
P_APPROACH = wp.constant(1)  # rigid approach delta_z, scaled (normal solver)
P_MAX_ITER = wp.constant(2)  # iteration limit of the solve
P_CHUNK = wp.constant(3)  # iterations per launch of the device loop: it stops at multiples of this
P_EXACT = wp.constant(4)  # normal solver: 1 to recompute K p at every iteration (two convolutions)
N_PARAMETERS = 5


@wp.struct
class Cells:
    """The entries a reducing launch visits: ``n`` of them; thread g visits ``g * outer + k *
    inner`` for k < ``per`` (``numerics.launch.ReductionLaunch``, one instance per shape)."""

    n: int
    outer: int
    inner: int
    per: int


@wp.func
def cell_index(thread: int, cells: Cells, k: int) -> int:
    """Index of the k-th entry visited by thread ``thread`` (= block * block_dim + lane)."""
    return thread * cells.outer + k * cells.inner


@wp.func
def block_add(sums: wp.array(dtype=Any), slot: int, value: Any):
    """sums[slot] += the sum of ``value`` over the threads of this block."""
    total = wp.tile_sum(wp.tile(value))
    wp.tile_atomic_add(sums, total, offset=slot)


@wp.func
def block_add_vector(sums: wp.array(dtype=Any), slot: int, values: Any, lane: int):
    """sums[slot + c] += the sum of ``values[c]`` over the threads of this block, for each
    component c of the vector ``values``: one block reduction of vectors (lane 0 adds the
    components), cheaper than one ``block_add`` per slot."""
    total = wp.tile_extract(wp.tile_sum(wp.tile(values, preserve_type=True)), 0)
    if lane == 0:
        for c in range(len(values)):
            wp.atomic_add(sums, slot + c, total[c])


@wp.func
def block_max(out: wp.array(dtype=Any), slot: int, value: Any, lane: int):
    """out[slot] = max(out[slot], the largest ``value`` of this block's threads): one atomic per
    block, by its lane 0."""
    largest = wp.tile_extract(wp.tile_max(wp.tile(value)), 0)
    if lane == 0:
        wp.atomic_max(out, slot, largest)


@wp.func
def cg_step_length(sums: wp.array(dtype=Any)):
    """The conjugate-gradient step tau = (g . t) / (t . H t), 0 when the denominator vanishes."""
    zero = sums[S_GT] - sums[S_GT]
    return wp.where(sums[S_RT] > zero, sums[S_GT] / sums[S_RT], zero)


@wp.func
def conjugacy(sums: wp.array(dtype=Any), scalars: wp.array(dtype=Any)):
    """The conjugacy factor beta = delta G / G_old of the next direction (0 on a restart and at
    the first iteration), G = ``sums[S_G]`` (g . M g, M the solver's preconditioner)."""
    zero = sums[S_G] - sums[S_G]
    beta = zero
    if scalars[C_G_OLD] > zero:
        beta = scalars[C_DELTA] * sums[S_G] / scalars[C_G_OLD]
    return beta


@wp.func
def cg_converged(sums: wp.array(dtype=Any), tol: Any):
    """Whether the iterate this iteration started from already meets the relative tolerance:
    then it is left as it is (near the solution tau is a ratio of rounding noise)."""
    return sums[S_VIOL] <= tol * tol * sums[S_RHS]


@wp.func
def relative_residual(sums: wp.array(dtype=Any)):
    """The relative residual sqrt(S_VIOL / S_RHS) of the iterate the sums describe (1 where the
    right-hand side is zero but not the violation), and whether both sums are finite; a residual
    that is not finite when they are not."""
    return residual_of(sums[S_VIOL], sums[S_RHS])


@wp.func
def residual_of(viol: Any, rhs: Any):
    """:func:`relative_residual` from the sums' values."""
    zero = type(viol)(0.0)
    res = zero
    if rhs > zero:
        res = wp.sqrt(viol / rhs)
    elif viol > zero:
        res = type(zero)(1.0)
    finite = wp.isfinite(viol) and wp.isfinite(rhs)
    if not finite:
        res = viol + rhs  # not finite: the host names the cell
    return res, finite


@wp.func
def stop_loop(scalars: wp.array(dtype=Any), loop: wp.array(dtype=wp.int32), refresh: wp.array(dtype=wp.int32),
              settled: bool):
    """End the device loop: for good (``settled``: converged, at the limit or not finite; the
    launch then makes the iterate's residual exact, ``refresh[0]`` = 1) or at a launch's end."""
    loop[0] = 0
    refresh[0] = wp.where(settled, 1, 0)
    scalars[C_STOP] = wp.where(settled, type(scalars[0])(1.0), type(scalars[0])(0.0))


@wp.kernel
def loop_start(sums: wp.array(dtype=Any), parameters: wp.array(dtype=Any), exact: int, scalars: wp.array(dtype=Any),
               loop: wp.array(dtype=wp.int32), refresh: wp.array(dtype=wp.int32)):
    """One thread, before a launch's iterations: go on (``loop[0]`` = 1) unless the iterate's
    residual is under ``parameters[P_TOL]`` or not finite, or the iteration limit is reached.
    ``exact`` = 1: the sums were just made exact (a solve's first launch), so a solve that settles
    here needs no refresh (a warm start already converged: one convolution instead of two)."""
    res, finite = relative_residual(sums)
    if finite and not (res < parameters[P_TOL]) and int(scalars[C_ITER]) < int(parameters[P_MAX_ITER]):
        loop[0] = 1
        refresh[0] = 0
        scalars[C_STOP] = type(scalars[0])(0.0)
    else:
        stop_loop(scalars, loop, refresh, True)
        if exact != 0:
            refresh[0] = 0


@wp.func
def advance(sums: wp.array(dtype=Any), parameters: wp.array(dtype=Any), restart_every: int, scalars: wp.array(dtype=Any),
            residual_history: wp.array(dtype=Any), loop: wp.array(dtype=wp.int32), refresh: wp.array(dtype=wp.int32)):
    """End of an iteration (one thread): record the relative residual of the iterate the
    iteration started from, carry G_old <- S_G and delta <- (no cell re-entered the free set),
    count the iteration, and stop the device loop (:func:`stop_loop`) once that residual is under
    ``parameters[P_TOL]`` or not finite or at ``parameters[P_MAX_ITER]`` iterations (settled), and at
    every multiple of ``parameters[P_CHUNK]`` (the host's turn: interrupts). Every
    ``restart_every`` iterations (0: never) the next direction is the gradient. Returns the
    iterations done and whether the loop stopped.

    Every load comes before the first store: the compiler keeps a load after a store to another
    array (they might alias), so each would wait for the one before, and a one-thread kernel is
    all latency."""
    viol = sums[S_VIOL]
    rhs = sums[S_RHS]
    g = sums[S_G]
    restart = sums[S_RESTART]
    it = int(scalars[C_ITER])
    tol = parameters[P_TOL]
    max_iter = int(parameters[P_MAX_ITER])
    chunk = int(parameters[P_CHUNK])
    zero = type(tol)(0.0)
    one = type(tol)(1.0)
    res, finite = residual_of(viol, rhs)
    if it < residual_history.shape[0]:
        residual_history[it] = res
    done = it + 1
    scalars[C_G_OLD] = wp.where(restart_every > 0 and done % restart_every == 0, zero, g)
    scalars[C_DELTA] = wp.where(restart > zero, zero, one)
    scalars[C_ITER] = type(zero)(done)
    settled = (not finite) or res < tol or done >= max_iter
    stopped = settled or done % chunk == 0
    if stopped:
        stop_loop(scalars, loop, refresh, settled)
    return done, stopped


@wp.kernel
def cg_advance(sums: wp.array(dtype=Any), parameters: wp.array(dtype=Any), restart_every: int, scalars: wp.array(dtype=Any),
               residual_history: wp.array(dtype=Any), loop: wp.array(dtype=wp.int32), refresh: wp.array(dtype=wp.int32)):
    """One thread, end of an iteration: :func:`advance`."""
    done, stopped = advance(sums, parameters, restart_every, scalars, residual_history, loop, refresh)


@wp.kernel
def sums_of_products(a0: wp.array(dtype=Any), b0: wp.array(dtype=Any), a1: wp.array(dtype=Any),
                     b1: wp.array(dtype=Any), a2: wp.array(dtype=Any), b2: wp.array(dtype=Any), slot0: int,
                     slot1: int, slot2: int, count: int, cells: Cells,
                     sums: wp.array(dtype=Any)):
    """sums[slot_k] += a_k . b_k for the first ``count`` (1 to 3) pairs, in one pass: the dot
    products of the solvers' vector algebra (the L-BFGS recursion and its new pairs, Anderson
    mixing's Gram matrix). The pairs past ``count`` are not read (any arrays will do); the
    Python side is ``numerics.launch.products``."""
    block, lane = wp.tid()
    thread = block * wp.block_dim() + lane
    zero = a0[0] - a0[0]
    s0 = zero
    s1 = zero
    s2 = zero
    for k in range(cells.per):
        i = cell_index(thread, cells, k)
        if i < cells.n:
            s0 += a0[i] * b0[i]
            if count > 1:
                s1 += a1[i] * b1[i]
            if count > 2:
                s2 += a2[i] * b2[i]
    block_add(sums, slot0, s0)
    if count > 1:
        block_add(sums, slot1, s1)
    if count > 2:
        block_add(sums, slot2, s2)


register_float_overloads(sums_of_products)
register_float_overloads(loop_start)
register_float_overloads(cg_advance)

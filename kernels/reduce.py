"""Block reductions for the solver kernels.

The solver kernels that reduce are launched with ``wp.launch_tiled`` over ``num_blocks`` blocks.
Thread ``g`` of the launch visits the cells ``g * outer + k * inner`` for k < ``per``: contiguous
chunks on the CPU (outer = per, inner = 1; one thread per block there), a grid-stride loop on
CUDA (outer = 1, inner = total threads) so that loads coalesce. Each block sums its threads'
partial sums with ``tile_sum`` and adds them to the output with one atomic per block.
"""

from typing import Any

import warp as wp


@wp.func
def cell_index(thread: int, outer: int, inner: int, k: int) -> int:
    """Index of the k-th cell visited by thread ``thread`` (= block * block_dim + lane)."""
    return thread * outer + k * inner


@wp.func
def block_add(sums: wp.array(dtype=Any), slot: int, value: Any):
    """sums[slot] += the sum of ``value`` over the threads of this block."""
    total = wp.tile_sum(wp.tile(value))
    wp.tile_atomic_add(sums, total, offset=slot)

"""Kernel launches recorded once and replayed: the host cost of a launch that repeats.

``wp.launch`` resolves the overload of a generic kernel and packs every argument each time it is
called: tens of microseconds of Python per launch, which on a GPU can take longer than the kernel.
A load step of the coupled adhesive problem makes about 70 launches per turn outside the captured
solver iterations and about 60 turns per state (Table 2), so a 256 x 256 cell spent most of its
time in ``wp.launch`` (measured with cProfile on an H100).

:class:`LaunchCache` records a launch (``wp.launch(record_cmd=True)``) the first time a kernel is
launched with a given set of arrays and values and replays the recorded :class:`warp.Launch` after
that. The key is the kernel, the launch shape and, per argument, the array's address, shape,
strides and type or the scalar's type and value, so a replay is exactly the launch it stands for.
Recorded launches keep no reference to their arrays (an array freed later is not held alive; a
new array at the same address with the same shape and type is the same argument to the kernel).
"""

from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import dataclass

import warp as wp


@dataclass(frozen=True)
class ReductionLaunch:
    """Launch shape of the reducing kernels (see kernels/reduce.py) over n entries on a device:
    ``num_blocks`` blocks of ``block_dim`` threads; thread g visits the entries ``g * outer + k *
    inner`` for k < ``per``."""

    num_blocks: int
    block_dim: int
    outer: int
    inner: int
    per: int

    #: CUDA: threads per block, and blocks per SM at most (``bench/reduction_launch.py``)
    block_dim_cuda = 256
    blocks_per_sm = 4

    @staticmethod
    def for_cells(n: int, device, blocks_per_sm: int | None = None) -> "ReductionLaunch":
        """The shape for ``n`` entries: on the CPU one contiguous sweep (its kernels run serially);
        on CUDA a grid-stride loop over at most ``blocks_per_sm`` (default: the class's) blocks per
        SM."""
        if device.is_cpu:
            return ReductionLaunch(1, 1, n, 1, n)
        block_dim = ReductionLaunch.block_dim_cuda
        per_sm = ReductionLaunch.blocks_per_sm if blocks_per_sm is None else int(blocks_per_sm)
        sms = device.sm_count if hasattr(device, "sm_count") else 132
        blocks = max(1, min(per_sm * sms, math.ceil(n / block_dim)))
        total = blocks * block_dim
        return ReductionLaunch(blocks, block_dim, 1, total, math.ceil(n / total))

    def args(self, n: int) -> list:
        return [n, self.outer, self.inner, self.per]


def _arg_key(a):
    if isinstance(a, wp.array):
        return (a.ptr, a.shape, a.strides, a.dtype)
    return (type(a), a.value if hasattr(a, "value") else a)


class LaunchCache:
    """Recorded launches of one device, replayed when a launch repeats.

    Args:
        device: the Warp device every launch goes to.
        capacity: launches kept (least recently used dropped first); launches with scalars that
            change every time (a load step's shifts) take a place each.
    """

    def __init__(self, device, capacity: int = 2048):
        self.device = device
        self.capacity = int(capacity)
        self._launches: OrderedDict = OrderedDict()

    def launch(self, kernel, dim, inputs, outputs=(), block_dim=None):
        """``wp.launch(kernel, dim, inputs, outputs, block_dim=block_dim)`` on the cache's device."""
        key = (kernel, tuple(dim) if isinstance(dim, (list, tuple)) else dim, block_dim,
               tuple(_arg_key(a) for a in inputs), tuple(_arg_key(a) for a in outputs))
        cmd = self._launches.get(key)
        if cmd is None:
            cmd = wp.launch(kernel, dim=dim, inputs=inputs, outputs=outputs, device=self.device, block_dim=block_dim,
                            record_cmd=True)
            cmd.fwd_args = cmd.adj_args = None  # hold no arrays (only needed to record into Warp's APIC streams)
            self._launches[key] = cmd
            while len(self._launches) > self.capacity:
                self._launches.popitem(last=False)
        else:
            self._launches.move_to_end(key)
        cmd.launch()

    def launch_rows(self, kernel, shape, inputs, outputs=()):
        """An elementwise kernel over a (rows, columns) ``shape``, launched over (rows, chunks):
        thread (i, c) does the entries j of row i from ``c * per`` to ``(c + 1) * per``, ``per``
        passed after ``inputs``. On CUDA one entry per thread (chunks = columns, per = 1); on the
        CPU, where Warp runs the threads one after another, a whole row per thread (chunks = 1,
        per = columns), which halves the per-entry overhead (n = 512: 2.57 -> 1.24 ms for the
        normal spectral product)."""
        rows, columns = shape
        chunks, per = (1, columns) if self.device.is_cpu else (columns, 1)
        self.launch(kernel, (rows, chunks), [*inputs, per], outputs)

    def launch_tiled(self, kernel, blocks: int, block_dim: int, inputs, outputs=()):
        """``wp.launch_tiled(kernel, dim=[blocks], ..., block_dim=block_dim)``: one tile per block.
        On the CPU the block is one thread (Warp runs CPU blocks of 1 unless configured otherwise)."""
        if self.device.is_cpu:
            block_dim = 1
        self.launch(kernel, (blocks, block_dim), inputs, outputs, block_dim=block_dim)

    def launch_reduce(self, kernel, shape: ReductionLaunch, n: int, inputs, outputs=()):
        """A reducing kernel (kernels/reduce.py) over ``n`` entries in the launch ``shape``:
        ``inputs``, then the shape's arguments (n, outer, inner, per), then ``outputs``."""
        self.launch_tiled(kernel, shape.num_blocks, shape.block_dim, [*inputs, *shape.args(n)], outputs)

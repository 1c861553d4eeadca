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

On the CPU, where Warp runs a launch on one thread, a launch whose fields are marked
:class:`Rows` (and sums :class:`Sums`) is split by rows over the CPU's threads
(:meth:`LaunchCache.split`): Warp lets go of the GIL while a CPU kernel runs, so the parts run at
once. What each part saves along whole paths: docs/performance.md, "The launch layer".
"""

from __future__ import annotations

import functools
import gc
import math
import os
import warnings
from collections import OrderedDict
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
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

    #: CUDA: threads per block, and blocks per SM at most (the fastest of the shapes tried for the
    #: solvers' reductions on an H100)
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
        """The reducing kernels' ``cells`` argument for ``n`` entries in this shape (one list)."""
        return [cells_of(n, self.outer, self.inner, self.per)]


@functools.lru_cache(maxsize=256)
def cells_of(n: int, outer: int, inner: int, per: int):
    """``kernels/reduce.py``'s ``Cells`` of these values: one instance per shape, so that a
    launch that repeats has the same argument (``LaunchCache``'s key) and is replayed."""
    from warpcontact.kernels.reduce import Cells

    cells = Cells()
    cells.n, cells.outer, cells.inner, cells.per = int(n), int(outer), int(inner), int(per)
    return cells


def products(*pairs) -> list:
    """The inputs of ``kernels/reduce.py``'s ``sums_of_products`` for one to three
    ``(a, b, slot)``: sums[slot] += a . b for each, in one pass (the pairs not given are not read:
    the first pair's arrays stand in for them)."""
    if not 1 <= len(pairs) <= 3:
        raise ValueError(f"products: one to three pairs, got {len(pairs)}")
    full = list(pairs) + [pairs[0]] * (3 - len(pairs))
    return [*(a for a, b, _ in full for a in (a, b)), *(int(slot) for _, _, slot in full), len(pairs)]


@dataclass(frozen=True)
class Rows:
    """A field argument of a launch the CPU may split by rows (:class:`LaunchCache`): each part
    of the launch gets the rows [r0, r1) of ``array``, along ``axis`` (1 for a stack of fields),
    or the entries [r0 w, r1 w) of a flat field w entries wide. Elsewhere ``array`` as it is."""

    array: wp.array
    axis: int = 0

    def part(self, r0: int, r1: int, width: int) -> wp.array:
        a = self.array
        if a.ndim == 1:
            return a[r0 * width : r1 * width]
        return a[r0:r1] if self.axis == 0 else a[:, r0:r1]


@dataclass(frozen=True)
class FlatRows(Rows):
    """A stack of flat fields, (k, n^2) with the cells on its last axis (an Anderson mixing's
    history columns), or one flat field: each part of a split CPU launch gets the entries
    [r0 w, r1 w) of every field of the stack."""

    def part(self, r0: int, r1: int, width: int) -> wp.array:
        a, entries = self.array, slice(r0 * width, r1 * width)
        return a[entries] if a.ndim == 1 else a[:, entries]


@dataclass(frozen=True)
class Cases(Rows):
    """An array of a batched solver whose first axis is the case (``BatchLaunches``): each part of
    a launch split over the cases gets the cases [r0, r1) of it, whatever its other axes."""

    def part(self, r0: int, r1: int, width: int) -> wp.array:
        return self.array[r0:r1]


@dataclass(frozen=True)
class Sums:
    """The array a reducing launch adds its block sums to (and may read). Each part of a split
    CPU launch adds to a copy of it; the copies' additions are added to it after the parts end
    (Warp's CPU atomics are plain additions: two threads must not add to one array). The slots in
    ``maxima`` hold a largest value (``block_max``), not a sum: they get the largest of the copies'."""

    array: wp.array
    maxima: tuple = ()


@dataclass(frozen=True)
class FirstRow:
    """An int argument: the first row of the part of a split CPU launch that gets it, 0 in a
    whole launch (for kernels whose work depends on the absolute row, not only on the part's
    rows)."""


def _plain(a):
    if isinstance(a, FirstRow):
        return 0
    return a.array if isinstance(a, (Rows, Sums)) else a


_part_kernels: dict = {}


def part_kernel(kernel, part: int):
    """The kernel that part ``part`` of a split CPU launch runs: ``kernel`` itself for part 0, for
    the others a copy compiled in a module of its own. Warp's CPU kernels point a static variable
    of their module at their tile storage (on their stack) while they run (warp/native/tile.h, on
    x86-64), so two kernels of one module must not run at once; kernels of different modules may.
    The copy has the overloads ``kernel`` has now."""
    if part == 0:
        return kernel
    key = (kernel, part)
    copy = _part_kernels.get(key)
    if copy is None:
        name = f"warpcontact_part{part}_{kernel.key}"
        wp.set_module_options({"enable_backward": kernel.module.options.get("enable_backward")}, module=name)
        copy = wp.kernel(kernel.func, module=name)
        for overload in list(kernel.overloads.values()):
            wp.overload(copy, [arg.type for arg in overload.adj.args])
        _part_kernels[key] = copy
    return copy


def _arg_key(a):
    """A launch argument's part of a :class:`LaunchCache` key: an array's address, shape, strides
    and type (a marked one's array's), a scalar's type and value (arrays first: most arguments
    are, and this runs for every argument of every launch)."""
    if isinstance(a, wp.array):
        return (a.ptr, a.shape, a.strides, a.dtype)
    if isinstance(a, (Rows, Sums)):
        a = a.array
        return (a.ptr, a.shape, a.strides, a.dtype)
    if isinstance(a, FirstRow):
        return (FirstRow,)
    return (type(a), a.value if hasattr(a, "value") else a)


class LaunchCache:
    """Recorded launches of one device, replayed when a launch repeats.

    Args:
        device: the Warp device every launch goes to.
        capacity: launches kept (least recently used dropped first); launches with scalars that
            change every time (a load step's shifts) take a place each.
    """

    #: CPU: launches over fewer entries than this (512 x 512) run whole on one thread. A split
    #: costs about 0.1 ms (waking the other thread, merging the sums); along whole paths on 2
    #: cores it paid from n = 512 on, not at 256 (docs/performance.md, "The launch layer").
    min_split_entries = 2**18
    #: CPU threads a cache splits launches over by default (None: one per CPU); 1: no split (what
    #: ``bench/paths.py --choices one-thread`` compares with)
    threads: int | None = None
    #: replay recorded launches; False: every launch is a plain ``wp.launch`` (``bench/paths.py
    #: --choices plain-launches``)
    replay = True

    def __init__(self, device, capacity: int = 2048, workers: int | None = None):
        self.device = device
        self.capacity = int(capacity)
        self._launches: OrderedDict = OrderedDict()
        self._pool = None
        self._splits: OrderedDict = OrderedDict()
        self.workers = workers or self.threads or os.cpu_count() or 1

    @property
    def workers(self) -> int:
        """CPU threads a launch with :class:`Rows` arguments is split over (Warp runs a CPU launch
        on one thread and lets go of the GIL while it runs); default one per CPU; 1 on CUDA."""
        return self._workers

    @workers.setter
    def workers(self, count: int):
        self._workers = 1 if self.device.is_cuda else max(1, int(count))
        self._splits.clear()
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None

    def _key(self, kernel, dim, block_dim, inputs, outputs):
        return (kernel, tuple(dim) if isinstance(dim, (list, tuple)) else dim, block_dim,
                tuple(map(_arg_key, inputs)), tuple(map(_arg_key, outputs)))

    def launch(self, kernel, dim, inputs, outputs=(), block_dim=None):
        """``wp.launch(kernel, dim, inputs, outputs, block_dim=block_dim)`` on the cache's device
        (:class:`Rows` and :class:`Sums` arguments taken as their arrays)."""
        if not self.replay:
            wp.launch(kernel, dim=dim, inputs=[_plain(a) for a in inputs], outputs=[_plain(a) for a in outputs],
                      device=self.device, block_dim=block_dim)
            return
        key = self._key(kernel, dim, block_dim, inputs, outputs)
        cmd = self._launches.get(key)
        if cmd is None:
            inputs, outputs = [_plain(a) for a in inputs], [_plain(a) for a in outputs]
            cmd = wp.launch(kernel, dim=dim, inputs=inputs, outputs=outputs, device=self.device, block_dim=block_dim,
                            record_cmd=True)
            cmd.fwd_args = cmd.adj_args = None  # hold no arrays (only needed to record into Warp's APIC streams)
            self._launches[key] = cmd
            while len(self._launches) > self.capacity:
                self._launches.popitem(last=False)
        else:
            self._launches.move_to_end(key)
        cmd.launch()

    def launch_cells(self, kernel, shape, inputs, outputs=()):
        """An elementwise kernel of one thread per entry (``i = wp.tid()``) over the entries of a
        (rows, columns) ``shape``, row-major; on the CPU split by rows over its threads
        (:meth:`split`; the part of rows [r0, r1) runs (r1 - r0) * columns threads)."""
        rows, columns = shape
        if self.device.is_cpu:
            self.split(kernel, shape, lambda r0, r1: ((r1 - r0) * columns, inputs), inputs, outputs)
        else:
            self.launch(kernel, rows * columns, inputs, outputs)

    def launch_rows(self, kernel, shape, inputs, outputs=()):
        """An elementwise kernel over a (rows, columns) ``shape``, launched over (rows, chunks):
        thread (i, c) does the entries j of row i from ``c * per`` to ``(c + 1) * per``, ``per``
        passed after ``inputs``. On CUDA one entry per thread (chunks = columns, per = 1); on the
        CPU, where Warp runs the threads one after another, a whole row per thread (chunks = 1,
        per = columns), which halves the per-entry overhead (n = 512: 2.57 -> 1.24 ms for the
        normal spectral product), and the rows split over the CPU threads (:meth:`split`)."""
        rows, columns = shape
        if self.device.is_cpu:
            self.split(kernel, shape, lambda r0, r1: ((r1 - r0, 1), [*inputs, columns]), inputs, outputs)
        else:
            self.launch(kernel, (rows, columns), [*inputs, 1], outputs)

    def split(self, kernel, shape, part_launch, inputs, outputs=(), block_dim=None, min_entries=None):
        """On the CPU, launch ``kernel`` as parts of the (rows, columns) ``shape`` on the
        ``workers`` threads, each part a block of rows [r0, r1) of every :class:`Rows` argument
        (and a copy of every :class:`Sums` argument, and the part's first row for a
        :class:`FirstRow` argument: a kernel that indexes whole arrays by the absolute row may be
        split by it alone); whole when it has fewer than ``min_split_entries`` entries or no Rows
        or FirstRow argument (``min_entries``: another threshold, for a kernel that does more
        than an elementwise pass's work an entry). ``part_launch(r0, r1)`` returns the launch
        dimensions and inputs of the rows [r0, r1) (the Rows arguments as given)."""
        rows, columns = shape
        parts = min(self.workers, rows)
        marked = any(isinstance(a, (Rows, FirstRow)) for a in [*inputs, *outputs])
        least = self.min_split_entries if min_entries is None else min_entries
        if parts < 2 or rows * columns < least or not marked:
            dim, part_inputs = part_launch(0, rows)
            self.launch(kernel, dim, part_inputs, outputs, block_dim)
            return
        key = self._key(kernel, shape, block_dim, inputs, outputs)
        plan = self._splits.get(key)
        if plan is None:
            plan = self._split_plan(kernel, shape, parts, part_launch, outputs, block_dim)
            self._splits[key] = plan
            while len(self._splits) > self.capacity:
                self._splits.popitem(last=False)
        else:
            self._splits.move_to_end(key)
        copies, launches = plan
        # this call's Sums arrays (the plan's key holds their addresses, the plan not the arrays)
        marked_sums = [a for a in outputs if isinstance(a, Sums)]
        totals = [a.array.numpy() for a in marked_sums]
        before = [t.copy() for t in totals]
        for part_copies in copies:
            for c, b in zip(part_copies, before):
                c[...] = b
        if self._pool is None:
            self._pool = ThreadPoolExecutor(max_workers=self.workers - 1, thread_name_prefix="warpcontact-launch")
        # the first part on this thread, the others on the pool's; result(): waits for each and
        # re-raises a part's exception here
        others = [self._pool.submit(cmd.launch) for cmd in launches[1:]]
        launches[0].launch()
        for future in others:
            future.result()
        for i, (a, t, b) in enumerate(zip(marked_sums, totals, before)):
            with np.errstate(invalid="ignore"):  # a maximum's slot from -inf: replaced below
                merged = b + sum(part_copies[i] - b for part_copies in copies)
            for slot in a.maxima:
                merged[slot] = max(b[slot], *(part_copies[i][slot] for part_copies in copies))
            t[...] = merged

    def _split_plan(self, kernel, shape, parts, part_launch, outputs, block_dim):
        """A split launch, recorded: each part's copies of the Sums arrays (kept, as NumPy views
        of the CPU arrays) and each part's recorded launch (which, like :meth:`launch`'s, holds no
        reference to its arrays)."""
        rows, columns = shape
        sums = [a.array for a in outputs if isinstance(a, Sums)]
        copies, launches = [], []
        bounds = [rows * k // parts for k in range(parts + 1)]
        for part, (r0, r1) in enumerate(zip(bounds[:-1], bounds[1:])):
            part_copies = [wp.empty_like(s) for s in sums]
            copy_of = dict(zip((id(s) for s in sums), part_copies))
            dim, part_inputs = part_launch(r0, r1)

            def piece(a):
                if isinstance(a, Rows):
                    return a.part(r0, r1, columns)
                if isinstance(a, FirstRow):
                    return r0
                if isinstance(a, Sums):
                    return copy_of[id(a.array)]
                return a

            cmd = wp.launch(part_kernel(kernel, part), dim=dim, inputs=[piece(a) for a in part_inputs],
                            outputs=[piece(a) for a in outputs], device=self.device, block_dim=block_dim,
                            record_cmd=True)
            cmd.fwd_args = cmd.adj_args = None
            copies.append([c.numpy() for c in part_copies])  # (each view holds its array)
            launches.append(cmd)
        return copies, launches

    def launch_tiled(self, kernel, blocks: int, block_dim: int, inputs, outputs=()):
        """``wp.launch_tiled(kernel, dim=[blocks], ..., block_dim=block_dim)``: one tile per block.
        On the CPU the block is one thread (Warp runs CPU blocks of 1 unless configured otherwise)."""
        if self.device.is_cpu:
            block_dim = 1
        self.launch(kernel, (blocks, block_dim), inputs, outputs, block_dim=block_dim)

    def launch_reduce(self, kernel, shape: ReductionLaunch, n: int, inputs, outputs=(), rows=None):
        """A reducing kernel (kernels/reduce.py) over ``n`` entries in the launch ``shape``:
        ``inputs``, then the shape's ``Cells`` (:meth:`ReductionLaunch.args`), then ``outputs``. With
        ``rows`` = (rows, columns) of the n entries, the CPU splits it over its threads by rows
        (:meth:`split`; its sums in :class:`Sums` arguments)."""
        if self.device.is_cpu and rows is not None:
            if rows[0] * rows[1] != n:
                raise ValueError(f"launch_reduce: rows {rows} do not hold the {n} entries")

            def part_launch(r0, r1):
                m = (r1 - r0) * rows[1]
                return (1, 1), [*inputs, *ReductionLaunch.for_cells(m, self.device).args(m)]

            self.split(kernel, rows, part_launch, inputs, outputs, block_dim=1)
            return
        self.launch_tiled(kernel, shape.num_blocks, shape.block_dim, [*inputs, *shape.args(n)], outputs)


class BatchLaunches:
    """The launches of a batched solver (``solvers/*_batch.py``) over B cases of ``n_cells`` cells
    each, recorded once and replayed (:class:`LaunchCache`: its arrays are the solver's own):
    elementwise kernels over (B, n_cells), reducing kernels over (B, blocks) tiles of the
    reduction's threads (``kernels/normal_batch.py``), kernels of one thread a case.

    On the CPU, where Warp runs a launch on one thread, the elementwise and reducing launches are
    split over the cases (:meth:`LaunchCache.split`, its threads and threshold), each part a block
    of cases: their kernels take the case from the launch's first index and every array they
    are given has one row a case (each part gets its cases' rows, :class:`Cases`, and adds its
    sums to its own cases' slots); a launch with any other array runs whole.

    Args:
        batch: cases B.
        n_cells: cells of a case.
        device: the Warp device.
    """

    def __init__(self, batch: int, n_cells: int, device):
        self.batch, self.n_cells = int(batch), int(n_cells)
        self.reduction = ReductionLaunch.for_cells(self.n_cells, device)
        self.cache = LaunchCache(device)

    def launch(self, kernel, dim, inputs, outputs=()):
        """Any other launch over ``dim``."""
        self.cache.launch(kernel, dim, inputs, outputs)

    def cells(self, kernel, inputs, outputs=()):
        """An elementwise kernel over (B, n_cells)."""
        self._by_cases(kernel, (self.batch, self.n_cells), inputs, outputs)

    def reduce(self, kernel, inputs, outputs):
        """A reducing kernel over (B, blocks) tiles: ``inputs``, the reduction's ``Cells``, ``outputs``."""
        r = self.reduction
        self._by_cases(kernel, (self.batch, r.num_blocks, r.block_dim), [*inputs, *r.args(self.n_cells)], outputs,
                       block_dim=r.block_dim)

    def _by_cases(self, kernel, dim, inputs, outputs, block_dim=None):
        """A launch over ``dim`` = (B, ...): on the CPU split over the cases where every array
        argument has one row a case, else whole."""
        if self.cache.device.is_cuda or any(isinstance(a, wp.array) and a.shape[0] != self.batch
                                            for a in (*inputs, *outputs)):
            self.cache.launch(kernel, dim, inputs, outputs, block_dim)
            return
        inputs = [Cases(a) if isinstance(a, wp.array) else a for a in inputs]
        outputs = [Cases(a) if isinstance(a, wp.array) else a for a in outputs]
        rest = tuple(dim[1:])  # (the split's threshold counts the cells: a reduction on the CPU is a thread a case)
        self.cache.split(kernel, (self.batch, self.n_cells), lambda r0, r1: ((r1 - r0, *rest), inputs), inputs,
                         outputs, block_dim)

    def cases(self, kernel, inputs, outputs=()):
        """A kernel of one thread a case."""
        self.cache.launch(kernel, self.batch, inputs, outputs)


def graphs_supported(device) -> bool:
    """Whether ``device`` runs the solvers' CUDA graphs: a CUDA device with conditional graph
    nodes (CUDA toolkit and driver 12.4+: ``wp.capture_while``, ``wp.capture_if``)."""
    return device.is_cuda and wp.is_conditional_graph_supported()


class CapturedGraphs:
    """Device work replayed as CUDA graphs: ``launch(key, work)`` runs ``work()`` eagerly the first
    time (loading its kernels and FFT plans), captures it (``wp.ScopedCapture``, which does not run
    it again) and replays the graph when ``key`` (the arrays the work touches and its variant)
    comes back. The values the work reads (tolerances, limits) live in device arrays, so one graph
    serves every call.

    A capture that fails (CUDA error 901 from its first operation, with many processes sharing a
    GPU) leaves the work run eagerly: from then on every launch is eager (``enabled`` False,
    ``failure`` says why), with one warning.

    Args:
        device: the Warp device.
        enabled: capture at all (False: every launch eager, as on the CPU).
        owner: who launches (named in the warning).
        max_graphs: graphs kept, the least recently used dropped first.
    """

    def __init__(self, device, enabled: bool, owner: str, max_graphs: int = 8):
        self.device = device
        self.enabled = bool(enabled)
        self.owner = owner
        self.max_graphs = int(max_graphs)
        self.graphs: OrderedDict = OrderedDict()
        #: why a capture failed, after which every launch is eager (None: none failed)
        self.failure: str | None = None

    def launch(self, key, work, ready=None):
        """Run ``work()``: eagerly, or from the graph captured for ``key``. ``ready()``, asked
        after an eager run: whether every kernel the work may launch has run eagerly by then (a
        generic kernel's overload made for the first time inside a capture is a module load
        there, which fails the capture; a loop whose body never ran has not loaded its kernels);
        until then the work runs eagerly and nothing is captured. None: ready at once."""
        if not self.enabled:
            work()
            return
        graph = self.graphs.get(key)
        if graph is not None:
            self.graphs.move_to_end(key)
            wp.capture_launch(graph)
            return
        work()
        if ready is not None and not ready():
            return
        # no garbage collection while capturing: a collected FFT backend's plans destroyed there
        # (cufftDestroy frees device memory) invalidate the capture (CUDA error 901): solvers
        # held in a reference cycle can be collected during a capture.
        collecting = gc.isenabled()
        gc.disable()
        try:
            with wp.ScopedCapture(device=self.device, force_module_load=False) as capture:
                work()
        except RuntimeError as e:
            if "capture" not in str(e):
                raise
            self.enabled = False
            self.graphs.clear()
            self.failure = str(e)
            warnings.warn(f"{self.owner}: a CUDA graph capture failed ({e}); its launches run without graphs "
                          f"from now on (the same results, more host time)", RuntimeWarning, stacklevel=3)
            return
        finally:
            if collecting:
                gc.enable()
        self.graphs[key] = capture.graph
        while len(self.graphs) > self.max_graphs:
            self.graphs.popitem(last=False)

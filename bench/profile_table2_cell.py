"""Probe: where the time of one Table 2 cell goes (host phases, host reads, GPU busy time).

Runs one cell (default k_tau 0.80, delta_z 1e-4 um, with adhesion) after a warm-up cell that
compiles the kernels and fills the caches, then:

1. the cell again, timed by phase: the turns' normal and tangential solves, the adhesive
   mixing, the known displacements, the turns' change check; with the count of solves, inner
   iterations, turns and host reads (``wp.array.numpy`` calls, each a device synchronisation);
2. on CUDA, with PyTorch installed, the same cell under ``torch.profiler``: the sum of the GPU
   kernels' durations (cuFFT's and Warp's), i.e. how busy the GPU was against the wall time;
3. the cell under cProfile: the host functions by own time.

    python bench/profile_table2_cell.py --device cuda:0 --n 256
"""

from __future__ import annotations

import argparse
import cProfile
import io
import pstats
import time
from collections import defaultdict

import warp as wp

from warpcontact.solvers.contact import ContactSolver
from warpcontact.solvers.fixed_point import AndersonMixing
from warpcontact.solvers.normal import NormalSolver
from warpcontact.solvers.tangential import TangentialSolver
from warpcontact.studies.table2 import Table2Settings, table2_cell


class Phases:
    """Wall time and calls per wrapped method (the device synchronised at each exit)."""

    def __init__(self, device):
        self.device = device
        self.time = defaultdict(float)
        self.calls = defaultdict(int)
        self.iterations = defaultdict(int)
        self._undo = []

    def wrap(self, cls, name, label):
        original = getattr(cls, name)
        phases = self

        def timed(*args, **kwargs):
            t0 = time.perf_counter()
            out = original(*args, **kwargs)
            wp.synchronize_device(phases.device)
            phases.time[label] += time.perf_counter() - t0
            phases.calls[label] += 1
            if hasattr(out, "iterations"):
                phases.iterations[label] += out.iterations
            return out

        setattr(cls, name, timed)
        self._undo.append((cls, name, original))

    def unwrap(self):
        for cls, name, original in reversed(self._undo):
            setattr(cls, name, original)
        self._undo.clear()


def count_reads():
    """Patch wp.array.numpy to count host reads; returns (counter, undo)."""
    original = wp.array.numpy
    count = [0]

    def numpy(self):
        count[0] += 1
        return original(self)

    wp.array.numpy = numpy

    def undo():
        wp.array.numpy = original

    return count, undo


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--n", type=int, default=256)
    ap.add_argument("--k-tau", type=float, default=0.80)
    ap.add_argument("--delta-z-um", type=float, default=1.0e-4)
    ap.add_argument("--no-adhesion", action="store_true")
    ap.add_argument("--top", type=int, default=25, help="cProfile rows to print")
    args = ap.parse_args()
    wp.config.quiet = True
    wp.init()
    device = wp.get_device(args.device)
    settings = Table2Settings(n=args.n, device=args.device)
    adhesion = not args.no_adhesion
    cell = lambda: table2_cell(args.k_tau, args.delta_z_um, settings, adhesion=adhesion)  # noqa: E731

    t0 = time.perf_counter()
    table2_cell(args.k_tau, args.delta_z_um, settings, adhesion=adhesion)
    print(f"# warm-up cell: {time.perf_counter() - t0:.2f} s (device {device}, n {args.n}, adhesion {adhesion})")

    t0 = time.perf_counter()
    r = cell()
    wall = time.perf_counter() - t0
    print(f"cell, plain: {wall:.2f} s, {r['states']} states, grid {r['grid_n']}, mu {r['mu']}")

    phases = Phases(device)
    phases.wrap(NormalSolver, "solve", "normal solve")
    phases.wrap(TangentialSolver, "solve", "tangential solve")
    phases.wrap(AndersonMixing, "step", "adhesive mixing")
    phases.wrap(ContactSolver, "_known_displacements", "known displacements")
    phases.wrap(ContactSolver, "_relative_change", "turn change check")
    phases.wrap(ContactSolver, "_turns", "turns (all)")
    reads, undo_reads = count_reads()
    t0 = time.perf_counter()
    cell()
    wall_phased = time.perf_counter() - t0
    undo_reads()
    phases.unwrap()
    print(f"cell, phases timed (a synchronisation after each): {wall_phased:.2f} s; host reads: {reads[0]}")
    for label in phases.time:
        its = phases.iterations.get(label)
        extra = f", {its} iterations ({1e3 * phases.time[label] / its:.3f} ms/it)" if its else ""
        print(f"  {label:24s} {phases.time[label]:8.2f} s  {phases.calls[label]:6d} calls{extra}")

    if device.is_cuda:
        try:
            import torch
            from torch.profiler import ProfilerActivity, profile

            torch.cuda.init()
            with profile(activities=[ProfilerActivity.CUDA]) as prof:
                t0 = time.perf_counter()
                cell()
                wp.synchronize_device(device)
                wall_prof = time.perf_counter() - t0
            busy_us = sum(e.device_time_total for e in prof.key_averages())
            kernels = sum(e.count for e in prof.key_averages())
            print(f"cell under torch.profiler: {wall_prof:.2f} s wall, GPU kernels {busy_us / 1e6:.2f} s busy "
                  f"({kernels} kernels, {100 * busy_us / 1e6 / wall_prof:.0f} % of the wall time)")
            print(prof.key_averages().table(sort_by="device_time_total", row_limit=12))
        except Exception as e:  # noqa: BLE001  (a probe: say why and go on)
            print(f"torch.profiler: not available ({type(e).__name__}: {e})")

    pr = cProfile.Profile()
    pr.enable()
    cell()
    pr.disable()
    out = io.StringIO()
    pstats.Stats(pr, stream=out).sort_stats("tottime").print_stats(args.top)
    print(out.getvalue())


if __name__ == "__main__":
    main()

"""Probe: the launch shape of the reducing solver kernels, by measurement.

The normal solver's reductions (kernels/normal.py: normal_gap, normal_direction_sum, normal_update;
kernels/spectral.py: spectral_normal_energy, over the spectrum's entries) are launched over
``blocks`` blocks of ``block_dim`` threads that stride over the grid (``launch.ReductionLaunch``).
This times each kernel, captured 20 times in a graph and replayed (``iteration_parts.timed_ms``),
on a solved Hertz state (bench_iteration.py's problem), for several block sizes and block counts
per SM and for one cell per thread, side by side in one run. ``--cold``: each call after an L2
flush (its time subtracted), as in a solve, where the transforms between the passes evict the
fields from the cache; replayed back to back, the passes of a 1024 grid run from L2.

    python bench/reduction_launch.py --device cuda:0 --sizes 1024 2048 4096 [--cold]
"""

from __future__ import annotations

import argparse
import math
import time

import warp as wp

from iteration_parts import timed_ms  # bench/, beside this script
from warpcontact.physics.geometry import Grid, Sphere
from warpcontact.kernels import normal as nk
from warpcontact.kernels import spectral
from warpcontact.numerics.launch import ReductionLaunch
from warpcontact.physics.materials import PAPER_PAIR
from warpcontact.numerics.model import ContactModel
from warpcontact.solvers import NormalSolver
from warpcontact.numerics.state import ContactState

R, DZ = 10e-6, 1.0e-10
A = math.sqrt(R * DZ)


def shapes(n_entries: int, device, block_dims, per_sm):
    """(label, ReductionLaunch) for each block size and blocks-per-SM count, and one entry per
    thread (blocks of 256)."""
    out = []
    saved = ReductionLaunch.block_dim_cuda
    try:
        for block_dim in block_dims:
            ReductionLaunch.block_dim_cuda = block_dim
            for k in per_sm:
                out.append((f"{block_dim}x{k}/SM", ReductionLaunch.for_cells(n_entries, device, blocks_per_sm=k)))
    finally:
        ReductionLaunch.block_dim_cuda = saved
    blocks = math.ceil(n_entries / 256)
    out.append(("cell/thread", ReductionLaunch(blocks, 256, 1, blocks * 256, 1)))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--device", default="cuda:0")
    ap.add_argument("--sizes", type=int, nargs="*", default=[1024, 2048])
    ap.add_argument("--per-sm", type=int, nargs="*", default=[4, 8, 16, 32])
    ap.add_argument("--block-dims", type=int, nargs="*", default=[256])
    ap.add_argument("--cold", action="store_true", help="each call after an L2 flush, its time subtracted")
    args = ap.parse_args()
    wp.config.quiet = True
    wp.init()
    device = wp.get_device(args.device)
    sm = getattr(device, "sm_count", 132)
    cold = ", cold (L2 flushed before each call)" if args.cold else ""
    print(f"# reduction launch shapes, ms per call{cold}; device {device} ({device.name}, {sm} SMs), "
          f"{time.strftime('%Y-%m-%d')}")
    for n in args.sizes:
        m = ContactModel(PAPER_PAIR, Sphere(R, "paraboloid"), Grid(n, 4 * A), device=device)
        s = NormalSolver(m)
        st = ContactState(m)
        s.solve(st, DZ)
        op = m.operator
        fft, spec = op.fft, op._buf[0]
        p, g, t, b = (a.flatten() for a in (st.pressure, st.gap, s.direction, s.interference))
        output = [fft.padded_output, fft.output_scale, n]
        # tau = 0 (g.t = 0, t.Kt = 1) on an iterate not converged (residual 1): the update runs
        # its whole path and leaves p and g as they are
        s.sums.assign([0.0, 1.0, 1.0, 0.0, 1.0] + [0.0] * (nk.N_SUMS - 5))
        cell_kernels = {
            "normal_gap": (nk.normal_gap, [st.disp_z.flatten(), b, p, s._cap], [g, s.sums]),
            "normal_direction_sum": (nk.normal_direction_sum, [g, p, s._cap, s.sums, s.scalars, fft.padded_output,
                                                           fft.output_scale, int(s.preconditioned), n],
                                     [t, fft.padded_input]),
            "normal_update": (nk.normal_update, [t, *output, b, s._cap, s.settings], [p, g, s.sums]),
        }
        energy = (spectral.spectral_normal_energy,
                  [op.influence, spec, fft.half_axis, fft.half_length, fft.energy_scale, 0, nk.S_RT, 0, op._mirror],
                  [s.sums])
        entries = op._spectral_entries
        for (label, shape), (_, spectral_shape) in zip(shapes(m.n_cells, device, args.block_dims, args.per_sm),
                                                       shapes(entries, device, args.block_dims, args.per_sm)):
            times = {name: timed_ms(m.device, lambda k=k: m.launches.launch_reduce(k[0], shape, m.n_cells, k[1], k[2]),
                                    cold=args.cold) for name, k in cell_kernels.items()}
            times["spectral_normal_energy"] = timed_ms(
                m.device, lambda: m.launches.launch_reduce(energy[0], spectral_shape, entries, energy[1], energy[2]),
                cold=args.cold)
            print(f"N = {n:5d} {label:>11} ({shape.num_blocks:6d} blocks): "
                  + "  ".join(f"{name} {ms:.4f}" for name, ms in times.items()), flush=True)


if __name__ == "__main__":
    main()

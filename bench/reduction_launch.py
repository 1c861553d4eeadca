"""Probe: the launch shape of the reducing solver kernels, by measurement.

The normal solver's reductions (kernels/normal.py: normal_gap, normal_step_sums, normal_update)
are launched over ``blocks`` blocks of 256 threads that stride over the grid
(``model.ReductionLaunch``). This times each kernel, captured 20 times in a graph and replayed
(``iteration_parts.timed_ms``), on a solved Hertz state (bench_iteration.py's problem), for
several block counts per SM and for one cell per thread, side by side in one run.

    python bench/reduction_launch.py --device cuda:0 --sizes 1024 2048 4096
"""

from __future__ import annotations

import argparse
import math
import time

import warp as wp

from iteration_parts import timed_ms  # bench/, beside this script
from warpcontact.geometry import Grid, Sphere
from warpcontact.kernels import normal as nk
from warpcontact.materials import PAPER_PAIR
from warpcontact.model import ContactModel, ReductionLaunch
from warpcontact.solvers import NormalSolver
from warpcontact.state import ContactState

R, DZ = 10e-6, 1.0e-10
A = math.sqrt(R * DZ)


def shapes(n_cells: int, sm_count: int, per_sm):
    """(label, ReductionLaunch) for each blocks-per-SM count, and one cell per thread."""
    out = []
    for k in per_sm:
        blocks = min(k * sm_count, math.ceil(n_cells / 256))
        total = blocks * 256
        out.append((f"{k}/SM", ReductionLaunch(blocks, 256, 1, total, math.ceil(n_cells / total))))
    blocks = math.ceil(n_cells / 256)
    out.append(("cell/thread", ReductionLaunch(blocks, 256, 1, blocks * 256, 1)))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--device", default="cuda:0")
    ap.add_argument("--sizes", type=int, nargs="*", default=[1024, 2048])
    ap.add_argument("--per-sm", type=int, nargs="*", default=[4, 8, 16, 32])
    args = ap.parse_args()
    wp.config.quiet = True
    wp.init()
    device = wp.get_device(args.device)
    sm = getattr(device, "sm_count", 132)
    print(f"# reduction launch shapes, ms per call; device {device} ({device.name}, {sm} SMs), {time.strftime('%Y-%m-%d')}")
    for n in args.sizes:
        m = ContactModel(PAPER_PAIR, Sphere(R, "paraboloid"), Grid(n, 4 * A), device=device)
        s = NormalSolver(m)
        st = ContactState(m)
        s.solve(st, DZ)
        fft = m.operator.fft
        p, g, t, b = (a.flatten() for a in (st.pressure, st.gap, s.direction, s.interference))
        output = [fft.padded_output, fft.output_scale, n]
        # tau = 0 (g.t = 0, t.Kt = 1) on an iterate not converged (residual 1): the update runs
        # its whole path and leaves p and g as they are
        s.sums.assign([0.0, 1.0, 1.0, 0.0, 1.0] + [0.0] * (nk.N_SUMS - 5))
        kernels = {
            "normal_gap": (nk.normal_gap, [st.disp_z.flatten(), b, p, s._cap], [g, s.sums]),
            "normal_step_sums": (nk.normal_step_sums, [g, t, *output], [s.sums]),
            "normal_update": (nk.normal_update, [t, *output, b, s._cap, s.settings], [p, g, s.sums]),
        }
        for label, shape in shapes(m.n_cells, sm, args.per_sm):
            m.reduction = shape
            times = {name: timed_ms(m.device, lambda k=k: m.launch_reduce(*k)) for name, k in kernels.items()}
            print(f"N = {n:5d} {label:>11} ({shape.num_blocks:6d} blocks): "
                  + "  ".join(f"{name} {ms:.4f}" for name, ms in times.items()), flush=True)


if __name__ == "__main__":
    main()

"""Probe: device memory in use after each stage of the coupled adhesive problem's set-up (model,
solver, state), against ``resources.breakdown``: where an estimate and the memory in use part.

    python bench/memory_stages.py 13668 float32 --device cuda:0

An allocation that fails is reported with its traceback (the stages before it are printed).
"""

from __future__ import annotations

import argparse
import math

import warp as wp

from warpcontact.numerics import resources
from warpcontact.physics.adhesion import SMC
from warpcontact.physics.friction import TaborVonMises
from warpcontact.physics.geometry import Grid, Sphere
from warpcontact.physics.materials import PAPER_PAIR
from warpcontact.numerics.model import ContactModel
from warpcontact.solvers.contact import ContactSolver
from warpcontact.numerics.state import ContactState
from warpcontact.studies.table2 import DELTA_N, DELTA_T, SIGMA_MAX, TAU_MAX

R, DZ = 10e-6, 1.0e-10  # bench/scale_check.py's problem
A = math.sqrt(R * DZ)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("n", type=int)
    ap.add_argument("dtype", choices=["float64", "float32"])
    ap.add_argument("--device", default="cuda:0")
    args = ap.parse_args()
    wp.config.quiet = True
    wp.init()
    dev = wp.get_device(args.device)
    if not dev.is_cuda:
        ap.error(f"--device {args.device}: the stages are measured on a CUDA device (free memory)")

    def used():
        wp.synchronize_device(dev)
        return (dev.total_memory - dev.free_memory) / 2**30

    base = used()
    b = resources.breakdown(args.n, args.dtype, "cuda", True, "cupy", adhesion=True)
    print({k: round(v / 2**30, 3) for k, v in b.items()}, flush=True)
    model = ContactModel(PAPER_PAIR, Sphere(R, "paraboloid"), Grid(args.n, 4 * A), device=dev, dtype=args.dtype)
    fft = model.operator.fft
    spectrum = 2 * args.n * (args.n + 1) * 2 * (8 if args.dtype == "float64" else 4)
    print(f"model: {used() - base:.3f} GiB in use; cuFFT work {fft.work_bytes / 2**30:.3f} GiB = "
          f"{fft.work_bytes / spectrum:.2f} spectra; pruned {fft.pruned}", flush=True)
    solver = ContactSolver(model, TaborVonMises(0.8, PAPER_PAIR.softer.yield_strength),  # noqa: F841
                           adhesion=SMC(SIGMA_MAX, TAU_MAX, DELTA_N, DELTA_T), max_outer=1, max_iter=5)
    print(f"solver: {used() - base:.3f} GiB in use", flush=True)
    state = ContactState(model)  # noqa: F841
    print(f"state: {used() - base:.3f} GiB in use (estimate {b['total'] / 2**30:.3f})", flush=True)


if __name__ == "__main__":
    main()

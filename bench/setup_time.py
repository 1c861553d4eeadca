"""Benchmark: the set-up of a ContactModel (influence coefficients, their spectra, the device copy).

For each n: seconds for ``influence_coefficients`` alone and for the whole ContactModel (paper
pair, Hertz sphere), after one small model has loaded the kernels.

    python bench/setup_time.py --device cuda:0 --sizes 2048 4096 8191
"""

from __future__ import annotations

import argparse
import os
import time

import warp as wp

from warpcontact.geometry import Grid, Sphere
from warpcontact.influence import influence_coefficients
from warpcontact.materials import PAPER_PAIR
from warpcontact.model import ContactModel


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--sizes", type=int, nargs="+", default=[1024, 2048])
    ap.add_argument("--dtype", default="float64")
    args = ap.parse_args()
    wp.config.quiet = True
    wp.init()
    sphere = Sphere(10e-6, "paraboloid")
    ContactModel(PAPER_PAIR, sphere, Grid(64, 1e-7), device=args.device, dtype=args.dtype)
    print(f"# model set-up, {args.dtype}, {args.device} ({wp.get_device(args.device).name}), {os.cpu_count()} CPUs, "
          f"{time.strftime('%Y-%m-%d')}")
    for n in args.sizes:
        t0 = time.perf_counter()
        coefficients = influence_coefficients(PAPER_PAIR, n, n, 1e-8, 1e-8)
        t_influence = time.perf_counter() - t0
        del coefficients
        t0 = time.perf_counter()
        model = ContactModel(PAPER_PAIR, sphere, Grid(n, 1e-7), device=args.device, dtype=args.dtype)
        wp.synchronize_device(model.device)
        t_model = time.perf_counter() - t0
        del model
        print(f"n {n:>6}: influence_coefficients {t_influence:7.2f} s, whole model {t_model:7.2f} s", flush=True)


if __name__ == "__main__":
    main()

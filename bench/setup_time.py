"""Benchmark: the set-up of a ContactModel (influence coefficients, their spectra, the device copy).

For each n: seconds for ``influence_coefficients`` alone and for the whole ContactModel (paper
pair, Hertz sphere), after one small model has loaded the kernels. Where the FFT backend makes
the six influence spectra its own way (cupy: cuFFT on the device), that step is timed side by side
with the host path it replaced (scipy in float64, cast, copied to the device), on the same
coefficients in the same run, with the largest difference between the two (ZZ and XZ spectra,
relative to the largest entry).

    python bench/setup_time.py --device cuda:0 --sizes 2048 4096 8191
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np
import warp as wp

from warpcontact.fft.base import FFTBackend
from warpcontact.geometry import Grid, Sphere
from warpcontact.influence import KERNELS, SPECTRUM_PARTS, influence_coefficients
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
        line = f"n {n:>6}: influence_coefficients {t_influence:7.2f} s, whole model {t_model:7.2f} s"
        fft = model.operator.fft
        if type(fft).influence_spectra is not FFTBackend.influence_spectra:
            line += spectra_side_by_side(model, n)
        del model
        print(line, flush=True)


def spectra_side_by_side(model, n) -> str:
    """The backend's influence_spectra against the host path (FFTBackend's), same coefficients."""
    fft, out, scratch = model.operator.fft, model.operator.influence, model.operator._buf[0]
    parts = [SPECTRUM_PARTS[k] for k in KERNELS]
    coefficients = influence_coefficients(PAPER_PAIR, n, n, 1e-8, 1e-8)
    arrays = [coefficients[k] for k in KERNELS]
    times, kept = {}, {}
    for label, method in (("backend", type(fft).influence_spectra), ("host", FFTBackend.influence_spectra)):
        wp.synchronize_device(model.device)
        t0 = time.perf_counter()
        method(fft, iter(arrays), parts, out, scratch)
        wp.synchronize_device(model.device)
        times[label] = time.perf_counter() - t0
        kept[label] = [out[i].numpy() for i in (0, 4)]
    diff = max(np.abs(a - b).max() / np.abs(b).max() for a, b in zip(kept["backend"], kept["host"]))
    return (f"; six spectra: {fft.name} {times['backend']:6.2f} s, host float64 + copy {times['host']:6.2f} s "
            f"({times['host'] / times['backend']:.1f}x), largest difference {diff:.1e} of the largest entry")

if __name__ == "__main__":
    main()

"""Benchmark: cuFFT's padded forward + inverse at the small sizes of Table 2's cells, both layouts.

At n = 256-600 a transform moves a few MB: launch latency, not bandwidth, sets its time, so the
number of kernels cuFFT splits a transform into matters. For each n: ms per forward + inverse
through the backend (padding and cropping passes included; replayed from a CUDA graph of 20),
pruned and 2-D layouts, and (with PyTorch's profiler) the kernels per pair.

    python bench/fft_small_sizes.py --sizes 256 300 315 320 360 384 512 588 600 640
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import warp as wp

from warpcontact.fft.cupy_backend import CupyFFT

from iteration_parts import timed_ms  # bench/, beside this script


def pair_ms(fft, field, spectrum, device):
    """ms per forward + inverse (replayed from a graph, best of 5), and the pair as a function."""
    def pair():
        fft.forward(field, spectrum)
        fft.inverse(spectrum, field)

    return timed_ms(device, pair, best_of=5), pair


def kernels_per_pair(pair, device):
    try:
        from torch.profiler import ProfilerActivity, profile
    except ImportError:
        return None
    wp.synchronize_device(device)
    with profile(activities=[ProfilerActivity.CUDA]) as prof:
        for _ in range(10):
            pair()
        wp.synchronize_device(device)
    return sum(e.count for e in prof.key_averages()) / 10


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--device", default="cuda:0")
    ap.add_argument("--sizes", type=int, nargs="*", default=[256, 300, 315, 320, 360, 384, 512, 588, 600, 640])
    ap.add_argument("--dtype", default="float64")
    args = ap.parse_args()
    wp.config.quiet = True
    wp.init()
    device = wp.get_device(args.device)
    dtype = wp.float64 if args.dtype == "float64" else wp.float32
    print(f"# padded forward + inverse, {args.dtype}, {device} ({wp.get_device(device).name}), {time.strftime('%Y-%m-%d')}")
    print(f"{'n':>6} {'2n factors':>14} {'pruned ms':>10} {'kernels':>8} {'2-D ms':>8} {'kernels':>8}")
    for n in args.sizes:
        row = []
        for pruned in (True, False):
            fft = CupyFFT(n, n, device, dtype, pruned=pruned)
            field = wp.array(np.random.default_rng(0).random((n, n)), dtype=dtype, device=device)
            spectrum = fft.alloc_spectra(1)[0]
            ms, pair = pair_ms(fft, field, spectrum, device)
            row += [ms, kernels_per_pair(pair, device)]
        m, f, k = 2 * n, [], 2
        while m > 1:
            while m % k == 0:
                f.append(k)
                m //= k
            k += 1
        fac = "*".join(str(x) for x in f)
        kp = lambda v: "-" if v is None else f"{v:.0f}"  # noqa: E731
        print(f"{n:>6} {fac:>14} {row[0]:>10.4f} {kp(row[1]):>8} {row[2]:>8.4f} {kp(row[3]):>8}", flush=True)


if __name__ == "__main__":
    main()

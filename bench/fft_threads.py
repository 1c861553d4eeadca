"""One thread or one per CPU: a CPU backend's transform pair (forward + inverse) by grid size, both
thread counts side by side in one run, for the rule the backends follow (``THREADS_FROM_CELLS``:
threads from that many cells on; ``warpcontact.fft.base.cpu_threads``).

    python bench/fft_threads.py [--backends fftw scipy] [--sizes 32 64 96 128 192 256 384 512 1024]

Prints one row per (backend, n): the best of 5 timings of each thread count [ms], their ratio and
the count the backend picks by default.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np
import warp as wp


def pair_ms(backend, n: int, threads: int) -> float:
    f = backend(n, n, "cpu", wp.float64, workers=threads)
    field = wp.array(np.random.default_rng(0).random((n, n)), dtype=wp.float64, device="cpu")
    spectrum = wp.zeros(f.spectral_shape, dtype=f.complex_dtype, device="cpu")
    out = wp.zeros((n, n), dtype=wp.float64, device="cpu")
    for _ in range(5):
        f.forward(field, spectrum)
        f.inverse(spectrum, out)
    repeats = max(1, 100_000 // (n * n))
    best = float("inf")
    for _ in range(5):
        t0 = time.perf_counter()
        for _ in range(repeats):
            f.forward(field, spectrum)
            f.inverse(spectrum, out)
        best = min(best, (time.perf_counter() - t0) / repeats)
    return best * 1e3


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--backends", nargs="+", default=["fftw", "scipy"], choices=["fftw", "scipy"])
    ap.add_argument("--sizes", type=int, nargs="+", default=[32, 64, 96, 128, 192, 256, 384, 512, 1024])
    a = ap.parse_args()
    wp.config.quiet = True
    wp.init()
    from warpcontact.fft.fftw_backend import FFTWBackend
    from warpcontact.fft.scipy_backend import ScipyFFT

    cpus = os.cpu_count() or 1
    classes = {"fftw": FFTWBackend, "scipy": ScipyFFT}
    print(f"| backend | n | 1 thread [ms] | {cpus} threads [ms] | {cpus} / 1 | default |")
    print("|---|---|---|---|---|---|")
    for name in a.backends:
        cls = classes[name]
        for n in a.sizes:
            one, many = pair_ms(cls, n, 1), pair_ms(cls, n, cpus)
            default = cls(n, n, "cpu", wp.float64).workers
            print(f"| {name} | {n} | {one:.3f} | {many:.3f} | {many / one:.2f} | {default} |", flush=True)


if __name__ == "__main__":
    main()

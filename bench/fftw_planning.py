"""FFTW's measured plans against its estimated ones, and scipy.fft, for the DC-FFT transform pair
of an iteration (the fftw backend's transform_input + transform_to_output; scipy's the same), on
the CPU: planning time and the pair's time, best of repeats, per grid size, in one run.

Measuring here starts from no wisdom (WARPCONTACT_FFTW_WISDOM="" and FFTW's wisdom forgotten
before each size), as on a machine's first run; later runs plan from the kept wisdom at once.

    pip install pyfftw && python bench/fftw_planning.py --sizes 128 256 512 1024 2048
"""

from __future__ import annotations

import argparse
import os
import time

os.environ["WARPCONTACT_FFTW_WISDOM"] = ""

import numpy as np  # noqa: E402
import pyfftw  # noqa: E402
import warp as wp  # noqa: E402

from warpcontact.fft import make_fft  # noqa: E402
from warpcontact.fft.fftw_backend import FFTWBackend  # noqa: E402


def pair_ms(backend, spectrum, repeats):
    def pair():
        backend.transform_input(spectrum)
        backend.transform_to_output(spectrum)

    pair()
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        pair()
        best = min(best, time.perf_counter() - t0)
    return 1e3 * best


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", type=int, nargs="*", default=[128, 256, 512, 1024])
    ap.add_argument("--dtype", default="float64", choices=["float64", "float32"])
    args = ap.parse_args()
    wp.config.quiet = True
    wp.init()
    dtype = getattr(wp, args.dtype)
    print(f"# DC-FFT pair of an iteration, CPU ({os.cpu_count()} cores; each backend's default threads: "
          f"the column 'threads'), {args.dtype}, {time.strftime('%Y-%m-%d')}")
    print(f"{'n':>6} {'threads':>8} {'scipy ms':>9} {'estimate: plan s':>17} {'ms':>8} {'measure: plan s':>16} {'ms':>8} "
          f"{'estimate/measure':>17}")
    for n in args.sizes:
        repeats = max(3, int(4e6 / n**2))
        row = {}
        scipy = make_fft("scipy", n, n, "cpu", dtype)
        scipy.padded_input.numpy()[:n, :n] = np.random.default_rng(0).random((n, n))
        row["scipy"] = pair_ms(scipy, scipy.alloc_spectra(1)[0], repeats)
        for measure in (False, True):
            pyfftw.forget_wisdom()
            b = FFTWBackend(n, n, "cpu", dtype, measure=measure)
            b.padded_input.numpy()[:n, :n] = np.random.default_rng(0).random((n, n))
            s = b.alloc_spectra(1)[0]
            t0 = time.perf_counter()
            b._plans_for(s)
            row[measure] = (time.perf_counter() - t0, pair_ms(b, s, repeats))
        (pe, te), (pm, tm) = row[False], row[True]
        print(f"{n:>6} {b.workers:>8} {row['scipy']:>9.3f} {pe:>17.3f} {te:>8.3f} {pm:>16.3f} {tm:>8.3f} {te / tm:>16.2f}x",
              flush=True)


if __name__ == "__main__":
    main()

"""Probe: float32 against float64 on the Hertz normal solve (tests/test_hertz.py's problem), with
the cupy backend's influence spectra made on the device in float32 (the default) and on the host
in float64 and cast (``FFTBackend.influence_spectra``, the path before 2026-11-23), side by side.

    python bench/float32_hertz.py --device cuda:0 --sizes 256 1024 4096

Prints, per size and path, F_z and p0 of the float32 solve relative to the float64 solve's.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import warp as wp

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from test_hertz import solve_hertz  # noqa: E402

from warpcontact.fft.base import FFTBackend  # noqa: E402
from warpcontact.fft.cupy_backend import CupyFFT  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--device", default="cuda:0")
    ap.add_argument("--sizes", type=int, nargs="+", default=[256, 1024, 4096])
    args = ap.parse_args()
    wp.config.quiet = True
    device_path = CupyFFT.influence_spectra
    for n in args.sizes:
        r64 = solve_hertz(n, args.device, "float64")
        f64, p64 = 1 + r64["force_err"], 1 + r64["p0_err"]
        for label, method in (("device f32 spectra", device_path), ("host f64 spectra, cast", FFTBackend.influence_spectra)):
            CupyFFT.influence_spectra = method
            try:
                r32 = solve_hertz(n, args.device, "float32")
            finally:
                CupyFFT.influence_spectra = device_path
            f32, p32 = 1 + r32["force_err"], 1 + r32["p0_err"]
            print(f"{args.device} n {n} {label}: F_z float32 vs float64 {f32 / f64 - 1:+.2e}, p0 {p32 / p64 - 1:+.2e}; "
                  f"iterations {r64['info'].iterations} / {r32['info'].iterations}, converged {r32['info'].converged}",
                  flush=True)


if __name__ == "__main__":
    main()

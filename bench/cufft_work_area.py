"""cuFFT's work area per grid size, in spectra, against the memory estimate's allowance.

For each n: ``CupyFFT(n, n).work_bytes`` divided by the bytes of one (2n, n + 1) spectrum, in
both layouts (pruned row and column plans, 2-D plans) and both float types, next to
``resources.cufft_work_spectra(n)``. Sizes whose transform length 2n has a large prime factor make
cuFFT use Bluestein's algorithm, whose buffers are several spectra (measured: up to 6.46).

    python bench/cufft_work_area.py            # on a machine with a CUDA device and CuPy
"""

import warp as wp

from warpcontact.fft.cupy_backend import CupyFFT
from warpcontact.numerics.resources import cufft_work_spectra

SIZES = (64, 127, 128, 131, 200, 251, 257, 509, 521, 1000, 1021, 1100, 1300, 2039, 2048, 3001, 4001, 4097, 6000, 8191)


def main():
    wp.config.quiet = True
    wp.init()
    device = wp.get_device("cuda:0")
    print(f"# cuFFT work area in spectra; {device.name}; columns: f64 pruned, f64 2-D, f32 pruned, f32 2-D, allowance")
    for n in SIZES:
        row = []
        for dtype in (wp.float64, wp.float32):
            real = 8 if dtype == wp.float64 else 4
            for pruned in (True, False):
                fft = CupyFFT(n, n, device, dtype, pruned=pruned)
                row.append(f"{fft.work_bytes / (2 * n * (n + 1) * 2 * real):7.3f}")
                del fft
        print(f"{n:>6} " + " ".join(row) + f"  {cufft_work_spectra(n):7.3f}", flush=True)


if __name__ == "__main__":
    main()

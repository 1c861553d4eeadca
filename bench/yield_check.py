"""Benchmark: the yield check of one state alone (``yielding.yield_check``: the von Mises maxima of
both bodies at the check's depths), on the tractions of a sliding Hertz contact on the domain of
the paper's Figure 2 (copper on steel, a = 38.7 nm on 136.16 nm; p0 = 3 GPa, shear (0.3, 0.1) p).

Each n is checked ``--repeat`` times in one process (the first loads the kernels and plans the
transforms: compare the later ones); prints one line per n with each check's seconds and each
body's maximum [MPa] and depth [m], which do not depend on the device or the code's version to
rounding. To compare two versions, install each beside the other and run them alternately:

    python bench/yield_check.py --device cpu --sizes 512 1024
    python bench/yield_check.py --device cuda --sizes 1024 4096 8192
    PYTHONPATH=old/ python bench/yield_check.py --device cpu --sizes 1024    # (old: pip install --target)
"""

from __future__ import annotations

import argparse
import time

import numpy as np

#: the domain [m] and the contact radius [m] of examples/figure2*.toml
SIZE, RADIUS = 1.3616e-07, 38.7e-9
P0 = 3e9


def hertz_fields(n: int) -> dict:
    """Hertz's pressure of peak ``P0`` on a disk of ``RADIUS`` centred on the grid, and a shear of
    (0.3, 0.1) times it [Pa]."""
    x = (np.arange(n) - n / 2 + 0.5) * SIZE / n
    r2 = (x[None, :] ** 2 + x[:, None] ** 2) / RADIUS**2
    p = P0 * np.sqrt(np.clip(1.0 - r2, 0.0, None))
    return {"pressure": p, "shear_x": 0.3 * p, "shear_y": 0.1 * p}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--sizes", type=int, nargs="+", default=[512])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)

    import warp as wp

    wp.config.quiet = True
    import warpcontact
    from warpcontact.numerics.yielding import yield_check
    from warpcontact.physics.geometry import Grid
    from warpcontact.physics.materials import PAPER_PAIR

    for n in args.sizes:
        grid, fields = Grid(n, SIZE), hertz_fields(n)
        seconds = []
        for _ in range(args.repeat):
            wp.synchronize()
            t0 = time.perf_counter()
            check = yield_check(PAPER_PAIR, grid, fields, device=args.device)
            wp.synchronize()
            seconds.append(time.perf_counter() - t0)
        maxima = ", ".join(f"{b} {check[b]['von_mises_max'] / 1e6:.4f} MPa at {check[b]['z']:.4e} m"
                           for b in ("sphere", "flat"))
        print(f"n = {n} ({args.device}, warpcontact {warpcontact.__version__} from {warpcontact.__file__}): "
              f"{' '.join(f'{s:.3f}' for s in seconds)} s; {maxima}", flush=True)


if __name__ == "__main__":
    main()

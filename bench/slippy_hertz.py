"""slippy 0.5.2 on bench_normal.py's Hertz problem, for ``bench_normal.py --slippy-python``.

Runs in slippy's own interpreter (it needs numpy < 1.27 and scipy < 1.12: a venv of its own,
``pip install --no-deps slippy==0.5.2`` then numpy, scipy, numba, sympy, tinydb, matplotlib,
scikit-image, pyfftw). Displacement-driven (``StaticStep(interference=delta_z)``, Love's
influence matrix), tolerance 1e-10, paper pair, R = 10 um, delta_z = 1e-4 um, domain 4a. Prints
one JSON line: total_s (the solve, after one untimed warm-up solve at the same size), F_z [N],
force_err (against Hertz).

    /path/to/slippy-venv/bin/python bench/slippy_hertz.py 512
    /path/to/slippy-venv/bin/python bench/slippy_hertz.py 512 --once   # no warm-up: as a user's
                                                                         # whole process runs it
"""

import json
import math
import sys
import time

import numpy as np
import slippy.contact as c
import slippy.surface as s

R, DZ = 10e-6, 1.0e-10
E1, NU1, E2, NU2 = 106e9, 0.33, 205e9, 0.31  # the paper's Table 1: copper sphere, steel flat


def solve(n, tag):
    size = 4 * math.sqrt(R * DZ)
    flat = s.FlatSurface(shift=(0, 0))
    ball = s.RoundSurface((R, R, R), extent=(size, size), shape=(n, n), generate=True)
    ball.material = c.Elastic(f"copper-{tag}", {"E": E1, "v": NU1})
    flat.material = c.Elastic(f"steel-{tag}", {"E": E2, "v": NU2})  # slippy wants unique names
    model = c.ContactModel(f"hertz-{tag}", ball, flat)
    model.add_step(c.StaticStep("step", interference=DZ, tolerance=1e-10, max_it=2000))
    t0 = time.perf_counter()
    out = model.solve(skip_data_check=True)
    return time.perf_counter() - t0, float(np.sum(out["loads_z"]) * ball.grid_spacing**2), bool(out["converged"])


def main():
    n = int(sys.argv[1])
    if "--once" not in sys.argv[2:]:
        solve(n, "warm-up")  # numba compilation, FFT plans
    total, force, converged = solve(n, "timed")
    e_star = 1.0 / ((1 - NU1**2) / E1 + (1 - NU2**2) / E2)
    hertz = 4.0 / 3.0 * e_star * math.sqrt(R) * DZ**1.5
    print(json.dumps({"n": n, "total_s": total, "force_N": force, "force_err": force / hertz - 1.0,
                      "converged": converged}))


if __name__ == "__main__":
    main()

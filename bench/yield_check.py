"""The yield check below the surface that every solve's result carries: its time by variant, side
by side in one process.

A Hertz state of the paper's pair (R = 10 um, delta_z = 1e-4 um, domain 4a, float64) solved once
per n; then ``stress.state_yield_check`` on it, each variant in turn, rounds alternating, best of
``--rounds`` (the first call of each, which compiles kernels and plans, is not counted):

- ``default``: as a frictionless solve runs it: the shear left out (neither transformed nor
  summed: 8 of the 14 basis kernels), the stress kernels' rows split over the CPU's threads;
- ``with-shear``: the shear's zero fields loaded as a coupled state's are (its terms summed, all
  14 basis kernels made): what the check of a state with friction costs;
- ``one-thread``: ``default`` with the stress kernels on one thread (on the CPU).

Every variant's maxima are checked equal to ``default``'s (the same bits: the left-out terms add
zeros, the split rows are computed alone).

    python bench/yield_check.py --sizes 256 512
    python bench/yield_check.py --device cuda:0 --sizes 1024 4096

Prints a markdown table.
"""

from __future__ import annotations

import argparse
import math
import time

VARIANTS = ("default", "with-shear", "one-thread")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--sizes", type=int, nargs="+", default=[256, 512])
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()

    import warp as wp

    wp.config.quiet = True
    wp.init()
    from warpcontact.numerics import stress
    from warpcontact.numerics.model import ContactModel
    from warpcontact.numerics.state import ContactState
    from warpcontact.physics.geometry import Grid, Sphere
    from warpcontact.physics.materials import PAPER_PAIR
    from warpcontact.solvers.normal import NormalSolver

    R, DZ = 10e-6, 1e-10
    device = wp.get_device(args.device)
    original = stress.SubsurfaceStress.__init__
    threads = {"value": None}

    def init(self, *a, **k):  # the one-thread variant: the evaluators' threads set to one
        original(self, *a, **k)
        if threads["value"] is not None:
            self.launches.workers = threads["value"]

    stress.SubsurfaceStress.__init__ = init
    print(f"<!-- python bench/yield_check.py --device {args.device} --sizes {' '.join(map(str, args.sizes))} "
          f"--rounds {args.rounds}; {device} -->")
    print("| n | " + " | ".join(f"{v} [s]" for v in VARIANTS) + " | same maxima |")
    print("|---|" + "---|" * (len(VARIANTS) + 1))
    for n in args.sizes:
        model = ContactModel(PAPER_PAIR, Sphere(R), Grid(n, 4 * math.sqrt(R * DZ)), device=device)
        state = ContactState(model)
        assert NormalSolver(model).solve(state, DZ).converged

        def check(variant):
            threads["value"] = 1 if variant == "one-thread" else None
            wp.synchronize_device(device)
            t0 = time.perf_counter()
            result = stress.state_yield_check(state, friction=variant == "with-shear", adhesion=False)
            wp.synchronize_device(device)
            return time.perf_counter() - t0, result

        best = {v: math.inf for v in VARIANTS}
        results = {}
        for variant in VARIANTS:  # compile kernels, make plans
            results[variant] = check(variant)[1]
        for _ in range(args.rounds):
            for variant in VARIANTS:
                wall, results[variant] = check(variant)
                best[variant] = min(best[variant], wall)
        same = all(results[v] == results["default"] for v in VARIANTS)
        print(f"| {n} | " + " | ".join(f"{best[v]:.3f}" for v in VARIANTS) + f" | {'yes' if same else 'NO'} |",
              flush=True)


if __name__ == "__main__":
    main()

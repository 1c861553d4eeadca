"""Scale check: the largest grid the device holds for the coupled adhesive problem, and one run
near it that compares the memory in use with ``resources.estimate_bytes``.

For each dtype it prints ``resources.largest_grid`` for this device (friction + SMC adhesion, one
state), then, for the grid sizes given, builds the model, solver and state, solves the normal
approach with adhesion (the Hertz problem of bench_iteration.py, domain 4a) and one tangential
step, and prints the device memory in use (CUDA: total - free, less the baseline before the
model) against the estimate, with the iterations and times. A grid the estimate says will not
fit is refused by ``resources.check_fits`` before anything is allocated: the message is printed.

    python bench/scale_check.py --device cuda:0 --sizes 8191 --dtype float64 --max-turns 3 --json scale.json
    python bench/scale_check.py --device cpu --sizes 64 128                    # a dry run here
"""

from __future__ import annotations

import argparse
import json
import math
import time

import warp as wp

from warpcontact.numerics import resources
from warpcontact.physics.adhesion import SMC
from warpcontact.errors import InputError
from warpcontact.physics.friction import TaborVonMises
from warpcontact.physics.geometry import Grid, Sphere
from warpcontact.physics.materials import PAPER_PAIR
from warpcontact.numerics.model import ContactModel
from warpcontact.studies.slip_search import estimate_delta_x_max
from warpcontact.solvers.contact import ContactSolver
from warpcontact.numerics.state import ContactState
from warpcontact.studies.table2 import DELTA_N, DELTA_T, SIGMA_MAX, TAU_MAX

R, DZ = 10e-6, 1.0e-10
A = math.sqrt(R * DZ)


def used_bytes(device) -> int:
    wp.synchronize_device(device)
    return int(device.total_memory - device.free_memory) if device.is_cuda else 0


def run(n, device, dtype, fft, max_turns: int, max_iter: int) -> dict:
    row = {"n": n, "dtype": dtype}
    try:
        row["estimate_GiB"] = resources.check_fits(n, dtype, device, True, fft, adhesion=True) / 2**30
    except InputError as e:
        row["refused"] = str(e)
        return row
    base = used_bytes(device)
    t0 = time.perf_counter()
    model = ContactModel(PAPER_PAIR, Sphere(R, "paraboloid"), Grid(n, 4 * A), device=device, dtype=dtype, fft=fft)
    law = TaborVonMises(0.8, PAPER_PAIR.softer.yield_strength)
    solver = ContactSolver(model, law, adhesion=SMC(SIGMA_MAX, TAU_MAX, DELTA_N, DELTA_T), max_turns=max_turns,
                           max_iter=max_iter)
    state = ContactState(model)
    row["setup_s"] = time.perf_counter() - t0
    print(f"  n {n} {dtype}: set-up {row['setup_s']:.1f} s, {(used_bytes(device) - base) / 2**30:.2f} GiB in use",
          flush=True)
    for name, approach in (("normal", (0.0, 0.0, DZ)),
                           ("tangential", (0.5 * estimate_delta_x_max(PAPER_PAIR, R, DZ, law), 0.0, DZ))):
        t0 = time.perf_counter()
        info = solver.step(state, approach)
        wp.synchronize_device(device)
        row[f"{name}_s"] = time.perf_counter() - t0
        row[f"{name}_iterations"] = info.iterations
        row[f"{name}_turns"] = info.outer_iterations
        row[f"{name}_converged"] = bool(info.converged)
        print(f"  n {n} {dtype}: {name} step {row[f'{name}_s']:.1f} s, {info.iterations} iterations, "
              f"{info.outer_iterations} turns, converged {info.converged}", flush=True)
    if device.is_cuda:
        row["memory_GiB"] = (used_bytes(device) - base) / 2**30
    row["fft"] = model.fft_name
    return row


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--device", default="cuda:0")
    ap.add_argument("--sizes", type=int, nargs="+", required=True)
    ap.add_argument("--dtype", nargs="+", default=["float64"])
    ap.add_argument("--fft", default="auto")
    ap.add_argument("--max-turns", type=int, default=1000,
                    help="turns of the adhesive fixed point per step (a few: a memory check that ends in time)")
    ap.add_argument("--max-iter", type=int, default=2000, help="iterations per inner solve")
    ap.add_argument("--json")
    a = ap.parse_args()
    wp.init()
    device = wp.get_device(a.device)
    limit, what = resources.memory_limit(device)
    kind = "cuda" if device.is_cuda else "cpu"
    print(f"# scale check on {a.device} ({device.name}): {what} {limit / 2**30:.2f} GiB; "
          f"coupled problem with SMC adhesion, one state")
    rows = []
    for dtype in a.dtype:
        n_max = resources.largest_grid(dtype, limit, True, device_kind=kind, fft=a.fft, adhesion=True)
        print(f"largest grid by the estimate, {dtype}: n = {n_max}", flush=True)
        rows.append({"dtype": dtype, "largest_grid": n_max})
        for n in a.sizes:
            r = run(n, device, dtype, a.fft, a.max_turns, a.max_iter)
            rows.append(r)
            if "refused" in r:
                print(f"  n {n} {dtype}: refused before allocating: {r['refused']}", flush=True)
            else:
                mem = f"{r['memory_GiB']:.2f} GiB in use" if "memory_GiB" in r else "(no device memory reading on the CPU)"
                print(f"  n {n} {dtype}: estimate {r['estimate_GiB']:.2f} GiB, {mem}, set-up {r['setup_s']:.1f} s",
                      flush=True)
            if a.json:
                with open(a.json, "w") as fh:
                    json.dump(rows, fh, indent=1)


if __name__ == "__main__":
    main()

"""Where the time of ``wc.solve`` goes: the model, the steps, the summaries, the fields, the yield
check, for the problem of bench/scaling.py (copper on steel, R = 10 um, delta_z = 1e-10 m then
delta_x = 2e-11 m with Tabor friction k_tau = 0.8, or frictionless with ``--frictionless``).

Each part of ``runner.run_path`` is timed where it is called (the device synchronised before each
clock reading, so that a part's kernels are counted in it): ``build`` (model, solvers, state),
``step`` (the solves), ``summary`` (``results.state_summary``), ``fields`` (``results.state_fields``:
the fields brought to the host), ``yield check`` (``yielding.state_yield_check``, from the last
state's tractions on the device), and the rest of ``wc.solve``. Second call of two in one process (the first
loads the kernels and captures the graphs). Prints a markdown table, one row per n.

    python bench/api_parts.py --device cuda:0 --sizes 1024 4096
    python bench/api_parts.py --sizes 256 512            # the CPU
    python bench/api_parts.py --device cuda:0 --frictionless --sizes 8192 --fields none
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections import defaultdict

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


def part_timer(spent: dict, device):
    """``timed(name, fn)``: ``fn`` wrapped so that its time goes into ``spent[name]`` [s], the
    device synchronised at each clock reading, its outermost calls only (a nested start's coarse
    steps run inside the fine step: counted once). Also bench/process_parts.py's."""
    import warp as wp

    depth = defaultdict(int)

    def timed(name, fn):
        def wrapper(*args, **kwargs):
            if depth[name]:
                return fn(*args, **kwargs)
            depth[name] += 1
            wp.synchronize_device(device)
            t0 = time.perf_counter()
            try:
                return fn(*args, **kwargs)
            finally:
                wp.synchronize_device(device)
                spent[name] = spent.get(name, 0.0) + time.perf_counter() - t0
                depth[name] -= 1
        return wrapper

    return timed


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--fft", default="auto")
    ap.add_argument("--dtype", default="float64", choices=["float64", "float32"])
    ap.add_argument("--sizes", type=int, nargs="+", default=[256, 512])
    ap.add_argument("--frictionless", action="store_true")
    ap.add_argument("--fields", default="all", choices=["all", "last", "none"],
                    help="whose fields wc.solve brings to the host (its fields= argument)")
    a = ap.parse_args()

    import warp as wp

    wp.config.quiet = True
    wp.init()
    import scaling

    import warpcontact as wc
    import warpcontact.studies.runner as runner
    from warpcontact.records.case import case_from_dict

    device = wp.get_device(a.device)
    spent = defaultdict(float)
    timed = part_timer(spent, device)

    originals = {k: getattr(runner, k) for k in ("build", "state_summary", "state_fields")}
    runner.build = timed("build", originals["build"])
    runner.state_summary = timed("summary", originals["state_summary"])
    runner.state_fields = timed("fields", originals["state_fields"])
    import warpcontact.numerics.yielding as yielding

    yielding.state_yield_check = timed("yield check", yielding.state_yield_check)
    from warpcontact.solvers.contact import ContactSolver

    contact_step = ContactSolver.step
    ContactSolver.step = timed("step", contact_step)
    parts = ("build", "step", "summary", "fields", "yield check")
    print(f"<!-- python bench/api_parts.py {' '.join(sys.argv[1:])}; {device.name}, {a.dtype} -->")
    print("| n | wc.solve [s] | " + " | ".join(f"{p} [s]" for p in parts) + " | rest [s] |")
    print("|---|---|" + "---|" * len(parts) + "---|")
    for n in a.sizes:
        case = case_from_dict(scaling.case_dict(n, not a.frictionless, a.device, a.dtype, a.fft))
        for _ in range(2):
            spent.clear()
            wp.synchronize_device(device)
            t0 = time.perf_counter()
            result = wc.solve(case, fields=a.fields)
            wp.synchronize_device(device)
            total = time.perf_counter() - t0
            del result
        rest = total - sum(spent[p] for p in parts)
        print(f"| {n} | {total:.2f} | " + " | ".join(f"{spent[p]:.2f}" for p in parts) + f" | {rest:.2f} |",
              flush=True)


if __name__ == "__main__":
    main()

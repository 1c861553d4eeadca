"""Which device kernels a solve spends its time in (CUDA): ``wc.solve`` of bench/scaling.py's
problem (coupled, or ``--frictionless``) under ``torch.profiler``, whose CUPTI tracing records every
kernel of the process (Warp's, cuFFT's, CuPy's), those replayed from CUDA graphs too.

The second of two solves in one process is profiled (the first loads the kernels and captures the
graphs). Prints, per n, the solve's wall time, its device time by kernel family (the transforms,
Warp's kernels by name, copies) with calls and ms, and the iterations the solve reports, so that a
cost per iteration can be read against the transforms' floor. Needs PyTorch (the GPU machine has
it; it is not a dependency of warpcontact).

    python bench/kernel_profile.py --sizes 4096 8192 [--dtype float64] [--frictionless] [--top 25]

``--path NAME``: a whole load path of bench/paths.py (``figure2c``, ``rough``, ...; in ``--dtype``) at each n
instead, profiled in its first solve at that n after a solve of the same path at n = 128 has
loaded the kernels (each n's graphs are captured inside the profiled solve, as a user's run
captures them).

    python bench/kernel_profile.py --path figure2c --sizes 1024 4096
"""

from __future__ import annotations

import argparse
import os
import re
import sys
import time
from collections import defaultdict

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


def family(name: str) -> str:
    """A kernel's family: cuFFT's many generated kernels in one row, Warp's by kernel name."""
    if re.search(r"fft|regular_fft|vector_fft|transpose_kernel", name, re.IGNORECASE):
        return "cuFFT"
    m = re.match(r"(\w+?)_cuda_kernel_forward", name)
    if m:
        return "warp: " + m.group(1)
    if "Memcpy" in name or "Memset" in name:
        return name.split(" (")[0]  # "Memcpy DtoD", "Memcpy DtoH", "Memcpy HtoD", "Memset"
    return name[:60]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--device", default="cuda:0")
    ap.add_argument("--fft", default="auto")
    ap.add_argument("--dtype", default="float64", choices=["float64", "float32"])
    ap.add_argument("--sizes", type=int, nargs="+", default=[4096])
    ap.add_argument("--frictionless", action="store_true")
    ap.add_argument("--top", type=int, default=25)
    ap.add_argument("--path", help="a path of bench/paths.py, profiled whole")
    a = ap.parse_args()

    import torch
    import warp as wp
    from torch.profiler import ProfilerActivity, profile

    wp.config.quiet = True
    wp.init()
    import scaling

    import warpcontact as wc
    from warpcontact.records.case import case_from_dict

    device = wp.get_device(a.device)
    torch.cuda.init()
    def path_case(n):
        d = paths.case_dict(a.path)
        d["grid"]["n"] = n
        d.setdefault("solver", {}).update(device=a.device, fft=a.fft, dtype=a.dtype)
        return case_from_dict(d)

    if a.path:
        import paths

        wc.solve(path_case(128), fields="none")
    for n in a.sizes:
        if a.path:
            case = path_case(n)
        else:
            case = case_from_dict(scaling.case_dict(n, not a.frictionless, a.device, a.dtype, a.fft))
            wc.solve(case, fields="none")
        wp.synchronize_device(device)
        with profile(activities=[ProfilerActivity.CUDA]) as prof:
            t0 = time.perf_counter()
            result = wc.solve(case, fields="none")
            wp.synchronize_device(device)
            wall = time.perf_counter() - t0
        spent, calls = defaultdict(float), defaultdict(int)
        for ev in prof.events():
            if ev.device_type == torch.autograd.DeviceType.CUDA:
                f = family(ev.name)
                spent[f] += ev.time_range.elapsed_us() / 1e3
                calls[f] += 1
        total = sum(spent.values())
        iters = [(s.get("iterations"), s.get("outer_iterations")) for s in result.states]
        what = f"path {a.path}" if a.path else ("frictionless" if a.frictionless else "coupled")
        print(f"\n### n = {n}, {a.dtype}, {what}: wall {wall:.3f} s, "
              f"device busy {total / 1e3:.3f} s; per state (iterations, turns): {iters}")
        print("| kernel family | calls | device ms | share |")
        print("|---|---|---|---|")
        for f, ms in sorted(spent.items(), key=lambda kv: -kv[1])[: a.top]:
            print(f"| {f} | {calls[f]} | {ms:.1f} | {ms / total:.1%} |")
        sys.stdout.flush()


if __name__ == "__main__":
    main()

"""Probe: where the time of a Hertz normal solve goes, beyond its iterations.

For each grid size N (problem of bench_iteration.py: paper pair, R = 10 um, delta_z = 1e-4 um,
domain 4a), on one device:

1. the converged solve (as bench_iteration.py times it): iterations, wall time, ms per iteration;
2. the marginal cost of an iteration and the fixed cost of a solve: two solves capped at
   ``--short`` and ``--long`` iterations with tolerance 0 (they never converge, so both run every
   iteration, with the same host reads); marginal = (T_long - T_short) / (long - short), fixed =
   T_short - short * marginal (first guess, first and final residual, host reads, set-up);
3. on CUDA with PyTorch, one converged solve under ``torch.profiler``: the GPU kernels' busy time
   against the wall time, and the kernels by total time;
4. with ``--cprofile``, one converged solve under cProfile: the host functions by own time;
5. with ``--trace DIR``, on CUDA with PyTorch, the timeline of one converged solve (state set-up
   included): a Chrome trace in DIR, and on stdout the device's busy time, its idle gaps over
   ``--gap`` us with the activity on each side, and the device time by phase (before the first
   iteration's transforms, the iterations, after the last);
6. the set-up of a state (``ContactState``) and a warm solve (from the converged pressure: no
   iteration, the start and the two exact residuals) on their own.

    python bench/profile_normal_solve.py --device cuda:0 --sizes 1024 2048
"""

from __future__ import annotations

import argparse
import math
import time

import warp as wp

from bench_iteration import best_wall_time  # bench/, beside this script
from warpcontact.physics.geometry import Grid, Sphere
from warpcontact.physics.materials import PAPER_PAIR
from warpcontact.numerics.model import ContactModel
from warpcontact.solvers import NormalSolver
from warpcontact.numerics.state import ContactState

R, DZ = 10e-6, 1.0e-10
A = math.sqrt(R * DZ)


def timeline(trace_path, gap_us, top):
    """Summary of the device's activity in a Chrome trace written by torch.profiler."""
    import json

    with open(trace_path) as fh:
        events = json.load(fh)["traceEvents"]
    gpu = sorted((e for e in events if e.get("ph") == "X" and e.get("cat") in ("kernel", "gpu_memset", "gpu_memcpy")),
                 key=lambda e: e["ts"])
    if not gpu:
        print("  trace: no device activity recorded")
        return
    span = gpu[-1]["ts"] + gpu[-1]["dur"] - gpu[0]["ts"]
    busy = sum(e["dur"] for e in gpu)
    gaps = []
    for a, b in zip(gpu, gpu[1:]):
        idle = b["ts"] - (a["ts"] + a["dur"])
        if idle > gap_us:
            gaps.append((idle, a["name"][:40], b["name"][:40], a["ts"] - gpu[0]["ts"]))
    print(f"  trace: {len(gpu)} device activities over {span / 1e3:.3f} ms, busy {busy / 1e3:.3f} ms; "
          f"{len(gaps)} gaps over {gap_us} us, {sum(g[0] for g in gaps) / 1e3:.3f} ms in all")
    for idle, before, after, at in sorted(gaps, reverse=True)[:top]:
        print(f"    {idle:8.1f} us idle at {at / 1e3:7.3f} ms, after {before} / before {after}")
    ffts = [i for i, e in enumerate(gpu) if "fft" in e["name"]]
    if ffts:
        first, last = ffts[0], ffts[-1]
        print(f"  device time before the first transform {sum(e['dur'] for e in gpu[:first]) / 1e3:.3f} ms "
              f"({first} activities), from it to the last {sum(e['dur'] for e in gpu[first:last + 1]) / 1e3:.3f} ms, "
              f"after {sum(e['dur'] for e in gpu[last + 1:]) / 1e3:.3f} ms ({len(gpu) - last - 1} activities)")


def probe(n, device, dtype, short, long, repeats, top, host_profile=False, trace_dir=None, gap_us=10.0,
          preconditioned=True):
    model = ContactModel(PAPER_PAIR, Sphere(R, "paraboloid"), Grid(n, 4 * A), device=device, dtype=dtype)
    solver = NormalSolver(model, preconditioned=preconditioned)
    info = {}

    def solve(max_iter=None, tol=None):
        def run():
            state = ContactState(model)
            solver.max_iter = max_iter or 2000
            info["last"] = solver.solve(state, DZ, tol=tol)
        return run

    kind = "preconditioned" if preconditioned else "plain"
    t_conv = best_wall_time(model.device, solve(), repeats)
    iters = info["last"].iterations
    t_short = best_wall_time(model.device, solve(short, 0.0), repeats)
    t_long = best_wall_time(model.device, solve(long, 0.0), repeats)
    marginal = (t_long - t_short) / (long - short)
    fixed = t_short - short * marginal
    print(f"N = {n} {dtype} {kind}: converged solve {iters} iterations, {1e3 * t_conv:.2f} ms, "
          f"{1e3 * t_conv / iters:.4f} ms/it; marginal iteration {1e3 * marginal:.4f} ms, fixed cost per solve "
          f"{1e3 * fixed:.2f} ms ({short} / {long} capped iterations: {1e3 * t_short:.2f} / {1e3 * t_long:.2f} ms)",
          flush=True)
    t_state = best_wall_time(model.device, lambda: ContactState(model), repeats)
    warm = ContactState(model)
    solver.max_iter = 2000
    solver.solve(warm, DZ)

    def warm_solve():
        info["warm"] = solver.solve(warm, DZ)

    t_warm = best_wall_time(model.device, warm_solve, repeats)
    print(f"  state set-up {1e3 * t_state:.3f} ms; warm solve ({info['warm'].iterations} iterations) {1e3 * t_warm:.3f} ms")
    if host_profile:
        import cProfile
        import io
        import pstats

        run = solve()
        profiler = cProfile.Profile()
        profiler.enable()
        run()
        wp.synchronize_device(model.device)
        profiler.disable()
        text = io.StringIO()
        pstats.Stats(profiler, stream=text).sort_stats("tottime").print_stats(top)
        print(text.getvalue())
    if not model.device.is_cuda:
        return
    try:
        import torch
        from torch.profiler import ProfilerActivity, profile
    except Exception as e:  # noqa: BLE001  (a probe: say why and go on)
        print(f"  torch.profiler: not available ({type(e).__name__}: {e})")
        return
    torch.cuda.init()
    run = solve()
    if trace_dir:
        import os

        os.makedirs(trace_dir, exist_ok=True)
        path = os.path.join(trace_dir, f"normal_solve_{n}_{dtype}.json")
        with profile(activities=[ProfilerActivity.CPU, ProfilerActivity.CUDA]) as prof:
            run()
            wp.synchronize_device(model.device)
        prof.export_chrome_trace(path)
        timeline(path, gap_us, top)
    with profile(activities=[ProfilerActivity.CUDA]) as prof:
        wp.synchronize_device(model.device)
        t0 = time.perf_counter()
        run()
        wp.synchronize_device(model.device)
        wall = time.perf_counter() - t0
    events = prof.key_averages()
    busy = sum(e.device_time_total for e in events) / 1e6
    print(f"  under torch.profiler: {1e3 * wall:.2f} ms wall, GPU kernels busy {1e3 * busy:.2f} ms "
          f"({100 * busy / wall:.0f} %), {sum(e.count for e in events)} kernels")
    print(events.table(sort_by="device_time_total", row_limit=top))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--sizes", type=int, nargs="*", default=[1024, 2048])
    ap.add_argument("--dtype", default="float64")
    ap.add_argument("--short", type=int, default=40)
    ap.add_argument("--long", type=int, default=200)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--top", type=int, default=25)
    ap.add_argument("--cprofile", action="store_true", help="one converged solve under cProfile")
    ap.add_argument("--trace", default=None, metavar="DIR", help="Chrome trace of one converged solve into DIR (CUDA, PyTorch)")
    ap.add_argument("--gap", type=float, default=10.0, help="device idle gaps listed from this length [us]")
    ap.add_argument("--plain", action="store_true", help="the solver without its preconditioner")
    args = ap.parse_args()
    wp.config.quiet = True
    wp.init()
    device = wp.get_device(args.device)
    print(f"# normal solve: fixed and marginal costs; device {device} ({device.name}), warp {wp.__version__}, "
          f"{time.strftime('%Y-%m-%d')}")
    for n in args.sizes:
        probe(n, device, args.dtype, args.short, args.long, args.repeats, args.top, args.cprofile, args.trace, args.gap,
              not args.plain)


if __name__ == "__main__":
    main()

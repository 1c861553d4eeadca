"""Benchmark: the Hertz normal solve (paper pair, R = 10 um, delta_z = 1e-4 um, domain 4a).

For each device and FFT backend available and each grid size, prints iterations, time per
iteration and total solve time (the clock stops after a device synchronisation; the first,
compiling solve is not timed). When the ``tamaas`` package is installed, Tamaas' own solver is
timed on the same problem in the same run and the ratio printed; with ``--slippy-python PY``,
slippy 0.5.2 too (``bench/slippy_hertz.py`` in that interpreter: slippy needs a venv of its own).

    python bench/bench_normal.py                       # CPU: N = 128 ... 1024
    python bench/bench_normal.py --device cuda         # GPU: N = 256 ... 4096
    python bench/bench_normal.py --sizes 256 512 --fft scipy warp --json out.json
    python bench/bench_normal.py --fft scipy --slippy-python /tmp/slippy_venv/bin/python
    python bench/bench_normal.py --modes default plain     # preconditioned (default) and plain, side by side
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import time

import warp as wp

from warpcontact.fft import available_backends
from warpcontact.physics.geometry import Grid, Sphere
from warpcontact.physics.materials import PAPER_PAIR
from warpcontact.numerics.launch import LaunchCache
from warpcontact.numerics.model import ContactModel
from warpcontact.physics.reference import hertz
from warpcontact.solvers import NormalSolver
from warpcontact.numerics.state import ContactState

R, DZ = 10e-6, 1.0e-10
A = math.sqrt(R * DZ)


#: the normal solver's variants a run may time side by side (``--modes``): its keyword arguments
MODES = {
    "default": {},  # preconditioned, one convolution per iteration
    "plain": {"normal_preconditioner": False},  # Polonsky-Keer without the preconditioner
    "two-conv": {"one_convolution": False},  # the gap recomputed (K p) at every iteration
    # the launch layer (numerics/launch.py): the default replays recorded launches and, on the CPU,
    # splits a launch by rows over the CPU's threads; "one-thread" replays without splitting;
    # "plain-launches" neither (a wp.launch per kernel, on one thread)
    "one-thread": {"launches": {"threads": 1}},
    "plain-launches": {"launches": {"threads": 1, "replay": False}},
}


def time_warpcontact(n, device, dtype, fft, repeats, mode="default"):
    choices = dict(MODES[mode])
    launches = {"threads": None, "replay": True, **choices.pop("launches", {})}
    for name, value in launches.items():  # the launch layer's defaults, for the caches made below
        setattr(LaunchCache, name, value)
    model = ContactModel(PAPER_PAIR, Sphere(R, "paraboloid"), Grid(n, 4 * A), device=device, dtype=dtype, fft=fft)
    solver = NormalSolver(model, **choices)
    best = math.inf
    info = None
    for rep in range(repeats + 1):  # the first solve compiles and warms caches: not timed
        state = ContactState(model)
        wp.synchronize_device(model.device)
        t0 = time.perf_counter()
        info = solver.solve(state, DZ)
        wp.synchronize_device(model.device)
        if rep > 0:
            best = min(best, time.perf_counter() - t0)
    F = float(state.pressure.numpy().sum()) * model.traction_scale * model.grid.cell_area
    return {"iterations": info.iterations, "total_s": best, "per_iter_ms": 1e3 * best / info.iterations,
            "residual": info.residual, "force_err": F / hertz(PAPER_PAIR, R, DZ)["force"] - 1.0}


def time_tamaas(n):
    """Tamaas 2.9's Polonsky-Keer-Rey solver with its non-periodic (DC-FFT) operator, tolerance
    1e-10, on the same Hertz problem. Tamaas drives it by the mean pressure (the Hertz force over
    the domain), not by the approach: the same contact, solved to the same tolerance."""
    import numpy as np
    import tamaas as tm

    L = 4 * A
    model = tm.ModelFactory.createModel(tm.model_type.basic_2d, [L, L], [n, n])
    model.E = PAPER_PAIR.E_star
    model.nu = 0.0  # with nu = 0 Tamaas' E* equals E
    x = (np.arange(n) - 0.5 * (n - 1)) * (L / n)
    X, Y = np.meshgrid(x, x, indexing="ij")
    surface = -(X**2 + Y**2) / (2 * R)
    tm.ModelFactory.registerNonPeriodic(model, "dcfft")
    solver = tm.PolonskyKeerRey(model, surface, 1e-10)
    solver.setIntegralOperator("dcfft")
    force = hertz(PAPER_PAIR, R, DZ)["force"]
    t0 = time.perf_counter()
    solver.solve(force / L**2)
    elapsed = time.perf_counter() - t0
    p = np.asarray(model.traction)
    return {"total_s": elapsed, "p0_err": float(p.max() / hertz(PAPER_PAIR, R, DZ)["p0"] - 1.0)}


def time_slippy(n, python):
    """slippy 0.5.2 on the same problem, in its own interpreter (bench/slippy_hertz.py)."""
    import subprocess
    import tempfile
    from pathlib import Path

    script = Path(__file__).resolve().with_name("slippy_hertz.py")
    with tempfile.TemporaryDirectory() as scratch:  # slippy writes its logs and databases into the working folder
        r = subprocess.run([python, str(script), str(n)], capture_output=True, text=True, timeout=3600, cwd=scratch)
    if r.returncode != 0:
        raise RuntimeError(f"slippy run failed: {r.stderr.strip().splitlines()[-1] if r.stderr.strip() else r.returncode}")
    return json.loads(r.stdout.strip().splitlines()[-1])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--sizes", type=int, nargs="*")
    ap.add_argument("--fft", nargs="*", help="backends (default: all available on the device)")
    ap.add_argument("--dtype", nargs="*", default=["float64"])
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--no-tamaas", action="store_true")
    ap.add_argument("--slippy-python", help="interpreter of a venv with slippy 0.5.2: time it side by side")
    ap.add_argument("--modes", nargs="*", default=["default"], choices=list(MODES),
                    help="normal-solver variants to time side by side: the default (preconditioned), plain "
                         "(no preconditioner), two convolutions per iteration; the launch layer without the "
                         "CPU's split launches (one-thread) and without replays either (plain-launches)")
    ap.add_argument("--json", help="also write the rows to this file")
    args = ap.parse_args()
    wp.config.quiet = True
    wp.init()
    device = wp.get_device(args.device)
    sizes = args.sizes or ([128, 256, 512, 1024] if device.is_cpu else [256, 512, 1024, 2048, 4096])
    backends = args.fft or available_backends(device)
    try:
        import tamaas  # noqa: F401

        have_tamaas = not args.no_tamaas and device.is_cpu
    except ImportError:
        have_tamaas = False
    print(f"# Hertz normal solve, paper pair, delta_z = {DZ} m, domain 4a; device {device} ({platform.processor() or platform.machine()}), "
          f"warp {wp.__version__}, {time.strftime('%Y-%m-%d')}")
    print(f"{'N':>6} {'dtype':>8} {'fft':>6} {'mode':>8} {'iters':>6} {'ms/iter':>9} {'total s':>9} {'F err':>9}"
          + ("  tamaas s  ratio" if have_tamaas else "")
          + ("  slippy s  ratio  slippy F err" if args.slippy_python else ""))
    rows = []
    for n in sizes:
        tam = time_tamaas(n) if have_tamaas else None
        slip = time_slippy(n, args.slippy_python) if args.slippy_python else None
        for dtype in args.dtype:
            for fft, mode in [(f, md) for f in backends for md in args.modes]:
                try:
                    r = time_warpcontact(n, args.device, dtype, fft, args.repeats, mode)
                except (ValueError, RuntimeError) as e:  # e.g. a size the tile-FFT backend cannot do
                    print(f"{n:>6} {dtype:>8} {fft:>6}  not run: {str(e).splitlines()[0][:90]}", flush=True)
                    continue
                row = {"n": n, "dtype": dtype, "fft": fft, "mode": mode, "device": str(device), **r}
                line = (f"{n:>6} {dtype:>8} {fft:>6} {mode:>8} {r['iterations']:>6} {r['per_iter_ms']:>9.2f} "
                        f"{r['total_s']:>9.3f} {r['force_err']:>9.1e}")
                if tam:
                    row["tamaas_s"] = tam["total_s"]
                    line += f"  {tam['total_s']:>8.2f}  {tam['total_s'] / r['total_s']:>5.1f}x"
                if slip:
                    row["slippy_s"], row["slippy_force_err"] = slip["total_s"], slip["force_err"]
                    line += f"  {slip['total_s']:>8.2f}  {slip['total_s'] / r['total_s']:>5.1f}x  {slip['force_err']:>+9.1e}"
                print(line, flush=True)
                rows.append(row)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=2)


if __name__ == "__main__":
    main()

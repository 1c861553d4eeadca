"""Benchmark: time per solver iteration against the FFT floor measured on the same device, same run.

For each grid size N, on the problem of bench_normal.py (paper pair, R = 10 um, delta_z = 1e-4 um,
domain 4a):

- normal: the Hertz normal solve (Polonsky-Keer, without the preconditioner: one convolution
  per iteration, the measure of the solver's cost) from rest (the pressure of a state allocated
  once zeroed before each solve) as the solver runs it by default otherwise (CUDA: graphs,
  one convolution per iteration, pruned cuFFT transforms); ms per iteration; on CUDA side by side
  with the same solve in three alternatives, each differing from the default in one thing:
  "eager" (no CUDA graphs: a Python launch per kernel and per transform), "2-conv" (K p
  recomputed every iteration: two convolutions per iteration), "strict" (K p recomputed after
  every projection: ``deferral = 0``) and "2-D fft" (cuFFT's 2-D plans of the whole
  padded grid instead of the pruned row and column plans); the iteration counts of each are in
  the JSON;
- floor1: one forward + one inverse transform of the padded 2N x 2N field by the FFT library
  alone (on CUDA cuFFT's 2-D D2Z + Z2D plans of the padded grid, as a user of the library would
  call them; on the CPU the scipy backend's transforms, which skip the padding already), without
  the padding and cropping passes, plus one elementwise pass (a device copy of an N x N field):
  the floor an iteration is measured against; ratio = normal / floor1;
- precond: the same solve as the solver runs it by default, preconditioned (a second padded
  transform pair per iteration: ``NormalSolver.preconditioned``): iterations, ms per iteration
  against floor2 (two pairs and one pass), and the whole solve's time against the plain one's
  (``solve x``: plain solve time / preconditioned solve time);
- coupled: one load step of the coupled problem (Tabor + von Mises, k_tau = 0.8, delta_x = half
  of Mindlin's delta_x_max) from the solved normal state: its inner iterations (normal and
  tangential CG) and ms per inner iteration; with --adhesion also the SMC law;
- floor3: three forward + three inverse transforms + one pass (the floor of a (p, q_x, q_y)
  iteration); ratio = coupled / floor3;
- memory: the device memory in use after the solves (CUDA: total - free, less the baseline
  before the model was built; CPU: the process's peak resident set) and resources.estimate_bytes
  for the same problem.

    python bench/bench_iteration.py --device cuda:0 --sizes 256 512 1024 2048 4096 --json out.json
    python bench/bench_iteration.py --sizes 128 256 512 1024                          # CPU
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import resource
import time

import warp as wp

from warpcontact.numerics import resources
from warpcontact.physics.adhesion import SMC
from warpcontact.physics.friction import TaborVonMises
from warpcontact.physics.geometry import Grid, Sphere
from warpcontact.physics.materials import PAPER_PAIR
from warpcontact.numerics.model import ContactModel
from warpcontact.studies.slip_search import estimate_delta_x_max
from warpcontact.solvers import NormalSolver
from warpcontact.solvers.contact import ContactSolver
from warpcontact.numerics.state import ContactState
from iteration_parts import best_wall_time  # bench/, beside this script

R, DZ = 10e-6, 1.0e-10
A = math.sqrt(R * DZ)


def unpruned_fft(model):
    """The model's FFT backend, or on CUDA's cupy backend a twin with 2-D plans of the whole padded
    grid (same spectral layout, so it can stand in for the pruned one)."""
    fft = model.operator.fft
    if fft.name != "cupy" or not fft.pruned:
        return fft
    from warpcontact.fft.cupy_backend import CupyFFT

    return CupyFFT(fft.ny, fft.nx, fft.device, fft.dtype, pruned=False)


def floor_ms(model, pairs: int, repeats: int, fft) -> float:
    """``pairs`` forward + inverse transforms of ``fft`` plus one N x N device copy [ms]."""
    field, out = model.field(), model.field()
    spec = fft.alloc_spectra(1)[0]

    def run():
        for _ in range(pairs):
            fft.library_transforms(field, spec)
        wp.copy(out, field)

    loops = 20

    def many():
        for _ in range(loops):
            run()

    return 1e3 * best_wall_time(model.device, many, repeats) / loops


def used_bytes(device) -> int:
    if device.is_cpu:
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    wp.synchronize_device(device)
    return int(device.total_memory - device.free_memory)


def bench(n, device, dtype, fft, repeats, adhesion: bool, compare_up_to: int = 2048, turn_mixing: bool = True):
    base = used_bytes(device)
    model = ContactModel(PAPER_PAIR, Sphere(R, "paraboloid"), Grid(n, 4 * A), device=device, dtype=dtype, fft=fft)
    row = {"n": n, "dtype": dtype, "fft": model.operator.fft.name if hasattr(model.operator.fft, "name") else fft}
    info = {}

    state = ContactState(model)  # allocated once, as a user's state is; each timed solve starts from rest

    def normal_ms(solver):
        def solve_normal():
            state.pressure.zero_()
            info["normal"] = solver.solve(state, DZ)

        t = best_wall_time(model.device, solve_normal, repeats)
        return info["normal"].iterations, 1e3 * t / info["normal"].iterations

    row["normal_iters"], row["normal_ms"] = normal_ms(NormalSolver(model, normal_preconditioner=False))
    row["precond_iters"], row["precond_ms"] = normal_ms(NormalSolver(model))
    row["normal_solve_ms"] = row["normal_iters"] * row["normal_ms"]
    row["precond_solve_ms"] = row["precond_iters"] * row["precond_ms"]
    law = TaborVonMises(0.8, PAPER_PAIR.softer.yield_strength)
    adh = SMC(2e7, 2e7, 5e-12, 5e-12) if adhesion else None
    # the minimised turns (this law's) Anderson-mixed, or plain
    solver = ContactSolver(model, law, adhesion=adh, turn_mixing=turn_mixing)
    start = ContactState(model)
    solver.step(start, (0.0, 0.0, DZ))
    dx = 0.5 * estimate_delta_x_max(PAPER_PAIR, R, DZ, law)
    trial = ContactState(model)

    def solve_coupled():
        trial.copy_from(start)
        info["coupled"] = solver.step(trial, (dx, 0.0, DZ))

    t = best_wall_time(model.device, solve_coupled, repeats)
    c = info["coupled"]
    row.update(coupled_iters=c.iterations, coupled_turns=c.outer_iterations, coupled_s=t,
               coupled_ms=1e3 * t / max(c.iterations, 1), coupled_converged=bool(c.converged))
    row["memory_MiB"] = (used_bytes(device) - (0 if device.is_cpu else base)) / 2**20
    floor_fft = unpruned_fft(model)
    if model.device.is_cuda and n <= compare_up_to:
        plain = {"normal_preconditioner": False}  # the alternatives of the plain solve (normal)
        row["eager_iters"], row["eager_ms"] = normal_ms(NormalSolver(model, use_graphs=False, **plain))
        row["two_conv_iters"], row["two_conv_ms"] = normal_ms(NormalSolver(model, one_convolution=False, **plain))
        strict = NormalSolver(model, deferral=0.0, **plain)
        row["strict_iters"], row["strict_ms"] = normal_ms(strict)
        if floor_fft is not model.operator.fft:
            pruned, model.operator.fft = model.operator.fft, floor_fft
            row["fft2d_iters"], row["fft2d_ms"] = normal_ms(NormalSolver(model, **plain))
            model.operator.fft = pruned
    row["floor1_ms"] = floor_ms(model, 1, repeats, floor_fft)
    row["floor2_ms"] = floor_ms(model, 2, repeats, floor_fft)
    row["floor3_ms"] = floor_ms(model, 3, repeats, floor_fft)
    row["normal_ratio"] = row["normal_ms"] / row["floor1_ms"]
    row["precond_ratio"] = row["precond_ms"] / row["floor2_ms"]
    row["precond_gain"] = row["normal_solve_ms"] / row["precond_solve_ms"]
    row["coupled_ratio"] = row["coupled_ms"] / row["floor3_ms"]
    kind = "cpu" if device.is_cpu else "cuda"
    row["estimate_MiB"] = resources.estimate_bytes(n, dtype, kind, True, fft, states=2, adhesion=adhesion) / 2**20
    return row


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--sizes", type=int, nargs="*")
    ap.add_argument("--fft", default="auto")
    ap.add_argument("--dtype", nargs="*", default=["float64"])
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--adhesion", action="store_true", help="the coupled step with the SMC law (2e7 Pa, 5e-12 m)")
    ap.add_argument("--no-turn-mixing", dest="turn_mixing", action="store_false",
                    help="the adhesive step's minimised turns as the plain fixed point (ContactSolver.turn_mixing)")
    ap.add_argument("--compare-up-to", type=int, default=2048,
                    help="largest N with the eager, 2-conv and 2-D fft columns (CUDA)")
    ap.add_argument("--json")
    args = ap.parse_args()
    wp.config.quiet = True
    wp.init()
    device = wp.get_device(args.device)
    sizes = args.sizes or ([128, 256, 512, 1024] if device.is_cpu else [256, 512, 1024, 2048, 4096])
    name = device.name if not device.is_cpu else (platform.processor() or platform.machine())
    print(f"# iteration vs FFT floor; device {device} ({name}), warp {wp.__version__}, fft {args.fft}, "
          f"{time.strftime('%Y-%m-%d')}; coupled step {'with' if args.adhesion else 'without'} adhesion")
    print(f"{'N':>6} {'dtype':>8} {'it':>5} {'ms/it':>8} {'floor1':>7} {'ratio':>6} | {'eager':>7} {'2-conv':>7} {'strict':>7} {'2-D fft':>7} | "
          f"{'pc it':>5} {'ms/it':>8} {'floor2':>7} {'ratio':>6} {'solve x':>7} | "
          f"{'it':>6} {'turns':>5} {'ms/it':>8} {'floor3':>7} {'ratio':>6} {'step s':>8} | {'mem MiB':>8} {'est MiB':>8}")
    rows = []
    for n in sizes:
        for dtype in args.dtype:
            r = bench(n, device, dtype, args.fft, args.repeats, args.adhesion, args.compare_up_to, args.turn_mixing)
            rows.append({"device": str(device), **r})
            side = " ".join(f"{r[k]:>7.3f}" if k in r else f"{'-':>7}" for k in ("eager_ms", "two_conv_ms", "strict_ms", "fft2d_ms"))
            print(f"{n:>6} {dtype:>8} {r['normal_iters']:>5} {r['normal_ms']:>8.3f} {r['floor1_ms']:>7.3f} "
                  f"{r['normal_ratio']:>6.2f} | {side} | {r['precond_iters']:>5} {r['precond_ms']:>8.3f} "
                  f"{r['floor2_ms']:>7.3f} {r['precond_ratio']:>6.2f} {r['precond_gain']:>7.2f} | "
                  f"{r['coupled_iters']:>6} {r['coupled_turns']:>5} {r['coupled_ms']:>8.3f} "
                  f"{r['floor3_ms']:>7.3f} {r['coupled_ratio']:>6.2f} {r['coupled_s']:>8.3f} | {r['memory_MiB']:>8.0f} "
                  f"{r['estimate_MiB']:>8.0f}" + ("" if r["coupled_converged"] else "  (coupled step not converged)"),
                  flush=True)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=2)


if __name__ == "__main__":
    main()

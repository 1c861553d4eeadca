"""Benchmark: where the time of one normal iteration goes, part by part, on one device.

Each part of NormalSolver's iteration (and the FFT backend's passes) is captured 20 times in a
CUDA graph and replayed; the table gives ms per call and the share of the sum. On the CPU the
parts are launched one by one. Problem as bench_iteration.py (Hertz, paper pair, domain 4a).

    python bench/iteration_parts.py --device cuda:0 --sizes 1024 2048 4096
"""

from __future__ import annotations

import argparse
import math
import time

import warp as wp

from warpcontact.geometry import Grid, Sphere
from warpcontact.kernels import normal as nk
from warpcontact.kernels import spectral
from warpcontact.materials import PAPER_PAIR
from warpcontact.model import ContactModel
from warpcontact.solvers import NormalSolver
from warpcontact.state import ContactState

R, DZ = 10e-6, 1.0e-10
A = math.sqrt(R * DZ)
REPEATS = 20


def timed_ms(device, fn, best_of: int = 3) -> float:
    """ms per call of fn(): replayed from a graph of REPEATS calls on CUDA, best of ``best_of``."""
    fn()
    if device.is_cuda:
        with wp.ScopedCapture(device=device, force_module_load=False) as cap:
            for _ in range(REPEATS):
                fn()
        run = lambda: wp.capture_launch(cap.graph)  # noqa: E731
    else:
        def run():
            for _ in range(REPEATS):
                fn()
    best = math.inf
    for _ in range(best_of):
        wp.synchronize_device(device)
        t0 = time.perf_counter()
        run()
        wp.synchronize_device(device)
        best = min(best, time.perf_counter() - t0)
    return 1e3 * best / REPEATS


def parts(n, device, dtype):
    m = ContactModel(PAPER_PAIR, Sphere(R, "paraboloid"), Grid(n, 4 * A), device=device, dtype=dtype)
    s = NormalSolver(m)
    st = ContactState(m)
    s.solve(st, DZ)  # a solved state: the sets are those of the last iterations
    fft, op = m.operator.fft, m.operator
    spec = op._buf[0]
    p, g, t, b = (a.flatten() for a in (st.pressure, st.gap, s.direction, s.interference))
    output = [fft.padded_output, fft.output_scale, n]
    out = {}
    # the convolution as the iteration runs it: from the padded input, into the padded output
    out["transforms in (library)"] = timed_ms(m.device, lambda: fft.transform_input(spec))
    out["spectral product"] = timed_ms(m.device, lambda: op.spectral_product(spectral.spectral_normal, [spec]))
    out["transforms out (library)"] = timed_ms(m.device, lambda: fft.transform_to_output(spec))
    out["library forward + inverse"] = timed_ms(m.device, lambda: fft.library_transforms(st.pressure, spec))
    if fft.name == "cupy":  # the two layouts of cuFFT side by side
        from warpcontact.fft.cupy_backend import CupyFFT

        other = CupyFFT(n, n, m.device, m.dtype, pruned=not fft.pruned)
        label = "pruned" if other.pruned else "2-D"
        out[f"library pair, {label} plans"] = timed_ms(m.device, lambda: other.library_transforms(st.pressure, spec))
    # the solver's passes
    out["normal_direction (+ pad)"] = timed_ms(m.device, lambda: m.launches.launch_rows(
        nk.normal_direction, m.grid.shape, [st.gap, st.pressure, s._cap, s.sums, s.scalars], [s.direction, fft.padded_input]))
    out["normal_step_sums (reads output)"] = timed_ms(m.device, lambda: m.launch_reduce(
        nk.normal_step_sums, [g, t, *output], [s.sums]))
    # tau = 0 (g.t = 0, t.Kt = 1) on an iterate not converged (residual 1): the update runs its
    # whole path and leaves p and the gap as they are
    s.sums.assign([0.0, 1.0, 1.0, 0.0, 1.0] + [0.0] * (nk.N_SUMS - 5))
    out["normal_update (carries g)"] = timed_ms(m.device, lambda: m.launch_reduce(
        nk.normal_update, [t, *output, b, s._cap, s.settings], [p, g, s.sums]))
    out["normal_advance"] = timed_ms(m.device, lambda: m.launch(
        nk.normal_advance, 1, [s.sums, s.settings, s.exact_every, s._column_norm, m.scalar(s.deferral)],
        [s.scalars, s.history, s.deferred, s.recompute, s.loop, s.refresh]))
    # what an iteration adds when the gap is made exact (a convolution of p and normal_gap)
    out["exact gap: normal_gap (reduce)"] = timed_ms(m.device, lambda: m.launch_reduce(
        nk.normal_gap, [st.disp_z.flatten(), b, p, s._cap], [g, s.sums]))
    out["exact gap: forward (pad + library)"] = timed_ms(m.device, lambda: fft.forward(st.pressure, spec))
    out["exact gap: inverse (library + crop)"] = timed_ms(m.device, lambda: fft.inverse(spec, st.disp_z))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--sizes", type=int, nargs="*", default=[1024, 2048])
    ap.add_argument("--dtype", default="float64")
    args = ap.parse_args()
    wp.config.quiet = True
    wp.init()
    device = wp.get_device(args.device)
    print(f"# parts of a normal iteration; device {device} ({device.name}), {args.dtype}, {time.strftime('%Y-%m-%d')}")
    for n in args.sizes:
        out = parts(n, device, args.dtype)
        # an iteration: transforms in + product + transforms out + the four solver passes; an
        # exact gap adds a padded forward, the product, a cropped inverse and normal_gap
        conv = out["transforms in (library)"] + out["spectral product"] + out["transforms out (library)"]
        passes = sum(v for k, v in out.items() if k.startswith("normal_"))
        exact = (out["exact gap: forward (pad + library)"] + out["spectral product"]
                 + out["exact gap: inverse (library + crop)"] + out["exact gap: normal_gap (reduce)"])
        print(f"N = {n}: one convolution {conv:.3f} ms, the solver's passes {passes:.3f} ms, sum of an iteration "
              f"{conv + passes:.3f} ms; an exact gap adds {exact:.3f} ms "
              f"(library pair {out['library forward + inverse']:.3f} ms)")
        for k, v in out.items():
            print(f"  {k:<36} {v:8.3f} ms")


if __name__ == "__main__":
    main()

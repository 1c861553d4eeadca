"""Benchmark: where the time of one normal iteration goes, part by part, on one device.

Each part of NormalSolver's iteration (and the FFT backend's passes) is captured 20 times in a
CUDA graph and replayed; the table gives ms per call. On the CPU the parts are launched one by
one. Problem as bench_iteration.py (Hertz, paper pair, domain 4a).

Replayed back to back, a part finds its arrays in the GPU's L2 cache (50 MB on an H100: the
fields of a 1024 grid, 8 MB each, fit), which in a solve the transforms between the passes have
evicted. ``--cold`` (CUDA) precedes every call with a copy of 256 MB, which evicts them, and
subtracts the time of that copy measured alone: the parts as a solve meets them.

    python bench/iteration_parts.py --device cuda:0 --sizes 1024 2048 4096 [--cold]
"""

from __future__ import annotations

import argparse
import math
import os
import time

import warp as wp

from warpcontact.physics.geometry import Grid, Sphere
from warpcontact.kernels import normal as nk
from warpcontact.numerics.launch import Rows, Sums
from warpcontact.physics.materials import PAPER_PAIR
from warpcontact.numerics.model import ContactModel
from warpcontact.solvers import NormalSolver
from warpcontact.numerics.state import ContactState

R, DZ = 10e-6, 1.0e-10
A = math.sqrt(R * DZ)
REPEATS = 20
#: bytes the cold mode copies before each call (more than the L2 cache of any GPU here)
FLUSH_BYTES = 256 * 2**20
_flush_buffers = {}


def _flush(device):
    """Copy FLUSH_BYTES on ``device`` (evicts the L2 cache)."""
    key = str(device)
    if key not in _flush_buffers:
        half = FLUSH_BYTES // 2 // 8
        _flush_buffers[key] = (wp.zeros(half, dtype=wp.float64, device=device), wp.zeros(half, dtype=wp.float64, device=device))
    src, dst = _flush_buffers[key]
    wp.copy(dst, src)


def best_wall_time(device, fn, repeats: int, warm_up: bool = True) -> float:
    """Best wall time of fn() over ``repeats`` runs, the device synchronised around each, after one
    untimed warm-up run unless ``warm_up`` is False [s]."""
    if warm_up:
        fn()
    best = math.inf
    for _ in range(repeats):
        wp.synchronize_device(device)
        t0 = time.perf_counter()
        fn()
        wp.synchronize_device(device)
        best = min(best, time.perf_counter() - t0)
    return best


def _replay_ms(device, fn, best_of: int) -> float:
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
    return 1e3 * best_wall_time(device, run, best_of, warm_up=False) / REPEATS


def timed_ms(device, fn, best_of: int = 3, cold: bool = False) -> float:
    """ms per call of fn(): replayed from a graph of REPEATS calls on CUDA, best of ``best_of``;
    ``cold`` (CUDA): each call after an L2 flush, whose own time is subtracted."""
    if not (cold and device.is_cuda):
        return _replay_ms(device, fn, best_of)

    def flushed():
        _flush(device)
        fn()

    return _replay_ms(device, flushed, best_of) - _replay_ms(device, lambda: _flush(device), best_of)


def parts(n, device, dtype, cold=False, workers=None):
    m = ContactModel(PAPER_PAIR, Sphere(R, "paraboloid"), Grid(n, 4 * A), device=device, dtype=dtype)
    if workers:  # the CPU threads the passes and spectral products are split over
        m.launches.workers = m.operator.launches.workers = workers
    s = NormalSolver(m)
    st = ContactState(m)
    s.solve(st, DZ)  # a solved state: the sets are those of the last iterations
    fft, op = m.operator.fft, m.operator
    spec = op._buf[0]
    p, g, t, b = (a.flatten() for a in (st.pressure, st.gap, s.direction, s.interference))
    output = [fft.padded_output, fft.output_scale, n]
    out = {}

    def timed(fn):
        return timed_ms(m.device, fn, cold=cold)

    # the convolution as the iteration runs it: from the padded input, into the padded output
    fourier = s.fourier_step_sums  # the path the solver takes on this device
    out["transforms in (library)"] = timed(lambda: fft.transform_input(spec))
    if fourier:
        out["spectral product, (K t) . t"] = timed(lambda: op.normal_product(spec, s.sums, nk.S_RT))
    else:
        out["spectral product"] = timed(lambda: op.normal_product(spec))
    out["transforms out (library)"] = timed(lambda: fft.transform_to_output(spec))
    out["library forward + inverse"] = timed(lambda: fft.library_transforms(st.pressure, spec))
    out["spectral product alone"] = timed(lambda: op.normal_product(spec))
    if fft.name == "cupy":  # the two layouts of cuFFT side by side
        from warpcontact.fft.cupy_backend import CupyFFT

        other = CupyFFT(n, n, m.device, m.dtype, pruned=not fft.pruned)
        label = "pruned" if other.pruned else "2-D"
        out[f"library pair, {label} plans"] = timed(lambda: other.library_transforms(st.pressure, spec))
    # the solver's passes, launched as the solver launches them (on the CPU split by rows over the
    # model's threads)
    p, g, t, b = (Rows(a) for a in (p, g, t, b))
    output[0] = Rows(output[0])
    direction_in = [g, p, s._cap, s.sums, s.scalars, output[0], fft.output_scale, int(s.preconditioned), n]
    if s.preconditioned:  # what the preconditioner adds to an iteration
        out["precondition: normal_free_gap (pad)"] = timed(lambda: m.launches.launch_rows(
            nk.normal_free_gap, m.grid.shape, [g, p, s._cap, n], [Rows(fft.padded_input)]))
        out["precondition: pair, 1/K, g . M g"] = timed(lambda: op.normal_padded(s.sums, nk.S_G, inverse=True))
    if fourier:
        out["normal_direction_sum (+ pad, g . t)"] = timed(lambda: m.launch_reduce(
            nk.normal_direction_sum, direction_in, [t, fft.padded_input]))
    else:
        out["normal_direction (+ pad)"] = timed(lambda: m.launches.launch_rows(
            nk.normal_direction, m.grid.shape, direction_in, [t, Rows(fft.padded_input)]))
        out["normal_step_sums (reads output)"] = timed(lambda: m.launch_reduce(
            nk.normal_step_sums, [g, t, *output], [Sums(s.sums)]))
    # tau = 0 (g.t = 0, t.Kt = 1) on an iterate not converged (residual 1): the update runs its
    # whole path and leaves p and the gap as they are
    s.sums.assign([0.0, 1.0, 1.0, 0.0, 1.0] + [0.0] * (nk.N_SUMS - 5))
    out["normal_update (carries g)"] = timed(lambda: m.launch_reduce(
        nk.normal_update, [t, *output, b, s._cap, s.settings], [p, g, Sums(s.sums)]))
    out["normal_advance"] = timed(lambda: m.launch(
        nk.normal_advance, 1, [s.sums, s.settings, s.exact_every, s._column_norm, m.scalar(s.deferral)],
        [s.scalars, s.history, s.deferred, s.recompute, s.loop, s.refresh, s.inner_loop]))
    # what an iteration adds when the gap is made exact (a convolution of p and normal_gap)
    out["exact gap: normal_gap (reduce)"] = timed(lambda: m.launch_reduce(
        nk.normal_gap, [Rows(st.disp_z.flatten()), b, p, s._cap], [g, Sums(s.sums)]))
    out["exact gap: forward (pad + library)"] = timed(lambda: fft.forward(st.pressure, spec))
    out["exact gap: inverse (library + crop)"] = timed(lambda: fft.inverse(spec, st.disp_z))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--sizes", type=int, nargs="*", default=[1024, 2048])
    ap.add_argument("--dtype", default="float64")
    ap.add_argument("--cold", action="store_true", help="each call after an L2 flush (CUDA), its time subtracted")
    ap.add_argument("--workers", type=int, nargs="*", default=[0],
                    help="CPU: threads the passes are split over, each count in turn (0: one per CPU)")
    args = ap.parse_args()
    wp.config.quiet = True
    wp.init()
    device = wp.get_device(args.device)
    cold = " (cold: L2 flushed before each call)" if args.cold and device.is_cuda else ""
    print(f"# parts of a normal iteration{cold}; device {device} ({device.name}), {args.dtype}, {time.strftime('%Y-%m-%d')}")
    for n, workers in ((n, w) for n in args.sizes for w in (args.workers if device.is_cpu else [0])):
        out = parts(n, device, args.dtype, args.cold, workers)
        # an iteration: transforms in + product (on CUDA with (K t) . t) + transforms out + the
        # solver's passes (four; three on CUDA); an exact gap adds a padded forward, the product, a cropped inverse and normal_gap
        product = out.get("spectral product, (K t) . t", out.get("spectral product"))
        conv = out["transforms in (library)"] + product + out["transforms out (library)"]
        passes = sum(v for k, v in out.items() if k.startswith("normal_"))
        exact = (out["exact gap: forward (pad + library)"] + out["spectral product alone"]
                 + out["exact gap: inverse (library + crop)"] + out["exact gap: normal_gap (reduce)"])
        precondition = sum(v for k, v in out.items() if k.startswith("precondition"))
        threads = f" ({workers or os.cpu_count()} CPU threads)" if device.is_cpu else ""
        print(f"N = {n}{threads}: one convolution {conv:.3f} ms, the solver's passes {passes:.3f} ms, sum of an iteration "
              f"{conv + passes:.3f} ms; the preconditioner adds {precondition:.3f} ms, an exact gap {exact:.3f} ms "
              f"(library pair {out['library forward + inverse']:.3f} ms)")
        for k, v in out.items():
            print(f"  {k:<36} {v:8.3f} ms")


if __name__ == "__main__":
    main()

"""Benchmark: the set-up of a ContactModel (influence coefficients, their spectra, the device copy).

For each n and each place the influence coefficients are computed (``--influence host``: numpy on
the CPU's threads, ``influence_coefficients``; ``device``: Warp kernels on ``--device``,
``device_coefficients``; ``both``, the default: side by side in one run), seconds for the six
coefficient arrays alone, for the FFT backend's six spectra made from them, and for the whole
ContactModel (paper pair, Hertz sphere, ``ContactModel(..., influence=...)``), after one small
model per path has loaded the kernels; with ``both``, the largest difference between the two
paths' coefficients (relative to each kernel's largest). Where the FFT backend makes the spectra
its own way (cupy: cuFFT on the device), a line per n also times that step against the host
transform it replaced (scipy in float64, cast, copied to the device), on the same coefficients.

    python bench/setup_time.py --device cuda:0 --sizes 1024 4096 --influence both

``--batch``: instead, the batched solves' influence spectra of every size of ``--sizes`` together
(``fft.batch``: the normal, tangential and coupling spectra and the tangential preconditioner's,
what a ``BatchContactSolver`` of each size makes), made on the host (numpy) and on ``--device``
(``scaled_influence``: Warp's coefficients and cuFFT), alternated over ``--rounds`` rounds (the
caches cleared before each). Table 2 at n = 256 batches five grids:

    python bench/setup_time.py --device cuda:0 --batch --sizes 256 300 315 360 588
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np
import warp as wp

from warpcontact.fft.base import FFTBackend
from warpcontact.physics.geometry import Grid, Sphere
from warpcontact.physics.influence import KERNELS, SPECTRUM_PARTS, device_coefficients, influence_coefficients
from warpcontact.physics.materials import PAPER_PAIR
from warpcontact.numerics.model import ContactModel


PATHS = {"host": ["host"], "device": ["device"], "both": ["host", "device"]}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--sizes", type=int, nargs="+", default=[1024, 2048])
    ap.add_argument("--dtype", default="float64")
    ap.add_argument("--influence", choices=list(PATHS), default="both",
                    help="where the influence coefficients are computed: host (numpy), device (Warp kernels), both")
    ap.add_argument("--batch", action="store_true",
                    help="the batched solves' spectra of all the sizes, on the host against the device")
    ap.add_argument("--rounds", type=int, default=3, help="--batch: host, device alternated this many times")
    args = ap.parse_args()
    wp.config.quiet = True
    wp.init()
    if args.batch:
        batch_spectra(args.sizes, args.device, args.rounds)
        return
    sphere = Sphere(10e-6, "paraboloid")
    paths = PATHS[args.influence]
    for path in paths:  # kernels loaded (and compiled) before anything is timed
        ContactModel(PAPER_PAIR, sphere, Grid(64, 1e-7), device=args.device, dtype=args.dtype, influence=path)
    device = wp.get_device(args.device)
    print(f"# model set-up, {args.dtype}, {args.device} ({device.name}), {os.cpu_count()} CPUs, "
          f"{time.strftime('%Y-%m-%d')}")
    print("| n | influence | coefficients | six spectra | whole model |" + (" device vs host |" if len(paths) > 1 else ""))
    print("|---|---|---|---|---|" + ("---|" if len(paths) > 1 else ""), flush=True)
    notes = []
    for n in args.sizes:
        dx = 1e-7 / n
        for path in paths:
            t_coefficients, t_spectra = coefficients_and_spectra(path, n, dx, args.device, args.dtype)
            t0 = time.perf_counter()
            model = ContactModel(PAPER_PAIR, sphere, Grid(n, 1e-7), device=args.device, dtype=args.dtype,
                                 influence=path)
            wp.synchronize_device(model.device)
            t_model = time.perf_counter() - t0
            line = (f"| {n} | {path} | {t_coefficients:.3f} s | {t_spectra:.3f} s ({model.fft_name}) | "
                    f"{t_model:.3f} s |")
            if len(paths) > 1:
                line += f" {largest_difference(n, dx, device):.1e} |" if path == "device" else " |"
            fft = model.operator.fft
            if path == "host" and type(fft).influence_spectra is not FFTBackend.influence_spectra:
                notes.append(f"n {n}:" + spectra_side_by_side(model, n))
            del model
            print(line, flush=True)
    for note in notes:
        print(note)


def batch_spectra(sizes, device, rounds: int):
    """Seconds to make the batched solves' spectra of every size in ``sizes``, on the host and on
    ``device`` alternated, after a first round of each that loads the kernels and the plans."""
    from warpcontact.fft import batch

    def made_on(where) -> float:
        for cached in (batch.normal_influence, batch.tangential_influence, batch.tangential_inverse_blocks):
            cached.cache_clear()
        wp.synchronize()
        t0 = time.perf_counter()
        for n in sizes:
            batch.normal_influence(n, where)
            batch.tangential_influence(PAPER_PAIR, n, where)
            batch.tangential_inverse_blocks(PAPER_PAIR, n, True, where)
        wp.synchronize()
        return time.perf_counter() - t0

    places = ["cpu"] + ([wp.get_device(device).alias] if wp.get_device(device).is_cuda else [])
    for where in places:
        made_on(where)  # kernels and plans loaded
    print(f"# the batched solves' influence spectra of n = {', '.join(map(str, sizes))}, {os.cpu_count()} CPUs")
    print("| round | " + " | ".join(f"made on {w}" for w in places) + " |")
    print("|---|" + "---|" * len(places))
    for r in range(rounds):
        print(f"| {r + 1} | " + " | ".join(f"{made_on(w):.3f} s" for w in places) + " |", flush=True)


def coefficients_and_spectra(path: str, n: int, dx: float, device, dtype) -> tuple[float, float]:
    """Seconds for the six coefficient arrays on ``path`` and for the FFT backend's six spectra
    made from them (a fresh backend of the model's kind; the arrays as the operator hands them)."""
    from warpcontact.fft import make_fft

    fft = make_fft("auto", n, n, device, getattr(wp, dtype))
    out, scratch = fft.alloc_influence(len(KERNELS)), fft.alloc_spectra(1)[0]
    wp.synchronize_device(fft.device)
    t0 = time.perf_counter()
    if path == "host":
        table = influence_coefficients(PAPER_PAIR, n, n, dx, dx)
        arrays = [table[k] for k in KERNELS]
    else:
        arrays = [a for _, a in device_coefficients(PAPER_PAIR, n, n, dx, dx, fft.device)]
        if not getattr(fft, "takes_device_coefficients", False):
            arrays = [a.numpy() for a in arrays]  # the operator's hand-over to a host transform
        wp.synchronize_device(fft.device)
    t_coefficients = time.perf_counter() - t0
    t0 = time.perf_counter()
    fft.influence_spectra(iter(arrays), [SPECTRUM_PARTS[k] for k in KERNELS], out, scratch)
    wp.synchronize_device(fft.device)
    return t_coefficients, time.perf_counter() - t0


def largest_difference(n: int, dx: float, device) -> float:
    """max over kernels of max |device - host| / max |host| of the six coefficient arrays."""
    host = influence_coefficients(PAPER_PAIR, n, n, dx, dx)
    worst = 0.0
    for k, a in device_coefficients(PAPER_PAIR, n, n, dx, dx, device):
        worst = max(worst, float(np.abs(a.numpy() - host[k]).max() / np.abs(host[k]).max()))
        del host[k]
    return worst


def spectra_side_by_side(model, n) -> str:
    """The backend's influence_spectra against the host path (FFTBackend's), same coefficients."""
    fft, out, scratch = model.operator.fft, model.operator.influence, model.operator._buf[0]
    parts = [SPECTRUM_PARTS[k] for k in KERNELS]
    coefficients = influence_coefficients(PAPER_PAIR, n, n, 1e-8, 1e-8)
    arrays = [coefficients[k] for k in KERNELS]
    times, kept = {}, {}
    for label, method in (("backend", type(fft).influence_spectra), ("host", FFTBackend.influence_spectra)):
        wp.synchronize_device(model.device)
        t0 = time.perf_counter()
        method(fft, iter(arrays), parts, out, scratch)
        wp.synchronize_device(model.device)
        times[label] = time.perf_counter() - t0
        kept[label] = [out[i].numpy() for i in (0, 4)]
    diff = max(np.abs(a - b).max() / np.abs(b).max() for a, b in zip(kept["backend"], kept["host"]))
    return (f" six spectra from the host coefficients: {fft.name} {times['backend']:6.2f} s, host float64 + copy {times['host']:6.2f} s "
            f"({times['host'] / times['backend']:.1f}x), largest difference {diff:.1e} of the largest entry")


if __name__ == "__main__":
    main()

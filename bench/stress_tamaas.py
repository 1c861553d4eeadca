"""Subsurface stress of a Hertz pressure: warpcontact against Tamaas, side by side (time and agreement).

The same problem for both: a Hertz pressure p0 sqrt(1 - r^2/a^2) sampled at the same points (our
cell centres; Tamaas's grid nodes are those points shifted, which a periodic code does not see),
nu = 0.3, on an n x n grid of side ``--size-in-a`` a, at ``--layers`` depths equally spaced down to
1.5 a (Tamaas: the nodes of its volume grid, linspace(0, 1.5 a, layers + 1), the surface dropped).

- warpcontact: ``stress.SubsurfaceStress`` (piecewise-constant tractions on cells, exact cell
  integrals, DC-FFT: no periodic images), on ``--device`` in ``--dtype``; set-up (buffers, FFT
  plans) timed apart from an evaluation (the second of two, the kernels compiled).
- Tamaas (``pip install tamaas``, CPU): a ``volume_2d`` model, ``boussinesq_gradient`` then
  ``hooke`` (the tractions sampled at nodes, periodic), then its ``von_mises`` operator.

Printed per n: times [s]; the largest difference of the six stress components and of von Mises
between the two codes below the contact (|x|, |y| <= a, depths >= 0.25 a, away from the
domain's edges, where a periodic code's images weigh as much as the load) [p0]; each code's
largest error on the axis against Johnson's closed form (eq. 3.45) [p0]; each code's von Mises
maximum [p0] and its depth [a] against Hertz's (0.620 at 0.481 a). The periodic images of Tamaas's domain (``--size-in-a`` a
wide) account for most of its difference from the closed form; run with a larger
``--size-in-a`` to see them shrink.

    python bench/stress_tamaas.py --n 64 128
    python bench/stress_tamaas.py --n 256 512 1024 2048 --device cuda --skip-tamaas   # GPU times

"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time

import numpy as np

from warpcontact.numerics import stress as st
from warpcontact.numerics import stress_reference as sr
from warpcontact.physics.geometry import Grid
from warpcontact.physics.materials import Material, MaterialPair

A, P0, NU = 1e-6, 1e9, 0.3
DEPTH_IN_A = 1.5
#: Tamaas's order of the six components (found by matching ours on this field: the off-diagonal
#: ones xy, xz, yz in that order, each times sqrt(2): Mandel's notation)
TAMAAS_ORDER = ("sigma_xx", "sigma_yy", "sigma_zz", "sigma_xy", "sigma_xz", "sigma_yz")


def hertz_pressure(grid):
    X, Y = grid.mesh()
    return P0 * np.sqrt(np.clip(1.0 - (X**2 + Y**2) / A**2, 0.0, None))


def ours(n, size_in_a, layers, device, dtype, time_only=False):
    """(timings, volume fields by name (layers, n, n) [Pa], axis index) of warpcontact; with
    ``time_only`` (timings, None, axis index): no volume kept (what ``warpcontact stress`` holds),
    the kernels loaded on a small grid, one timed evaluation."""
    import warp as wp

    mat = Material(E=100e9, nu=NU)
    grid = Grid(n, size_in_a * A)
    depths = np.arange(1, layers + 1) * (DEPTH_IN_A * A / layers)
    p = hertz_pressure(grid)
    if time_only:
        small = Grid(32, size_in_a * A)
        q = hertz_pressure(small)
        st.SubsurfaceStress(MaterialPair(mat, mat), small, depths, device=device, dtype=dtype).evaluate(q, 0 * q, 0 * q)
    t0 = time.perf_counter()
    ev = st.SubsurfaceStress(MaterialPair(mat, mat), grid, depths, device=device, dtype=dtype, volume=not time_only)
    wp.synchronize_device(ev.device)
    setup = time.perf_counter() - t0
    ev.volume = False  # the timed evaluation copies sections only, as the command does
    if time_only:
        t0 = time.perf_counter()
        ev.evaluate(p, 0 * p, 0 * p)
        wp.synchronize_device(ev.device)
        return {"setup_s": setup, "evaluate_s": time.perf_counter() - t0}, None, n // 2
    ev.evaluate(p, 0 * p, 0 * p)  # compiles the kernels
    t0 = time.perf_counter()
    ev.evaluate(p, 0 * p, 0 * p)
    wp.synchronize_device(ev.device)
    run = time.perf_counter() - t0
    ev.volume = True
    res = ev.evaluate(p, 0 * p, 0 * p)
    return {"setup_s": setup, "evaluate_s": run}, res.bodies["flat"].volume, n // 2


def tamaas(n, size_in_a, layers):
    """(timings, volume fields by name (layers, n, n) [Pa]) of Tamaas, or None when not installed."""
    try:
        import tamaas as tm
    except ImportError:
        return None
    grid = Grid(n, size_in_a * A)
    L = size_in_a * A
    model = tm.ModelFactory.createModel(tm.model_type.volume_2d, [DEPTH_IN_A * A, L, L], [layers + 1, n, n])
    model.E, model.nu = 100e9, NU
    tm.ModelFactory.registerVolumeOperators(model)
    traction = np.zeros((n, n, 3))
    traction[..., 2] = hertz_pressure(grid).T  # Tamaas's arrays are [x, y]; ours [y, x]
    gradient = np.zeros((layers + 1, n, n, 6))
    stress = np.zeros_like(gradient)
    vm = np.zeros((layers + 1, n, n, 1))
    t0 = time.perf_counter()
    model.operators["boussinesq_gradient"](traction, gradient)
    model.operators["hooke"](gradient, stress)
    model.operators["von_mises"](stress, vm)
    run = time.perf_counter() - t0
    # Tamaas writes symmetric tensors in Mandel's notation: the off-diagonal components times sqrt(2)
    mandel = np.array([1.0, 1.0, 1.0, *(3 * [1.0 / math.sqrt(2.0)])])
    out = {name: stress[1:, :, :, k].transpose(0, 2, 1) * mandel[k] for k, name in enumerate(TAMAAS_ORDER)}
    out["von_mises"] = vm[1:, :, :, 0].transpose(0, 2, 1)
    return {"evaluate_s": run, "version": tm.__version__}, out


def axis_error(fields, i, layers):
    """Largest error on the axis cell (i, i) against Johnson's eq. 3.45 [p0]."""
    z = np.arange(1, layers + 1) * (DEPTH_IN_A / layers)
    ref = sr.hertz_axis_stress(z, NU)
    return max(float(np.max(np.abs(fields[f][:, i, i] / P0 - ref[r])))
               for f, r in (("sigma_zz", "sigma_zz"), ("sigma_xx", "sigma_rr"), ("sigma_yy", "sigma_rr")))


def vm_max(fields, layers):
    """(largest von Mises [p0], its depth [a])."""
    per_depth = fields["von_mises"].reshape(layers, -1).max(axis=1)
    k = int(np.argmax(per_depth))
    return float(per_depth[k] / P0), (k + 1) * DEPTH_IN_A / layers


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, nargs="+", default=[64, 128])
    ap.add_argument("--layers", type=int, default=32)
    ap.add_argument("--size-in-a", type=float, default=4.0)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--dtype", default="float64", choices=("float64", "float32"))
    ap.add_argument("--skip-tamaas", action="store_true", help="time warpcontact only (GPU sizes)")
    ap.add_argument("--json", action="store_true", help="print the records as JSON")
    ap.add_argument("--time-only", action="store_true",
                    help="time one evaluation without keeping the volume (no accuracy columns): grids whose "
                         "volume does not fit in memory")
    args = ap.parse_args(argv)
    records = []
    ref_value, ref_depth = sr.hertz_von_mises_max(NU)
    print(f"Hertz, nu = {NU}: von Mises max {ref_value:.4f} p0 at {ref_depth:.4f} a; {args.layers} depths to "
          f"{DEPTH_IN_A} a; domain {args.size_in_a} a; warpcontact on {args.device} ({args.dtype})")
    have_tamaas = False
    for n in args.n:
        t_ours, f_ours, i = ours(n, args.size_in_a, args.layers, args.device, args.dtype, args.time_only)
        if args.time_only:
            records.append({"n": n, "a_in_cells": n / args.size_in_a, "warpcontact": t_ours})
            print(f"n = {n:5d} (a = {n / args.size_in_a:6.1f} cells): warpcontact set-up {t_ours['setup_s']:.3f} s, "
                  f"evaluate {t_ours['evaluate_s']:.3f} s (timing only)", flush=True)
            continue
        rec = {"n": n, "a_in_cells": n / args.size_in_a, "warpcontact": t_ours,
               "warpcontact_axis_error_p0": axis_error(f_ours, i, args.layers),
               "warpcontact_vm_max": vm_max(f_ours, args.layers)}
        tam = None if args.skip_tamaas else tamaas(n, args.size_in_a, args.layers)
        if tam is not None:
            have_tamaas = True
            t_tam, f_tam = tam
            rec["tamaas"] = t_tam
            rec["tamaas_axis_error_p0"] = axis_error(f_tam, i, args.layers)
            rec["tamaas_vm_max"] = vm_max(f_tam, args.layers)
            half = int(round(n / args.size_in_a))  # a, in cells
            near = (slice(int(math.ceil(0.25 * args.layers / DEPTH_IN_A)) - 1, None),
                    slice(i - half, i + half + 1), slice(i - half, i + half + 1))
            rec["difference_p0"] = {f: float(np.max(np.abs(f_ours[f][near] - f_tam[f][near])) / P0)
                                    for f in (*st.COMPONENTS, "von_mises")}
        records.append(rec)
        line = (f"n = {n:5d} (a = {n / args.size_in_a:6.1f} cells): warpcontact set-up {t_ours['setup_s']:.3f} s, "
                f"evaluate {t_ours['evaluate_s']:.3f} s, axis error {rec['warpcontact_axis_error_p0']:.1e} p0, "
                f"vm max {rec['warpcontact_vm_max'][0]:.4f} p0 at {rec['warpcontact_vm_max'][1]:.3f} a")
        if tam is not None:
            diff = max(rec["difference_p0"].values())
            line += (f"\n            Tamaas {t_tam['version']} evaluate {t_tam['evaluate_s']:.3f} s, axis error "
                     f"{rec['tamaas_axis_error_p0']:.1e} p0, vm max {rec['tamaas_vm_max'][0]:.4f} p0 at "
                     f"{rec['tamaas_vm_max'][1]:.3f} a; largest difference between the codes below the contact "
                     f"{diff:.1e} p0")
        print(line, flush=True)
    if not have_tamaas and not args.skip_tamaas:
        print("Tamaas is not installed here (pip install tamaas): warpcontact's side only")
    if args.json:
        print(json.dumps(records, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())

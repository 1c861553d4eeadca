"""Frictionless, adhesionless contact of a rough surface: warpcontact against Tamaas on the same heights.

    pip install --target DIR tamaas        # Tamaas (Frerot, Anciaux & Molinari), not a dependency
    PYTHONPATH=DIR python validation/tamaas_rough.py --n 128 --steps 6

A rigid rough indenter (a synthetic self-affine surface, ``warpcontact.rough_surface``: Hurst 0.8,
rms slope 0.1 by default, wavelengths down to 4 pixels) pressed into an elastic half-space
(E = 100 GPa, nu = 0.3), the domain of n x n cells non-periodic in both codes: warpcontact solves
its load path by rigid approaches (DC-FFT, cells of uniform pressure); Tamaas solves each state at
the same mean pressure (its Polonsky-Keer-Rey solver, its non-periodic DC-FFT Boussinesq operator
``ModelFactory.registerNonPeriodic``, tolerance 1e-12). Per state: the force, both codes' contact
areas (cells with p > 0) and their difference, the largest pressure, and the rms difference of the
pressure fields relative to their rms; the contact patches (warpcontact's summary); and kappa =
(A / A0) / (p / (E* h'_rms)), the area-load slope Persson's theory puts at sqrt(8 / pi) = 1.60 at
small loads (A0 the domain, p the mean pressure, h'_rms the surface's rms slope). ``--out DIR``
writes the table as table.md and the rows as result.json.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

E, NU = 100e9, 0.3


def rough_case(folder: Path, n: int, pixel: float, hurst: float, rms_slope: float, seed: int, depth: float,
               steps: int) -> Path:
    """The case: the rough heights as a rigid body's height map over an elastic flat."""
    import warpcontact as wc

    heights = wc.rough_surface(n, n * pixel, hurst, rms_slope=rms_slope, short_cutoff=4 * pixel, seed=seed)
    np.save(folder / "rough.npy", heights)
    path = folder / "case.toml"
    path.write_text(f'[sphere]\nprofile = "height_map"\nheight_map = "rough.npy"\npixel_size = {pixel!r}\nrigid = true\n\n'
                    f"[flat]\nE = {E!r}\nnu = {NU!r}\n\n[grid]\nn = {n}\nsize = \"map\"\n\n"
                    f"[load]\ndelta_z = {depth!r}\nsteps = {steps}\n")
    return path


def tamaas_pressure(gap0: np.ndarray, size: float, mean_pressure: float) -> np.ndarray:
    """Tamaas's pressure [Pa] on the rigid surface whose gap before deformation is ``gap0`` [m]
    ([row = y, column = x], as warpcontact's fields), at ``mean_pressure`` [Pa] over the domain."""
    import tamaas as tm

    n = gap0.shape[0]
    model = tm.ModelFactory.createModel(tm.model_type.basic_2d, [size, size], [n, n])
    model.E, model.nu = E, NU
    tm.ModelFactory.registerNonPeriodic(model, "dcfft")
    surface = np.ascontiguousarray(-(gap0 - gap0.min()))  # Tamaas's heights point towards the other body
    solver = tm.PolonskyKeerRey(model, surface, 1e-12, tm.PolonskyKeerRey.pressure, tm.PolonskyKeerRey.pressure)
    solver.setIntegralOperator("dcfft")
    solver.setMaxIterations(20000)
    solver.solve(mean_pressure)
    return np.array(model.traction, dtype=np.float64).reshape(n, n)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=128)
    ap.add_argument("--pixel", type=float, default=1e-9, help="cell side [m]")
    ap.add_argument("--hurst", type=float, default=0.8)
    ap.add_argument("--rms-slope", type=float, default=0.1)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--depth", type=float, default=None, help="the deepest approach [m] (default: 1.5 rms heights)")
    ap.add_argument("--steps", type=int, default=6)
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)
    try:
        import tamaas  # noqa: F401
    except ImportError:
        sys.exit("tamaas is not installed: pip install --target DIR tamaas, then PYTHONPATH=DIR")
    import warnings

    import warpcontact as wc
    from warpcontact.records.case import load_case

    folder = Path(tempfile.mkdtemp(prefix="tamaas_rough_"))
    heights_probe = wc.rough_surface(args.n, args.n * args.pixel, args.hurst, rms_slope=args.rms_slope,
                                     short_cutoff=4 * args.pixel, seed=args.seed)
    depth = args.depth if args.depth is not None else 1.5 * float(heights_probe.std())
    case = load_case(rough_case(folder, args.n, args.pixel, args.hurst, args.rms_slope, args.seed, depth, args.steps))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the plausibility notes of a rigid body; the table says what counts
        result = wc.solve(case, fields="all")
    size = case.grid.size
    dA = case.grid.cell_area
    gap0 = case.sphere.initial_gap(case.grid)  # the rigid surface's gap before deformation [m]
    # Persson's area-load relation at small loads, A / A0 = kappa p / (E* h'_rms), kappa = sqrt(8 / pi)
    # (Persson 2001; numerical studies give 1.6-2.2, rising as the contacts resolve fewer cells)
    slope_rms = wc.surface_statistics(gap0, case.grid.dx)["rms_slope"]
    e_star = E / (1.0 - NU * NU)
    rows = []
    for k, s in enumerate(result.states):
        f = result.fields[k]
        ours = f["pressure"]
        force = s["force"]["z"]
        if force <= 0:
            continue
        theirs = tamaas_pressure(gap0, size, force / (size * size))
        a_ours, a_theirs = int((ours > 0).sum()), int((theirs > 0).sum())
        rms = float(np.sqrt(np.mean(ours ** 2)))
        rows.append({"delta_z": s["delta"]["z"], "force": force, "area": a_ours * dA, "area_tamaas": a_theirs * dA,
                     "area_difference": (a_ours - a_theirs) / a_theirs,
                     "force_tamaas": float(theirs.sum() * dA),
                     "max_pressure": float(ours.max()), "max_pressure_tamaas": float(theirs.max()),
                     "pressure_rms_difference": float(np.sqrt(np.mean((ours - theirs) ** 2))) / rms,
                     "patches": s.get("contact_patches"), "converged": s["converged"],
                     "kappa": (a_ours / ours.size) / (force / (size * size) / (e_star * slope_rms))})
    lines = ["| delta_z [nm] | F_z [nN] | contact area [nm^2]: warpcontact / Tamaas | difference | p max [GPa]: "
             "warpcontact / Tamaas | pressure rms difference | patches | kappa |", "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['delta_z'] * 1e9:.3f} | {r['force'] * 1e9:.4g} | {r['area'] * 1e18:.1f} / "
                     f"{r['area_tamaas'] * 1e18:.1f} | {100 * r['area_difference']:+.2f} % | "
                     f"{r['max_pressure'] / 1e9:.3f} / {r['max_pressure_tamaas'] / 1e9:.3f} | "
                     f"{r['pressure_rms_difference']:.1e} | {r['patches']} | {r['kappa']:.2f} |")
    print("\n".join(lines))
    print(f"\n(n = {args.n}, cells of {args.pixel:g} m, Hurst {args.hurst}, rms slope {args.rms_slope}, seed {args.seed}; "
          f"rms height {heights_probe.std():.3g} m)")
    if args.out:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        (out / "table.md").write_text("\n".join(lines) + "\n")
        (out / "result.json").write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()

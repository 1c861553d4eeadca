"""Maugis-Dugdale pull-off against the grid: its convergence table.

    python validation/md_convergence.py [--lam 2] [--n 96 192] [--smoothing 0.3] [--ramps both centred]
                                   [--domain 5] [--path cli|test] [--out out/md_convergence]
                                   [--device cuda:0]
    python validation/md_convergence.py --continuum 1200 [--lam 2] [--smoothing 0.3] [--ramps both centred]

The Dugdale law at Maugis parameter lambda (R = 1 um, w = 0.5 J/m^2, the paper's pair, float64,
on DEVICE, the CPU by default), domain DOMAIN x a0 (a0: JKR's contact radius at zero load) on n x n cells, through
``warpcontact.studies.approach_retract`` with the refined pull-off. ``--path cli`` is ``warpcontact
pull-off``'s default path (20 steps each way from -2 ranges to delta_z = 2 h_0 and back to
-4 ranges, extended until the contact breaks); ``--path test`` the tests' (12 steps each way,
-h_0 -> 2 h_0 -> -3 h_0). Prints one row per (lambda, smoothing, ramps, n): the refined pull-off
(the most tensile state), the parabola's lowest value through the substeps (``fit``), the
substeps' largest distance from it (``scatter``: the grid's sawtooth), the substeps' mean and
range, Maugis-Dugdale's value and the differences, cell_softening, the Dugdale zone's width at
pull-off in cells (Maugis-Dugdale's), whether every state converged and the time. Each row's
whole result (curve and substeps) goes to OUT/<tag>.json.

``--continuum N``: the same laws without the grid: the axisymmetric problem on N rings of
constant traction out to 1.2 a0 (the exact displacement of a uniformly loaded annulus, Johnson
1985 section 3.2, at the rings' midpoints), the energy 1/2 u.K u + sum A phi(h) minimised under
h >= 0 (L-BFGS-B, then Newton on the active set) along the same retraction in steps of 0.05 h_0,
the pull-off the parabola through the lowest three. This separates the ramps' own change of the
pull-off (the law's, what remains as the grid is refined) from the grid's. About 15 s at N = 600,
4 min at 1200 (2 CPU cores); the sharp law (smoothing 0) traps the zone's edge between rings and
is not resolved this way.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time

import numpy as np

from warpcontact.physics.adhesion import Dugdale, cell_softening
from warpcontact.studies.approach_retract import approach_retract
from warpcontact.physics.geometry import Grid, Sphere
from warpcontact.physics.materials import PAPER_PAIR
from warpcontact.numerics.model import ContactModel
from warpcontact.physics.reference import _md_path, _md_state, maugis_dugdale_pull_off, maugis_dugdale_scales
from warpcontact.solvers.contact import ContactSolver

R, W = 1e-6, 0.5
E_STAR = PAPER_PAIR.E_star
A0 = (9 * math.pi * W * R**2 / (2 * E_STAR)) ** (1 / 3)  # JKR contact radius at zero load


def sigma_0_at(lam: float) -> float:
    return lam / (9 * R / (2 * math.pi * W * E_STAR**2)) ** (1 / 3)


def md_radii(lam: float) -> tuple[float, float]:
    """Maugis-Dugdale's contact and cohesive-zone radii [m] at the load-control pull-off."""
    st = _md_state(lam, _md_path(lam).u_pull_off_load)
    unit = maugis_dugdale_scales(E_STAR, R, W, sigma_0_at(lam))["radius"]
    return float(st["A"][0]) * unit, float(st["C"][0]) * unit


def run(lam: float, n: int, smoothing: float, ramps: str | None, domain: float, path: str,
        device: str = "cpu") -> dict:
    sigma_0 = sigma_0_at(lam)
    law = Dugdale(sigma_0=sigma_0, h_0=W / sigma_0, smoothing=smoothing, ramps=ramps)
    model = ContactModel(PAPER_PAIR, Sphere(R), Grid(n, domain * A0), device=device)
    solver = ContactSolver(model, None, adhesion=law)
    t0 = time.perf_counter()
    if path == "cli":
        r = approach_retract(model, solver, -2.0 * law.range, 2.0 * law.h_0, -4.0 * law.range, 20, extend=True)
    else:
        r = approach_retract(model, solver, -law.h_0, 2.0 * law.h_0, -3.0 * law.h_0, 12)
    elapsed = time.perf_counter() - t0
    unit = math.pi * R * W
    ref = maugis_dugdale_pull_off(lam)
    sub = [c["force"]["z"] / unit for c in r["refined"] if c.get("purpose") == "pull-off"]
    a, c = md_radii(lam)
    dx = model.grid.dx
    row = {
        "lambda": lam, "n": n, "smoothing": smoothing, "ramps": ramps, "domain_a0": domain,
        "path": path, "device": device, "cell_softening": cell_softening(law, model),
        "pull_off": r["pull_off_force"] / unit,
        "fit": (r["pull_off_fit"] / unit) if r["pull_off_fit"] is not None else None,
        "scatter": (r["pull_off_scatter"] / unit) if r["pull_off_scatter"] is not None else None,
        "substeps_mean": float(np.mean(sub)) if sub else None,
        "substeps_range": float(np.ptp(sub)) if sub else None,
        "md": ref, "a_cells": a / dx, "c_cells": c / dx, "converged": r["converged"], "elapsed_s": elapsed,
        "states": len(r["curve"]) + len(r["refined"]),
    }
    row["diff"] = row["pull_off"] / ref - 1.0
    row["diff_fit"] = row["fit"] / ref - 1.0 if row["fit"] is not None else None
    row["result"] = {k: v for k, v in r.items() if k in ("curve", "refined", "contact_events", "pull_off_delta_z")}
    return row


# -- the axisymmetric continuum -------------------------------------------------------------------


def ring_influence(n_rings: int, r_max: float):
    """(ring midpoints [m], compliance G [m/Pa]: displacement at midpoint i of unit pressure on
    ring j, ring areas [m^2]) for n_rings rings of equal width out to r_max."""
    from scipy.special import ellipe, ellipk

    edges = np.linspace(0.0, r_max, n_rings + 1)
    rc = 0.5 * (edges[1:] + edges[:-1])

    def disc(b):  # both surfaces' displacement x E* of unit pressure on the disc r < b
        out = np.empty_like(rc)
        inside = rc <= b
        out[inside] = 4.0 * b / math.pi * ellipe((rc[inside] / b) ** 2)
        k2 = (b / rc[~inside]) ** 2
        out[~inside] = 4.0 * rc[~inside] / math.pi * (ellipe(k2) - (1.0 - k2) * ellipk(k2))
        return out

    discs = np.stack([disc(b) for b in edges[1:]], axis=1)
    G = discs.copy()
    G[:, 1:] -= discs[:, :-1]
    return rc, G / E_STAR, math.pi * (edges[1:] ** 2 - edges[:-1] ** 2)


def law_numpy(h, law: Dugdale):
    """(potential, tension) of a Dugdale law at gaps h [m] (kernels/adhesive.py's, in SI)."""
    s0, h0, c = law.sigma_0, law.h_0, law.smoothing * law.h_0
    if law.ramps == "centred":
        lo = h0 - 0.5 * c
        f = np.clip(h - lo, 0.0, c)
        return s0 * (np.minimum(h, lo) + f - f * f / (2 * c)) - s0 * h0, s0 * np.clip((h0 + 0.5 * c - h) / c, 0, 1)
    r = np.minimum(h, c)
    p = np.clip(h - c, 0.0, h0 - c)
    f = np.clip(h - h0, 0.0, c)
    return (s0 * (r * r / (2 * c) + p + f - f * f / (2 * c)) - s0 * h0,
            s0 * np.clip(np.minimum(h / c, (h0 + c - h) / c), 0, 1))


def continuum_pull_off(lam: float, smoothing: float, ramps: str, n_rings: int) -> dict:
    """The axisymmetric pull-off of the law (module docstring)."""
    from scipy.optimize import minimize

    if not smoothing > 0:
        raise SystemExit("--continuum needs smoothing > 0 (the sharp law traps the zone's edge between rings)")
    sigma_0 = sigma_0_at(lam)
    law = Dugdale(sigma_0=sigma_0, h_0=W / sigma_0, smoothing=smoothing, ramps=ramps)
    rc, G, area = ring_influence(n_rings, 1.2 * A0)
    K = np.linalg.inv(G) * area[:, None]
    K = 0.5 * (K + K.T)  # the elastic energy 1/2 u.K u (K symmetric to the rings' quadrature)
    g0 = rc**2 / (2 * R)
    scale = law.sigma_0 * law.h_0 * area.sum()
    h0 = law.h_0
    eps = 1e-9 * h0

    def solve(delta, u):
        off = g0 - delta

        def energy(x):
            phi, t = law_numpy(np.maximum(off + x, 0.0), law)
            Kx = K @ x
            return (0.5 * x @ Kx + area @ phi) / scale, (Kx + area * t) / scale

        u = minimize(energy, np.maximum(u, -off), jac=True, method="L-BFGS-B", bounds=[(-o, None) for o in off],
                     options={"maxiter": 200000, "maxfun": 400000, "ftol": 1e-16, "gtol": 1e-13, "maxcor": 30}).x
        for _ in range(30):  # Newton on the active set: the law is piecewise linear
            h = np.maximum(off + u, 0.0)
            g = K @ u + area * law_numpy(h, law)[1]
            held = (off + u <= 1e-12 * h0) & (g > 0)
            k = (law_numpy(h + eps, law)[1] - law_numpy(np.maximum(h - eps, 0.0), law)[1]) / (2 * eps)
            M = K + np.diag(area * k)
            M[held] = 0.0
            M[held, np.flatnonzero(held)] = 1.0
            rhs = -g
            rhs[held] = -off[held] - u[held]
            u = np.maximum(u + np.linalg.solve(M, rhs), -off)
            h = np.maximum(off + u, 0.0)
            g = K @ u + area * law_numpy(h, law)[1]
            free = ~((h <= 1e-12 * h0) & (g > 0))
            if np.abs(g[free]).max() < 1e-11 * law.sigma_0 * area.max():
                break
        return u, (K @ u) / area

    unit = math.pi * R * W
    u = np.zeros_like(rc)
    F = []
    t0 = time.perf_counter()
    for delta in list(np.linspace(-0.5 * h0, 2 * h0, 6)) + list(np.arange(2 * h0, -4 * h0, -0.05 * h0)):
        u, p = solve(delta, u)
        F.append((p * area).sum() / unit)
        if not (np.maximum(g0 - delta + u, 0.0) == 0.0).any() and delta < 0:
            break
    F = np.array(F[6:])
    k = int(np.argmin(F))
    best = F[k]
    if 0 < k < len(F) - 1:
        y0, y1, y2 = F[k - 1:k + 2]
        if y0 - 2 * y1 + y2 > 0:
            best = y1 - (y2 - y0) ** 2 / (8 * (y0 - 2 * y1 + y2))
    ref = maugis_dugdale_pull_off(lam)
    return {"lambda": lam, "smoothing": smoothing, "ramps": ramps, "rings": n_rings, "pull_off": float(best),
            "md": ref, "diff": float(best / ref - 1.0), "elapsed_s": time.perf_counter() - t0}


HEADER = (f"{'lambda':>6} {'n':>4} {'smooth':>6} {'ramps':>8} {'dom':>4} {'soft':>5} {'zone':>5} {'pull-off':>8} "
          f"{'diff':>7} {'fit':>8} {'diff':>7} {'scatter':>7} {'sub mean':>8} {'sub rng':>7} {'MD':>8} conv  time")


def line(row: dict) -> str:
    fmt = lambda v, f: "-" if v is None else format(v, f)
    return (f"{row['lambda']:>6g} {row['n']:>4d} {row['smoothing']:>6g} {row['ramps']:>8} {row['domain_a0']:>4g} "
            f"{row['cell_softening']:>5.2f} {row['c_cells'] - row['a_cells']:>5.1f} {row['pull_off']:>8.4f} "
            f"{100 * row['diff']:>+6.2f}% {fmt(row['fit'], '8.4f')} {fmt(row['diff_fit'] and 100 * row['diff_fit'], '+6.2f')}% "
            f"{fmt(row['scatter'], '7.4f')} {fmt(row['substeps_mean'], '8.4f')} {fmt(row['substeps_range'], '7.4f')} "
            f"{row['md']:>8.4f} {'yes' if row['converged'] else 'NO':>4} {row['elapsed_s']:5.0f}s")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--lam", type=float, nargs="+", default=[2.0])
    p.add_argument("--n", type=int, nargs="+", default=[96, 192])
    p.add_argument("--smoothing", type=float, nargs="+", default=[0.3])
    p.add_argument("--ramps", nargs="+", default=["both", "centred"], choices=("both", "centred"))
    p.add_argument("--domain", type=float, default=5.0, help="domain side in a0 (default 5)")
    p.add_argument("--path", choices=("cli", "test"), default="cli")
    p.add_argument("--out", default="out/md_convergence")
    p.add_argument("--device", default="cpu", help="Warp device of the grid runs (e.g. cuda:0)")
    p.add_argument("--continuum", type=int, metavar="RINGS", help="the axisymmetric continuum on RINGS rings instead")
    args = p.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)
    if args.continuum:
        print(f"{'lambda':>6} {'smooth':>6} {'ramps':>8} {'rings':>5} {'pull-off':>8} {'MD':>8} {'diff':>8}  time")
        for lam in args.lam:
            for s in args.smoothing:
                for ramps in args.ramps:
                    c = continuum_pull_off(lam, s, ramps or "both", args.continuum)
                    print(f"{lam:>6g} {s:>6g} {c['ramps']:>8} {c['rings']:>5d} {c['pull_off']:>8.4f} {c['md']:>8.4f} "
                          f"{100 * c['diff']:>+7.3f}% {c['elapsed_s']:5.0f}s", flush=True)
        return 0
    print(HEADER, flush=True)
    for lam in args.lam:
        for s in args.smoothing:
            for ramps in args.ramps:
                for n in args.n:
                    row = run(lam, n, s, ramps, args.domain, args.path, args.device)
                    tag = f"lam{lam:g}_n{n}_s{s:g}_{row['ramps']}_d{args.domain:g}_{args.path}"
                    with open(os.path.join(args.out, tag + ".json"), "w") as f:
                        json.dump(row, f, indent=1)
                    print(line(row), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""The JKR side: pull-off at a large Tabor parameter with the adhesive minimisation, against 1.5 pi R w.

    python validation/jkr_limit.py [--law exponential|smc|lj93] [--tabor 10] [--n 2048] [--size 4]
                              [--device cuda:0] [--dtype float64] [--steps 40]

The paper's pair (E* = 78 GPa), R = 1 um, w = 0.5 J/m^2; the law's length from the Tabor parameter
mu = (R w^2 / (E*^2 l^3))^(1/3) (l: rho, delta_n or z0); domain ``--size`` JKR radii a0 at zero
load; displacement control from first touch to the approach of a = a0 in JKR, then back to
past JKR's jump-out, ``--steps`` states each way (the retraction's finer near JKR's pull-off).
Prints each state (approach, force / (pi R w), iterations, converged), the pull-off against JKR's
1.5 pi R w and DMT's 2 pi R w, the cell_softening of the grid, the time and, on CUDA, the device
memory in use at its highest.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from warpcontact.physics.adhesion import SMC, Exponential, LennardJones93, cell_softening
from warpcontact.physics.geometry import Grid, Sphere
from warpcontact.physics.materials import PAPER_PAIR
from warpcontact.numerics.model import ContactModel
from warpcontact.solvers.adhesive import AdhesiveNormalSolver
from warpcontact.numerics.state import ContactState

R, W = 1e-6, 0.5


def law_for(name: str, tabor: float, e_star: float):
    length = (R * W**2 / (e_star**2 * tabor**3)) ** (1.0 / 3.0)
    if name == "exponential":
        return Exponential(W, length)
    if name == "lj93":
        return LennardJones93(W, length)
    sigma = W / (math.e * length)
    return SMC(sigma, sigma, length, length)


def device_memory_in_use(device: str) -> float | None:
    if not device.startswith("cuda"):
        return None
    import warp as wp

    info = wp.get_device(device)
    return float(info.total_memory - info.free_memory)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--law", default="exponential", choices=["exponential", "smc", "lj93"])
    ap.add_argument("--tabor", type=float, default=10.0)
    ap.add_argument("--n", type=int, default=2048)
    ap.add_argument("--size", type=float, default=4.0, help="domain side in JKR radii a0")
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--dtype", default="float64")
    ap.add_argument("--steps", type=int, default=40)
    a = ap.parse_args()
    e_star = PAPER_PAIR.E_star
    law = law_for(a.law, a.tabor, e_star)
    a0 = (9 * math.pi * W * R**2 / (2 * e_star)) ** (1 / 3)
    delta_a0 = a0**2 / R - math.sqrt(2 * math.pi * W * a0 / e_star)  # JKR approach at a = a0
    scale = (math.pi**2 * W**2 * R / e_star**2) ** (1 / 3)
    t0 = time.perf_counter()
    model = ContactModel(PAPER_PAIR, Sphere(R), Grid(a.n, a.size * a0), device=a.device, dtype=a.dtype)
    solver = AdhesiveNormalSolver(model, law)
    state = ContactState(model)
    setup = time.perf_counter() - t0
    approach = np.linspace(-2.0 * law.range, delta_a0, a.steps)
    retract = np.concatenate([np.linspace(delta_a0, -0.6 * scale, a.steps // 2)[1:],
                              np.linspace(-0.6 * scale, -1.5 * scale, a.steps // 2)[1:]])
    forces, peak_memory = [], device_memory_in_use(a.device) or 0.0
    print(f"law {a.law} tabor {a.tabor} length {law.range:.3e} m, n {a.n}, dx {model.grid.dx:.3e} m, "
          f"cell_softening {cell_softening(law, model):.2f}, device {a.device} {a.dtype}", flush=True)
    t1 = time.perf_counter()
    all_converged = True
    for branch, path in (("approach", approach), ("retract", retract)):
        for dz in path:
            info = solver.solve(state, float(dz))
            f = float((state.pressure.numpy().astype(np.float64)
                       + state.adhesive_pressure.numpy().astype(np.float64)).sum()) * e_star * model.grid.dx**2
            forces.append(f)
            all_converged &= info.converged
            mem = device_memory_in_use(a.device)
            peak_memory = max(peak_memory, mem or 0.0)
            print(f"{branch:8s} dz {dz:+.3e} F/(pi R w) {f / (math.pi * R * W):+.4f} it {info.iterations:4d} "
                  f"conv {info.converged}", flush=True)
    solve_time = time.perf_counter() - t1
    pull_off = min(forces) / (math.pi * R * W)
    print(f"pull-off {pull_off:.4f} pi R w (JKR -1.5: {pull_off / -1.5 - 1:+.2%}; DMT -2), every state converged "
          f"{all_converged}; set-up {setup:.1f} s, {len(forces)} states {solve_time:.1f} s"
          + (f", device memory in use {peak_memory / 2**30:.2f} GiB" if peak_memory else ""))


if __name__ == "__main__":
    main()

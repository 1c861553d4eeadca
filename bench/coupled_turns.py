"""The coupled step with adhesion and friction: minimised turns against lagged turns (or the
tangential solves on the whole grid against the contact's window), side by side.

    python bench/coupled_turns.py [--n 64] [--cells 0.5:1e-4,0.8:1e-4] [--device cpu] [--dtype float64]
    python bench/coupled_turns.py --compare window --n 96 --cells 0.8:1e-4,0.5:1e-5

For each adhesive Table 2 cell (k_tau:delta_z_um, the SMC law of ``Table2Settings``) runs the
gross-slip search twice in one process: with the minimised turns (each normal solve the whole
adhesive problem, plain turns over the shear) and with the lagged turns (the adhesive tractions a
fixed point of their own, Anderson-mixed across turns), each forced (``ContactSolver.turns``; by
default the solver picks by the law's Maugis parameter: lagged for these DMT-side cells). Both
use the solver's inner solves and turn tolerance as they are.
``--compare window``: the solver's turns both times, the tangential solves on the whole grid and
on the contact's window (``TangentialSolver.window`` forced off and on).
Prints per cell: states, turns per state (largest and total), inner iterations, time, and
delta_x_max and mu from each, with their relative difference.
"""

from __future__ import annotations

import argparse
import time

from warpcontact.physics.friction import TaborVonMises
from warpcontact.physics.geometry import Sphere
from warpcontact.physics.materials import PAPER_PAIR
from warpcontact.numerics.model import ContactModel
from warpcontact.studies.slip_search import find_gross_slip
from warpcontact.solvers.contact import ContactSolver
from warpcontact.studies.table2 import RADIUS, UM, Table2Settings, cell_grid


#: the two runs of each cell, by ``--compare``: (name, ContactSolver.turns or None, window or None)
COMPARE = {"turns": (("minimised", "minimised", None), ("lagged", "lagged", None)),
           "window": (("whole grid", None, False), ("window", None, True))}


def run(k_tau, dz_um, settings, turns_kind, window):
    law = settings.adhesion_law()
    dz = dz_um * UM
    model = ContactModel(PAPER_PAIR, Sphere(RADIUS), cell_grid(dz, settings, law), device=settings.device,
                         dtype=settings.dtype)
    solver = ContactSolver(model, TaborVonMises(k_tau, PAPER_PAIR.softer.yield_strength), adhesion=law)
    if turns_kind is not None:
        solver.turns = turns_kind
    if window is not None:
        solver.tangential.window = window
    turns, iterations = [], []
    step = solver.step

    def counted(state, approach):
        info = step(state, approach)
        turns.append(info.outer_iterations)
        iterations.append(info.iterations)
        return info

    solver.step = counted
    t0 = time.perf_counter()
    r = find_gross_slip(model, solver, dz, rel_tol=settings.rel_tol)
    return dict(time=time.perf_counter() - t0, turns=turns, iterations=iterations, dx=r["delta_x_max"] / UM,
                mu=r["mu"], converged=r["converged"], grid=model.grid.n)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=64)
    ap.add_argument("--cells", default="0.5:1e-4,0.8:1e-4")
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--dtype", default="float64")
    ap.add_argument("--compare", default="turns", choices=sorted(COMPARE))
    a = ap.parse_args()
    settings = Table2Settings(n=a.n, device=a.device, dtype=a.dtype)
    print("| k_tau | delta_z [um] | turns | states | max turns | total turns | iterations | time [s] | "
          "delta_x_max [um] | mu | converged |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for cell in a.cells.split(","):
        k, dz = (float(v) for v in cell.split(":"))
        res = []
        for name, turns_kind, window in COMPARE[a.compare]:
            r = run(k, dz, settings, turns_kind, window)
            res.append(r)
            print(f"| {k} | {dz:g} | {name} (grid {r['grid']}) | {len(r['turns'])} | {max(r['turns'])} | "
                  f"{sum(r['turns'])} | {sum(r['iterations'])} | {r['time']:.2f} | {r['dx']:.6g} | {r['mu']:.6g} | "
                  f"{r['converged']} |", flush=True)
        first, second = res
        names = [name for name, _, _ in COMPARE[a.compare]]
        print(f"|  |  | ratio {names[1]}/{names[0]} time {second['time'] / first['time']:.2f}, delta_x_max differs "
              f"{first['dx'] / second['dx'] - 1:+.2e}, mu {first['mu'] / second['mu'] - 1:+.2e} |  |  |  |  |  |  |  |  |")


if __name__ == "__main__":
    main()

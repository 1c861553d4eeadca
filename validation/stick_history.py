"""The stick shear's history: a dissimilar pair's stick traction depends on when each cell entered
the contact, and a normal leg in N steps leaves a staircase of amplitude about 1/N in it.

    python validation/stick_history.py [--n 64] [--steps 1 8 32 128] [--out docs/img/stick_history.png]

The case: a 52100 steel sphere (R = 2 um, E 210 GPa, nu 0.3) on fused silica (E 72 GPa,
nu 0.17), Tabor k_tau 0.7, delta_z = 2 nm in N equal steps, then delta_x = 0.1 nm in 8 steps, on
n x n cells over 4 Hertz radii. Between dissimilar bodies a stuck cell carries the radial shear
that the bodies' different radial displacements under the normal load build up while it sticks
(Goodman's, Spence's problem). A cell that enters the contact during a step sticks from the
step's end on: it misses that step's share, and its ring differs from the next ring by up to
one step's increment of the coupling shear. With N steps the stick zone's q_x is a staircase of
about 1/N of that shear; as N grows it tends to the profile of a continuous normal loading.
Prints, per N, how far the stick zone's q_x on the centre row lies from the finest N's (RMS and
largest, over the cells stuck in both) and F_x; draws q_x along the centre row for each N.
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np


def case(n: int, steps: int) -> dict:
    R, dz, dx = 2e-6, 2e-9, 0.1e-9
    a = (R * dz) ** 0.5
    path = [[0.0, 0.0, dz * k / steps] for k in range(1, steps + 1)]
    path += [[dx * k / 8, 0.0, dz] for k in range(1, 9)]
    return {"sphere": {"radius": R, "E": 210e9, "nu": 0.3, "yield_strength": 2.0e9},
            "flat": {"E": 72e9, "nu": 0.17, "yield_strength": 8.0e9},
            "grid": {"n": n, "size": 4 * a}, "load": {"path": path},
            "friction": {"law": "tabor", "k_tau": 0.7}, "solver": {"device": "cpu"}}


def centre_row(n: int, steps: int):
    """(x [m], q_x [Pa], stick mask) along the centre row of the last state, and F_x [N]."""
    import warpcontact as wc

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = wc.solve(case(n, steps), fields="last")
    f = r.fields[-1]
    row = n // 2
    size = r.model.grid.size
    x = (np.arange(n) + 0.5) * size / n - size / 2
    return x, f["shear_x"][row], f["status"][row] == 1, r.states[-1]["force"]["x"], r.states[-1]["converged"]


def deviation(qx, stick, ref_qx, ref_stick) -> tuple[float, float]:
    """(RMS, largest) |q_x - q_x of the reference| over the cells stuck in both [Pa]."""
    both = stick & ref_stick
    d = np.abs(qx - ref_qx)[both]
    return float(np.sqrt(np.mean(d ** 2))), float(d.max())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=64)
    ap.add_argument("--steps", type=int, nargs="+", default=[1, 8, 32, 128])
    ap.add_argument("--out", default="docs/img/stick_history.png")
    args = ap.parse_args()
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 3.8), layout="constrained")
    rows = {steps: centre_row(args.n, steps) for steps in args.steps}
    finest = max(args.steps)
    _, ref_qx, ref_stick, _, _ = rows[finest]
    print(f"| normal steps | q_x against {finest} steps, RMS / largest [MPa] | F_x [uN] | converged |")
    print("|---|---|---|---|")
    for steps, (x, qx, stick, fx, ok) in rows.items():
        rms, big = deviation(qx, stick, ref_qx, ref_stick)
        print(f"| {steps} | {rms / 1e6:.1f} / {big / 1e6:.1f} | {fx * 1e6:.5f} | {ok} |")
        shown = np.where(stick | (qx != 0), qx, np.nan)
        ax.plot(x * 1e9, shown / 1e6, marker=".", ms=3, lw=0.8, label=f"{steps} normal step{'s' if steps > 1 else ''}")
    ax.set_xlabel("x along the centre row [nm]")
    ax.set_ylabel("q_x [MPa]")
    ax.set_title(f"Stick shear of steel on silica after the normal leg in N steps (n = {args.n})", fontsize=9)
    ax.legend(fontsize=8)
    fig.savefig(args.out, dpi=110)
    print(f"-> {args.out}")


if __name__ == "__main__":
    main()

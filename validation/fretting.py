"""Fretting against Mindlin and Deresiewicz (docs/fretting.md): the tables of its validation section.

Steel on steel (E = 210 GPa, nu = 0.3: Dundurs beta = 0), Coulomb mu = 0.3, R = 10 um, delta_z =
1 nm (Hertz: a = 100 nm, P = 15.4 uN, delta_s = 0.364 nm at gross slip), the paraboloid profile, a
domain of 3 a, 4 normal steps; one whole cycle after the first quarter unless said.

    python validation/fretting.py energy --n 48 64 96 128 --steps 8 16    # W against the closed form
    python validation/fretting.py transition --n 64 96                    # Fouvry's A around delta_s
    python validation/fretting.py closure --n 48 64                       # three cycles: the loop settles
    python validation/fretting.py normal-steps --n 64 --normal-steps 1 6 24 96   # a dissimilar pair
    python validation/fretting.py figure --out docs/img                   # fretting_loop.png, fretting_gross.png

Each prints a Markdown table (2 CPU cores: seconds per row at n <= 128).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import warpcontact as wc  # noqa: E402
from warpcontact.physics.materials import Material, MaterialPair  # noqa: E402
from warpcontact.physics.reference import hertz  # noqa: E402

R, DZ, MU, E, NU = 1e-5, 1e-9, 0.3, 210e9, 0.3
PAIR = MaterialPair(Material(E, NU), Material(E, NU))
HERTZ = hertz(PAIR, R, DZ)
DELTA_S = 3.0 * MU * HERTZ["force"] * PAIR.mindlin_compliance / (16.0 * HERTZ["a"])
COPPER = {"E": 106e9, "nu": 0.33}
STEEL_FLAT = {"E": 205e9, "nu": 0.31}


def amplitude_at(x: float) -> float:
    """delta* [m] of Q* = x mu P by Mindlin's relation."""
    return DELTA_S * (1.0 - (1.0 - x) ** (2.0 / 3.0))


def case(n, amplitude, steps=8, cycles=1, normal_steps=4, sphere=None, flat=None) -> dict:
    return {"sphere": {"radius": R, "profile": "paraboloid", **(sphere or {"E": E, "nu": NU})},
            "flat": flat or {"E": E, "nu": NU},
            "grid": {"n": n, "size": 3.0 * HERTZ["a"]},
            "load": {"delta_z": DZ, "delta_x_amplitude": amplitude, "cycles": cycles, "normal_steps": normal_steps,
                     "tangential_steps": steps},
            "friction": {"law": "coulomb", "mu": MU}}


def run(d) -> tuple[dict, float]:
    t = time.perf_counter()
    r = wc.fretting(d)
    return r, time.perf_counter() - t


def energy(args):
    print("| n | steps per quarter | x = Q*/(mu P) | W [J] | closed form [J] | W / closed - 1 | error estimate | "
          "Q* / closed - 1 | A (closed) | time [s] |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for n in args.n:
        for q in args.steps:
            for x in args.x:
                r, t = run(case(n, amplitude_at(x), q))
                c, ref = r["cycles"][0], r["closed_form"]
                print(f"| {n} | {q} | {x:g} | {c['energy']:.4e} | {ref['energy']:.4e} | "
                      f"{c['energy'] / ref['energy'] - 1:+.2%} | {c['energy_error'] / c['energy']:.1e} | "
                      f"{c['force_amplitude'] / ref['force_amplitude'] - 1:+.3%} | {c['energy_ratio']:.4f} "
                      f"({ref['energy_ratio']:.4f}) | {t:.1f} |", flush=True)


def transition(args):
    print("| n | delta* / delta_s | regime | A | closed form A | min stick area [m^2] |")
    print("|---|---|---|---|---|---|")
    for n in args.n:
        for ratio in args.ratio:
            r, _ = run(case(n, ratio * DELTA_S))
            c, ref = r["cycles"][0], r["closed_form"]
            print(f"| {n} | {ratio:g} | {c['regime']} | {c['energy_ratio']:.4f} | {ref['energy_ratio']:.4f} | "
                  f"{c['min_stick_area']:.3e} |", flush=True)


def closure(args):
    print("| n | x | max \\|F2 - F1\\| / mu P | max \\|F3 - F2\\| / mu P | W2 / W1 - 1 | W3 / W2 - 1 |")
    print("|---|---|---|---|---|---|")
    for n in args.n:
        for x in args.x:
            r, _ = run(case(n, amplitude_at(x), cycles=3))
            cy = r["cycles"]
            fx = [np.array([s["force"]["x"] for s in r["states"][c["first_state"]:c["last_state"] + 1]]) for c in cy]
            mu_p = MU * r["normal_force"]
            print(f"| {n} | {x:g} | {np.abs(fx[1] - fx[0]).max() / mu_p:.1e} | "
                  f"{np.abs(fx[2] - fx[1]).max() / mu_p:.1e} | "
                  f"{cy[1]['energy'] / cy[0]['energy'] - 1:+.1e} | {cy[2]['energy'] / cy[1]['energy'] - 1:+.1e} |",
                  flush=True)


def normal_steps(args):
    """Copper on steel (beta = -0.04): each cycle's energy against the normal leg's steps."""
    amp = args.amplitude
    print("| n | normal_steps | W, cycle 1 [J] | W, cycle 2 [J] | Q*, cycle 2 [N] | F_z [N] |")
    print("|---|---|---|---|---|---|")
    for n in args.n:
        for ns in args.normal_steps:
            r, _ = run(case(n, amp, cycles=2, normal_steps=ns, sphere=COPPER, flat=STEEL_FLAT))
            c = r["cycles"]
            print(f"| {n} | {ns} | {c[0]['energy']:.4e} | {c[1]['energy']:.4e} | {c[1]['force_amplitude']:.4e} | "
                  f"{r['normal_force']:.5e} |", flush=True)


def figure(args):
    """The loops of docs/fretting.md, drawn as `warpcontact fretting` draws loop.png."""
    from warpcontact.plots import fretting_loop, save

    out = Path(args.out)
    for name, amplitude in (("fretting_loop.png", amplitude_at(0.6)), ("fretting_gross.png", 1.3 * DELTA_S)):
        r, _ = run(case(96, amplitude, steps=8, cycles=2))
        save(fretting_loop(r), out / name)
        print(out / name)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="study", required=True)
    e = sub.add_parser("energy")
    e.add_argument("--n", type=int, nargs="+", default=[96])
    e.add_argument("--steps", type=int, nargs="+", default=[8])
    e.add_argument("--x", type=float, nargs="+", default=[0.3, 0.6, 0.9])
    t = sub.add_parser("transition")
    t.add_argument("--n", type=int, nargs="+", default=[64])
    t.add_argument("--ratio", type=float, nargs="+", default=[0.98, 0.99, 0.995, 1.0, 1.01, 1.02])
    c = sub.add_parser("closure")
    c.add_argument("--n", type=int, nargs="+", default=[48])
    c.add_argument("--x", type=float, nargs="+", default=[0.3, 0.6, 0.9])
    s = sub.add_parser("normal-steps")
    s.add_argument("--n", type=int, nargs="+", default=[64])
    s.add_argument("--normal-steps", type=int, nargs="+", default=[1, 6, 24, 96])
    s.add_argument("--amplitude", type=float, default=1.5e-10, help="delta* [m]")
    f = sub.add_parser("figure")
    f.add_argument("--out", default="docs/img")
    args = p.parse_args()
    {"energy": energy, "transition": transition, "closure": closure, "normal-steps": normal_steps,
     "figure": figure}[args.study](args)


if __name__ == "__main__":
    main()

"""Adhesion under tangential load: the contact radius against the tangential force, against Savkoor &
Briggs (1977) (docs/validation.md, "Adhesion under tangential load").

A sphere of R = 10 mm, E = 1 MPa, nu = 0.5 on a rigid flat (Dundurs beta = 0: the normal and
tangential problems uncouple), the exponential law w = 0.05 J/m^2 with rho from the Tabor parameter
mu_T = (R w^2 / (E*^2 rho^3))^(1/3), Coulomb friction with a large mu (full stick but for the
contact's edge, where the contact pressure falls to zero). JKR at zero load: a0 = 375.7 um, and
Savkoor-Briggs' critical force T_c = 3.848 mN. The normal approach is JKR's at zero load,
a0^2 / (3 R) = 4.705 um, in ``--normal-steps`` steps; then delta_x rises in ``--steps`` equal steps
to ``--max-ratio`` x T_c / (8 a0 G*) (full stick: T = 8 a G* delta_x). Each state's contact radius
a = sqrt(A_c / pi) (A_c: the cells with p_c > 0, the gap closed) is compared with
``warpcontact.physics.reference.savkoor_briggs`` at the state's own P and T.

    python validation/savkoor_briggs.py                          # 2 CPU cores: n = 96, Tabor 3, ~5 s
    python validation/savkoor_briggs.py --n 128 --tabor 5 --size 2.5

The case resolved at Tabor 10, on one H100 (float64: 27.6 GiB of device memory by
``numerics.resources.estimate_bytes``; about 5 minutes, under 10, by the CPU runs' iterations per
state and the JKR study's time per iteration at n = 2048; the script prints the time and the
device memory in use):

    python validation/savkoor_briggs.py --device cuda --n 4096 --size 2.5 --tabor 10 --steps 12 \
        --out bench_results/savkoor_briggs_tabor10

(Tabor 10: rho = 0.2414 um; domain 2.5 a0 = 0.939 mm, cells of 0.229 um = 0.95 rho, cell_softening
0.16, a0 = 1640 cells, the cohesive zone at the edge about 1 um = 4-5 cells; Maugis-Dugdale puts
a at zero load 0.2 % below JKR's there.) Prints the table (Markdown) and writes ``--out``
(default bench_results/savkoor_briggs/): table.md, result.json and savkoor_briggs.png (a / a0
against T / T_c, the model's states on the closed form).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import warpcontact as wc  # noqa: E402
from warpcontact.physics.materials import Material, MaterialPair  # noqa: E402
from warpcontact.physics.reference import savkoor_briggs  # noqa: E402

R, E, NU, W = 1e-2, 1e6, 0.5, 0.05
PAIR = MaterialPair(Material(E, NU), Material.rigid())
E_STAR, COMPLIANCE = PAIR.E_star, PAIR.mindlin_compliance  # E* [Pa], 1/G* [1/Pa]
ZERO_LOAD = savkoor_briggs(0.0, 0.0, R, E_STAR, COMPLIANCE, W)
A0 = ZERO_LOAD["a"]  # JKR's contact radius at P = 0 [m]
T_C0 = ZERO_LOAD["critical_force"]  # Savkoor-Briggs' critical T at P = 0 [N]
DELTA_Z = A0**2 / (3.0 * R)  # JKR's approach at P = 0 [m]
DELTA_C = T_C0 * COMPLIANCE / (8.0 * A0)  # full stick's delta_x at T_c [m]


def rho_for(tabor: float) -> float:
    """The exponential law's length [m] of Tabor parameter mu_T = (R w^2 / (E*^2 rho^3))^(1/3)."""
    return (R * W**2 / (E_STAR**2 * tabor**3)) ** (1.0 / 3.0)


def case(n: int, size: float, tabor: float, mu: float, steps: int, max_ratio: float, normal_steps: int,
         device: str = "cpu", dtype: str = "float64") -> dict:
    """The study's case: ``size`` in a0, ``max_ratio`` the largest delta_x in DELTA_C."""
    return {"sphere": {"radius": R, "E": E, "nu": NU, "profile": "paraboloid"},
            "flat": {"rigid": True},
            "grid": {"n": n, "size": size * A0},
            "load": {"delta_z": DELTA_Z, "delta_x": max_ratio * DELTA_C, "normal_steps": normal_steps,
                     "tangential_steps": steps},
            "friction": {"law": "coulomb", "mu": mu},
            "adhesion": {"law": "exponential", "w": W, "rho": rho_for(tabor)},
            "solver": {"device": device, "dtype": dtype}}


def compare(states: list) -> list:
    """Rows of the tangential leg (the last normal state first): the model's a = sqrt(A_c / pi)
    against Savkoor-Briggs at the state's P = F_z and T = F_x."""
    rows = []
    for s in states:
        P, T = s["force"]["z"], s["force"]["x"]
        a = math.sqrt(s["contact_area"] / math.pi)
        ref = savkoor_briggs(P, T, R, E_STAR, COMPLIANCE, W)
        rows.append({"delta_x": s["delta"]["x"], "T": T, "P": P, "a": a, "a_sb": ref["a"], "a_jkr": ref["a_jkr"],
                     "T_c": ref["critical_force"], "ratio": ref["ratio"],
                     "difference": a / ref["a"] - 1.0 if math.isfinite(ref["a"]) else math.nan,
                     "stick_share": s["stick_area"] / s["contact_area"] if s["contact_area"] > 0 else 0.0,
                     "stiffness_ratio": T * COMPLIANCE / (8.0 * a * s["delta"]["x"]) if s["delta"]["x"] > 0 else math.nan,
                     "converged": bool(s["converged"]), "iterations": s.get("iterations"),
                     "turns": s.get("outer_iterations")})
    return rows


def run(c: dict) -> tuple[list, float]:
    """Every state of the case's path; the tangential leg's rows, and the path's time [s]."""
    t = time.perf_counter()
    states = list(wc.path(c))
    elapsed = time.perf_counter() - t
    leg = [s for s in states if s["delta"]["x"] > 0.0]
    return compare([states[-len(leg) - 1]] + leg), elapsed


def table(rows: list) -> str:
    head = ("| delta_x [um] | T [mN] | T / T_c | P [mN] | a [um] | a, Savkoor-Briggs [um] | difference | "
            "a / a_JKR(P) | stick / contact | T / (8 a G* delta_x) |\n|---|---|---|---|---|---|---|---|---|---|\n")
    lines = []
    for r in rows:
        sb = f"{r['a_sb'] * 1e6:.2f}" if math.isfinite(r["a_sb"]) else "none (T > T_c)"
        diff = f"{r['difference']:+.2%}" if math.isfinite(r["difference"]) else "-"
        stiff = f"{r['stiffness_ratio']:.4f}" if math.isfinite(r["stiffness_ratio"]) else "-"
        lines.append(f"| {r['delta_x'] * 1e6:.3f} | {r['T'] * 1e3:.4f} | {r['ratio']:.3f} | {r['P'] * 1e3:+.4f} | "
                     f"{r['a'] * 1e6:.2f} | {sb} | {diff} | {r['a'] / r['a_jkr']:.4f} | {r['stick_share']:.4f} | "
                     f"{stiff} |" + ("" if r["converged"] else " not converged"))
    return head + "\n".join(lines) + "\n"


def figure(rows: list, path: Path, title: str) -> None:
    """a / a0 against T / T_c: the model's states, Savkoor-Briggs at the states' P and JKR's a(P)."""
    import numpy as np

    from warpcontact.plots.base import CONTACT_COLOR, STICK_COLOR, _figure, save

    P = rows[0]["P"]
    ref0 = savkoor_briggs(P, 0.0, R, E_STAR, COMPLIANCE, W)
    x = np.linspace(0.0, 1.0, 401)
    a_sb = [savkoor_briggs(P, xi * ref0["critical_force"], R, E_STAR, COMPLIANCE, W)["a"] for xi in x]
    fig = _figure((5.6, 3.8))
    ax = fig.add_subplot()
    ax.plot(x, np.asarray(a_sb) / A0, color=STICK_COLOR, label="Savkoor & Briggs (G_I + G_II = w)")
    ax.plot([0.0, 1.0], [ref0["a_critical"] / A0] * 2, ":", color=STICK_COLOR, lw=0.8)
    x_max = max(1.05, max(r["ratio"] for r in rows) * 1.03)
    ax.plot([0.0, x_max], [ref0["a_jkr"] / A0] * 2, "--", color="0.4", lw=1.0, label="JKR at P (G_I = w)")
    ax.plot([r["ratio"] for r in rows], [r["a"] / A0 for r in rows], "o", color=CONTACT_COLOR, ms=5,
            label="warpcontact (exponential law)")
    ax.set_xlim(0.0, x_max)
    ax.set_xlabel("T / T_c")
    ax.set_ylabel("a / a0")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=8, loc="lower left")
    ax.grid(alpha=0.3)
    save(fig, path, dpi=110)


def device_memory_in_use(device: str) -> float | None:
    if not device.startswith("cuda"):
        return None
    import warp as wp

    info = wp.get_device(device)
    return float(info.total_memory - info.free_memory)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=96, help="cells per side")
    ap.add_argument("--size", type=float, default=3.0, help="domain side in a0 (JKR's radius at zero load)")
    ap.add_argument("--tabor", type=float, default=3.0, help="Tabor parameter (sets rho)")
    ap.add_argument("--mu", type=float, default=100.0, help="Coulomb friction coefficient (large: stick)")
    ap.add_argument("--steps", type=int, default=10, help="steps of delta_x")
    ap.add_argument("--normal-steps", type=int, default=4)
    ap.add_argument("--max-ratio", type=float, default=1.1, help="largest delta_x in T_c / (8 a0 G*)")
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--dtype", default="float64")
    ap.add_argument("--out", default=str(ROOT / "bench_results" / "savkoor_briggs"))
    a = ap.parse_args(argv)
    c = case(a.n, a.size, a.tabor, a.mu, a.steps, a.max_ratio, a.normal_steps, a.device, a.dtype)
    from warpcontact.numerics.resources import estimate_bytes

    kind = "cuda" if a.device.startswith("cuda") else "cpu"
    estimate = estimate_bytes(a.n, a.dtype, kind, True, "auto", adhesion=True)
    dx = a.size * A0 / a.n
    rho = rho_for(a.tabor)
    print(f"a0 {A0 * 1e6:.2f} um, T_c(P = 0) {T_C0 * 1e3:.4f} mN, delta_z {DELTA_Z * 1e6:.3f} um; Tabor {a.tabor:g}: "
          f"rho {rho * 1e6:.4f} um; n {a.n}, domain {a.size:g} a0, cell {dx * 1e6:.4f} um = {dx / rho:.2f} rho, "
          f"a0 = {A0 / dx:.0f} cells; mu {a.mu:g}; {a.device} {a.dtype}; estimated memory {estimate / 2**30:.2f} GiB",
          flush=True)
    rows, elapsed = run(c)
    peak = device_memory_in_use(a.device)
    text = table(rows)
    print(text, end="")
    timing = f"{len(rows) - 1 + a.normal_steps} states in {elapsed:.1f} s" + (
        f", device memory in use {peak / 2**30:.2f} GiB" if peak else "")
    print(timing)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "table.md").write_text(text)
    (out / "result.json").write_text(json.dumps({"case": c, "rows": rows, "time_s": elapsed, "device_memory": peak,
                                                 "estimated_memory": estimate}, indent=1, default=str))
    figure(rows, out / "savkoor_briggs.png",
           f"R = 10 mm, E = 1 MPa, nu = 0.5 on a rigid flat, w = 0.05 J/m^2: Tabor {a.tabor:g}, n = {a.n}")
    print(f"-> {out}")


if __name__ == "__main__":
    main()

"""Robustness along whole load paths: every shipped example path, Table 2's cells and paths a user
would try besides, at several grid sizes, with each "auto" choice as chosen and forced on and off.

Each path runs in a process of its own under a time limit (a path that stalls is cut off and
reported as such, not waited for): the case file with ``grid.n`` and the solver's choices replaced,
everything else as shipped. Per path: the states solved, whether every state converged, the largest
and the total inner iterations of a state, the most turns of a state, and the time of the path's
solve (the process's imports, model and compile excluded: ``solve``'s own clock; the first state
includes the kernels' compile on a cold cache). A table in Markdown on stdout, one JSON line per
run under ``bench_results/paths/``.

Paths (``--paths``, names or "all"; default: the examples and the extras):

- the examples: ``examples/figure1a-d.toml``, ``figure2a-d.toml`` (16 states: 8 normal steps with
  friction, then 8 tangential; 1b-d and 2b, 2d with SMC adhesion) and
  ``table2_k080_dz5e-5.toml``;
- ``steel``: figure2c's path for steel on steel (E 210 GPa, nu 0.3, S_Y 400 MPa: another pair,
  identical materials, no coupling);
- ``hardness``: figure2a's path at 4 times its approach with the hardness cap on;
- ``stall``: ``hardness`` with k_VM = 2.3 (4 times von Mises's 1/sqrt(3)): the turns' gain at the
  crossover that refinement raises (about sqrt(n)), on grids the CPU affords: the plain turns stall
  from n = 128 (docs/model.md, "The turns' stall");
- ``float32``: figure2c's path in float32;
- ``dugdale`` / ``exponential``: figure2c's path with friction and Dugdale (sigma_0 2 MPa, h_0 5 pm)
  or exponential (w 1.36e-5 J/m^2, rho 5 pm) adhesion;
- ``frictionless``: figure2c's sphere and pair without friction, its 8 normal steps alone;
- ``unload``: figure2c's normal leg up in 8 steps, 4 tangential steps, and back down to a quarter of
  the approach in 4 steps (the contact recedes under a shear history);
- ``rough``: figure2d's sphere, pair, friction and SMC adhesion on a rough flat (a self-affine map
  of 256^2 pixels over the domain: H 0.8, rms height 50 pm against the 150 pm approach, wavelengths
  down to 2.1 nm; the same map resampled onto every n), 5 normal and 5 tangential steps: a contact
  of many patches;
- ``table2:K:DZ`` (``:adh`` at the end: with adhesion): a Table 2 cell's path to the paper's delta_x_max (k_tau K, delta_z DZ um; the
  cell's domain as ``table2`` builds it, n replaced), ``--table2`` adds all 24 (both columns).

``--choices one-thread plain-launches``: the launch layer's alternatives beside ``auto`` (on the
CPU, launches not split over its threads; and every launch a plain ``wp.launch``).
``--choices slip-separate``: a turn's slip with adhesion, the shear's normal displacement and a
step's final slip from separate products (``ContactSolver.shared_transforms`` False).
``--choices turn-ratio-1e-3 turn-ratio-3e-2``: a lagged turn's inner tolerance at 1/1000 or 1/30 of
the coupled residual instead of 1/100 (solvers/turns.py, ``TURN_TOL_RATIO``).

Usage (the ratios between choices matter, not the seconds: run them in one call):

    python bench/paths.py --device cuda --sizes 256 1024 2048 4096 --choices auto nested-off
    python bench/paths.py --device cpu --sizes 256 512 1024 --paths figure2c --choices all
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
EXAMPLE_PATHS = ["figure1a", "figure1b", "figure1c", "figure1d", "figure2a", "figure2b", "figure2c", "figure2d",
                 "table2_k080_dz5e-5"]
EXTRA_PATHS = ["steel", "hardness", "stall", "float32", "dugdale", "exponential", "unload", "rough", "frictionless"]
#: the ``rough`` path's flat: a self-affine map of ROUGH_PIXELS^2 pixels over figure2d's domain
#: (H 0.8, rms height 50 pm, wavelengths down to 4 pixels, seed 1), resampled onto every grid
ROUGH_PIXELS = 256
#: the solver's choices a run forces ([solver] keys; the rest "auto")
CHOICES = {
    "auto": {},
    "nested-on": {"nested": True},
    "nested-off": {"nested": False},
    "nested32-on": {"nested": True, "nested_float32": True},
    "nested32-off": {"nested_float32": False},
    "window-on": {"window": True},
    "window-off": {"window": False},
    "both-off": {"nested": False, "window": False},
    "precond32-on": {"preconditioner_float32": True},
    "precond32-off": {"preconditioner_float32": False},
    "precond-padded": {"preconditioner_grid": "padded"},
    "response32-on": {"response_float32": True},
    "response32-off": {"response_float32": False},
}
#: choices of the launch layer (numerics/launch.py, ``LaunchCache``'s class defaults), the solver's
#: choices "auto": on the CPU, launches not split over its threads; and not replayed either
LAUNCH_CHOICES = {
    "one-thread": {"threads": 1},
    "plain-launches": {"threads": 1, "replay": False},
}
#: choices of the contact solver's class defaults, the solver's choices "auto": a turn's slip and
#: the shear's normal displacement from separate products (``ContactSolver.shared_transforms``)
SOLVER_CLASS_CHOICES = {
    "slip-separate": {"shared_transforms": False},
}
#: choices of the turns' tolerance schedule (solvers/turns.py's constants), the solver's choices
#: "auto": a lagged turn's inner tolerance at 1/1000 or 1/30 of the coupled residual, not 1/100
TURNS_CHOICES = {
    "turn-ratio-1e-3": {"TURN_TOL_RATIO": 1e-3},
    "turn-ratio-3e-2": {"TURN_TOL_RATIO": 3e-2},
}


def load_toml(path: Path) -> dict:
    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        import tomli as tomllib
    with open(path, "rb") as f:
        return tomllib.load(f)


def case_dict(name: str) -> dict:
    """The case (a dict as a case file reads) of a path by its name."""
    if name in EXAMPLE_PATHS:
        return load_toml(EXAMPLES / f"{name}.toml")
    if name.startswith("table2:"):
        return table2_case(name)
    base = load_toml(EXAMPLES / "figure2c.toml")
    if name == "steel":
        steel = {"E": 210e9, "nu": 0.3, "yield_strength": 400e6, "hardness": 2.0e9}
        base["sphere"].update(steel)
        base["flat"] = dict(steel)
    elif name in ("hardness", "stall"):
        base = load_toml(EXAMPLES / "figure2a.toml")
        if name == "stall":
            base["friction"]["k_vm"] = 2.3
        base["load"]["delta_z"] *= 4.0
        base["load"]["delta_x"] *= 4.0
        base["grid"]["size"] *= 2.0
        base["friction"]["hardness_cap"] = True
    elif name == "float32":
        base["solver"]["dtype"] = "float32"
    elif name == "dugdale":
        base["adhesion"] = {"law": "dugdale", "sigma_0": 2.0e6, "h_0": 5.0e-12}
    elif name == "exponential":
        base["adhesion"] = {"law": "exponential", "w": 1.36e-5, "rho": 5.0e-12}
    elif name == "rough":
        base = load_toml(EXAMPLES / "figure2d.toml")
        base["flat"].update(height_map=str(rough_map(base["grid"]["size"])), pixel_size=base["grid"]["size"] / ROUGH_PIXELS)
        base["grid"]["size"] = "map"
        base["load"]["steps"] = 5
    elif name == "frictionless":
        del base["friction"]
        base["load"] = {"delta_z": base["load"]["delta_z"], "steps": 8}
    elif name == "unload":
        load = base.pop("load")
        dz, dx = load["delta_z"], load["delta_x"]
        up = [[0.0, 0.0, dz * k / 8] for k in range(1, 9)]
        shear = [[dx * k / 8, 0.0, dz] for k in range(1, 5)]
        down = [[dx / 2, 0.0, dz * (1.0 - 0.75 * k / 4)] for k in range(1, 5)]
        base["load"] = {"path": up + shear + down}
    else:
        raise SystemExit(f"paths.py: no path named {name!r}")
    return base


def rough_map(size: float) -> Path:
    """The ``rough`` path's height map [m] as a .npy file (written once, under bench_results/)."""
    import numpy as np

    from warpcontact.physics.roughness import rough_surface

    path = ROOT / "bench_results" / "paths" / f"rough_{ROUGH_PIXELS}.npy"
    if not path.exists():
        path.parent.mkdir(parents=True, exist_ok=True)
        np.save(path, rough_surface(ROUGH_PIXELS, size, 0.8, rms_height=5e-11, short_cutoff=4 * size / ROUGH_PIXELS,
                                    seed=1))
    return path


def table2_case(name: str) -> dict:
    """``table2:K:DZ`` (K: k_tau, DZ: delta_z in um; ":adh" at the end: with the SMC law of
    ``table2``'s defaults): the paper's pair and sphere, the cell's domain as ``table2`` builds it at
    its default resolution (``cell_grid``; n is replaced), Tabor + von Mises, 8 normal steps and 8
    tangential steps up to the paper's delta_x_max."""
    from warpcontact.studies import table2 as t2

    parts = name.split(":")
    adhesion = parts[-1] == "adh"
    k_tau, dz_um = float(parts[1]), float(parts[2])
    settings = t2.Table2Settings()
    law = settings.adhesion_law() if adhesion else None
    dz = dz_um * t2.UM
    grid = t2.cell_grid(dz, settings, law)
    dx_max_um = t2.paper_table()[(k_tau, dz_um, adhesion)][0]
    base = load_toml(EXAMPLES / "figure2c.toml")
    base["grid"] = {"n": grid.n, "size": grid.size}
    base["load"] = {"delta_z": dz, "delta_x": dx_max_um * t2.UM, "steps": 8}
    base["friction"] = {"law": "tabor", "k_tau": k_tau}
    if adhesion:
        base["adhesion"] = {"law": "smc", "sigma_max": settings.sigma_max, "tau_max": settings.tau_max,
                            "delta_n": settings.delta_n, "delta_t": settings.delta_t}
    return base


def table2_names() -> list[str]:
    from warpcontact.studies import table2 as t2

    return [f"table2:{k}:{dz}{':adh' if adh else ''}" for adh in (False, True) for k, dz in t2.cells()]


def child(args) -> None:
    """One path in this process: print one JSON line."""
    d = json.loads(args.child)
    import warpcontact as wc
    from warpcontact.numerics.launch import LaunchCache

    for name, value in d.pop("launches", {}).items():
        setattr(LaunchCache, name, value)
    from warpcontact.solvers.contact import ContactSolver

    for name, value in d.pop("contact_solver", {}).items():
        setattr(ContactSolver, name, value)
    from warpcontact.solvers import turns

    for name, value in d.pop("turns", {}).items():
        setattr(turns, name, value)

    t0 = time.perf_counter()
    result = wc.solve(d, fields="none")
    elapsed = time.perf_counter() - t0
    states = result.states
    print("RESULT " + json.dumps({
        "states": len(states),
        "converged": all(bool(s["converged"]) for s in states),
        "max_iterations": max(int(s["iterations"]) for s in states),
        "total_iterations": sum(int(s["iterations"]) for s in states),
        "max_turns": max(int(s["outer_iterations"]) for s in states),
        "total_turns": sum(int(s["outer_iterations"]) for s in states),
        "iterations": [int(s["iterations"]) for s in states],
        "force_x": [float(s["force"]["x"]) for s in states],  # N: runs of one path compared state by state
        "force_z": [float(s["force"]["z"]) for s in states],
        "solve_s": elapsed,
    }), flush=True)


def run_one(name: str, n: int, choice: str, device: str, timeout: float) -> dict:
    d = case_dict(name)
    d["grid"]["n"] = int(n)
    solver = d.setdefault("solver", {})
    solver.update({"device": device, "nested": "auto", "nested_float32": "auto", "window": "auto",
                   "preconditioner_float32": "auto",
                   "response_float32": "auto", **CHOICES.get(choice, CHOICES["auto"])})
    if choice in LAUNCH_CHOICES:
        d["launches"] = LAUNCH_CHOICES[choice]
    if choice in SOLVER_CLASS_CHOICES:
        d["contact_solver"] = SOLVER_CLASS_CHOICES[choice]
    if choice in TURNS_CHOICES:
        d["turns"] = TURNS_CHOICES[choice]
    row = {"path": name, "n": n, "choice": choice, "device": device, "dtype": solver.get("dtype", "float64")}
    t0 = time.perf_counter()
    try:
        p = subprocess.run([sys.executable, __file__, "--child", json.dumps(d)], capture_output=True, text=True,
                           timeout=timeout, env={**os.environ, "PYTHONUNBUFFERED": "1"})
    except subprocess.TimeoutExpired:
        row.update(status=f"cut off after {timeout:.0f} s", process_s=time.perf_counter() - t0)
        return row
    row["process_s"] = time.perf_counter() - t0
    line = next((ln for ln in p.stdout.splitlines() if ln.startswith("RESULT ")), None)
    if p.returncode != 0 or line is None:
        tail = (p.stderr.strip().splitlines() or ["(no output)"])[-1]
        row.update(status=f"failed: {tail[:120]}")
        return row
    row.update(json.loads(line[len("RESULT "):]))
    row["status"] = "ok" if row["converged"] else "not converged"
    return row


def table(rows: list[dict]) -> str:
    head = ("| path | n | choice | states | all converged | largest state (inner it.) | total | most turns "
            "| turns in all | solve [s] | process [s] |\n|---|---|---|---|---|---|---|---|---|---|---|")
    lines = [head]
    for r in rows:
        if "states" not in r:
            lines.append(f"| {r['path']} | {r['n']} | {r['choice']} | - | {r['status']} | - | - | - | - | - | "
                         f"{r.get('process_s', 0):.1f} |")
            continue
        lines.append(f"| {r['path']} | {r['n']} | {r['choice']} | {r['states']} | "
                     f"{'yes' if r['converged'] else 'NO'} | {r['max_iterations']} | {r['total_iterations']} | "
                     f"{r['max_turns']} | {r.get('total_turns', '-')} | {r['solve_s']:.2f} | {r['process_s']:.1f} |")
    return "\n".join(lines)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--device", default="cpu")
    p.add_argument("--sizes", type=int, nargs="+", default=[256, 512])
    p.add_argument("--paths", nargs="+", default=["all"])
    p.add_argument("--table2", action="store_true", help="add Table 2's 24 cells")
    p.add_argument("--choices", nargs="+", default=["auto"],
                   help=f"of {list(CHOICES)} or 'all' (the solver's), or of {list(LAUNCH_CHOICES)} (the launch "
                        f"layer's), {list(SOLVER_CLASS_CHOICES)} (the contact solver's class defaults) or "
                        f"{list(TURNS_CHOICES)} (the turns' tolerance schedule)")
    p.add_argument("--timeout", type=float, default=300.0, help="seconds a path may take (its whole process)")
    p.add_argument("--out", default=str(ROOT / "bench_results" / "paths"))
    p.add_argument("--child", help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.child:
        return child(args)
    names = EXAMPLE_PATHS + EXTRA_PATHS if args.paths == ["all"] else args.paths
    if args.table2:
        names = names + table2_names()
    choices = list(CHOICES) if args.choices == ["all"] else args.choices
    known = list(CHOICES) + list(LAUNCH_CHOICES) + list(SOLVER_CLASS_CHOICES) + list(TURNS_CHOICES)
    for c in choices:
        if c not in known:
            raise SystemExit(f"paths.py: --choices takes {known} or all, not {c!r}")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    log = out / f"paths_{args.device.replace(':', '')}_{time.strftime('%Y%m%d_%H%M%S')}.jsonl"
    rows = []
    for n in args.sizes:
        for name in names:
            for choice in choices:
                row = run_one(name, n, choice, args.device, args.timeout)
                rows.append(row)
                with open(log, "a") as f:
                    f.write(json.dumps(row) + "\n")
                print(f"{name} n={n} {choice}: {row['status']}"
                      + (f", largest state {row['max_iterations']}, {row['solve_s']:.2f} s" if "states" in row else ""),
                      file=sys.stderr, flush=True)
    print(table(rows))
    print(f"\n(one JSON line a run: {log})")


if __name__ == "__main__":
    main()

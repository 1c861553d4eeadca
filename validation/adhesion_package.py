"""The adhesive sphere-on-flat case through warpcontact and through the Adhesion package, side by side.

    python validation/adhesion_package.py [--case examples/pull_off_jkr.toml] [--steps 20] [--repeats 2]
                                     [--adhesion-path /tmp/adhpkg] [--gtol 1e-7] [--out out/adhesion_package]

Ours: ``warpcontact.api.run_pull_off`` on the case (its default path: -2 ranges of the law, moved out
while the first state touches, up to the case's delta_z and back until the contact breaks; jumps
located by bisection, the pull-off refined by 7 substeps around the most tensile state).

Theirs: the Adhesion package of Pastewka and co-workers (pip packages ``adhesion`` and
``contactmechanics``, https://github.com/ContactEngineering/Adhesion) on the same problem: a
non-periodic half-space (``FreeFFTElasticHalfSpace``, the pair's E*, the same physical size and
n x n points), the same exact sphere on the same cell centres (``make_sphere`` with its centre half
a cell off a grid point, checked against our initial gap), the ``Exponential`` interaction with the
same w and rho (its traction checked against ours at three gaps), a bounded (non-penetration)
``BoundedSmoothContactSystem``, and the SAME rigid approaches: our curve's delta_z list, approach
then retraction, each state started from the last one's displacements shifted by the change of
offset (as their tests do), minimised by ``minimize_proxy`` (scipy's L-BFGS-B, ``lbounds="auto"``,
``gtol = --gtol * (w / rho) * cell area``, ``ftol = 0``). Their pull-off is refined as ours: 7
substeps of the two steps around the most tensile retraction state, from the state before it.

Conventions (read from their source): gap = u - h - offset with h = sqrt(R^2 - r^2) - R <= 0, so
offset = our delta_z (approach positive) and u = our displacement; their ``compute_normal_force``
= sum of -substrate.force, compressive positive like our F_z; ``Exponential.evaluate`` returns
(V, dV/dg, d2V/dg2) with V = -w exp(-g / rho), so dV/dg = (w / rho) exp(-g / rho) is the attractive
traction, our t(h).

The two run in separate processes (ours needs Warp, theirs ``PYTHONPATH=--adhesion-path``), in the
order A B A B ...; the table gives each run's time (the solves of the path, set-up and imports
excluded; the process's wall time beside it) and pull-off / (pi R w), and the force-approach
curves' largest difference on the shared delta_z list. Outputs: OUT/ours_K.json, OUT/theirs_K.json,
OUT/table.md. Exit 2 when the Adhesion package is not importable (the message says how to install it).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
#: gaps (in units of rho) where the two laws' tractions are compared
CHECK_GAPS = (0.0, 1.0, 3.0)
#: both tractions are w / rho exp(-h / rho) in float64; ours is evaluated in scaled units (h / dx,
#: t / E*) and scaled back: a few ulps apart
TRACTION_RTOL = 1e-12
#: refinement substeps, as warpcontact.studies.approach_retract.REFINE_SUBSTEPS (checked in the ours worker)
SUBSTEPS = 8
#: Maugis-Dugdale at lambda = 1.127 mu (docs/validation.md, the exponential law's mapping) for mu = 3
MD_AT_TABOR_3 = -1.513


# ----------------------------------------------------------------------------------------------
# ours (Warp)
def worker_ours(a) -> dict:
    import numpy as np
    import warp as wp
    from warpcontact.kernels import adhesive as ak

    from warpcontact.studies import approach_retract as ar
    from warpcontact.api import run_pull_off
    from warpcontact.records.case import load_case
    from warpcontact.studies.runner import build

    assert ar.REFINE_SUBSTEPS == SUBSTEPS, "the refinement of theirs follows ours: update SUBSTEPS"
    case = load_case(a.case)
    t0 = time.perf_counter()
    model, solver, _ = build(case)
    law = solver.adhesion
    setup = time.perf_counter() - t0
    r = run_pull_off(case, model, solver, steps=a.steps)

    @wp.kernel
    def traction_at(h: wp.array(dtype=wp.float64), law_id: int, pa: wp.float64, pb: wp.float64,
                    pc: wp.float64, t: wp.array(dtype=wp.float64)):
        i = wp.tid()
        _phi, ti, _k = ak.law_values(law_id, h[i], wp.float64(0.0), pa, pb, pc)
        t[i] = ti

    law_id, (pa, pb, pc), _ = law.normal_law(model)
    L, S = model.length_scale, model.traction_scale
    gaps = np.array([g * law.rho for g in CHECK_GAPS])
    h = wp.array(gaps / L, dtype=wp.float64, device=model.device)
    t = wp.zeros(len(gaps), dtype=wp.float64, device=model.device)
    wp.launch(traction_at, dim=len(gaps), inputs=[h, law_id, pa, pb, pc], outputs=[t], device=model.device)
    state_z = lambda c: {"delta_z": c["delta"]["z"], "force_z": c["force"]["z"], "branch": c["branch"]}
    retract = [c for c in r["curve"] if c["branch"] == "retract"]
    return {
        "code": "warpcontact", "n": case.grid.n, "size": case.grid.size, "radius": case.sphere.radius,
        "E_star": case.pair.E_star, "w": law.work_of_adhesion, "rho": law.rho,
        "initial_gap": model.sphere.initial_gap(model.grid).tolist(),
        "length_scale": L,
        "check_gaps": gaps.tolist(), "check_tractions": (t.numpy() * S).tolist(),
        "curve": [state_z(c) for c in r["curve"]],
        "states": len(r["curve"]) + len(r["refined"]),
        "pull_off_force": r["pull_off_force"], "pull_off_delta_z": r["pull_off_delta_z"],
        "pull_off_path": min(c["force"]["z"] for c in retract),
        "converged": r["converged"], "solve_s": r["elapsed_s"], "setup_s": setup,
        "solver": f"AdhesiveNormalSolver, relative projected gradient (2-norm) < {solver.adhesive.tol:g}",
        "threads": os.cpu_count(),
    }


# ----------------------------------------------------------------------------------------------
# theirs (the Adhesion package)
def worker_theirs(a) -> dict:
    import Adhesion
    import ContactMechanics
    import numpy as np
    from Adhesion.Interactions import Exponential
    from Adhesion.System import BoundedSmoothContactSystem
    from ContactMechanics import FreeFFTElasticHalfSpace
    from SurfaceTopography import make_sphere

    plan = json.loads(Path(a.plan).read_text())
    n, size, R, E, w, rho = (plan[k] for k in ("n", "size", "radius", "E_star", "w", "rho"))
    dx = size / n
    t0 = time.perf_counter()
    substrate = FreeFFTElasticHalfSpace((n, n), E, (size, size))
    # our cell centres: (i - (n - 1) / 2) dx; theirs i dx - centre
    surface = make_sphere(R, (n, n), (size, size), centre=(size / 2 - dx / 2, size / 2 - dx / 2))
    h0 = np.array(plan["initial_gap"])
    height_error = float(np.max(np.abs(surface.heights() + h0.T)))  # ours [y, x], theirs [x, y]
    # sqrt(R^2 - r^2) - R loses digits to cancellation: round-off of a few eps R
    assert height_error <= 16 * np.finfo(float).eps * R, f"sphere heights differ by {height_error:g} m"
    interaction = Exponential(w, rho)
    system = BoundedSmoothContactSystem(substrate, interaction, surface)
    _, dV, _ = interaction.evaluate(np.array(plan["check_gaps"]), potential=True, gradient=True)
    setup = time.perf_counter() - t0
    options = {"gtol": a.gtol * (w / rho) * dx * dx, "ftol": 0.0, "maxiter": 100_000}
    records, messages = [], {}
    disp, prev = None, None

    def solve(offset, x0):
        nonlocal disp, prev
        if x0 is not None and prev is not None:
            x0 = x0 + (offset - prev)  # the last state shifted with the rigid body (their tests' warm start)
        sol = system.minimize_proxy(offset=offset, initial_displacements=x0, lbounds="auto", options=options)
        messages[str(sol.message)] = messages.get(str(sol.message), 0) + 1
        disp, prev = sol.x.reshape(substrate.nb_subdomain_grid_pts).copy(), offset
        return {"delta_z": offset, "force_z": float(system.compute_normal_force()), "nit": int(sol.nit),
                "success": bool(sol.success)}

    t1 = time.perf_counter()
    weakest, before_weakest, before = None, None, None
    for c in plan["curve"]:
        before = disp
        s = solve(c["delta_z"], disp)
        s["branch"] = c["branch"]
        records.append(s)
        if c["branch"] == "retract" and (weakest is None or s["force_z"] < records[weakest]["force_z"]):
            weakest, before_weakest = len(records) - 1, (before, records[-2]["delta_z"])
    refined = []
    if weakest is not None and weakest + 1 < len(records):  # substeps from the state before the weakest
        z_from, z_to = records[weakest - 1]["delta_z"], records[weakest + 1]["delta_z"]
        disp, prev = before_weakest[0], before_weakest[1]
        for j in range(1, SUBSTEPS):
            refined.append(solve(z_from + (z_to - z_from) * j / SUBSTEPS, disp))
    solve_s = time.perf_counter() - t1
    retract = [s for s in records if s["branch"] == "retract"]
    low = min(retract + refined, key=lambda s: s["force_z"])
    return {
        "code": f"Adhesion {Adhesion.__version__} / ContactMechanics {ContactMechanics.__version__}",
        "n": n, "check_tractions": dV.tolist(), "height_error": height_error,
        "curve": records, "refined": refined, "states": len(records) + len(refined),
        "pull_off_force": low["force_z"], "pull_off_delta_z": low["delta_z"],
        "pull_off_path": min(s["force_z"] for s in retract),
        "converged": all(s["success"] for s in records + refined), "messages": messages,
        "nit": [s["nit"] for s in records + refined],
        "solve_s": solve_s, "setup_s": setup,
        "solver": f"minimize_proxy L-BFGS-B, max |projected gradient| per point < {a.gtol:g} (w/rho) dx^2, ftol 0",
    }


# ----------------------------------------------------------------------------------------------
# driver
def importable(path: str) -> str | None:
    env = {**os.environ, "PYTHONPATH": path}
    p = subprocess.run([sys.executable, "-c", "import Adhesion, ContactMechanics, SurfaceTopography"],
                       check=False, env=env, capture_output=True, text=True)
    return None if p.returncode == 0 else (p.stderr.strip().splitlines() or ["?"])[-1]


def run_worker(kind: str, a, k: int) -> dict:
    out = Path(a.out) / f"{kind}_{k}.json"
    cmd = [sys.executable, str(Path(__file__).resolve()), "--worker", kind, "--case", a.case, "--steps",
           str(a.steps), "--gtol", str(a.gtol), "--result", str(out)]
    env = dict(os.environ)
    if kind == "theirs":
        cmd += ["--plan", str(Path(a.out) / "plan.json")]
        env["PYTHONPATH"] = a.adhesion_path
        if a.their_blas_threads:  # scipy's L-BFGS-B (setulb) runs on OpenBLAS: its threads fight on a busy CPU
            env["OPENBLAS_NUM_THREADS"] = env["OMP_NUM_THREADS"] = str(a.their_blas_threads)
    t0 = time.perf_counter()
    p = subprocess.run(cmd, check=False, env=env, cwd=ROOT, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if p.returncode != 0:
        sys.exit(f"the {kind} run failed ({p.returncode}):\n{p.stderr[-3000:]}")
    r = json.loads(out.read_text())
    r["wall_s"] = wall
    out.write_text(json.dumps(r))
    print(f"  {kind} run {k}: solves {r['solve_s']:.1f} s, process {wall:.1f} s, {r['states']} states, "
          f"pull-off {r['pull_off_force']:.5e} N", flush=True)
    return r


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", default="examples/pull_off_jkr.toml")
    ap.add_argument("--steps", type=int, default=20, help="steps each way of our path (default 20, the CLI's)")
    ap.add_argument("--repeats", type=int, default=2, help="runs of each code, A B A B (default 2)")
    ap.add_argument("--adhesion-path", default="/tmp/adhpkg",
                    help="PYTHONPATH of the Adhesion package's install (default /tmp/adhpkg)")
    ap.add_argument("--gtol", type=float, default=1e-7,
                    help="theirs: max |projected gradient| per point in units of (w / rho) dx^2 (default 1e-7)")
    ap.add_argument("--their-blas-threads", type=int, default=1,
                    help="theirs: OPENBLAS_NUM_THREADS and OMP_NUM_THREADS (default 1, their fastest here; 0: "
                         "leave the environment's)")
    ap.add_argument("--out", default="out/adhesion_package")
    ap.add_argument("--worker", choices=["ours", "theirs"], help=argparse.SUPPRESS)
    ap.add_argument("--plan", help=argparse.SUPPRESS)
    ap.add_argument("--result", help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.worker:
        r = (worker_ours if a.worker == "ours" else worker_theirs)(a)
        Path(a.result).write_text(json.dumps(r))
        return 0
    if a.repeats < 1:
        print("error: --repeats must be at least 1", file=sys.stderr)
        return 2
    why = importable(a.adhesion_path)
    if why:
        print(f"error: the Adhesion package is not importable with PYTHONPATH={a.adhesion_path} ({why}); install "
              f"it with: pip install --target {a.adhesion_path} adhesion contactmechanics "
              f"(or pass --adhesion-path DIR)", file=sys.stderr)
        return 2
    Path(a.out).mkdir(parents=True, exist_ok=True)
    ours, theirs = [], []
    for k in range(a.repeats):  # A B A B
        ours.append(run_worker("ours", a, k))
        if k == 0:
            plan = {key: ours[0][key] for key in ("n", "size", "radius", "E_star", "w", "rho", "initial_gap",
                                                  "check_gaps", "curve")}
            (Path(a.out) / "plan.json").write_text(json.dumps(plan))
            for g, t in zip(ours[0]["check_gaps"], ours[0]["check_tractions"]):
                print(f"  our traction at gap {g:.3e} m: {t:.6e} Pa")
        else:
            assert [c["delta_z"] for c in ours[k]["curve"]] == [c["delta_z"] for c in ours[0]["curve"]]
        theirs.append(run_worker("theirs", a, k))
    o, t = ours[0], theirs[0]
    for g, x, y in zip(o["check_gaps"], o["check_tractions"], t["check_tractions"]):
        assert abs(x - y) <= TRACTION_RTOL * abs(x), f"the laws differ at gap {g:g} m: ours {x:.15e}, theirs {y:.15e} Pa"
    unit = math.pi * o["radius"] * o["w"]
    diffs = sorted(((abs(p["force_z"] - q["force_z"]) / unit, p["delta_z"], p["branch"])
                    for p, q in zip(o["curve"], t["curve"])), reverse=True)
    best_o, best_t = min(r["solve_s"] for r in ours), min(r["solve_s"] for r in theirs)
    tabor = (o["radius"] * o["w"] ** 2 / (o["E_star"] ** 2 * o["rho"] ** 3)) ** (1 / 3)
    lines = [
        (f"Case {a.case}: n = {o['n']}, Tabor parameter {tabor:.3g}, {len(o['curve'])} path states (same delta_z "
         f"list), pi R w = {unit:.4e} N."),
        "",
        ("| code | n | states | pull-off / (pi R w) refined | on the path | time [s] per run (solves; process) | "
         "best | curve: largest difference / (pi R w) |"),
        "|---|---|---|---|---|---|---|---|",
    ]
    where = (f"{diffs[0][0]:.1e} (at delta_z {diffs[0][1]:.3e} m, {diffs[0][2]}); "
             f"{diffs[1][0]:.1e} at every other state")
    for name, rs, best in (("warpcontact", ours, best_o), (t["code"], theirs, best_t)):
        times = ", ".join(f"{r['solve_s']:.1f} ({r['wall_s']:.1f})" for r in rs)
        lines.append(f"| {name} | {rs[0]['n']} | {rs[0]['states']} | {rs[0]['pull_off_force'] / unit:.4f} | "
                     f"{rs[0]['pull_off_path'] / unit:.4f} | {times} | {best:.1f} | "
                     f"{'-' if rs is ours else where} |")
    lines += [
        "| JKR (Tabor -> infinity) | | | -1.5 | | | | |",
        f"| Maugis-Dugdale, lambda = 1.127 mu = {1.127 * tabor:.2f} | | | {MD_AT_TABOR_3:.3f} | | | | |"
        if abs(tabor - 3.0) < 0.05 else None,
        "",
        f"Time ratio theirs / ours, best of {a.repeats}: {best_t / best_o:.1f}; per pair: "
        + ", ".join(f"{q['solve_s'] / p['solve_s']:.1f}" for p, q in zip(ours, theirs)) + ".",
        f"Ours: {o['solver']}, every state converged: {all(r['converged'] for r in ours)}.",
        (f"Theirs: {t['solver']}, every minimisation successful: {all(r['converged'] for r in theirs)} "
         f"({t['messages']}; L-BFGS-B iterations per state {min(t['nit'])}-{max(t['nit'])})."),
        (f"Tractions at gaps {', '.join(f'{g:.3g}' for g in o['check_gaps'])} m agree to {TRACTION_RTOL:g} "
         f"relative; sphere heights to {t['height_error']:.1e} m."),
    ]
    text = "\n".join(line for line in lines if line is not None)
    (Path(a.out) / "table.md").write_text(text + "\n")
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Iterations, time per step and memory against the grid: the frictionless and the coupled step,
the tangential solver as Chen & Wang publish it and preconditioned, side by side in one run.

The problem: copper on steel (``PAPER_PAIR``), R = 10 um, domain 4 sqrt(R delta_z),
delta_z = 1e-10 m then delta_x = 2e-11 m, one step per leg. Rows:

- ``normal``: frictionless, the step to delta_z from rest (one preconditioned normal solve);
- ``coupled plain`` / ``coupled precond``: Tabor + von Mises (k_tau = 0.8), the step to delta_z
  from rest, then the step to delta_x; the tangential solver with ``preconditioned`` False (Chen &
  Wang's iteration: two applications of K_tt per iteration) or True (one application and the
  block-circulant inverse on the stick cells, ``TangentialSolver``): the solver's defaults
  otherwise (the turns' normal solves preconditioned, their tolerance from the coupled residual);
- ``coupled before``: the coupled step without those two defaults (preconditioned
  tangential solves; plain normal solves in the turns, their tolerance from the last turn's
  change), side by side with ``coupled precond``;
- ``coupled nested``: ``coupled precond`` with the nested start (``SolverSettings.nested``: each
  step solved first on the grids of n/2, n/4, ... down to 64 cells, its tractions and statuses
  starting the step on n); the coarse grids' iterations are shown after a "+".
- ``coupled default`` / ``coupled window`` / ``coupled whole``: the solver's defaults (the nested
  start where ``nested = "auto"`` takes it; the window where ``window = "auto"`` takes it), then
  with the tangential solves always on the window of the grid that holds the contact
  (``SolverSettings.window``), then always on the whole grid (no window).

- ``coupled exact``: the solver's defaults, every turn's solves at the full tolerance
  (``turn_tolerance = "exact"``: fewer, more exact turns) instead of loose early
  turns.
- ``coupled unmixed``: ``coupled precond`` with the minimised turns (adhesion towards JKR) as the
  plain fixed point x <- G(x) instead of Anderson-mixed (``ContactSolver.turn_mixing``).

The rows ``coupled-plain`` ... ``coupled-nested`` take the window where ``"auto"`` does.
``--adhesion`` adds the SMC law (``SMC_LAW``) to every row: the adhesive coupled step.

Columns: the inner iterations (normal and tangential solves together) and turns of each step,
the tangential iterations among them, the side of the last tangential solve's window ("w", in
cells; none where it ran on the whole grid), the best wall time of each step over ``--repeats`` runs
after one untimed warm-up (kernels loaded, CUDA graphs captured; the device synchronised before
the clock stops), the model's set-up time, and ``wc.solve`` in process (the whole path through
the Python API: model, states, summaries and fields, second call of two) unless ``--no-api``.
On CUDA the device memory in use at its highest over the samples taken after the set-up and
after every step (total less free, less what the process held before the model), and Warp's
memory pool's high-water mark; each configuration runs in a process of its own, so neither
carries another's allocations. On the CPU the process's peak resident set.

    python bench/scaling.py                                   # CPU, n = 64 ... 1024
    python bench/scaling.py --sizes 64 128 256 --dtypes float64
    python bench/scaling.py --device cuda:0 --fft cupy        # GPU, n = 256 ... 8192
    python bench/scaling.py --rows coupled-plain coupled-precond --json out.json

Prints a markdown table (and with ``--json`` writes every number). Needs nothing outside the
repository and its Python dependencies.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import resource
import subprocess
import sys
import time

R, DZ, DX = 10e-6, 1.0e-10, 2.0e-11
A = math.sqrt(R * DZ)
#: ``--adhesion``: the SMC law of ``bench_iteration.py --adhesion`` (sigma_max = tau_max = 2e7 Pa,
#: delta_n = delta_t = 5e-12 m: Maugis parameter 0.41, the minimised turns)
SMC_LAW = {"law": "smc", "sigma_max": 2e7, "tau_max": 2e7, "delta_n": 5e-12, "delta_t": 5e-12}
ROWS = ("normal", "coupled-plain", "coupled-precond", "coupled-before", "coupled-nested", "coupled-default",
        "coupled-window", "coupled-whole", "coupled-exact", "coupled-unmixed")


def row_settings(row: str) -> dict:
    """The solver settings of a row (see the module docstring), by name."""
    if row == "normal":
        return {}
    choices = {"tangential_preconditioner": row != "coupled-plain"}
    if row in ("coupled-window", "coupled-whole"):
        choices["window"] = row == "coupled-window"
    if row == "coupled-exact":
        choices["turn_tolerance"] = "exact"
    if row == "coupled-unmixed":  # the minimised turns (adhesion) as the plain fixed point
        choices["turn_mixing"] = False
    if row not in ("coupled-default", "coupled-window", "coupled-whole", "coupled-exact"):
        choices["nested"] = row == "coupled-nested"
    if row == "coupled-before":
        choices.update(normal_preconditioner=False, turn_tolerance="change")
    return choices
CPU_SIZES = [64, 128, 256, 512, 1024]
GPU_SIZES = [256, 512, 1024, 2048, 4096, 8192]


def case_dict(n: int, friction: bool, device: str, dtype: str, fft: str, adhesion: bool = False) -> dict:
    """The problem as a case for ``wc.solve``: the paper's pair as Table 1 gives it."""
    from warpcontact.physics.materials import PAPER_PAIR

    def material(m):
        return {"E": m.E, "nu": m.nu, "yield_strength": m.yield_strength, "hardness": m.hardness}

    d = {"sphere": {"radius": R, **material(PAPER_PAIR.sphere)}, "flat": material(PAPER_PAIR.flat),
         "grid": {"n": n, "size": 4 * A},
         "load": {"delta_z": DZ, "delta_x": DX if friction else 0.0, "delta_y": 0.0, "steps": 1},
         "solver": {"device": device, "dtype": dtype, "fft": fft}}
    if friction:
        d["friction"] = {"law": "tabor", "k_tau": 0.8}
    if adhesion:
        d["adhesion"] = dict(SMC_LAW)
    return d


def measure(config: dict) -> dict:
    """One configuration (row, n, dtype, device, fft, repeats, api), in this process."""
    import warp as wp

    wp.config.quiet = True
    wp.init()
    from warpcontact.physics.friction import TaborVonMises
    from warpcontact.physics.geometry import Grid, Sphere
    from warpcontact.physics.materials import PAPER_PAIR
    from warpcontact.numerics.model import ContactModel
    from warpcontact.solvers.contact import ContactSolver
    from warpcontact.numerics.state import ContactState

    row, n, dtype = config["row"], config["n"], config["dtype"]
    device = wp.get_device(config["device"])
    cuda = device.is_cuda

    def in_use():
        wp.synchronize_device(device)
        return device.total_memory - device.free_memory

    base = in_use() if cuda else 0
    samples = []
    t0 = time.perf_counter()
    model = ContactModel(PAPER_PAIR, Sphere(R), Grid(n, 4 * A), device=device, dtype=dtype, fft=config["fft"])
    wp.synchronize_device(device)
    setup = time.perf_counter() - t0
    friction = TaborVonMises(0.8, PAPER_PAIR.softer.yield_strength) if row != "normal" else None
    adhesion = None
    if config.get("adhesion"):
        from warpcontact.physics.adhesion import SMC

        adhesion = SMC(*(SMC_LAW[k] for k in ("sigma_max", "tau_max", "delta_n", "delta_t")))
    solver = ContactSolver(model, friction, adhesion=adhesion, **row_settings(row))
    tangential = getattr(solver, "tangential", None)
    counts = {"tangential": 0}
    if tangential is not None:
        solve = tangential.solve

        def counted(*args, **kwargs):
            info = solve(*args, **kwargs)
            counts["tangential"] += info.iterations
            return info

        tangential.solve = counted
    steps = [(0.0, 0.0, DZ)] if row == "normal" else [(0.0, 0.0, DZ), (DX, 0.0, DZ)]
    out = {**config, "setup_s": setup, "steps": []}
    best = [math.inf] * len(steps)
    for repeat in range(config["repeats"] + 1):
        state = ContactState(model)
        records = []
        for k, approach in enumerate(steps):
            counts["tangential"] = 0
            wp.synchronize_device(device)
            t0 = time.perf_counter()
            info = solver.step(state, approach)
            wp.synchronize_device(device)
            wall = time.perf_counter() - t0
            if repeat > 0:  # the first run loads the kernels and captures the graphs
                best[k] = min(best[k], wall)
            records.append({"iterations": info.iterations, "turns": info.outer_iterations,
                            "coarse_iterations": getattr(solver, "nested_iterations", 0),
                            "tangential_iterations": counts["tangential"], "converged": bool(info.converged),
                            "window": tangential.last_window if tangential is not None else None})
            if cuda:
                samples.append(in_use() - base)
        out["steps"] = records
    for record, wall in zip(out["steps"], best):
        record["time_s"] = wall
    del solver, state, model
    if config["api"]:
        import warpcontact as wc
        from warpcontact.records.case import case_from_dict
        import warpcontact.studies.runner as runner

        case = case_from_dict(case_dict(n, row != "normal", config["device"], dtype, config["fft"],
                                        bool(config.get("adhesion"))))
        original = runner.ContactSolver

        def contact_solver(*args, **kwargs):  # the solver settings of the row
            return original(*args, **{**kwargs, **row_settings(row)})

        runner.ContactSolver = contact_solver
        try:
            times = []
            for _ in range(2):
                wp.synchronize_device(device)
                t0 = time.perf_counter()
                result = wc.solve(case)
                wp.synchronize_device(device)
                times.append(time.perf_counter() - t0)
                if cuda:
                    samples.append(in_use() - base)
                del result
        finally:
            runner.ContactSolver = original
        out["api_s"] = times[-1]
    if cuda:
        out["peak_in_use_bytes"] = max(samples) if samples else 0
        out["warp_pool_high_bytes"] = int(wp.get_mempool_used_mem_high(device)) if wp.is_mempool_enabled(device) else 0
    else:
        out["peak_rss_bytes"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    return out


def run_one(config: dict, timeout: float | None) -> dict:
    """:func:`measure` in a fresh process (clean memory counters); the error where it fails."""
    cmd = [sys.executable, os.path.abspath(__file__), "--one", json.dumps(config)]
    try:
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {**config, "error": f"over {timeout:.0f} s"}
    for line in reversed(done.stdout.splitlines()):
        if line.startswith("{"):
            return json.loads(line)
    tail = (done.stderr or done.stdout).strip().splitlines()
    return {**config, "error": tail[-1] if tail else f"exit {done.returncode}"}


def table(results: list, cuda: bool) -> str:
    """The markdown table of the results."""
    head = ["row", "n", "dtype", "step 1: iterations (turns) [tangential]", "step 1 [s]",
            "step 2: iterations (turns) [tangential]", "step 2 [s]", "set-up [s]", "wc.solve [s]",
            "GPU peak in use / Warp pool [GiB]" if cuda else "peak RSS [GiB]"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in results:
        if "error" in r:
            lines.append(f"| {r['row']} | {r['n']} | {r['dtype']} | {r['error']} |" + " |" * (len(head) - 4))
            continue
        cells = [r["row"], str(r["n"]), r["dtype"]]
        for k in range(2):
            if k < len(r["steps"]):
                s = r["steps"][k]
                mark = "" if s["converged"] else " (not converged)"
                coarse = f" +{s['coarse_iterations']}" if s.get("coarse_iterations") else ""
                window = f" w{s['window']}" if s.get("window") else ""
                cells += [f"{s['iterations']} ({s['turns']}) [{s['tangential_iterations']}]{coarse}{window}{mark}",
                          f"{s['time_s']:.3f}"]
            else:
                cells += ["", ""]
        cells += [f"{r['setup_s']:.2f}", f"{r['api_s']:.2f}" if "api_s" in r else ""]
        if cuda:
            cells.append(f"{r['peak_in_use_bytes'] / 2**30:.2f} / {r['warp_pool_high_bytes'] / 2**30:.2f}")
        else:
            cells.append(f"{r['peak_rss_bytes'] / 2**30:.2f}")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--fft", default="auto", help="FFT backend (auto, scipy, fftw, cupy, warp)")
    ap.add_argument("--sizes", type=int, nargs="+", help="n (default: CPU 64 ... 1024, CUDA 256 ... 8192)")
    ap.add_argument("--dtypes", nargs="+", default=["float64", "float32"], choices=["float64", "float32"])
    ap.add_argument("--rows", nargs="+", default=list(ROWS), choices=list(ROWS))
    ap.add_argument("--repeats", type=int, default=2, help="timed runs of each step after the warm-up (best kept)")
    ap.add_argument("--no-api", dest="api", action="store_false", help="skip the wc.solve timing")
    ap.add_argument("--timeout", type=float, default=None, help="seconds per configuration (default: none)")
    ap.add_argument("--adhesion", action="store_true", help="every row with the SMC law (SMC_LAW) added")
    ap.add_argument("--json", help="write every number here")
    ap.add_argument("--one", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.one:
        print(json.dumps(measure(json.loads(args.one))), flush=True)
        return
    cuda = args.device.startswith("cuda")
    sizes = args.sizes or (GPU_SIZES if cuda else CPU_SIZES)
    results = []
    for n in sizes:
        for dtype in args.dtypes:
            for row in args.rows:
                config = {"row": row, "n": n, "dtype": dtype, "device": args.device, "fft": args.fft,
                          "repeats": args.repeats, "api": args.api, "adhesion": args.adhesion}
                r = run_one(config, args.timeout)
                results.append(r)
                print(f"# {row} n={n} {dtype}: " + (r["error"] if "error" in r else ", ".join(
                    f"{s['iterations']} it ({s['turns']} turns) {s['time_s']:.3f} s" for s in r["steps"])),
                    file=sys.stderr, flush=True)
    print(f"<!-- python bench/scaling.py {' '.join(sys.argv[1:])}; {platform.node()}, {platform.processor() or ''} "
          f"{os.cpu_count()} CPUs -->")
    print(table(results, cuda))
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"argv": sys.argv, "results": results}, f, indent=1)


if __name__ == "__main__":
    main()

"""The batch engine's cost per case beyond the cases themselves, and the time to a first answer.

    python3 bench/batch_overhead.py                       # 100-case sweep at n = 128, 3 placements
    python3 bench/batch_overhead.py --cases 20 --n 64     # shorter
    python3 bench/batch_overhead.py --help-time           # `warpcontact --help`, whole processes
    python3 bench/batch_overhead.py --table2 32 --workers 2   # table2 --no-adhesion, whole process

The sweep: frictionless Hertz solves of examples/hertz.toml (one state each) at ``--cases``
approaches between 0.8e-10 and 1.0e-10 m on one grid, so every case after a worker's first reuses
its model (warpcontact.studies.batch.cached_model). Each placement (this process; a local cluster of 1
worker; of 2 workers) runs the same sweep into a fresh folder, and reports:

- start: starting the local cluster [s] (0 in this process);
- wall: from the first submission to the last case written [s];
- case: the sum over cases of the time inside the case's function on its worker (cached model
  looked up, solver set up, solve, summary) [s];
- overhead per case = (wall x workers - case) / cases [ms]: worker time not spent in a case
  (scheduling, moving results, writing each record, sweep.csv and sweep.json, progress);
- fresh model per case: the mean time of ``api.solve`` with a model of its own, for the first 5
  cases (what each case would cost without the cache) [ms].

Times are wall-clock on whatever machine runs it; the CPU's cores are shared by the workers.
"""

from __future__ import annotations

import argparse
import json
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
HERTZ = ROOT / "examples" / "hertz.toml"


def sweep_file(folder: Path, cases: int, n: int, device: str) -> Path:
    values = ", ".join(f"{0.8e-10 + 0.2e-10 * i / max(1, cases - 1):.6e}" for i in range(cases))
    text = HERTZ.read_text().replace("n = 128 ", f"n = {n} ").replace('device = "cpu"', f'device = "{device}"')
    (folder / "base.toml").write_text(text)
    path = folder / "sweep.toml"
    path.write_text(f'base = "base.toml"\n[sweep]\n"load.delta_z" = [{values}]\n[run]\ntask = "solve"\n')
    return path


def run_placement(path: Path, workers: int | None, in_process: bool) -> dict:
    from warpcontact.studies.batch import Placement
    from warpcontact.studies.sweep import run_sweep
    from warpcontact.studies.sweep_spec import load_sweep

    sweep = load_sweep(path)
    out = Path(tempfile.mkdtemp(prefix="batch_overhead_"))
    try:
        t0 = time.perf_counter()
        if in_process:
            report = run_sweep(sweep, out, quiet=True, placement=Placement(workers=1))
        elif workers == 1:  # Placement(workers=1) alone means this process
            report = _one_worker_cluster(sweep, out)
        else:
            report = run_sweep(sweep, out, quiet=True, placement=Placement(workers=workers))
        total = time.perf_counter() - t0
    finally:
        shutil.rmtree(out, ignore_errors=True)
    b = report.batch
    n = len(report.records)
    assert n == len(sweep.cases) and all(r["converged"] for r in report.records), "a case did not converge"
    return {"where": b.where, "workers": b.workers, "cases": n, "start_s": b.start_s, "wall_s": b.wall_s,
            "case_s": b.task_s, "total_s": total, "overhead_ms": 1e3 * (b.wall_s * b.workers - b.task_s) / n,
            "case_ms": 1e3 * b.task_s / n}


def _one_worker_cluster(sweep, out):
    """A sweep on a local cluster of one worker process (Placement(workers=1) runs in this process)."""
    from distributed import LocalCluster

    from warpcontact.studies.batch import Placement
    from warpcontact.studies.sweep import run_sweep

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None,
                      host="127.0.0.1", memory_limit=0) as cluster:
        return run_sweep(sweep, out, quiet=True, placement=Placement(scheduler=cluster.scheduler_address))


def fresh_model_ms(path: Path, count: int = 5) -> float:
    from warpcontact import api
    from warpcontact.studies.sweep_spec import load_sweep

    times = []
    for sc in load_sweep(path).cases[:count]:
        t0 = time.perf_counter()
        api.solve(sc.case)
        times.append(time.perf_counter() - t0)
    return 1e3 * statistics.mean(times)


def help_time(repeat: int = 9) -> dict:
    exe = shutil.which("warpcontact")
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        subprocess.run([exe, "--help"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
        times.append(time.perf_counter() - t0)
    return {"best_s": min(times), "median_s": statistics.median(times), "repeat": repeat}


def table2_time(n: int, workers: int) -> dict:
    out = Path(tempfile.mkdtemp(prefix="batch_t2_"))
    try:
        t0 = time.perf_counter()
        r = subprocess.run([sys.executable, "-m", "warpcontact.cli", "table2", "--no-adhesion", "--n", str(n),
                            "--workers", str(workers), "--quiet", "--out", str(out)], capture_output=True, text=True)
        wall = time.perf_counter() - t0
        cells = json.loads((out / "table2.json").read_text())["cells"]
    finally:
        shutil.rmtree(out, ignore_errors=True)
    return {"n": n, "workers": workers, "wall_s": wall, "cells": len(cells), "status": r.returncode,
            "cell_s_sum": sum(c["elapsed_s"] for c in cells)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=100)
    ap.add_argument("--n", type=int, default=128)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--placements", default="process,1,2",
                    help="comma-separated: 'process' (in this process) and worker counts of a local cluster")
    ap.add_argument("--help-time", action="store_true", help="time `warpcontact --help` only")
    ap.add_argument("--table2", type=int, metavar="N", help="time `table2 --no-adhesion --n N` only")
    ap.add_argument("--workers", type=int, default=2, help="workers of --table2")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    if args.help_time:
        r = help_time()
        print(json.dumps(r) if args.json else f"warpcontact --help: best {r['best_s']:.3f} s, median "
                                               f"{r['median_s']:.3f} s of {r['repeat']}")
        return
    if args.table2:
        r = table2_time(args.table2, args.workers)
        print(json.dumps(r) if args.json else f"table2 --no-adhesion --n {r['n']} --workers {r['workers']}: "
              f"{r['wall_s']:.1f} s whole process, {r['cells']} cells (sum of cell times {r['cell_s_sum']:.1f} s), "
              f"exit {r['status']}")
        return
    folder = Path(tempfile.mkdtemp(prefix="batch_sweep_"))
    try:
        path = sweep_file(folder, args.cases, args.n, args.device)
        rows = []
        for p in args.placements.split(","):
            in_process = p == "process"
            rows.append(run_placement(path, None if in_process else int(p), in_process))
        fresh = fresh_model_ms(path)
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    if args.json:
        print(json.dumps({"n": args.n, "cases": args.cases, "fresh_model_case_ms": fresh, "placements": rows}))
        return
    print(f"{args.cases}-case sweep, n = {args.n}, {args.device}; a case with a model of its own: {fresh:.0f} ms")
    print("| where | workers | start [s] | wall [s] | case, mean [ms] | overhead per case [ms] |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['where']} | {r['workers']} | {r['start_s']:.2f} | {r['wall_s']:.2f} | {r['case_ms']:.0f} | "
              f"{r['overhead_ms']:.1f} |")


if __name__ == "__main__":
    main()

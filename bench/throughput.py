"""Cases per second of many small cases on one device: one at a time, worker processes, batched solves.

    python3 bench/throughput.py --device cuda --sizes 128 256 --cases 200 --workers 4 8 16
    python3 bench/throughput.py --device cpu --sizes 64 128 --cases 24 --workers 2
    python3 bench/throughput.py --problem normal --device cuda --sizes 64 128 256 512 --cases 512 --batches 16 64 256

The case is a sweep's: the paper's pair (Table 1), R = 10 um, Tabor + von Mises (k_tau 0.8),
domain 4 sqrt(R delta_z), one normal step to delta_z = 1e-10 m and one tangential step to
delta_x, the cases' delta_x spread over 1.0e-11 ... 3.0e-11 m (every one in partial slip). Each
size runs, side by side in one process:

- ``api``: ``warpcontact.solve(case, fields="none", model=...)`` one case after another in this
  process, the model built once (kernels compiled and FFT plans made by one warm-up case first);
- ``W workers``: the sweep engine (``run_sweep``, one case at a time: ``batch=0``) on a local
  cluster of W processes, this one included (on CUDA pinned to the host's GPUs in turn: several
  to a GPU where W passes their number), each worker building its model once; the first case of
  each worker pays for its kernels' load from the on-disk cache. ``--batched-workers`` adds ``W
  workers, batched``: the same with the sweep's default batching, each worker solving its share
  of the cases together (``sweep.batched_groups``).

``batch B`` rows (``--batches``): ``warpcontact.solve_batch(cases, batch=B)`` (each batch's
kernels and transforms launched once for its B cases; one warm-up batch first); a case whose
batched step did not converge is solved on its own inside it (counted: ``solved_alone``).
``--plain-tangential`` adds, after them, the largest batch with the batched tangential solves'
plain iteration and again with the preconditioned one (the default), side by side;
``--padded-preconditioner`` likewise the largest batch with the preconditioners' circulants on
the padded grids and again on the grids themselves (the default, ``preconditioner_grid``). ``--parts``:
the largest batch once more, each part timed with the device synchronised around it (the
batched steps, the normal and tangential solves inside them, the yield checks), a table of its
own.

``--problem adhesive``: the coupled case with Table 2's SMC law (``[adhesion]``, the defaults of
``warpcontact table2``): the batched steps' lagged turns carry each case's adhesive tractions.

``--problem gross-slip``: the coupled case's gross-slip search (``find_gross_slip``: 4 normal
steps, then load and bisection steps, 14-18 states) at delta_z spread over 0.5 ... 1.5 x 1e-10 m:
``api`` one case after another (``tasks.gross_slip_summary``, the model reused) against ``batch
B`` rows (``batch_solve.gross_slip_batch``).

``--problem normal``: the same pair and sphere without ``[friction]``, one normal step to delta_z
spread over 0.5 ... 1.5 x 1e-10 m; besides ``api``, ``batch B`` rows (on CUDA
the yield checks of the cases a state ends made together); ``--own-checks`` adds ``api`` and the
largest batch with each case's yield check made depth by depth (on CUDA a case's depths are
otherwise evaluated together, ``yielding.state_yield_check``); ``--sweeps`` adds the command's own
path, ``run_sweep`` of the same cases (task "solve") in this process, each case written to its
folder as it ends: ``sweep, one at a time`` (``batch=0``) and ``sweep, batch B`` (the largest of
``--batches``).

Reported: the wall time from the first case to the last result [s], the cluster's start [s]
(apart), cases per second over the wall time, and the ratio to ``api``. Every case must converge.
Times are wall-clock on whatever machine runs it. ``--out DIR`` writes the rows as JSON lines
(default bench_results/throughput/, git-ignored).
"""

from __future__ import annotations

import argparse
import json
import math
import shutil
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

R, DZ = 10e-6, 1.0e-10
A = math.sqrt(R * DZ)


def base_case(n: int, device: str, dtype: str, adhesion: bool = False) -> str:
    """The case as TOML text (the paper's pair, Tabor k_tau 0.8; ``adhesion``: with Table 2's
    SMC law)."""
    from warpcontact.physics.materials import PAPER_PAIR
    from warpcontact.studies.table2 import Table2Settings

    def material(m):
        return f"E = {m.E!r}\nnu = {m.nu!r}\nyield_strength = {m.yield_strength!r}\nhardness = {m.hardness!r}\n"

    law = Table2Settings()
    smc = (f"[adhesion]\nlaw = \"smc\"\nsigma_max = {law.sigma_max!r}\ntau_max = {law.tau_max!r}\n"
           f"delta_n = {law.delta_n!r}\ndelta_t = {law.delta_t!r}\n\n")
    return (f"[sphere]\nradius = {R!r}\n{material(PAPER_PAIR.sphere)}\n[flat]\n{material(PAPER_PAIR.flat)}\n"
            f"[grid]\nn = {n}\nsize = {4 * A!r}\n\n[load]\ndelta_z = {DZ!r}\ndelta_x = 2e-11\nsteps = 1\n\n"
            f"[friction]\nlaw = \"tabor\"\nk_tau = 0.8\n\n" + (smc if adhesion else "")
            + f"[solver]\ndevice = \"{device}\"\ndtype = \"{dtype}\"\n")


def slips(cases: int) -> list[float]:
    return [1.0e-11 + 2.0e-11 * i / max(1, cases - 1) for i in range(cases)]


def sweep_file(folder: Path, n: int, cases: int, device: str, dtype: str, adhesion: bool = False) -> Path:
    (folder / "base.toml").write_text(base_case(n, device, dtype, adhesion))
    values = ", ".join(f"{v:.6e}" for v in slips(cases))
    path = folder / "sweep.toml"
    path.write_text(f'base = "base.toml"\n[sweep]\n"load.delta_x" = [{values}]\n[run]\ntask = "solve"\n')
    return path


def one_at_a_time(cases: list, own_checks: bool = False) -> dict:
    """``api``: the cases one after another in this process, one model; ``own_checks``: each
    case's yield check depth by depth (as on the CPU), not its depths together."""
    import warpcontact as wc
    from warpcontact.numerics import yielding
    from warpcontact.studies.runner import build_model

    by_planes = yielding.state_yield_check
    if own_checks:
        yielding.state_yield_check = yielding._own_yield_check
    try:
        model = build_model(cases[0])
        wc.solve(cases[0], fields="none", model=model)  # warm-up: kernels, plans
        t0 = time.perf_counter()
        results = [wc.solve(case, fields="none", model=model) for case in cases]
        wall = time.perf_counter() - t0
    finally:
        yielding.state_yield_check = by_planes
    assert all(r.converged for r in results), "a case did not converge"
    return {"placement": "api" + (", own checks" if own_checks else ""), "workers": 1, "cases": len(cases),
            "start_s": 0.0, "wall_s": wall}


def normal_cases(n: int, cases: int, device: str, dtype: str) -> list:
    """``--problem normal``: the paper's pair without friction, one step to delta_z spread over
    0.5 ... 1.5 x DZ, the domain 4 contact radii at the deepest."""
    import warpcontact as wc
    from warpcontact.physics.materials import PAPER_PAIR

    def material(m):
        return {"E": m.E, "nu": m.nu, "yield_strength": m.yield_strength, "hardness": m.hardness}

    size = 4 * math.sqrt(R * 1.5 * DZ)
    return [wc.case_from_dict({"sphere": {"radius": R, **material(PAPER_PAIR.sphere)}, "flat": material(PAPER_PAIR.flat),
                               "grid": {"n": n, "size": size},
                               "load": {"delta_z": DZ * (0.5 + i / max(1, cases - 1)), "steps": 1},
                               "solver": {"device": device, "dtype": dtype}})
            for i in range(cases)]


def normal_sweep_file(folder: Path, n: int, cases: int, device: str, dtype: str) -> Path:
    """``normal_cases``' cases as a sweep file: the base without friction, their delta_z swept."""
    base = base_case(n, device, dtype).replace('[friction]\nlaw = "tabor"\nk_tau = 0.8\n\n', "")
    base = base.replace("delta_x = 2e-11\n", "").replace(f"size = {4 * A!r}", f"size = {4 * math.sqrt(R * 1.5 * DZ)!r}")
    (folder / "base.toml").write_text(base)
    values = ", ".join(repr(DZ * (0.5 + i / max(1, cases - 1))) for i in range(cases))
    path = folder / "sweep.toml"
    path.write_text(f'base = "base.toml"\n[sweep]\n"load.delta_z" = [{values}]\n[run]\ntask = "solve"\n')
    return path


def swept(path: Path, batch: int) -> dict:
    """``sweep, ...``: ``run_sweep`` of the file in this process, ``batch`` cases per batched solve
    (0: one at a time), after a warm-up sweep of its first cases."""
    from warpcontact.studies.batch import Placement
    from warpcontact.studies.sweep import run_sweep
    from warpcontact.studies.sweep_spec import load_sweep

    sweep = load_sweep(path)
    out = Path(tempfile.mkdtemp(prefix="throughput_"))
    try:
        warm = replace(sweep, cases=sweep.cases[:max(2, min(batch, len(sweep.cases)))])
        run_sweep(warm, out / "warm", quiet=True, placement=Placement(workers=1), batch=batch)
        t0 = time.perf_counter()
        report = run_sweep(sweep, out / "run", quiet=True, placement=Placement(workers=1), batch=batch)
        wall = time.perf_counter() - t0
    finally:
        shutil.rmtree(out, ignore_errors=True)
    assert len(report.records) == len(sweep.cases) and all(r["converged"] for r in report.records), \
        "a case did not converge"
    return {"placement": "sweep, " + (f"batch {batch}" if batch else "one at a time"), "workers": 1,
            "cases": len(report.records), "start_s": 0.0, "wall_s": wall}


def batched(cases: list, batch: int, own_checks: bool = False, plain_tangential: bool = False,
            padded: bool = False) -> dict:
    """``batch B``: ``solve_batch`` with batches of B cases (None: its default, the row ``solve_batch
    default``: on the CPU one at a time); ``own_checks``: each case's yield
    check made on its own (as on the CPU), not the batch's together; ``plain_tangential``: the
    batched tangential solves' plain iteration (``BatchContactSolver.tangential_preconditioned``
    False) instead of the preconditioned one; ``padded``: the batched preconditioners on the
    padded grids (``periodic_preconditioner`` False), not the grids themselves."""
    import warpcontact as wc
    from warpcontact.fft.batch import BatchConvolution, BatchElasticOperator
    from warpcontact.solvers.contact_batch import BatchContactSolver
    from warpcontact.studies import batch_solve

    made_together, own_solve = batch_solve._yield_checks, batch_solve.run_path
    BatchContactSolver.tangential_preconditioned = not plain_tangential
    BatchConvolution.periodic_preconditioner = BatchElasticOperator.periodic_preconditioner = not padded
    alone = []
    if own_checks:
        def own(ended, arrays):  # each case's state gets its row, for its own check at its end
            for m in ended:
                m.copy_fields(arrays)
            return {}

        batch_solve._yield_checks = own

    def counted(case, **kw):  # a case the batch handed back to be solved on its own
        alone.append(case)
        return own_solve(case, **kw)

    batch_solve.run_path = counted
    try:
        wc.solve_batch(cases[:batch or 8], batch=batch)  # warm-up: kernels, plans of this batch size
        alone.clear()
        t0 = time.perf_counter()
        results = wc.solve_batch(cases, batch=batch)
        wall = time.perf_counter() - t0
    finally:
        batch_solve._yield_checks, batch_solve.run_path = made_together, own_solve
        BatchContactSolver.tangential_preconditioned = True
        BatchConvolution.periodic_preconditioner = BatchElasticOperator.periodic_preconditioner = True
    assert all(not isinstance(r, Exception) and r.converged for r in results), "a case did not converge"
    return {"placement": (f"batch {batch}" if batch else "solve_batch default") + (", own checks" if own_checks else "")
            + (", plain tangential" if plain_tangential else "")
            + (", padded preconditioners" if padded else ""), "workers": 1,
            "cases": len(cases), "start_s": 0.0, "wall_s": wall, "solved_alone": len(alone)}


def batched_parts(cases: list, batch: int) -> dict:
    """``--parts``: ``solve_batch`` with batches of B cases (after a warm-up batch), each part timed
    with the device synchronised before and after it: the batched steps (``BatchContactSolver.step``),
    the normal and tangential solves inside them (every batched solver's ``solve``: the whole
    grid's and the windows'), the yield checks made together (CUDA) and those each case makes on
    its own (``own yield checks``: the CPU's). Seconds of each, and the whole; and each kind of
    solve's useful share: the rows' iterations summed over the rows times the most of a row, per
    batched solve summed (a batched iteration passes over every row while any row goes on)."""
    import warp as wp

    import warpcontact as wc
    from warpcontact.numerics import yielding
    from warpcontact.solvers import contact_batch, normal_batch, tangential_batch
    from warpcontact.studies import batch_solve

    seconds = {"steps": 0.0, "normal solves": 0.0, "tangential solves": 0.0, "yield checks": 0.0,
               "own yield checks": 0.0}
    rows = {"normal solves": [0, 0], "tangential solves": [0, 0]}  # the rows' iterations, rows x the most
    wrapped = [(contact_batch.BatchContactSolver, "step", "steps"),
               (normal_batch.BatchNormalSolver, "solve", "normal solves"),
               (tangential_batch.BatchTangentialSolver, "solve", "tangential solves"),
               (batch_solve, "_yield_checks", "yield checks"),
               (yielding, "_own_yield_check", "own yield checks")]
    originals = [getattr(owner, name) for owner, name, _ in wrapped]

    def timed(f, part):
        def run(*args, **kwargs):
            wp.synchronize()
            t0 = time.perf_counter()
            try:
                result = f(*args, **kwargs)
            finally:
                wp.synchronize()
                seconds[part] += time.perf_counter() - t0
            if part in rows:  # one SolveInfo a row
                iterations = [int(info.iterations) for info in result]
                rows[part][0] += sum(iterations)
                rows[part][1] += len(iterations) * max(iterations, default=0)
            return result
        return run

    wc.solve_batch(cases[:batch], batch=batch)  # warm-up: kernels, plans of this batch size
    for (owner, name, part), f in zip(wrapped, originals):
        setattr(owner, name, timed(f, part))
    try:
        wp.synchronize()
        t0 = time.perf_counter()
        wc.solve_batch(cases, batch=batch)
        wp.synchronize()
        seconds["whole"] = time.perf_counter() - t0
    finally:
        for (owner, name, _), f in zip(wrapped, originals):
            setattr(owner, name, f)
    for part, (useful, passed) in rows.items():
        seconds[f"{part.split()[0]} useful share"] = useful / passed if passed else 1.0
    return seconds


def slip_cases(n: int, cases: int, device: str, dtype: str) -> list:
    """``--problem adhesive``: the coupled case with Table 2's SMC law (``[adhesion]``, the defaults of
``warpcontact table2``): the batched steps' lagged turns carry each case's adhesive tractions.

``--problem gross-slip``: the coupled case's pair and law, the gross-slip search at
    delta_z spread over 0.5 ... 1.5 x DZ (4 normal steps, then the load and bisection steps)."""
    from warpcontact.studies.sweep_spec import load_sweep
    from warpcontact.studies.tasks import prepare

    folder = Path(tempfile.mkdtemp(prefix="throughput_case_"))
    try:
        (folder / "base.toml").write_text(base_case(n, device, dtype).replace("delta_x = 2e-11\n", ""))
        values = ", ".join(repr(DZ * (0.5 + i / max(1, cases - 1))) for i in range(cases))
        path = folder / "sweep.toml"
        path.write_text(f'base = "base.toml"\n[sweep]\n"load.delta_z" = [{values}]\n[run]\ntask = "gross-slip"\n')
        return [prepare(sc.case) for sc in load_sweep(path).cases]
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def searched(cases: list, batch: int) -> dict:
    """``--problem gross-slip``: ``api`` (batch 0: ``gross_slip_summary`` one case after another,
    the model reused) or ``batch B`` (``batch_solve.gross_slip_batch``), after a warm-up."""
    from warpcontact.studies.batch_solve import gross_slip_batch
    from warpcontact.studies.runner import build_model
    from warpcontact.studies.tasks import gross_slip_summary

    if batch:
        gross_slip_batch(cases[:batch], batch=batch)
        t0 = time.perf_counter()
        results = [r if isinstance(r, Exception) else r[0] for r in gross_slip_batch(cases, batch=batch)]
    else:
        model = build_model(cases[0])
        gross_slip_summary(cases[0], model=model)
        t0 = time.perf_counter()
        results = [gross_slip_summary(c, model=model) for c in cases]
    wall = time.perf_counter() - t0
    assert all(not isinstance(r, Exception) and r["converged"] for r in results), "a case did not converge"
    return {"placement": f"batch {batch}" if batch else "api", "workers": 1, "cases": len(cases), "start_s": 0.0,
            "wall_s": wall, "states": sum(len(r["states"]) for r in results)}


def with_workers(path: Path, workers: int, batch: int | None = 0) -> dict:
    """``W workers``: the sweep engine on a local cluster of ``workers`` processes, ``batch`` cases
    per batched solve (0: one at a time; None: the sweep's default)."""
    from warpcontact.studies.batch import Placement
    from warpcontact.studies.sweep import run_sweep
    from warpcontact.studies.sweep_spec import load_sweep

    sweep = load_sweep(path)
    out = Path(tempfile.mkdtemp(prefix="throughput_"))
    try:
        report = run_sweep(sweep, out, quiet=True, placement=Placement(workers=workers), batch=batch)
    finally:
        shutil.rmtree(out, ignore_errors=True)
    assert len(report.records) == len(sweep.cases) and all(r["converged"] for r in report.records), \
        "a case did not converge"
    b = report.batch
    return {"placement": f"{workers} workers" + (", batched" if batch != 0 else ""), "workers": b.workers,
            "cases": len(report.records),
            "start_s": b.start_s, "wall_s": b.wall_s}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--dtype", default="float64", choices=["float64", "float32"])
    ap.add_argument("--sizes", type=int, nargs="+", default=[64, 128])
    ap.add_argument("--cases", type=int, default=24)
    ap.add_argument("--workers", type=int, nargs="*", default=[2],
                    help="worker counts of the local clusters (besides the one-at-a-time row; none: that row alone)")
    ap.add_argument("--problem", default="coupled", choices=["coupled", "adhesive", "normal", "gross-slip"],
                    help="coupled: Tabor friction, a normal and a tangential step; adhesive: the same with Table 2's "
                         "SMC law; normal: no friction, one step; gross-slip: the coupled case's gross-slip search")
    ap.add_argument("--batches", type=int, nargs="*", default=[16, 64],
                    help="batch sizes of the batched rows (none: no batched row)")
    ap.add_argument("--default-batch", action="store_true",
                    help="normal: add a row of solve_batch without --batch (its default: on the CPU one at a time)")
    ap.add_argument("--batched-workers", action="store_true",
                    help="add the workers' rows with the sweep's default batching (each worker its share together)")
    ap.add_argument("--own-checks", action="store_true",
                    help="add rows with each case's yield check made depth by depth (one at a time; the "
                         "largest batch)")
    ap.add_argument("--sweeps", action="store_true",
                    help="add run_sweep of the cases, one at a time and batched (--problem normal)")
    ap.add_argument("--plain-tangential", action="store_true",
                    help="coupled: add rows of the largest batch with the batched tangential solves' plain iteration")
    ap.add_argument("--padded-preconditioner", action="store_true",
                    help="add rows of the largest batch with the preconditioners' circulants on the padded grids, "
                         "then on the grids themselves (the default)")
    ap.add_argument("--parts", action="store_true",
                    help="coupled: the largest batch once more with its parts timed (steps, normal and tangential "
                         "solves, yield checks; the device synchronised around each)")
    ap.add_argument("--out", default="bench_results/throughput")
    args = ap.parse_args(argv)
    if any(w < 2 for w in args.workers):
        ap.error("--workers: counts of at least 2 (one worker is the 'api' row)")
    import warp as wp

    wp.config.quiet = True
    out_dir = Path(args.out)
    out_dir.mkdir(parents=True, exist_ok=True)
    log = out_dir / f"throughput_{args.device.replace(':', '')}_{time.strftime('%Y%m%d_%H%M%S')}.jsonl"
    rows, parts = [], []
    for n in args.sizes:
        if args.problem == "gross-slip":
            cases = slip_cases(n, args.cases, args.device, args.dtype)
            base = searched(cases, 0)
            runs = [base] + [searched(cases, b) for b in args.batches]
        elif args.problem == "normal":
            cases = normal_cases(n, args.cases, args.device, args.dtype)
            base = one_at_a_time(cases)
            runs = [base] + [batched(cases, b) for b in args.batches]
            if args.default_batch:
                runs.append(batched(cases, None))
            if args.own_checks:
                runs.append(one_at_a_time(cases, own_checks=True))
                if args.batches:
                    runs.append(batched(cases, max(args.batches), own_checks=True))
            if args.sweeps:
                folder = Path(tempfile.mkdtemp(prefix="throughput_case_"))
                try:
                    path = normal_sweep_file(folder, n, args.cases, args.device, args.dtype)
                    runs += [swept(path, 0), swept(path, max(args.batches or [16]))]
                finally:
                    shutil.rmtree(folder, ignore_errors=True)
        else:
            folder = Path(tempfile.mkdtemp(prefix="throughput_case_"))
            try:
                from warpcontact.studies.sweep_spec import load_sweep

                path = sweep_file(folder, n, args.cases, args.device, args.dtype, args.problem == "adhesive")
                cases = [sc.case for sc in load_sweep(path).cases]
                base = one_at_a_time(cases)
                runs = [base] + [with_workers(path, w) for w in args.workers]
                if args.batched_workers:
                    runs += [with_workers(path, w, None) for w in args.workers]
                runs += [batched(cases, b) for b in args.batches]
                if args.plain_tangential and args.batches:
                    runs += [batched(cases, max(args.batches), plain_tangential=True), batched(cases, max(args.batches))]
                if args.padded_preconditioner and args.batches:
                    runs += [batched(cases, max(args.batches), padded=True), batched(cases, max(args.batches))]
                if args.own_checks:
                    runs.append(one_at_a_time(cases, own_checks=True))
                if args.parts and args.batches:
                    parts.append((n, max(args.batches), batched_parts(cases, max(args.batches))))
            finally:
                shutil.rmtree(folder, ignore_errors=True)
        for r in runs:
            r.update(n=n, device=args.device, dtype=args.dtype, cases_per_s=r["cases"] / r["wall_s"],
                     ratio=base["wall_s"] / r["wall_s"])
            rows.append(r)
            with log.open("a") as f:
                f.write(json.dumps(r) + "\n")
            print(f"n={n} {r['placement']}: {r['cases_per_s']:.1f} cases/s ({r['ratio']:.2f}x)", file=sys.stderr,
                  flush=True)
    print("\n| n | placement | cases | wall [s] | cluster start [s] | cases/s | against api | solved alone |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['n']} | {r['placement']} | {r['cases']} | {r['wall_s']:.2f} | {r['start_s']:.1f} | "
              f"{r['cases_per_s']:.1f} | {r['ratio']:.2f}x | {r.get('solved_alone', '-')} |")
    if parts:
        names = list(parts[0][2])
        print("\n| n | batch | " + " | ".join(k if "share" in k else f"{k} [s]" for k in names) + " |")
        print("|---|---|" + "---|" * len(names))
        for n, batch, seconds in parts:
            print(f"| {n} | {batch} | " + " | ".join(f"{seconds[k]:.2f}" for k in names) + " |")
    print(f"\n({args.device}, {args.dtype}, {args.problem}; one JSON line a row: {log})")


if __name__ == "__main__":
    main()

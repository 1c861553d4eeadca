"""``warpcontact sweep SWEEP.toml --out DIR``: the cartesian product of listed case parameters.

Each finished case is written at once (``DIR/cases/<id>.json``, and ``DIR/sweep.csv`` with one
row per finished case); a rerun skips the cases already finished. At the end, after the table,
``DIR/sweep.png`` draws the results against the swept values (:func:`warpcontact.plots.sweep_figure`).
The sweep file format is in ``docs/sweeps.md``; the work is done by :mod:`warpcontact.studies.sweep`.
Wire it into ``cli/__init__.py`` with::

    from .sweep import add_parser, cmd_sweep
    add_parser(sub)                  # in _parser(), on the subparsers object
    {..., "sweep": cmd_sweep}        # in main()'s table of commands

Exit status: 0 every case converged; 2 a mistake in the sweep file or a combination (raised as
InputError for cli.main to report); 3 some case did not converge or recorded an error (results
written); 74 an output could not be written (raised as OutputError for cli.main to report; the
finished cases are on disk, a rerun resumes; sweep.png too, which comes after the table); 130,
143, 129 stopped by Ctrl-C, SIGTERM, SIGHUP (finished cases are written; rerun to finish).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..records.case import FFT_BACKENDS

EXIT_NOT_CONVERGED = 3
EXIT_INTERRUPTED = 130  # Ctrl-C; SIGTERM 143, SIGHUP 129: interrupts.exit_status()

EXAMPLE_SWEEP = """example:
  warpcontact sweep examples/sweep_k_tau.toml --out out/sweep
  warpcontact sweep examples/sweep_k_tau.toml --out out/sweep --device cuda --dtype float32

a sweep file holds the base case (a [base] table, or base = "case.toml" relative to the sweep
file), the swept case keys with their values, and the task:

  base = "table2_k080_dz5e-5.toml"
  [sweep]
  "friction.k_tau" = [0.5, 0.8, 0.95]
  "load.delta_z" = [1e-11, 5e-11]
  [run]
  task = "gross-slip"               # or "solve", "pull-off", "fretting"; default gross-slip when the base has [friction]
  # scheduler = "tcp://host:8786"   # run on a dask cluster started by hand (docs/scaling.md)

"friction.law" and "adhesion.law" may list "none": that combination runs without the table
(with and without adhesion in one sweep: "adhesion.law" = ["smc", "none"], task = "solve").

writes OUT/cases/<id>.json for each case as soon as it finishes (the swept values, the summary:
delta_x_max [m], mu, force [N] for gross-slip, the last state's forces and areas for solve;
elapsed_s, the whole case), OUT/sweep.csv (one row per finished case, swept keys first),
OUT/sweep.json (complete or not) and, at the end, OUT/sweep.png (the results against the first
swept key, a line per value of the second; task fretting over two keys: OUT/map.png too, the regime
and the energy over their plane). Run it again to finish an interrupted sweep: finished
cases are skipped. See docs/sweeps.md."""


def add_parser(sub):
    """Register the ``sweep`` sub-command on an argparse subparsers object; returns its parser."""
    p = add_many_case_command(
        sub, "sweep", "sweep file (TOML; see docs/sweeps.md)", cmd_sweep,
        help="run the cartesian product of listed case parameters (k_tau, delta_z, grid, adhesion, ...)",
        description="Run every combination of the values listed in SWEEP (a TOML file: a base case, a [sweep] "
        "table of dotted case keys and lists, a [run] task), writing each finished case at once; a rerun skips "
        "finished cases.",
        epilog=EXAMPLE_SWEEP,
    )
    return p


def add_many_case_command(sub, name: str, file_help: str, func, **texts):
    """Register a command that runs many cases of one TOML file and resumes (``sweep``, ``fit``): its
    file as the positional ``name`` (shown as ``NAME.toml``), :func:`add_many_case_options`, and
    ``func`` to run it; ``texts``: the parser's help, description and epilog (printed as written)."""
    p = sub.add_parser(name, formatter_class=argparse.RawDescriptionHelpFormatter, **texts)
    p.add_argument(name, metavar=f"{name.upper()}.toml", help=file_help)
    add_many_case_options(p)
    p.set_defaults(func=func)
    return p


def add_many_case_options(p):
    """The options of a command that runs many cases of one file and resumes (``sweep``, ``fit``):
    ``--out``, the solver overrides of every case, ``--quiet`` and the batch options."""
    p.add_argument("--out", required=True, help="output folder (created if needed; reused to resume)")
    p.add_argument("--device", help="override [solver] device of every case: cpu, cuda, cuda:N")
    p.add_argument("--dtype", choices=("float64", "float32"), help="override [solver] dtype of every case")
    p.add_argument("--fft", choices=FFT_BACKENDS, help="override [solver] fft of every case")
    p.add_argument("--quiet", action="store_true", help="no progress lines (warnings and errors are still printed)")
    add_batch_options(p, default_workers="one per GPU for CUDA cases, else one per CPU core")
    p.add_argument("--batch", type=int, metavar="B",
                   help="with the task \"solve\" (normal contact, friction, friction with an SMC law on the DMT "
                   "side) or \"gross-slip\" (the cases of these with friction): cases of one grid solved B at a "
                   "time by batched steps, in this process or, on several workers, each such group a task of a "
                   "worker (default: on CUDA, as many as half the free memory holds, up to 256; on the CPU one case "
                   "at a time); 0: one case at a time everywhere")


def batch_from(args) -> int | None:
    """``--batch`` of a many-case command; InputError for a negative count."""
    if args.batch is not None and args.batch < 0:
        from ..errors import InputError

        raise InputError("--batch", f"must be a whole number of cases, 0 or more, got {args.batch}")
    return args.batch


def add_batch_options(p, default_workers: str, default: int | None = None):
    """``--workers`` (``default``: None sizes a local cluster to the machine) and ``--scheduler`` of a
    command of many cases (:mod:`warpcontact.studies.batch`); ``default_workers`` says the default in words."""
    p.add_argument("--workers", type=int, metavar="N", default=default,
                   help="cases computed at once: 1 computes them in this process, one after another; N > 1 in "
                   "this process and N - 1 worker processes of a local cluster, which start beside it "
                   f"(default: {default_workers}). On CUDA the workers take the GPUs in turn (this process the "
                   "first)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run the cases on the workers of a running dask scheduler (tcp://host:8786) instead of a "
                   "local cluster; see docs/scaling.md")


def placement_from(args, scheduler=None):
    """The :class:`warpcontact.studies.batch.Placement` of ``--workers`` / ``--scheduler`` (``scheduler``: a
    file's ``[run] scheduler``, which the option overrides). InputError for workers < 1."""
    from ..studies.batch import Placement
    from ..errors import InputError

    if args.workers is not None and args.workers < 1:
        raise InputError("--workers", f"must be at least 1, got {args.workers}")
    return Placement(scheduler=args.scheduler or scheduler, workers=args.workers,
                     device=getattr(args, "device", None) or "cpu")


def plot_sweep(sweep, records, out) -> None:
    """Draw OUT/sweep.png from the finished ``records`` of ``sweep`` (:func:`warpcontact.plots.sweep_figure`),
    and for a fretting sweep of two or more keys OUT/map.png (:func:`warpcontact.plots.fretting_map`);
    :func:`~warpcontact.studies.sweep.run_sweep` calls it after sweep.csv is written. A figure that
    cannot be drawn is a warning line (the table and the cases stand); one that cannot be written
    raises OutputError; a stop leaves no part of the file (KeyboardInterrupt propagates)."""
    from .. import plots
    from ..files import output_error

    figures = [("sweep.png", lambda: plots.sweep_figure(records, sweep.keys, sweep.task))]
    if sweep.task == "fretting" and len(sweep.keys) >= 2:  # the regime and the energy over the plane
        figures.append(("map.png", lambda: plots.fretting_map(records, sweep.keys)))
    for name, draw in figures:
        path = Path(out) / name
        try:
            fig = draw()
        except (ValueError, TypeError, KeyError, IndexError, ArithmeticError) as e:  # the table is what counts
            print(f"warpcontact: warning: {path} not drawn ({type(e).__name__}: {e}); the results are in "
                  f"{Path(out) / 'sweep.csv'}", file=sys.stderr)
            continue
        try:
            plots.save(fig, path)  # whole or not at all, a stop included
        except OSError as e:
            raise output_error(path, e) from None


def cmd_sweep(args) -> int:
    """Run the sweep of ``args.sweep`` into ``args.out``. Returns 0 (every case converged), 3 (a case
    did not converge or recorded an error) or 128 + the signal (stopped: 130 Ctrl-C, 143 SIGTERM,
    129 SIGHUP). A bad sweep file raises InputError; a write that fails, OutputError (naming the
    finished cases kept)."""
    from .. import interrupts
    from ..studies.sweep import run_sweep
    from ..studies.sweep_spec import load_sweep

    sweep = load_sweep(args.sweep, device=args.device, dtype=args.dtype, fft=args.fft)
    placement = placement_from(args, sweep.scheduler)
    report = run_sweep(sweep, args.out, quiet=args.quiet, placement=placement, batch=batch_from(args),
                       finish=lambda records: plot_sweep(sweep, records, args.out))  # writes after a stop: deferred
    out = args.out
    if report.write_error is not None:
        if Path(report.write_error.path).name in ("sweep.png", "map.png"):  # the last outputs: every case is written
            raise report.write_error.with_hint(
                f"every case and sweep.csv are kept in {out}: free space and run the same command again to draw "
                "the plot") from None
        raise report.write_error.with_hint(
            f"{len(report.records)} of {report.total} case(s) finished and kept in {out}: free space and run the "
            "same command again to resume") from None
    if report.interrupted:
        print(f"{interrupts.describe()}: {len(report.records)} of {report.total} case(s) finished and written to "
              f"{out}; rerun to finish", file=sys.stderr)
        return interrupts.exit_status()
    bad = report.not_converged
    if not args.quiet:
        print(f"sweep: {report.total} case(s) in {out}: {len(report.computed)} computed, {len(report.skipped)} "
              f"skipped (finished before); {len(bad)} without a converged result [{report.elapsed_s:.1f} s]",
              file=sys.stderr)
    if bad:
        errors = sum(1 for r in bad if r.get("status") == "error")
        print(f"not converged: {len(bad) - errors} case(s) did not converge and {errors} recorded an error "
              f"({', '.join(r['label'] for r in bad[:5])}{', ...' if len(bad) > 5 else ''}); see {out}/sweep.csv",
              file=sys.stderr)
        return EXIT_NOT_CONVERGED
    return 0

"""``warpcontact fit FIT.toml --out DIR``: the case parameters that reproduce measurements.

The fit file format is in ``docs/fit.md``; the work is done by :mod:`warpcontact.studies.fit`. Wired into
``cli/__init__.py`` as the sweep command is (``add_parser(sub)``; ``"fit": cmd_fit`` in main()'s table).

Exit status: 0 the optimiser converged (warnings, such as a parameter the data do not fix, are
printed); 2 a mistake in the fit file or the CSV (raised as InputError for cli.main to report,
naming the key or the CSV line); 3 the optimiser stopped at its evaluation limit, or a case gave
no result (an error, a state not converged); 74 an output could not be written; 130, 143, 129
stopped by Ctrl-C, SIGTERM, SIGHUP (finished evaluations are kept; rerun to resume).
"""

from __future__ import annotations

import math
import sys

EXIT_NOT_CONVERGED = 3

EXAMPLE_FIT = """example:
  warpcontact fit examples/fit_k_tau.toml --out out/fit_k_tau
  warpcontact fit examples/fit_k_tau.toml --out out/fit_k_tau --workers 1

a fit file holds the base case, the CSV of measurements, the fitted case keys with their bounds,
and the task that makes each row's outputs:

  base = "table2_k080_dz5e-5.toml"
  [data]
  file = "fit_k_tau.csv"            # columns: case keys (load.delta_z), outputs (mu), sigma_mu
  [fit]
  "friction.k_tau" = { min = 0.3, max = 0.97, start = 0.5 }
  [run]
  task = "gross-slip"               # or "solve", "pull-off"
  # scheduler = "tcp://host:8786"   # run on a dask cluster started by hand (docs/scaling.md)

writes OUT/fit.json (each parameter's value, stderr and bound hit, the correlation matrix,
residual_rms, converged, evaluations), OUT/fit.png (data against the fitted model, one panel per
output), OUT/fitted.toml (the base case with the fitted values, for `warpcontact solve`) and
OUT/evaluations/<hash>.json (every case computed; a rerun reuses them). See docs/fit.md."""


def add_parser(sub):
    """Register the ``fit`` sub-command on an argparse subparsers object; returns its parser."""
    from .sweep import add_many_case_command

    return add_many_case_command(
        sub, "fit", "fit file (TOML; see docs/fit.md)", cmd_fit,
        help="fit case parameters (k_tau, the adhesion law, ...) to measurements, with standard errors",
        description="Fit the case keys listed in FIT (a TOML file: a base case, a CSV of measurements, the fitted "
        "keys with bounds, a [run] task) to the measurements by bounded nonlinear least squares; every model "
        "evaluation is kept, so a rerun resumes.",
        epilog=EXAMPLE_FIT,
    )


def _value(e: dict) -> str:
    s = e["stderr"]
    err = "inf" if not math.isfinite(s) else f"{s:.2g}"
    bound = f", at its {e['at_bound']}" if e["at_bound"] else ""
    note = "" if e["identified"] else " (NOT fixed by the data)"
    return f"{e['value']:.6g} +- {err}{bound}{note}"


def cmd_fit(args) -> int:
    """Run the fit of ``args.fit`` into ``args.out``. Returns 0 (converged), 3 (not converged, or an
    evaluation failed) or 128 + the signal (stopped). A bad fit file raises InputError; a write
    that fails, OutputError."""
    from .. import interrupts
    from .sweep import batch_from, placement_from
    from ..studies.fit import load_fit, run_fit

    fit = load_fit(args.fit, device=args.device, dtype=args.dtype, fft=args.fft)
    placement = placement_from(args, fit.scheduler)
    report = run_fit(fit, args.out, quiet=args.quiet, placement=placement, batch=batch_from(args))
    out = args.out
    ev = report.evaluations
    kept = f"{ev['computed']} case(s) computed now, {ev['cached']} found done, kept in {out}/evaluations"
    if report.write_error is not None:
        raise report.write_error.with_hint(f"{kept}: free space and run the same command again to resume") from None
    if report.interrupted:
        print(f"{interrupts.describe()}: {kept}; rerun to resume", file=sys.stderr)
        return interrupts.exit_status()
    if report.error is not None:
        print(f"warpcontact: fit stopped: {report.error} ({kept})", file=sys.stderr)
        return EXIT_NOT_CONVERGED
    if not args.quiet:
        for key, e in report.parameters.items():
            print(f"fit: {key} = {_value(e)}", file=sys.stderr)
        print(f"fit: residual rms {report.residual_rms:.4g}; {report.message.rstrip('.')}; {ev['iterations']} "
              f"iteration(s), {ev['count']} case evaluation(s) ({ev['cached']} cached) [{report.elapsed_s:.1f} s] -> "
              f"{out}/fit.json, fit.png, fitted.toml", file=sys.stderr)
    if not report.converged:
        print(f"not converged: {report.message} (the evaluation limit: [run] max_evaluations); the last point is "
              f"in {out}/fit.json; rerun with a larger limit to go on from the cache", file=sys.stderr)
        return EXIT_NOT_CONVERGED
    return 0

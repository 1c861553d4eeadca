"""``warpcontact table2``: the paper's Table 2, cell by cell on the batch engine, each finished
cell written at once; a rerun with the same settings skips the finished cells. The work is done by
:class:`warpcontact.studies.table2.Table2Run`."""

from __future__ import annotations

import sys

from .. import interrupts
from ..errors import InputError
from .solve import EXIT_CHECK_FAILED, EXIT_NOT_CONVERGED


def _option(e: InputError) -> InputError:
    """``e`` keyed by the command's option (--sigma-max, --k-tau) instead of the study's key."""
    return InputError("--" + e.key.split(".")[-1].replace("_", "-"), e.problem)


def cmd_table2(args) -> int:
    """Run the cells of Table 2 that ``args`` select into ``args.out``. Returns 0 (every cell
    converged and passed its yield check), 3 (a cell did not converge), EXIT_CHECK_FAILED (a yield
    check failed) or 128 + the signal (stopped; the finished cells are written). A bad option raises
    InputError; a write that fails, OutputError (naming the finished cells kept)."""
    from ..studies.table2 import Table2Run, Table2Settings, check_law
    from .sweep import placement_from

    for n in args.n:
        if n < 8:
            raise InputError("--n", f"must be at least 8, got {n}")
    if not (args.size_in_a > 2.0):
        raise InputError("--size-in-a", f"the domain must hold the contact diameter 2a: use more than 2, got {args.size_in_a}")
    settings = Table2Settings(size_in_a=args.size_in_a, device=args.device or "cpu", dtype=args.dtype or "float64",
                              fft=args.fft or "auto", sigma_max=args.sigma_max, tau_max=args.tau_max,
                              delta_n=args.delta_n, delta_t=args.delta_t, contact_shear=args.contact_shear)
    columns = (False,) if args.no_adhesion else (True,) if args.adhesion_only else (False, True)
    try:
        check_law(settings, adhesive=not args.no_adhesion)
        study = Table2Run(settings, args.out, args.n, columns, args.k_tau, args.delta_z_um)
    except InputError as e:
        raise _option(e) from None
    if args.batch is not None and args.batch < 0:
        raise InputError("--batch", f"must be a whole number of cells, 0 or more, got {args.batch}")
    report = study.run(placement_from(args), quiet=args.quiet, batch=args.batch)
    if report.write_error is not None:
        rest = "finish" if report.write_error_at_end else "compute the others"
        raise report.write_error.with_hint(f"{report.kept} cell(s) finished and kept in {report.path}: free space "
                                           f"and run the same command again to {rest}") from None
    if report.interrupted:
        print(f"{interrupts.describe()}: {len(report.records)} cell(s) written to {report.out}; rerun to finish",
              file=sys.stderr)
        return interrupts.exit_status()
    if report.not_converged:
        return EXIT_NOT_CONVERGED
    return EXIT_CHECK_FAILED if report.check_failed else 0

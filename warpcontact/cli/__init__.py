"""Command line: ``warpcontact solve CASE.toml --out DIR`` and the other commands.

Exit status (every command; docs/faults.md says what each leaves on disk):

- 0 success;
- 2 a mistake in the input (one line on stderr naming it, no traceback);
- 3 a state did not converge (results are written and marked ``converged: false``);
- 74 an output could not be written (no space left, read-only file system, quota, I/O error:
  one line naming the file; what was written before is left whole; sysexits' EX_IOERR);
- 130, 143, 129 stopped by Ctrl-C, SIGTERM, SIGHUP (128 + the signal's number, as shells report
  it): the states or cases finished so far are written, marked ``"interrupted": true``.
"""

from __future__ import annotations

import argparse
import errno
import math
import os
import sys
from pathlib import Path

from .. import interrupts
from ..records.case import FFT_BACKENDS
from .solve import EXIT_CHECK_FAILED, EXIT_NOT_CONVERGED, _earlier_run, _remove_stale, _turns_hint, cmd_solve
from ..errors import ConvergenceError, InputError, NonFiniteError, OutputError
from ..records.guards import check_failure
from ..records.progress import Progress, end_line, write_above

EXIT_INPUT = 2
EXIT_WRITE_ERROR = 74
EXIT_INTERRUPTED = 130  # Ctrl-C; SIGTERM 143, SIGHUP 129: interrupts.exit_status()
#: --fields of solve: runner.FIELDS_CHOICES (not imported here: the parser is built before the solver is needed)
FIELDS_CHOICES = ("all", "last", "none")

EXAMPLE_SOLVE = """example:
  warpcontact solve examples/hertz.toml --out out/hertz
  warpcontact solve examples/hertz.toml --out out/hertz --device cuda --dtype float32

writes OUT/result.json (forces [N], contact area [m^2] and radius [m], max pressure [Pa],
convergence, timings, the case; "complete": false until the run has solved and written
everything) and OUT/fields.npz (pressure, shear, gap, slip fields in SI units for every state
of the path, with masks; loads with numpy alone; --fields last or none writes less)."""


def _common(p):
    p.add_argument("--out", required=True, help="output folder (created if needed)")
    p.add_argument("--device", help="override [solver] device: cpu, cuda, cuda:N")
    p.add_argument("--dtype", choices=("float64", "float32"), help="override [solver] dtype")
    p.add_argument("--fft", choices=FFT_BACKENDS, help="override [solver] fft")
    p.add_argument("--quiet", action="store_true", help="no progress output")


def _case_command(sub, name: str, case_help: str = "case file (TOML)", **texts):
    """Register a command of one case file (``solve``, ``gross-slip``, ``pull-off``): its parser,
    ``texts`` its help, description and epilog (printed as written), and the positional ``case``;
    returns the parser."""
    p = sub.add_parser(name, formatter_class=argparse.RawDescriptionHelpFormatter, **texts)
    p.add_argument("case", help=case_help)
    return p


class _Parser(argparse.ArgumentParser):
    """argparse's parser, whose "invalid choice" names the choice probably meant (``grossslip``:
    did you mean 'gross-slip'?)."""

    def error(self, message):
        import difflib
        import re

        m = re.search(r"invalid choice: '([^']*)' \(choose from (.*)\)", message)
        if m:
            choices = re.findall(r"'([^']*)'", m.group(2))
            near = difflib.get_close_matches(m.group(1), choices, n=1)
            if near:
                message += f"; did you mean '{near[0]}'?"
        super().error(message)


def _parser():
    parser = _Parser(
        prog="warpcontact",
        description="Sphere-on-flat contact with friction and adhesion (DC-FFT, conjugate gradients, NVIDIA Warp).",
    )
    from .. import __version__

    parser.add_argument("--version", action="version", version=f"warpcontact {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    p = _case_command(
        sub, "solve",
        help="solve every state of a case's load path",
        description="Solve every state of the load path of CASE (a TOML file, SI units; see docs/case-files.md).",
        epilog=EXAMPLE_SOLVE,
    )
    p.add_argument("--fields", choices=FIELDS_CHOICES, default="all",
                   help="whose fields OUT/fields.npz holds: every state's (all, the default), the last state's "
                   "(last: 1/n_states of the size) or none (no fields.npz)")
    _common(p)

    g = _case_command(
        sub, "gross-slip",
        help="find delta_x at gross slip and the static friction coefficient",
        description="Load the case's delta_z in [load] normal_steps (default steps) with friction active, then "
        "raise delta_x until no cell sticks; bisect to 1 %. The case needs a [friction] table; its delta_x, delta_y "
        "(or amplitudes) are not used.",
        epilog="example:\n  warpcontact gross-slip examples/table2_k080_dz5e-5.toml --out out/gs\n\n"
        "writes OUT/result.json with delta_x_max [m], mu, the force at delta_x_max [N] and every state of the path.",
    )
    _common(g)

    t = sub.add_parser(
        "table2",
        help="compute the paper's Table 2 (24 cells: 12 adhesionless, 12 adhesive)",
        description="delta_x_max and mu for k_tau in (0.50, 0.80, 0.95) x delta_z in (1e-5, 5e-5, 1e-4, 1.5e-4) um, "
        "copper sphere R = 10 um on hardened steel, without and with adhesion (the SMC law; the paper gives no "
        "parameters: the defaults below are ours, docs/validation.md 'Adhesion defaults' says why), compared with the paper. "
        "Each finished cell is written at once; a rerun with the same settings skips finished cells.",
        epilog="example:\n  warpcontact table2 --out out/table2 --n 128\n"
        "  warpcontact table2 --no-adhesion --out out/table2 --n 64 128   # grid convergence: both resolutions\n"
        "  warpcontact table2 --adhesion-only --sigma-max 2e6 --tau-max 2e6 --out out/t2_s2e6",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    from ..studies.table2 import Table2Settings as _T2

    col = t.add_mutually_exclusive_group()
    col.add_argument("--no-adhesion", action="store_true", help="only the adhesionless columns")
    col.add_argument("--adhesion-only", action="store_true", help="only the adhesive columns")
    t.add_argument("--sigma-max", type=float, default=_T2.sigma_max, help=f"SMC peak normal traction [Pa] (default {_T2.sigma_max:g})")
    t.add_argument("--tau-max", type=float, default=_T2.tau_max, help=f"SMC peak shear traction [Pa] (default {_T2.tau_max:g})")
    t.add_argument("--delta-n", type=float, default=_T2.delta_n, help=f"SMC normal length [m] (default {_T2.delta_n:g})")
    t.add_argument("--delta-t", type=float, default=_T2.delta_t, help=f"SMC tangential length [m] (default {_T2.delta_t:g})")
    t.add_argument("--contact-shear", choices=("bounded", "added"), default="bounded",
                   help="the SMC shear inside the contact: bounded with the contact shear (default), or added to it "
                        "as the paper's text reads")
    t.add_argument("--n", type=int, nargs="+", default=[128], help="cells per side; several values give a grid study")
    t.add_argument("--size-in-a", type=float, default=3.0, help="domain side in Hertz radii a = sqrt(R delta_z)")
    from .sweep import add_batch_options

    add_batch_options(t, "1", default=1)  # warpcontact.studies.batch
    t.add_argument("--batch", type=int, metavar="B",
                   help="the cells (the adhesive ones with an SMC law on the DMT side, the default) searched B of "
                   "one grid at a time by batched steps: in this process, or with --workers or --scheduler each "
                   "such group on a worker; 0: one cell at a time (default: on CUDA, those of grids up to 256 cells "
                   "per side all together, where they pay; otherwise one at a time)")
    po = _case_command(
        sub, "pull-off", "case file (TOML) with an [adhesion] table",
        help="approach and retract the sphere: force-displacement curve and pull-off force",
        description="Needs an [adhesion] table. delta_z runs from -2 ranges of the law up to the case's delta_z and "
        "back down to --retract-to (default: -(4 ranges of the law)), in --steps steps each way.",
        epilog="example:\n  warpcontact pull-off examples/pull_off_dmt.toml --out out/pull\n\n"
        "writes OUT/result.json (pull_off_force [N], the most tensile total F_z, and the curve) and OUT/pull_off.png.",
    )
    po.add_argument("--steps", type=int, default=20, help="steps each way (default 20)")
    po.add_argument("--retract-to", type=float, help="last delta_z [m] (default: -4 ranges of the law)")
    _common(po)

    from . import fretting as _fretting

    fr = _case_command(sub, "fretting", "case file (TOML) with a [friction] table and a cyclic path ([load] "
                       "delta_x_amplitude)", help=_fretting.HELP, description=_fretting.DESCRIPTION,
                       epilog=_fretting.EXAMPLE)
    fr.add_argument("--fields", choices=FIELDS_CHOICES, default="last", help=_fretting.FIELDS_HELP)
    _common(fr)

    from .figure import add_parser as add_figure_parser
    from .sweep import add_parser as add_sweep_parser

    add_figure_parser(sub)
    add_sweep_parser(sub)
    from .stress import add_parser as add_stress_parser

    add_stress_parser(sub)
    from .fit import add_parser as add_fit_parser

    add_fit_parser(sub)
    from .surface import add_parser as add_surface_parser

    add_surface_parser(sub)
    t.add_argument("--k-tau", type=float, nargs="+", help="only these k_tau columns (0.50, 0.80, 0.95)")
    t.add_argument("--delta-z-um", type=float, nargs="+", help="only these delta_z rows in um (1e-5, 5e-5, 1e-4, 1.5e-4)")
    _common(t)
    sc = sub.add_parser(
        "schema",
        help="print the JSON Schema of a case file (for editors that complete and check TOML)",
        description="Print the JSON Schema (draft 2020-12) of a case file, built from the checks that every command "
        "makes: tables, keys, types, ranges, choices, defaults and descriptions. Point an editor at it to complete "
        "and check case files as they are typed (docs/case-files.md).",
        epilog="example:\n  warpcontact schema --out case.schema.json\n  warpcontact schema | python3 -m json.tool",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sc.add_argument("--out", metavar="FILE", help="write the schema to FILE (whole or not at all) instead of printing it")
    sc.set_defaults(out_is_file=True)  # every other command's --out is a folder
    return parser


def cmd_gross_slip(args) -> int:
    from ..api import check_gross_slip_case, run_gross_slip
    from ..records.case import load_case
    from ..records.guards import GROSS_SLIP_RESULTS
    from ..records.results import atomic_write_json
    from ..studies.runner import build

    case = load_case(args.case).with_overrides(device=args.device, dtype=args.dtype, fft=args.fft)
    check_gross_slip_case(case)
    model, solver, _ = build(case)
    out = Path(args.out)
    info = _run_info(model, case)

    progress = Progress("gross-slip", quiet=args.quiet)  # a search: the number of states is not known
    states = []  # the finished states: written after each, and on a stop

    def on_state(k, s):
        with interrupts.deferred():  # the list and the file stay in step
            states.append(s)
            _write_partial(out, {"states": states}, info, GROSS_SLIP_RESULTS)
        progress.update(k + 1, s["iterations"], s["residual"],
                        f"{s['kind']} delta_x {s['delta']['x']:.4e} m, {s['stick_cells']} stick cells")

    earlier = _earlier_run(out, ("result.json",))
    try:
        if earlier:  # replaced at once; elsewhere nothing is written before the first state finishes
            with interrupts.deferred():
                _write_partial(out, {"states": states}, info, GROSS_SLIP_RESULTS)
        r = run_gross_slip(case, model, solver, on_state=on_state)
    except KeyboardInterrupt as e:
        interrupts.stopping(e)  # first: a second signal does not cut what follows
        progress.close()
        return _interrupted(out, {"states": states}, info, GROSS_SLIP_RESULTS, e, earlier)
    finally:
        progress.close()
    result = {**r, "complete": True, "interrupted": False, **info}
    with interrupts.deferred(raise_after=False):
        atomic_write_json(out / "result.json", result)
    if not r["converged"]:
        print(f"not converged: a state of the gross-slip path did not converge{_turns_hint(r['states'], case)}; "
              f"see {out / 'result.json'}", file=sys.stderr)
        return EXIT_NOT_CONVERGED
    if check_failure(r.get("yield_check")) is not None:
        return EXIT_CHECK_FAILED
    if not args.quiet:
        mu = "undefined (F_z <= 0: adhesion holds the sphere in tension)" if r["mu"] is None else f"{r['mu']:.4f}"
        print(f"delta_x_max = {r['delta_x_max']:.4e} m, mu = {mu}  [{r['elapsed_s']:.1f} s] -> {out}", file=sys.stderr)
    return 0


def cmd_pull_off(args) -> int:
    from ..api import check_pull_off_case, run_pull_off
    from ..records.case import load_case
    from ..records.guards import PULL_OFF_RESULTS
    from ..records.results import atomic_write_json
    from ..studies.runner import build

    case = load_case(args.case).with_overrides(device=args.device, dtype=args.dtype, fft=args.fft)
    if args.steps < 2:
        raise InputError("--steps", f"must be at least 2, got {args.steps}")
    dz_max = case.load.delta_z_max
    if args.retract_to is not None and not args.retract_to < dz_max:
        raise InputError("--retract-to", f"must lie below the deepest approach {dz_max:g} m, got {args.retract_to:g}")
    check_pull_off_case(case, args.steps, args.retract_to)
    model, solver, _ = build(case)
    out = Path(args.out)

    info = _run_info(model, case)
    progress = Progress("pull-off", total=2 * args.steps + 1, quiet=args.quiet)
    curve, refined = [], []  # the finished states (path, refinement): written after each, and on a stop
    finished = {"curve": curve, "refined": refined}

    def on_state(k, total, s):
        with interrupts.deferred():  # the lists and the file stay in step
            (refined if "purpose" in s else curve).append(s)
            _write_partial(out, finished, info, PULL_OFF_RESULTS)
        progress.total = total  # grows where the path finds a jump to locate or goes on in contact
        what = f", {s['purpose']}" if "purpose" in s else ""
        progress.update(k + 1, s["iterations"], s["residual"],
                        f"delta_z {s['delta']['z']:+.3e} m, F_z {s['force']['z']:+.3e} N, "
                        f"{s['outer_iterations']} turns{what}")

    earlier = _earlier_run(out, ("result.json", "pull_off.png"))
    try:
        if earlier:  # replaced at once; elsewhere nothing is written before the first state finishes
            with interrupts.deferred():
                _write_partial(out, finished, info, PULL_OFF_RESULTS)
                _remove_stale(out / "pull_off.png")
        r = run_pull_off(case, model, solver, steps=args.steps, retract_to=args.retract_to, on_state=on_state)
    except KeyboardInterrupt as e:
        interrupts.stopping(e)  # first: a second signal does not cut what follows
        progress.close()
        return _interrupted(out, finished, info, PULL_OFF_RESULTS, e, earlier)
    finally:
        progress.close()
    R, w = case.sphere.radius, r["work_of_adhesion"]
    result = {**r, "interrupted": False, **info}
    with interrupts.deferred(raise_after=False):  # the plot first: complete = every output written
        try:
            _plot_pull_off(r, out / "pull_off.png", result)
        except OSError as e:
            from ..records.results import output_error

            error = output_error(out / "pull_off.png", e)
            atomic_write_json(out / "result.json", {**result, "complete": False, "write_error": str(error)})
            raise error from None
        atomic_write_json(out / "result.json", {**result, "complete": True})
    if not r["converged"]:
        print(f"not converged: a state of the approach-retract curve did not converge{_turns_hint(r['curve'], case)}; "
              f"see {out / 'result.json'}", file=sys.stderr)
        return EXIT_NOT_CONVERGED
    if not args.quiet:
        for line in _contact_event_lines(r):
            print(line, file=sys.stderr)
        if case.sphere.hertzian:
            print(f"pull-off force {r['pull_off_force']:.4e} N = {r['pull_off_force'] / (math.pi * R * w):.3f} pi R w "
                  f"(Tabor parameter {result['tabor_parameter']:.3g}) -> {out}", file=sys.stderr)
        else:
            print(f"pull-off force {r['pull_off_force']:.4e} N ({case.sphere.description}) -> {out}", file=sys.stderr)
    return 0


def _contact_event_lines(r) -> list[str]:
    """One line per place the contact formed or broke on the path, and one where it never left."""
    lines = []
    for e in r["contact_events"]:
        how = "jumps" if e["jump"] else "changes continuously"
        lines.append(f"{e['of']} {e['kind']} ({e['branch']}) between delta_z {e['delta_z_before']:+.4e} and "
                     f"{e['delta_z_after']:+.4e} m: F_z {how} from {e['force_before']:+.4e} to {e['force_after']:+.4e} N, "
                     f"contact radius {e['contact_radius_before']:.3e} -> {e['contact_radius_after']:.3e} m")
    for where in r.get("in_contact_at", []):
        lines.append(f"warning: the sphere is in contact at the path's {where} (delta_z "
                     f"{r['delta_start' if where == 'start' else 'delta_end']:+.4e} m): the curve misses the jump "
                     f"{'in' if where == 'start' else 'out'}" + (" (give --retract-to further out)" if where == "end" else ""))
    return lines


def _run_info(model, case) -> dict:
    """What a result.json records of the run: device, dtype, FFT, software version, the case."""
    from .. import __version__

    return {"device": str(model.device), "dtype": model.dtype_name, "fft": model.fft_name,
            "software": {"warpcontact": __version__}, "case": case.to_dict()}


def _write_partial(out: Path, finished: dict, info: dict, keys, stop: BaseException | None = None):
    """OUT/result.json of a run not finished: the states so far (``finished``: lists of state
    summaries by their names, the path's first) and ``info``, the results ``keys`` null,
    ``complete: false``; after a stop (``stop``: the KeyboardInterrupt), ``interrupted: true`` and
    the signal."""
    from ..records.results import atomic_write_json

    states = [s for group in finished.values() for s in group]
    record = {**{k: None for k in keys}, "converged": False, "complete": False, "interrupted": stop is not None,
              **finished, **info}
    if stop is not None:
        signal_name = interrupts.signal_name(interrupts.stop_signal(stop))
        record["stop_signal"] = signal_name
        record["note"] = f"interrupted ({signal_name}) after {len(states)} state(s): {', '.join(keys)} not reported"
    else:
        record["note"] = f"running, or stopped without a chance to write (kill -9): {len(states)} state(s) so far"
    atomic_write_json(out / "result.json", record)


def _interrupted(out: Path, finished: dict, info: dict, keys, stop: BaseException | None = None,
                 earlier: bool = True) -> int:
    """After a stop (Ctrl-C, SIGTERM, SIGHUP): OUT/result.json with what finished, marked interrupted
    and not converged (:func:`_write_partial`); one line on stderr. Before the first state finished
    nothing is written, unless an earlier run's result.json was replaced (``earlier``): then the
    file records the stop. Returns the exit status (130, 143, 129)."""
    states = [s for group in finished.values() for s in group]
    if not states and not earlier:
        print(f"{interrupts.describe(stop)}: stopped before the first state finished; nothing was written",
              file=sys.stderr)
        return interrupts.exit_status(stop)
    with interrupts.deferred(raise_after=False):
        _write_partial(out, finished, info, keys, stop if stop is not None else KeyboardInterrupt())
    if not states:
        print(f"{interrupts.describe(stop)}: stopped before the first state finished; {out / 'result.json'} "
              "(which replaced the earlier run's) records the stop and holds no state", file=sys.stderr)
    else:
        print(f"{interrupts.describe(stop)}: {len(states)} state(s) finished and written to {out}", file=sys.stderr)
    return interrupts.exit_status(stop)


def _plot_pull_off(r, path, result):
    from ..plots import pull_off_curve, save

    save(pull_off_curve(result), path)


def cmd_schema(args) -> int:
    from ..schema import schema_json

    text = schema_json()
    if args.out is None:
        sys.stdout.write(text)
        return 0
    from ..records.results import atomic_write_bytes

    atomic_write_bytes(Path(args.out), text.encode())
    print(f"schema -> {args.out}", file=sys.stderr)
    return 0


def check_out(out, is_file: bool = False) -> None:
    """Refuse ``--out`` before anything runs (InputError, exit 2) where the outputs could not be
    written: a folder option naming an existing file (a file option: an existing folder), or a
    folder that cannot be made or written in. Judged on the nearest folder that exists, by making
    and removing a temporary file there (what permissions, read-only file systems and ACLs
    allow), so nothing is left behind and no folder is made before the run needs it."""
    path = Path(out)
    try:
        if is_file and path.is_dir():
            raise InputError("--out", f"{path} is a folder: name the file to write")
        if not is_file and path.exists() and not path.is_dir():
            raise InputError("--out", f"{path} is a file, not a folder: name a new or existing folder for the outputs")
        folder = path.parent if is_file else path
        existing = folder
        while not existing.exists() and existing != existing.parent:
            existing = existing.parent
        if not existing.is_dir():
            raise InputError("--out", f"{existing} is a file, so the folder {folder} cannot be made")
    except OSError as e:  # a path that cannot even be looked at (a folder without search permission)
        raise InputError("--out", f"cannot reach {path} ({(e.strerror or str(e)).lower()})") from None
    import tempfile

    try:
        with tempfile.NamedTemporaryFile(dir=existing, prefix=".warpcontact-", suffix=".probe"):
            pass
    except OSError as e:
        raise InputError("--out", f"cannot write in {existing} ({(e.strerror or str(e)).lower()}): name a folder "
                                  "you can write to") from None


def _show_warning(message, category, filename, lineno, file=None, line=None):
    write_above(f"warpcontact: warning: {message}")  # above a progress bar being drawn


#: errors of the system met while writing: reported in one line, exit EXIT_WRITE_ERROR
WRITE_ERRNOS = tuple(getattr(errno, name) for name in ("ENOSPC", "EROFS", "EDQUOT", "EIO", "EFBIG")
                     if hasattr(errno, name))


def main(argv=None) -> int:
    import warnings

    warnings.showwarning = _show_warning
    interrupts.reset()  # a new run: no stop received yet
    interrupts.install()
    try:
        args = _parser().parse_args(argv)  # imports the commands' modules: a second or so
    except KeyboardInterrupt as e:
        print(f"{interrupts.describe(e)}: stopped during the set-up, before anything was written", file=sys.stderr)
        return interrupts.exit_status(e)
    try:
        from .figure import cmd_figure
        from .sweep import cmd_sweep
        from .stress import cmd_stress
        from .fit import cmd_fit
        from .fretting import cmd_fretting
        from .surface import cmd_surface
        from .table2 import cmd_table2

        if getattr(args, "out", None) is not None:  # before any command starts: nothing is solved in vain
            check_out(args.out, getattr(args, "out_is_file", False))
        commands = {"solve": cmd_solve, "gross-slip": cmd_gross_slip, "table2": cmd_table2, "figure": cmd_figure,
                    "pull-off": cmd_pull_off, "sweep": cmd_sweep, "stress": cmd_stress, "fit": cmd_fit,
                    "schema": cmd_schema, "fretting": cmd_fretting, "surface": cmd_surface}
        return commands[args.command](args)
    except InputError as e:
        end_line()  # of a progress bar being drawn
        print(f"warpcontact: error: {e}", file=sys.stderr)
        return EXIT_INPUT
    except (NonFiniteError, ConvergenceError) as e:
        end_line()
        print(f"warpcontact: error: {e}", file=sys.stderr)
        return EXIT_NOT_CONVERGED
    except OutputError as e:
        end_line()
        print(f"warpcontact: error: {e}", file=sys.stderr)
        return EXIT_WRITE_ERROR
    except OSError as e:
        if e.errno not in WRITE_ERRNOS:
            raise
        end_line()
        where = f" {e.filename}" if e.filename else " an output"
        print(f"warpcontact: error: cannot write{where}: {(e.strerror or str(e)).lower()}", file=sys.stderr)
        return EXIT_WRITE_ERROR
    except KeyboardInterrupt as e:  # the commands catch a stop once they have written: this is the set-up
        end_line()
        print(f"{interrupts.describe(e)}: stopped during the set-up, before anything was written to {args.out}",
              file=sys.stderr)
        return interrupts.exit_status(e)


def end_process(status: int):
    """End the process with ``status`` once a command has returned: the streams flushed and the
    exit functions run (logging's, multiprocessing's, dask's: what registered one), then
    ``os._exit``. The interpreter's own teardown is skipped: freeing every object and unloading
    Warp, LLVM and FFTW took 0.4-0.6 s of a 2.5 s `warpcontact solve` on 2 cores (the same process
    ending through ``os._exit``: 1.88-1.93 s against 2.39-2.49 s) and does nothing a finished
    command needs; every output is written and closed by then."""
    import atexit

    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe: nothing more to say there
            pass
    atexit._run_exitfuncs()
    os._exit(status)


def run(argv=None):
    """The ``warpcontact`` command: :func:`main` on ``argv`` (default: the process's arguments),
    then :func:`end_process` with its exit status (an error that escapes ``main``, or the
    SystemExit of ``--help``, ends the process as Python does)."""
    end_process(main(argv))


if __name__ == "__main__":
    run()

"""``warpcontact solve CASE.toml --out DIR``: the command's work (its parser is in ``cli/__init__.py``), and
the helpers that the other commands of a load path share (gross-slip, pull-off in ``cli/__init__.py``;
``figure`` on a case file, ``cli/figure.py``, solves through :func:`cmd_solve`).

The command line's modules import one way: ``cli`` imports ``cli.solve``, ``cli.figure``,
``cli.sweep``, ``cli.stress`` and ``cli.fit``; ``cli.figure`` imports ``cli.solve``; none imports
``cli`` itself, and ``cli.solve`` imports no other module of the command line
(tests/test_imports.py checks it).
"""

from __future__ import annotations

import sys
from pathlib import Path

from .. import interrupts
from ..errors import OutputError
from ..records.progress import Progress

EXIT_NOT_CONVERGED = 3
#: the solve's results written, a check after it (the yield check) failed (its warning says why)
EXIT_CHECK_FAILED = 4


def cmd_solve(args) -> int:
    from ..records.case import load_case
    from ..records.guards import check_failure
    from ..records.results import atomic_write_json, atomic_write_npz
    from ..studies.runner import run_path

    case = load_case(args.case).with_overrides(device=args.device, dtype=args.dtype, fft=args.fft)
    fields = getattr(args, "fields", None) or "all"
    out = Path(args.out)
    result_path, fields_path = out / "result.json", out / "fields.npz"
    progress = Progress("solve", total=len(case.load.path()), quiet=args.quiet)

    earlier = _earlier_run(out, ("result.json", "fields.npz"))

    def on_start(result):
        """Where an earlier run left its files, the first write: this run's result.json (complete:
        false, no state yet) replaces the earlier one, whose fields.npz goes with it (it would not
        match). Elsewhere nothing is written before the first state finishes."""
        if earlier:
            atomic_write_json(result_path, result.summary(complete=False))
            _remove_stale(fields_path)

    def on_state(k, total, summary, result):
        progress.update(k + 1, summary["iterations"], summary["residual"], f"F_z {summary['force']['z']:.3e} N")
        atomic_write_json(result_path, result.summary(complete=False))  # nothing finished is lost

    try:
        result = run_path(case, on_state=on_state, fields=fields, on_start=on_start)
        if result.interrupted:
            interrupts.stopping()  # a second signal does not cut the last writes
    finally:
        progress.close()
    if result.interrupted and not result.states and not earlier:
        print(f"{interrupts.describe()}: stopped before the first state finished; nothing was written", file=sys.stderr)
        return interrupts.exit_status()
    with interrupts.deferred(raise_after=False):  # the last writes are not cut by a second signal
        _write_solve_outputs(result, out, fields, atomic_write_json, atomic_write_npz)
    if result.interrupted and not result.states:
        print(f"{interrupts.describe()}: stopped before the first state finished; {result_path} (which replaced "
              "the earlier run's) records the stop and holds no state", file=sys.stderr)
        return interrupts.exit_status()
    if result.interrupted:
        print(f"{interrupts.describe()}: {len(result.states)} of {len(case.load.path())} state(s) finished and "
              f"written to {out}", file=sys.stderr)
        return interrupts.exit_status()
    if not result.converged:
        bad = [i for i, s in enumerate(result.states) if not s["converged"]]
        s = result.states[bad[0]]
        print(
            f"not converged: state {bad[0]} stopped at residual {s['residual']:.3e} after {s['iterations']} "
            f"iterations (tolerance {case.solver.tol:g}){_turns_hint(result.states, case)}; results written to {out} "
            "with converged = false",
            file=sys.stderr,
        )
        return EXIT_NOT_CONVERGED
    if check_failure(result.yield_check) is not None:
        return EXIT_CHECK_FAILED
    if not args.quiet:
        last = result.states[-1]
        print(
            f"F = ({last['force']['x']:.4e}, {last['force']['y']:.4e}, {last['force']['z']:.4e}) N, "
            f"contact radius {last['contact_radius']:.4e} m, max pressure {last['max_pressure']:.4e} Pa "
            f"[{result.model.device}, {result.model.dtype_name}, {result.elapsed_s:.2f} s] -> {out}",
            file=sys.stderr,
        )
    return 0


def _remove_stale(path: Path):
    """Remove an output an earlier run left (it would not belong to this run's result)."""
    try:
        path.unlink(missing_ok=True)
    except OSError as e:
        from ..records.results import output_error

        raise output_error(path, e, "remove the earlier run's") from None


def _write_solve_outputs(result, out: Path, fields: str, atomic_write_json, atomic_write_npz):
    """The last writes of ``solve``: OUT/fields.npz (the fields kept, when any), then OUT/result.json
    marked complete when every state is solved and both are written. When the fields do not fit,
    result.json still gets every summary (``write_error`` says what failed) and the OutputError is
    raised with the option that writes fewer."""
    fields_path, result_path = out / "fields.npz", out / "result.json"
    fields_error = None
    if fields != "none" and result.fields:
        try:
            atomic_write_npz(fields_path, result.stacked_fields())
        except OutputError as e:
            fields_error = e.with_hint(_fewer_fields_hint(result, e))
    summary = result.summary(complete=fields_error is None and not result.interrupted)
    summary["fields_file"] = fields_path.name if fields != "none" and fields_error is None and result.fields else None
    summary["fields_kept"] = fields
    if fields_error is not None:
        summary["write_error"] = str(fields_error)
    try:
        atomic_write_json(result_path, summary)
    except OutputError as e:
        raise (fields_error or e) from None
    if fields_error is not None:
        raise fields_error


def _fewer_fields_hint(result, e: OutputError) -> str:
    """What to say when fields.npz does not fit: the summaries are written; the option that writes fewer."""
    from ..errors import human_bytes

    n = len(result.fields)
    text = f"the fields of {n} state(s) are what does not fit (every state's summary is in result.json)"
    if n > 1 and e.needed_bytes:
        return text + f": --fields last writes the last state's (about {human_bytes(e.needed_bytes / n)}), " \
                      "--fields none writes none"
    return text + ": --fields none writes none"


def _earlier_run(out: Path, names) -> bool:
    """True when OUT holds one of ``names``, an earlier run's files that this run replaces first."""
    return any((out / name).exists() for name in names)


def _turns_hint(states, case) -> str:
    """What to say when an unconverged state used every turn its step was allowed."""
    limit = case.solver.max_turns
    if any(not st.get("converged", True) and st.get("outer_iterations", 0) >= limit for st in states):
        return (f" (a load step used all solver.max_turns = {limit} turns without the tractions settling: raise it "
                "in [solver]; the adhesive fixed point converges slowly at large Tabor parameters)")
    return ""

"""``warpcontact solve CASE.toml --out DIR``: the command's work (its parser is in ``cli/__init__.py``), and
the helpers that the other commands of a load path share (gross-slip, pull-off in ``cli/__init__.py``;
``figure`` on a case file, ``cli/figure.py``, solves through :func:`cmd_solve`; ``fretting``,
``cli/fretting.py``, through :func:`solve_and_write`).

The command line's modules import one way: ``cli`` imports ``cli.solve``, ``cli.figure``,
``cli.sweep``, ``cli.stress``, ``cli.fit`` and ``cli.fretting``; ``cli.figure`` and
``cli.fretting`` import ``cli.solve``; none imports
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

    case = load_case(args.case).with_overrides(device=args.device, dtype=args.dtype, fft=args.fft)
    figures = ()
    if not case.sphere.hertzian:  # a punch, a cone, a height map: the area and patches against the load
        from ..plots import contact_load

        figures = (("load.png", contact_load),)
    return solve_and_write(case, args, "solve", figures=figures)


def solve_and_write(case, args, command: str, extra=None, figures=(), report=None) -> int:
    """Solve every state of ``case``'s path and write ``args.out``: result.json (from the start,
    after each state and at the end), fields.npz (``args.fields``), then ``figures``: the work of
    ``solve``, shared with the commands that add to it (``fretting``). ``extra(states)``: keys
    added to result.json at every write, from the states finished so far; ``figures``: (file name,
    draw) pairs, ``draw(record)`` a Figure of the finished result.json record, drawn when every
    state is solved (an earlier run's files of these names are removed at the start);
    ``report(record)``: the lines printed on success (by default the last state's forces).
    Returns the exit status."""
    from ..records.guards import check_failure
    from ..records.results import atomic_write_json, atomic_write_npz
    from ..studies.runner import run_path

    fields = getattr(args, "fields", None) or "all"
    out = Path(args.out)
    result_path, fields_path = out / "result.json", out / "fields.npz"
    progress = Progress(command, total=len(case.load.path()), quiet=args.quiet)
    figure_names = [name for name, _ in figures]

    def record(result, complete=False):
        return {**result.summary(complete=complete), **(extra(result.states) if extra is not None else {})}

    earlier = _earlier_run(out, ("result.json", "fields.npz", *figure_names))

    def on_start(result):
        """Where an earlier run left its files, the first write: this run's result.json (complete:
        false, no state yet) replaces the earlier one, whose fields.npz and figures go with it (they
        would not match). Elsewhere nothing is written before the first state finishes."""
        if earlier:
            atomic_write_json(result_path, record(result))
            for name in ("fields.npz", *figure_names):
                _remove_stale(out / name)

    def on_state(k, total, summary, result):
        progress.update(k + 1, summary["iterations"], summary["residual"], f"F_z {summary['force']['z']:.3e} N")
        atomic_write_json(result_path, record(result))  # nothing finished is lost

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
        final = _write_solve_outputs(result, out, fields, atomic_write_json, atomic_write_npz, record, figures)
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
        lines = report(final) if report is not None else [
            f"F = ({last['force']['x']:.4e}, {last['force']['y']:.4e}, {last['force']['z']:.4e}) N, "
            f"contact radius {last['contact_radius']:.4e} m, max pressure {last['max_pressure']:.4e} Pa"]
        lines[-1] += f" [{result.model.device}, {result.model.dtype_name}, {result.elapsed_s:.2f} s] -> {out}"
        for line in lines:
            print(line, file=sys.stderr)
    return 0


def _remove_stale(path: Path):
    """Remove an output an earlier run left (it would not belong to this run's result)."""
    try:
        path.unlink(missing_ok=True)
    except OSError as e:
        from ..records.results import output_error

        raise output_error(path, e, "remove the earlier run's") from None


def _write_solve_outputs(result, out: Path, fields: str, atomic_write_json, atomic_write_npz, record=None,
                         figures=()) -> dict:
    """The last writes of ``solve``: OUT/fields.npz (the fields kept, when any), the ``figures``
    (file name, draw) of a path solved to its end, then OUT/result.json marked complete when every
    state is solved and every output written. ``record(result, complete)``: result.json's content
    (default ``result.summary``). When the fields do not fit, result.json still gets every summary
    (``write_error`` says what failed) and the OutputError is raised with the option that writes
    fewer; a figure that cannot be written leaves result.json incomplete with ``write_error``.
    Returns the record written."""
    fields_path, result_path = out / "fields.npz", out / "result.json"
    if record is None:
        def record(result, complete=False):
            return result.summary(complete=complete)
    fields_error = figure_error = None
    if fields != "none" and result.fields:
        try:
            atomic_write_npz(fields_path, result.stacked_fields(in_memory=False))
        except OutputError as e:
            fields_error = e.with_hint(_fewer_fields_hint(result, e))
    summary = record(result, complete=False)
    if figures and fields_error is None and not result.interrupted and result.states:
        from ..plots import save
        from ..records.results import output_error

        for name, draw in figures:
            try:
                save(draw(summary), out / name)
            except OSError as e:
                figure_error = output_error(out / name, e)
                break
    error = fields_error or figure_error
    summary["complete"] = error is None and not result.interrupted
    summary["fields_file"] = fields_path.name if fields != "none" and fields_error is None and result.fields else None
    summary["fields_kept"] = fields
    if error is not None:
        summary["write_error"] = str(error)
    try:
        atomic_write_json(result_path, summary)
    except OutputError as e:
        raise (error or e) from None
    if error is not None:
        raise error
    return summary


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

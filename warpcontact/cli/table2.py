"""``warpcontact table2``: the paper's Table 2, cell by cell on the batch engine, each finished
cell written at once; a rerun with the same settings skips the finished cells."""

from __future__ import annotations

import math
import sys
from pathlib import Path

from .. import interrupts
from ..errors import InputError, OutputError
from ..records.guards import check_failure
from ..records.progress import Progress
from .solve import EXIT_CHECK_FAILED, EXIT_NOT_CONVERGED


def cmd_table2(args) -> int:
    import json
    import math

    from ..records.results import atomic_write_bytes, atomic_write_json
    from ..studies.batch import Task, run_tasks
    from .sweep import placement_from
    from ..records.guards import RunChecks
    from ..studies.table2 import Table2Settings, cell_model_key, cells, markdown, run_cell

    for n in args.n:
        if n < 8:
            raise InputError("--n", f"must be at least 8, got {n}")
    if not (args.size_in_a > 2.0):
        raise InputError("--size-in-a", f"the domain must hold the contact diameter 2a: use more than 2, got {args.size_in_a}")
    law = dict(sigma_max=args.sigma_max, tau_max=args.tau_max, delta_n=args.delta_n, delta_t=args.delta_t)
    if args.contact_shear != "bounded":  # the default is left out: its cells match the records that lack the key
        law["contact_shear"] = args.contact_shear
    try:
        Table2Settings(**law).adhesion_law()
        if not args.no_adhesion:  # a length in nm written as m, ...: the plausibility of every case
            from ..records.case import AdhesionSpec
            from ..physics.materials import PAPER_PAIR
            from ..records.plausibility import check_adhesion

            bodies = {k: (m.E, m.nu, m.yield_strength, m.hardness)
                      for k, m in (("sphere", PAPER_PAIR.sphere), ("flat", PAPER_PAIR.flat))}
            check_adhesion(AdhesionSpec("smc", **law), PAPER_PAIR.E_star, bodies)
    except InputError as e:  # name the option, not the case-file key
        raise InputError("--" + e.key.split(".")[-1].replace("_", "-"), e.problem) from None
    columns = (False,) if args.no_adhesion else (True,) if args.adhesion_only else (False, True)
    out = Path(args.out)
    path = out / "table2.json"
    records = json.loads(path.read_text())["cells"] if path.exists() else []
    selected = cells()
    for name, values, column in (("--k-tau", args.k_tau, 0), ("--delta-z-um", args.delta_z_um, 1)):
        if values:
            known = sorted({c[column] for c in cells()})
            for v in values:
                if not any(math.isclose(v, k, rel_tol=1e-9) for k in known):
                    raise InputError(name, f"{v!r} is not a cell of Table 2; choose from {known}")
            selected = [c for c in selected if any(math.isclose(c[column], v, rel_tol=1e-9) for v in values)]
    todo = [(n, k, dz, adh) for adh in columns for n in args.n for k, dz in selected]
    _table2_resolution(todo, args.size_in_a, law)
    settings_key = (args.size_in_a, args.device or "cpu", args.dtype or "float64", args.fft or "auto")
    law_key = tuple(sorted(law.items()))

    def key(n, k, dz, adh, size_in_a, device, dtype, fft, law=None):
        return (n, k, dz, adh, size_in_a, device, dtype, fft, law if adh else None)

    def record_law(r):
        d = r.get("adhesion_law") or {}
        return tuple(sorted((name, d.get(name)) for name in law))

    done = {key(r["n"], r["k_tau"], r["delta_z_um"], r.get("adhesion", False), r.get("size_in_a", 3.0),
                r.get("device", "cpu"), r.get("dtype", "float64"), r.get("fft", "auto"), record_law(r)) for r in records}
    placement = placement_from(args)
    interrupted = False
    write_error = None  # an OutputError that stopped the run
    kept = len(records)  # cells in table2.json on disk
    finished = sum(1 for c in todo if key(*c, *settings_key, law_key) in done)
    progress = Progress("table2", total=len(todo), quiet=args.quiet, start=finished)  # a bar over the cells
    pending = [(i, c) for i, c in enumerate(todo) if key(*c, *settings_key, law_key) not in done]

    def settings_for(n):
        return Table2Settings(n=n, size_in_a=args.size_in_a, device=args.device or "cpu",
                              dtype=args.dtype or "float64", fft=args.fft or "auto", **law)

    def label(n, k, dz, adh):
        return f"n {n} k_tau {k:.2f} delta_z {dz:.1e} um {'adhesive' if adh else 'adhesionless'}"

    def write(complete=False, stopped=False):
        nonlocal kept
        status = {"complete": complete, "interrupted": stopped, "cells_planned": len(todo),
                  "cells_done": finished, "stop_signal": interrupts.signal_name(interrupts.stop_signal())
                  if stopped else None}
        try:
            _write_table2(out, records, status, atomic_write_json, atomic_write_bytes, markdown)
        except OutputError as e:
            if Path(e.path).name != "table2.json":  # the JSON, written first, holds them all
                kept = len(records)
            raise
        kept = len(records)

    def finish(i, cell, rec, settings):
        """Keep a finished cell and write the tables at once; False if stopped meanwhile (a stop
        signal, a write error)."""
        nonlocal finished, write_error
        rec.update(size_in_a=args.size_in_a, device=settings.device, dtype=settings.dtype, fft=settings.fft)
        with interrupts.deferred():  # the tables are written whole, then a stop that came meanwhile is raised
            records.append(rec)
            finished += 1
            try:
                write()
            except OutputError as e:
                write_error = e
                return False
        progress.write(f"table2 [{i + 1}/{len(todo)}] {cell}: {_table2_result(rec)}")
        RunChecks(None).yielded(rec.get("yield_check"), f"in Table 2 cell {cell} (at delta_x_max)")  # each cell a run
        progress.status(finished)
        return True

    try:
        with interrupts.deferred():
            write()  # this run's marker (complete: false) replaces the last run's before any cell
        tasks = []
        for i, (n, k, dz, adh) in pending:  # one task of the batch engine per cell
            settings = settings_for(n)
            tasks.append(Task(str(i), label(n, k, dz, adh), run_cell, (k, dz, settings, adh),
                              cell_model_key(dz, settings, adh)))

        def on_result(task, rec):
            return finish(int(task.key), task.label, rec, task.args[2])

        def on_state(task, j, s):  # the states of a cell computed in this process, on a terminal
            progress.status(finished, s["iterations"], s["residual"], f"{task.label}: state {j + 1} ({s['kind']})")

        run_tasks(tasks, on_result, placement, progress=progress, failed=lambda rec: not rec["converged"],
                  on_state=on_state, before=finished)
    except KeyboardInterrupt as e:
        interrupts.stopping(e)  # a second signal does not cut the last writes
        interrupted = True
    progress.close()
    if write_error is not None:
        raise write_error.with_hint(f"{kept} cell(s) finished and kept in {path}: free space and run the same "
                                    "command again to compute the others") from None
    with interrupts.deferred(raise_after=False):
        try:
            write(complete=not interrupted, stopped=interrupted)
        except OutputError as e:
            raise e.with_hint(f"{kept} cell(s) finished and kept in {path}: free space and run the same command "
                              "again to finish") from None
    if interrupted:
        print(f"{interrupts.describe()}: {len(records)} cell(s) written to {out}; rerun to finish", file=sys.stderr)
        return interrupts.exit_status()
    if not all(r["converged"] for r in records):
        return EXIT_NOT_CONVERGED
    return EXIT_CHECK_FAILED if any(check_failure(r.get("yield_check")) for r in records) else 0


def _table2_resolution(todo, size_in_a: float, law: dict) -> None:
    """One warning when a Table 2 cell's grid is too coarse by the rule of every command
    (guards.resolution_advice), judged before the run on each cell's Hertz contact radius
    a = sqrt(R delta_z) and, in the adhesive columns, the adhesive zone that the Hertz gap
    leaves within the law's range delta_n (the DMT side's width, an upper bound)."""
    import warnings

    from ..records.guards import (
        CoarseGridWarning,
        adhesive_zone_estimate,
        resolution_advice,
        resolution_needs,
    )
    from ..studies.table2 import RADIUS

    worst = None
    for n, _, dz_um, adh in todo:
        a = math.sqrt(RADIUS * dz_um * 1e-6)
        widths = {"contact_radius": a}
        if adh:
            widths["adhesive_zone"] = adhesive_zone_estimate(a, RADIUS, law["delta_n"])
        needs = resolution_needs(n, size_in_a * a, **widths)
        if needs and (worst is None or max(x[-1] for x in needs) > worst[0]):
            worst = (max(x[-1] for x in needs), n, dz_um, widths)
    if worst is not None:
        need, n, dz_um, widths = worst
        text = resolution_advice(n, size_in_a * math.sqrt(RADIUS * dz_um * 1e-6), f"at delta_z = {dz_um:g} um",
                                 **widths)
        warnings.warn(f"table2 --n {n}: {text.split(' on the ')[0]}: results carry a large discretisation error; "
                      f"--n {need} would do", CoarseGridWarning, stacklevel=2)


def _table2_result(rec) -> str:
    """A finished cell's result line: delta_x_max [um] and mu against the paper, the time [s]."""
    if not rec["converged"]:
        return f"not converged (a state of the path did not converge), {rec['elapsed_s']:.0f} s"
    mu = ("undefined (F_z <= 0)" if rec["mu"] is None
          else f"{rec['mu']:.4f} ({100 * rec['rel_diff_mu']:+.1f} %)")
    return (f"delta_x_max {rec['delta_x_max_um']:.3e} um ({100 * rec['rel_diff_delta_x_max']:+.1f} %), "
            f"mu {mu}, {rec['elapsed_s']:.0f} s")


def _write_table2(out, records, status, atomic_write_json, atomic_write_bytes, markdown):
    """OUT/table2.json (``status``: complete, interrupted, cells planned and done; the cells),
    then table2.md and table2.csv, each whole (atomic: a failure raises OutputError and leaves
    the file as it was)."""
    import csv
    import io

    records = sorted(records, key=lambda r: (r.get("adhesion", False), r["n"], r["k_tau"], r["delta_z_um"]))
    atomic_write_json(out / "table2.json", {**status, "cells": records})
    atomic_write_bytes(out / "table2.md", markdown(records).encode())
    buf = io.StringIO()
    law_keys = ["sigma_max", "tau_max", "delta_n", "delta_t", "contact_shear"]
    keys = ["n", "k_tau", "delta_z_um", "adhesion", *law_keys, "delta_x_max_um", "paper_delta_x_max_um",
            "rel_diff_delta_x_max", "mu", "paper_mu", "rel_diff_mu", "mu_elastic", "converged", "yielded",
            "yield_margin", "elapsed_s"]
    w = csv.DictWriter(buf, fieldnames=keys, extrasaction="ignore")
    w.writeheader()
    def law_value(r, k):
        law = r.get("adhesion_law") or {}
        return law.get(k, "bounded" if k == "contact_shear" and law else "")

    w.writerows({**r, **{k: law_value(r, k) for k in law_keys}} for r in records)
    atomic_write_bytes(out / "table2.csv", buf.getvalue().encode())

"""The seed paper's Table 2: delta_x at gross slip and the static friction coefficient.

Copper sphere (R = 10 um) on hardened steel (Table 1), Tabor + von Mises shear limit, the 24
cells k_tau in (0.50, 0.80, 0.95) x delta_z in (1.0e-5, 5.0e-5, 1.0e-4, 1.5e-4) um, without and
with adhesion (the SMC law with ``Table2Settings``' parameters; the paper gives none:
docs/validation.md, "Adhesion defaults", gives the reasoning and docs/img/adhesion_sensitivity.png
the dependence).

A run of the table (:class:`Table2Run`, the ``warpcontact table2`` command's work) computes its cells
on the batch engine and writes ``OUT/table2.json``, ``.md`` and ``.csv`` after each finished cell; a
rerun with the same settings skips the cells finished before.
"""

from __future__ import annotations

import csv
import math
import time
from dataclasses import dataclass
from pathlib import Path

from .. import interrupts
from ..errors import InputError, OutputError
from ..physics.geometry import Grid, Sphere
from ..records.guards import grid_holding, suggested_adhesive_size, withhold_if_unconverged
from ..physics.materials import PAPER_PAIR

# the solvers (Warp, SciPy) are imported where a cell is computed: the command line's parser reads
# Table2Settings' defaults without them

RADIUS = 10e-6
K_TAU = (0.50, 0.80, 0.95)
DELTA_Z_UM = (1.0e-5, 5.0e-5, 1.0e-4, 1.5e-4)
UM = 1e-6
#: what a cell reports only when every state of its path converged
TABLE2_RESULTS = ("delta_x_max_um", "delta_x_gross_um", "mu", "mu_elastic", "force_N", "force_elastic_N",
                  "rel_diff_delta_x_max", "rel_diff_mu")
#: adhesion defaults of the adhesive cells (docs/validation.md, "Adhesion defaults": why these)
#: sigma_max = tau_max = 1 MPa, delta_n = delta_t = 5 pm (w = e sigma_max delta_n = 1.36e-5 J/m^2):
#: of the 12 pairs of validation/adhesion_sensitivity.py the weakest that raises mu
#: in all 12 cells, as the paper's columns do; RMS 10.8 points from the paper's change by adhesion
#: (the nominal best, 2 pm: 9.9 points, lowers mu in 7 of 12 cells)
SIGMA_MAX = 1.0e6
TAU_MAX = 1.0e6
DELTA_N = 5.0e-12
DELTA_T = 5.0e-12


def paper_table(path=None) -> dict:
    """The paper's values: {(k_tau, delta_z_um, adhesion): (delta_x_max_um, mu)}.

    Read from ``shared/data/table2.csv`` when it is found (or ``path``), else from the copy below.
    """
    rows = {}
    candidates = [Path(path)] if path else [Path(__file__).resolve().parents[2] / "shared" / "data" / "table2.csv"]
    for c in candidates:
        if c.exists():
            with open(c) as fh:
                for r in csv.DictReader(line for line in fh if not line.startswith("#")):
                    rows[(float(r["k_tau"]), float(r["delta_z_um"]), r["adhesion"] == "yes")] = (
                        float(r["delta_x_max_um"]), float(r["mu"]))
            return rows
    return dict(_PAPER)


# transcription of the paper's Table 2, used when the CSV is not beside us, laid out as the paper
# prints it: per column (adhesion) and k_tau (K_TAU), the (delta_x_max_um, mu) of each delta_z in
# DELTA_Z_UM
_PAPER_ROWS = {
    (False, 0.50): ((4.2e-6, 0.332), (2.1e-5, 0.332), (4.2e-5, 0.332), (5.5e-5, 0.308)),
    (False, 0.80): ((9.6e-6, 0.769), (4.8e-5, 0.769), (7.3e-5, 0.665), (7.7e-5, 0.495)),
    (False, 0.95): ((2.2e-5, 1.755), (6.7e-5, 1.250), (8.2e-5, 0.827), (8.5e-5, 0.583)),
    (True, 0.50): ((4.4e-6, 0.340), (2.4e-5, 0.350), (4.9e-5, 0.357), (6.5e-5, 0.325)),
    (True, 0.80): ((1.0e-5, 0.788), (5.4e-5, 0.809), (8.5e-5, 0.688), (8.8e-5, 0.502)),
    (True, 0.95): ((2.3e-5, 1.798), (7.5e-5, 1.277), (9.5e-5, 0.843), (9.8e-5, 0.587)),
}
_PAPER = {(k, dz, adh): cell for (adh, k), cells in _PAPER_ROWS.items()
          for dz, cell in zip(DELTA_Z_UM, cells, strict=True)}


@dataclass(frozen=True)
class Table2Settings:
    """Grid and solver settings of a Table 2 run.

    Attributes:
        n: cells per side of a domain of ``size_in_a`` contact radii (the resolution: cell side
            size_in_a a / n). Adhesive cells whose law reaches beyond that domain get a larger
            one with the same cell side (see :func:`cell_grid`).
        size_in_a: domain side in Hertz contact radii a = sqrt(R delta_z) of each cell.
        device, dtype, fft: as in case files.
        rel_tol: bisection bracket of delta_x_max, relative.
        sigma_max, tau_max: the SMC law's peak normal and shear tractions [Pa] (adhesive cells).
        delta_n, delta_t: its characteristic lengths [m].
        contact_shear: its shear inside the contact, "bounded" or "added"
            (``warpcontact.physics.adhesion.SMC``).
    """

    n: int = 128
    size_in_a: float = 3.0
    device: str = "cpu"
    dtype: str = "float64"
    fft: str = "auto"
    rel_tol: float = 0.01
    sigma_max: float = SIGMA_MAX
    tau_max: float = TAU_MAX
    delta_n: float = DELTA_N
    delta_t: float = DELTA_T
    contact_shear: str = "bounded"

    def adhesion_law(self):
        """The SMC law of these parameters (``warpcontact.physics.adhesion.SMC``)."""
        from ..physics.adhesion import SMC

        return SMC(self.sigma_max, self.tau_max, self.delta_n, self.delta_t, contact_shear=self.contact_shear)


def cell_grid(delta_z: float, settings: Table2Settings, adhesion=None, radius: float = RADIUS) -> Grid:
    """The grid of a cell at normal approach ``delta_z`` [m]: ``settings.n`` cells over
    ``settings.size_in_a`` Hertz radii sqrt(``radius`` delta_z) (``radius``: the sphere's, Table 2's
    10 um by default); with an adhesive law whose tail (the gap where its
    traction falls to 1 % of its peak) lies beyond that domain, the domain grows to hold it
    (:func:`warpcontact.records.guards.suggested_adhesive_size`) and the cell count with it, so the cell side
    stays the same (:func:`warpcontact.records.guards.grid_holding`). Outside the contact the adhesive
    annulus at gap h carries 2 pi R sigma(h) dh, a
    force that does not fall with r: a domain that cuts the tail cuts the adhesive force (for the
    SMC law, a fraction (1 + x) e^-x of it is left out beyond gap x delta_n)."""
    size = settings.size_in_a * math.sqrt(radius * delta_z)
    if adhesion is None:
        return Grid(settings.n, size)
    return grid_holding(settings.n, size, suggested_adhesive_size(radius, delta_z, adhesion))


def table2_cell(k_tau: float, delta_z_um: float, settings: Table2Settings, on_state=None, adhesion: bool = False,
                model=None) -> dict:
    """One cell: delta_x_max, mu and the paper's values, with relative differences.

    With ``adhesion`` the SMC law of ``settings`` acts; mu = F_x / F_z with the total F_z
    (adhesive part included, MODEL.md section 7), and mu_elastic = F_x / F_z of the contact
    pressure alone is reported beside it. ``model``: the cell's model to reuse (a
    :class:`~warpcontact.numerics.model.ContactModel` of :func:`cell_model_key`), else one is built.
    """
    from .slip_search import solve_search
    from ..solvers.contact import ContactSolver

    if model is None:
        model = cell_model(delta_z_um, settings, adhesion)
    search, finish, law = cell_search(k_tau, delta_z_um, settings, adhesion, model, on_state)
    return finish(solve_search(search, ContactSolver(model, law, adhesion=search.adhesion)))


def cell_model(delta_z_um: float, settings: Table2Settings, adhesion: bool):
    """The model of a cell (:func:`cell_model_key`)."""
    from ..numerics.model import ContactModel

    adhesive = settings.adhesion_law() if adhesion else None
    return ContactModel(PAPER_PAIR, Sphere(RADIUS), cell_grid(delta_z_um * UM, settings, adhesive),
                        device=settings.device, dtype=settings.dtype, fft=settings.fft)


def cell_search(k_tau: float, delta_z_um: float, settings: Table2Settings, adhesion: bool, model, on_state=None):
    """(search, finish, law): a cell's gross-slip search on its ``model``
    (:class:`~warpcontact.studies.slip_search.GrossSlipSearch`, whoever solves its states: one at a
    time, :func:`table2_cell`, or batched with other cells', :meth:`Table2Run.run`),
    ``finish(result)`` its record, and its Tabor-von Mises law."""
    from ..physics.friction import TaborVonMises
    from .slip_search import GrossSlipSearch
    from ..numerics.yielding import state_yield_keys

    dz = delta_z_um * UM
    adhesive = settings.adhesion_law() if adhesion else None
    law = TaborVonMises(k_tau, PAPER_PAIR.softer.yield_strength)
    t0 = time.perf_counter()
    search = GrossSlipSearch(model, law, adhesive, dz, rel_tol=settings.rel_tol, on_state=on_state,
                             at_max=state_yield_keys)

    def finish(r: dict) -> dict:
        paper_dx, paper_mu = paper_table().get((k_tau, delta_z_um, bool(adhesion)), (math.nan, math.nan))
        dx_um = r["delta_x_max"] / UM
        record = {
            "k_tau": k_tau,
            "delta_z_um": delta_z_um,
            "adhesion": bool(adhesion),
            "delta_x_max_um": dx_um,
            "delta_x_gross_um": r["delta_x_gross"] / UM,
            "mu": r["mu"],
            "mu_elastic": r["mu_elastic"],
            "force_N": r["force"],
            "force_elastic_N": r["force_elastic"],
            "paper_delta_x_max_um": paper_dx,
            "paper_mu": paper_mu,
            "rel_diff_delta_x_max": dx_um / paper_dx - 1.0,
            "rel_diff_mu": None if r["mu"] is None else r["mu"] / paper_mu - 1.0,
            "converged": r["converged"],
            "n": settings.n,
            "grid_n": model.grid.n,
            "size_m": model.grid.size,
            "cell_m": model.grid.dx,
            "mu_b": law.mu_b,
            "crossover_pressure_Pa": law.crossover_pressure,
            "elapsed_s": time.perf_counter() - t0,
            "states": len(r["states"]),
            **{k: r.get(k) for k in ("yielded", "yield_margin", "yield_check")},  # at delta_x_max (find_gross_slip)
        }
        if "mu_note" in r:
            record["mu_note"] = r["mu_note"]
        if adhesive is not None:
            record["adhesion_law"] = adhesive.describe()
        return withhold_if_unconverged(record, TABLE2_RESULTS)

    return search, finish, law


def cell_model_key(delta_z_um: float, settings: Table2Settings, adhesion: bool) -> tuple:
    """What the model of a cell depends on (:func:`warpcontact.studies.batch.model_key`): cells of one
    delta_z, column and grid share it, whatever their k_tau."""
    from .batch import model_key

    grid = cell_grid(delta_z_um * UM, settings, settings.adhesion_law() if adhesion else None)
    return model_key(PAPER_PAIR, Sphere(RADIUS), grid, settings.device, settings.dtype, settings.fft)


def run_cell(k_tau: float, delta_z_um: float, settings: Table2Settings, adhesion: bool, on_state=None) -> dict:
    """:func:`table2_cell` where the batch engine runs it (a worker of ``warpcontact table2
    --workers``, or this process): the model from the process's cache (a cell of the last cell's
    grid reuses it; :func:`warpcontact.studies.batch.cached_model`); on a worker pinned to a GPU a CUDA
    cell runs on that GPU."""
    import dataclasses

    from .batch import cached_model, worker_device
    from ..numerics.model import ContactModel

    device = worker_device(settings.device)
    if device != settings.device:
        settings = dataclasses.replace(settings, device=device)
    key = cell_model_key(delta_z_um, settings, adhesion)
    model = cached_model(key, lambda: ContactModel(key[0], key[1], key[2], device=settings.device,
                                                   dtype=settings.dtype, fft=settings.fft))
    return table2_cell(k_tau, delta_z_um, settings, on_state=on_state, adhesion=adhesion, model=model)


def search_entries(cells: list) -> list:
    """The gross-slip searches of ``cells`` ((k_tau, delta_z_um, settings, adhesion) each) for
    ``batch_solve.search_batch``: each started on the model it is given, or run on its own."""
    from .batch_solve import SearchEntry

    entries = []
    for k, dz, settings, adh in cells:
        def start(model, k=k, dz=dz, settings=settings, adh=adh):
            search, finish, law = cell_search(k, dz, settings, adh, model)
            return search, finish, law, math.inf

        entries.append(SearchEntry(alone=lambda k=k, dz=dz, settings=settings, adh=adh: run_cell(k, dz, settings, adh),
                                   start=start, model_key=cell_model_key(dz, settings, adh),
                                   build=lambda dz=dz, settings=settings, adh=adh: cell_model(dz, settings, adh),
                                   adhesive=adh))
    return entries


def search_cells(cells: list, batch: int, on_state=None) -> list:
    """Cells of one grid ((k_tau, delta_z_um, settings, adhesion) each) searched together by
    batched steps (``batch_solve.search_batch``, ``batch`` at a time), where the batch engine runs
    them (a worker of ``warpcontact table2 --workers``, on its GPU, or this process): one value a
    cell, in order: (its record, its checks' warnings' messages), or the error it raised
    (``batch.carried``). ``on_state`` is not called: the cells' states are solved together."""
    import dataclasses

    from .batch import carried, worker_device
    from .batch_solve import search_batch

    cells = [(k, dz, dataclasses.replace(settings, device=worker_device(settings.device)), adh)
             for k, dz, settings, adh in cells]
    values = []
    for entry in search_batch(search_entries(cells), batch):
        if isinstance(entry, BaseException):
            error = carried(entry)
            if error is None:
                raise entry
            entry = error
        values.append(entry)
    return values


def cells():
    """The (k_tau, delta_z_um) cells of each column (with or without adhesion)."""
    return [(k, dz) for k in K_TAU for dz in DELTA_Z_UM]


def _law_text(record) -> str:
    """The adhesion column of the Markdown table: "no", or the SMC law's parameters."""
    law = record.get("adhesion_law")
    if not record.get("adhesion"):
        return "no"
    if not law:
        return "yes"
    added = ", added in contact" if law.get("contact_shear") == "added" else ""
    return (f"SMC {law['sigma_max']:g} / {law['tau_max']:g} Pa, "
            f"{law['delta_n']:g} / {law['delta_t']:g} m{added}")


def _elastic_text(record) -> str:
    """The elastic column: "yes" or "no, yielded", with the margin S_Y / von Mises max; "-" when not
    checked (a record without the yield keys, or no check)."""
    y, m = record.get("yielded"), record.get("yield_margin")
    if y is None:
        return "-"
    return f"{'no, yielded' if y else 'yes'} (margin {m:.3g})" if m is not None else ("no, yielded" if y else "yes")


def markdown(records: list) -> str:
    """The table as Markdown: computed, paper, relative difference; unconverged cells marked."""
    lines = [
        "| k_tau | delta_z (um) | adhesion | delta_x_max (um) | paper | diff | mu | paper | diff | n | converged "
        "| elastic at delta_x_max |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in records:
        if r["converged"]:
            dx, ddx = f"{r['delta_x_max_um']:.3e}", f"{100 * r['rel_diff_delta_x_max']:+.1f} %"
            if r["mu"] is None:
                mu, dmu = "undefined (F_z <= 0)", "-"
            else:
                mu, dmu = f"{r['mu']:.4f}", f"{100 * r['rel_diff_mu']:+.1f} %"
        else:
            dx = mu = ddx = dmu = "not converged"
        lines.append(
            f"| {r['k_tau']:.2f} | {r['delta_z_um']:.1e} | {_law_text(r)} | {dx} | {r['paper_delta_x_max_um']:.1e} | {ddx} | "
            f"{mu} | {r['paper_mu']:.3f} | {dmu} | {r['n']} | {r['converged']} | {_elastic_text(r)} |"
        )
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------------------------------
# A run of the table: its cells on the batch engine, each finished cell written at once.

#: the SMC law's columns of table2.csv
_CSV_LAW = ("sigma_max", "tau_max", "delta_n", "delta_t", "contact_shear")


def cell_law(settings: Table2Settings) -> dict:
    """The SMC law's parameters of ``settings`` that tell adhesive cells apart: sigma_max, tau_max
    [Pa], delta_n, delta_t [m], and contact_shear only when not "bounded" (so the cells of the
    default match the records written without that key)."""
    law = {k: getattr(settings, k) for k in ("sigma_max", "tau_max", "delta_n", "delta_t")}
    if settings.contact_shear != "bounded":
        law["contact_shear"] = settings.contact_shear
    return law


def check_law(settings: Table2Settings, adhesive: bool = True) -> None:
    """InputError (keyed as in a case file: adhesion.sigma_max, ...) for an SMC law of ``settings``
    out of range and, when adhesive cells run, for one implausible on the paper's pair (a length in
    nm written as m, ...: :func:`warpcontact.records.plausibility.check_adhesion`)."""
    settings.adhesion_law()
    if adhesive:
        from ..records.case import AdhesionSpec
        from ..records.plausibility import check_adhesion

        bodies = {k: (m.E, m.nu, m.yield_strength, m.hardness)
                  for k, m in (("sphere", PAPER_PAIR.sphere), ("flat", PAPER_PAIR.flat))}
        check_adhesion(AdhesionSpec("smc", **cell_law(settings)), PAPER_PAIR.E_star, bodies)


def select_cells(k_tau=(), delta_z_um=()) -> list:
    """The (k_tau, delta_z_um) cells of each column whose k_tau is among ``k_tau`` and delta_z [um]
    among ``delta_z_um`` (empty: all); InputError (key "k_tau" or "delta_z_um") for a value that is
    no cell of the table."""
    selected = cells()
    for name, values, column in (("k_tau", k_tau, 0), ("delta_z_um", delta_z_um, 1)):
        if values:
            known = sorted({c[column] for c in cells()})
            for v in values:
                if not any(math.isclose(v, k, rel_tol=1e-9) for k in known):
                    raise InputError(name, f"{v!r} is not a cell of Table 2; choose from {known}")
            selected = [c for c in selected if any(math.isclose(c[column], v, rel_tol=1e-9) for v in values)]
    return selected


def check_resolution(todo, size_in_a: float, law: dict) -> None:
    """One warning when a Table 2 cell's grid is too coarse by the rule of every command
    (guards.resolution_advice), judged before the run on each cell's Hertz contact radius
    a = sqrt(R delta_z) and, in the adhesive columns, the adhesive zone that the Hertz gap
    leaves within the law's range delta_n (the DMT side's width, an upper bound). ``todo``: the
    cells (n, k_tau, delta_z_um, adhesion); ``law``: the SMC law's parameters (delta_n [m])."""
    import warnings

    from ..records.guards import (
        CoarseGridWarning,
        adhesive_zone_estimate,
        resolution_advice,
        resolution_needs,
    )

    worst = None
    for n, _, dz_um, adh in todo:
        a = math.sqrt(RADIUS * dz_um * UM)
        widths = {"contact_radius": a}
        if adh:
            widths["adhesive_zone"] = adhesive_zone_estimate(a, RADIUS, law["delta_n"])
        needs = resolution_needs(n, size_in_a * a, **widths)
        if needs and (worst is None or max(x[-1] for x in needs) > worst[0]):
            worst = (max(x[-1] for x in needs), n, dz_um, widths)
    if worst is not None:
        need, n, dz_um, widths = worst
        text = resolution_advice(n, size_in_a * math.sqrt(RADIUS * dz_um * UM), f"at delta_z = {dz_um:g} um",
                                 **widths)
        warnings.warn(f"table2 --n {n}: {text.split(' on the ')[0]}: results carry a large discretisation error; "
                      f"--n {need} would do", CoarseGridWarning, stacklevel=2)


def result_text(rec) -> str:
    """A finished cell's result line: delta_x_max [um] and mu against the paper, the time [s]."""
    if not rec["converged"]:
        return f"not converged (a state of the path did not converge), {rec['elapsed_s']:.0f} s"
    mu = ("undefined (F_z <= 0)" if rec["mu"] is None
          else f"{rec['mu']:.4f} ({100 * rec['rel_diff_mu']:+.1f} %)")
    return (f"delta_x_max {rec['delta_x_max_um']:.3e} um ({100 * rec['rel_diff_delta_x_max']:+.1f} %), "
            f"mu {mu}, {rec['elapsed_s']:.0f} s")


def write_table2(out, records, status: dict) -> None:
    """OUT/table2.json (``status``: complete, interrupted, cells planned and done; the cells),
    then table2.md and table2.csv, each whole (atomic: a failure raises OutputError and leaves
    the file as it was)."""
    import io

    from ..files import atomic_write_bytes, atomic_write_json

    out = Path(out)
    records = sorted(records, key=lambda r: (r.get("adhesion", False), r["n"], r["k_tau"], r["delta_z_um"]))
    atomic_write_json(out / "table2.json", {**status, "cells": records})
    atomic_write_bytes(out / "table2.md", markdown(records).encode())
    buf = io.StringIO()
    keys = ["n", "k_tau", "delta_z_um", "adhesion", *_CSV_LAW, "delta_x_max_um", "paper_delta_x_max_um",
            "rel_diff_delta_x_max", "mu", "paper_mu", "rel_diff_mu", "mu_elastic", "converged", "yielded",
            "yield_margin", "elapsed_s"]
    w = csv.DictWriter(buf, fieldnames=keys, extrasaction="ignore")
    w.writeheader()

    def law_value(r, k):
        law = r.get("adhesion_law") or {}
        return law.get(k, "bounded" if k == "contact_shear" and law else "")

    w.writerows({**r, **{k: law_value(r, k) for k in _CSV_LAW}} for r in records)
    atomic_write_bytes(out / "table2.csv", buf.getvalue().encode())


def _cell_key(n, k, dz, adh, size_in_a, device, dtype, fft, law=None) -> tuple:
    """What a finished cell must match to stand for a planned one: its place in the table, grid and
    solver settings and, for an adhesive cell, the law's parameters (a tuple of sorted items)."""
    return (n, k, dz, adh, size_in_a, device, dtype, fft, law if adh else None)


def _record_key(r: dict, law_names) -> tuple:
    """:func:`_cell_key` of a record of table2.json (the defaults for the keys an older record
    lacks), its law read for the parameters ``law_names``."""
    law = r.get("adhesion_law") or {}
    return _cell_key(r["n"], r["k_tau"], r["delta_z_um"], r.get("adhesion", False), r.get("size_in_a", 3.0),
                     r.get("device", "cpu"), r.get("dtype", "float64"), r.get("fft", "auto"),
                     tuple(sorted((name, law.get(name)) for name in law_names)))


class Table2Run:
    """A run of Table 2 into the folder ``out``: the cells of each n of ``ns`` (default:
    ``settings.n``), each column of ``columns`` (adhesion False, True) and the cells of
    :func:`select_cells` (``k_tau``, ``delta_z_um``: empty for all), with the grid, solver and
    law settings of ``settings`` (its n replaced by each of ``ns``).

    Made, it reads ``out/table2.json`` (the cells finished by earlier runs), selects the cells
    (InputError for one that is no cell of the table), warns once of a grid too coarse
    (:func:`check_resolution`) and counts the planned cells finished before: those whose record
    matches their place, grid, solver settings and, adhesive, their law (:func:`_cell_key`).
    :meth:`run` computes the others.

    Attributes:
        records: every cell of table2.json, those of earlier runs first, then each one finished
            by this run.
        todo: the planned cells (n, k_tau, delta_z_um, adhesion).
        finished: the planned cells finished (before or by this run).
        kept: the cells in table2.json on disk.
        interrupted: a stop (Ctrl-C, SIGTERM, SIGHUP) ended :meth:`run`; the finished cells are written.
        write_error: the OutputError that ended :meth:`run` (no space left, ...), or None.
        write_error_at_end: whether it came at the last write, after the run's cells, rather than
            at a finished cell's (the cells still to compute were left).
    """

    def __init__(self, settings: Table2Settings, out, ns=None, columns=(False, True), k_tau=(), delta_z_um=()):
        import json

        self.settings = settings
        self.out = Path(out)
        self.path = self.out / "table2.json"
        self.records = json.loads(self.path.read_text())["cells"] if self.path.exists() else []
        selected = select_cells(k_tau, delta_z_um)
        self.todo = [(n, k, dz, adh) for adh in columns for n in (ns or (settings.n,)) for k, dz in selected]
        law = cell_law(settings)
        check_resolution(self.todo, settings.size_in_a, law)
        law_key = tuple(sorted(law.items()))
        done = {_record_key(r, law) for r in self.records}
        self._pending = [(i, c) for i, c in enumerate(self.todo)
                         if _cell_key(*c, *self._settings_key(), law_key) not in done]
        self.finished = len(self.todo) - len(self._pending)
        self.kept = len(self.records)
        self.interrupted = False
        self.write_error = None
        self.write_error_at_end = False

    def _settings_key(self) -> tuple:
        """The settings a finished cell must share beside its place: size_in_a, device, dtype, fft."""
        s = self.settings
        return (s.size_in_a, s.device, s.dtype, s.fft)

    @property
    def not_converged(self) -> list:
        """The records of table2.json whose path did not converge."""
        return [r for r in self.records if not r["converged"]]

    @property
    def check_failed(self) -> bool:
        """Whether a record's yield check failed (:func:`warpcontact.records.guards.check_failure`)."""
        from ..records.guards import check_failure

        return any(check_failure(r.get("yield_check")) for r in self.records)

    def _write(self, complete=False, stopped=False) -> None:
        """The tables with the run's status (:func:`write_table2`); ``kept`` follows what is on disk."""
        status = {"complete": complete, "interrupted": stopped, "cells_planned": len(self.todo),
                  "cells_done": self.finished, "stop_signal": interrupts.signal_name(interrupts.stop_signal())
                  if stopped else None}
        try:
            write_table2(self.out, self.records, status)
        except OutputError as e:
            if Path(e.path).name != "table2.json":  # the JSON, written first, holds them all
                self.kept = len(self.records)
            raise
        self.kept = len(self.records)

    def _batched_cells(self, batch) -> tuple[list, int | None]:
        """The pending cells searched by batched steps (:meth:`run`) and their batch: with
        ``batch`` given, all of them (the adhesive ones where the batched turns carry their law,
        ``batch_solve.lagged_smc``); without it, those of grids that few searches pay batched on
        (``batch_solve.few_searches_batched``: on CUDA up to 256 cells per side), all at once."""
        from .batch_solve import few_searches_batched, lagged_smc

        # the adhesive cells where the batched turns carry their law
        adhesive = any(c[3] for _, c in self._pending) and lagged_smc(
            self.settings.adhesion_law(), RADIUS, PAPER_PAIR.E_star, capped=False)
        cells = [(i, c) for i, c in self._pending if adhesive or not c[3]]
        if batch is None:
            cells = [(i, c) for i, c in cells if few_searches_batched(c[0], self.settings.device)]
            batch = len(cells)
        if not batch or len(cells) < 2:
            return [], batch
        return cells, batch

    def _cell_task(self, i: int, cell):
        """The batch engine's task of planned cell ``i`` (n, k_tau, delta_z_um, adhesion) on its own
        (``run_cell``)."""
        from .batch import Task

        k, dz, settings, adh = self._cell_args(cell)
        return Task(str(i), self._label(settings.n, k, dz, adh), run_cell, (k, dz, settings, adh),
                    cell_model_key(dz, settings, adh))

    def _batched_tasks(self, cells, batch) -> tuple[list, dict]:
        """The batch engine's tasks of ``cells`` searched by batched steps on its workers: the cells
        of one grid (as ``search_batch`` batches them) ``batch`` at a time, each such group a task
        (``search_cells``; a lone cell its own task, ``_cell_task``), the largest grids first; and
        each group's cells' own tasks by its key (``batch.each_case`` hands their values back)."""
        from .batch import Task

        grids: dict = {}
        for i, cell in cells:
            k, dz, settings, adh = self._cell_args(cell)
            grids.setdefault((cell_model_key(dz, settings, adh)[2].n, adh), []).append(self._cell_task(i, cell))
        tasks, members = [], {}
        # the largest grids first (a worker free early then takes a short group, not the longest)
        for (grid_n, adh), own in sorted(grids.items(), key=lambda g: -g[0][0]):
            for first in range(0, len(own), batch):
                chunk = own[first:first + batch]
                if len(chunk) == 1:
                    tasks.append(chunk[0])
                    continue
                key = f"grid{grid_n}-{'adhesive' if adh else 'adhesionless'}-{first}"
                members[key] = chunk
                tasks.append(Task(key, f"{len(chunk)} {'adhesive' if adh else 'adhesionless'} cells on the grid of "
                                       f"{grid_n} cells per side, batched", search_cells,
                                  ([t.args for t in chunk], batch), (grid_n, adh), cases=len(chunk)))
        return tasks, members

    def _run_batched(self, cells, batch, progress) -> None:
        """Search ``cells`` ((index, (n, k_tau, delta_z_um, adhesion)) each) by batched steps, each
        record kept and the tables written as the cell ends."""
        from .batch_solve import search_batch

        planned = [self._cell_args(c) for _, c in cells]

        def on_case(j, entry):
            self._finish_searched(cells[j][0], planned[j], entry, progress)

        progress.status(self.finished, extra=f"{len(cells)} cells, batched")
        search_batch(search_entries(planned), batch, on_case)

    def _cell_args(self, cell) -> tuple:
        """(k_tau, delta_z_um, settings, adhesion) of a planned cell (n, k_tau, delta_z_um, adhesion)."""
        import dataclasses

        n, k, dz, adh = cell
        return k, dz, dataclasses.replace(self.settings, n=n), adh

    @staticmethod
    def _label(n, k, dz, adh) -> str:
        return f"n {n} k_tau {k:.2f} delta_z {dz:.1e} um {'adhesive' if adh else 'adhesionless'}"

    def _finish_searched(self, i, args, entry, progress) -> bool:
        """A cell searched by batched steps: its error raised, else its checks' warnings issued (as
        a cell on its own gives them) and the cell kept (``_finish``)."""
        import warnings

        from .batch import raised

        error = entry if isinstance(entry, BaseException) else raised(entry)
        if error is not None:
            raise error
        record, messages = entry
        for message in messages:
            warnings.warn(message, stacklevel=2)
        k, dz, settings, adh = args
        return self._finish(i, self._label(settings.n, k, dz, adh), record, settings, progress)

    def _finish(self, i, cell, rec, settings, progress) -> bool:
        """Keep a finished cell and write the tables at once; False if stopped meanwhile (a stop
        signal, a write error)."""
        from ..records.guards import RunChecks

        rec.update(size_in_a=settings.size_in_a, device=settings.device, dtype=settings.dtype, fft=settings.fft)
        with interrupts.deferred():  # the tables are written whole, then a stop that came meanwhile is raised
            self.records.append(rec)
            self.finished += 1
            try:
                self._write()
            except OutputError as e:
                self.write_error = e
                return False
        progress.write(f"table2 [{i + 1}/{len(self.todo)}] {cell}: {result_text(rec)}")
        RunChecks(None).yielded(rec.get("yield_check"), f"in Table 2 cell {cell} (at delta_x_max)")  # each cell a run
        progress.status(self.finished)
        return True

    def run(self, placement=None, quiet: bool = False, log=None, batch: int | None = None) -> "Table2Run":
        """Compute the planned cells not finished before where ``placement`` says
        (:class:`warpcontact.studies.batch.Placement`; default: this process) and write the tables
        after each (:func:`write_table2`; table2.json's ``complete`` is false until the last write).
        With ``batch`` B, the cells (the adhesive ones where the batched turns carry their law) are
        searched together by batched steps (``batch_solve.search_batch``, B cells of one grid at a
        time); with 0 one at a time; by default (None) together on CUDA up to 256 cells per side
        (``_batched_cells``), where a column's 12 cells pay batched, else one at a time. In this
        process the batched steps come first; on more workers the engine spreads the cells, those
        searched together as a task a group of one grid.
        A stop ends the run with ``interrupted`` set; a write that fails, with ``write_error``. Unless
        quiet, a result line per cell goes to ``log`` (stderr), under a progress bar on a terminal.
        Returns self."""
        from .batch import Placement, each_case, run_tasks
        from ..records.progress import Progress

        placement = placement or Placement(workers=1, device=self.settings.device)
        progress = Progress("table2", total=len(self.todo), quiet=quiet, stream=log, start=self.finished)
        try:
            with interrupts.deferred():
                self._write()  # this run's marker (complete: false) replaces the last run's before any cell
            together, batch = self._batched_cells(batch)
            tasks, members = [], {}
            if together and placement.in_process(len(self._pending)):
                self._run_batched(together, batch, progress)
            elif together:
                tasks, members = self._batched_tasks(together, batch)
            tasks += [self._cell_task(i, c) for i, c in self._pending if (i, c) not in together]  # one task a cell

            def on_result(task, value):  # a cell's: its record on its own, or its entry searched with others
                if isinstance(value, dict):
                    return self._finish(int(task.key), task.label, value, task.args[2], progress)
                return self._finish_searched(int(task.key), task.args, value, progress)

            def failed(value):  # a cell's record, or a searched cell's (record, messages)
                record = value[0] if isinstance(value, tuple) else value
                return isinstance(record, dict) and not record["converged"]

            def on_state(task, j, s):  # the states of a cell computed in this process, on a terminal
                progress.status(self.finished, s["iterations"], s["residual"],
                                f"{task.label}: state {j + 1} ({s['kind']})")

            run_tasks(tasks, each_case(on_result, members), placement, progress=progress, failed=failed,
                      on_state=on_state, before=self.finished)
        except KeyboardInterrupt as e:
            interrupts.stopping(e)  # a second signal does not cut the last writes
            self.interrupted = True
        progress.close()
        if self.write_error is not None:
            return self
        with interrupts.deferred(raise_after=False):
            try:
                self._write(complete=not self.interrupted, stopped=self.interrupted)
            except OutputError as e:
                self.write_error, self.write_error_at_end = e, True
        return self

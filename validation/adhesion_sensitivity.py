"""How delta_x_max and mu of the paper's Table 2 depend on the SMC parameters, and a fit to the
paper's adhesive columns.

The paper gives no adhesive parameters. This study runs the 12 adhesive cells of Table 2 (and the
12 adhesionless ones, the reference of each cell) for every (sigma_max, delta_n) of a grid, with
tau_max = sigma_max and delta_t = delta_n, in parallel processes (each Warp CPU process is serial).
Every finished cell is appended to ``OUT/cells.jsonl`` at once, and a rerun skips the cells found
there. Then it writes:

- ``OUT/adhesion_sensitivity.png``: the change of delta_x_max and mu by adhesion (adhesive /
  adhesionless - 1) against sigma_max, one line per delta_n, for three cells; the paper's change
  as a dashed line;
- ``OUT/fit.json`` and the printout: for every parameter pair, over the 24 numbers (12
  delta_x_max, 12 mu), the RMS of the difference between our change by adhesion (adhesive /
  adhesionless - 1) and the paper's (``rms_change``, in the same units: 0.05 = 5 points), which
  the best pair minimises: it compares what adhesion does, apart from the differences of the
  adhesionless cells themselves; and the RMS of the relative difference from the paper's adhesive
  columns (``rms``). Pairs with an unconverged cell, or a cell where F_z <= 0 at gross slip
  (adhesion holds the sphere in tension, mu undefined), are listed and left out of the fit.

Adhesive cells run on the domain that holds the law's tail (``table2.cell_grid``: the cell side
of ``--n`` over ``--size-in-a`` radii, more cells), so the cost grows with delta_n.

    python validation/adhesion_sensitivity.py --out out/adh --workers 2 --n 64          # here: hours
    python validation/adhesion_sensitivity.py --out out/adh --workers 15 --n 64         # 16 cores: minutes
    python validation/adhesion_sensitivity.py --out out/adh --plot-only                 # from cells.jsonl
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

SIGMA_MAX = (1e6, 2e6, 5e6, 1e7)  # Pa
DELTA_N = (2e-12, 5e-12, 2e-11)  # m
PLOT_CELLS = ((0.50, 1.0e-5), (0.50, 1.5e-4), (0.80, 5.0e-5), (0.95, 1.5e-4))


def _key(r):
    law = r.get("adhesion_law") or {}
    return (r["k_tau"], r["delta_z_um"], bool(r["adhesion"]), law.get("sigma_max"), law.get("delta_n"), r["n"])


def _run_cell(job):
    """One Table 2 cell in a worker process: (k_tau, delta_z_um, adhesion, sigma_max, delta_n, n, size_in_a)."""
    k, dz, adh, sigma, dn, n, size_in_a = job
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    from warpcontact.studies.table2 import Table2Settings, table2_cell

    settings = Table2Settings(n=n, size_in_a=size_in_a, fft="scipy",
                              **({"sigma_max": sigma, "tau_max": sigma, "delta_n": dn, "delta_t": dn} if adh else {}))
    try:
        return table2_cell(k, dz, settings, adhesion=adh)
    except Exception as e:  # recorded, the study goes on
        law = {"sigma_max": sigma, "delta_n": dn} if adh else None
        return {"k_tau": k, "delta_z_um": dz, "adhesion": adh, "adhesion_law": law, "n": n, "converged": False,
                "error": f"{type(e).__name__}: {e}"}


def _cost(job):
    """Relative cost of a cell: its grid's cell count (the tail-holding domain of adhesive cells)."""
    from warpcontact.studies.table2 import Table2Settings, cell_grid

    k, dz, adh, sigma, dn, n, size_in_a = job
    if not adh:
        return n * n
    st = Table2Settings(n=n, size_in_a=size_in_a, sigma_max=sigma, tau_max=sigma, delta_n=dn, delta_t=dn)
    return cell_grid(dz * 1e-6, st, st.adhesion_law()).n ** 2


def _warm_up():
    """Compile the kernels once in this process, so that the workers find them in the cache."""
    import warp as wp

    wp.config.quiet = True
    from warpcontact.physics.adhesion import SMC
    from warpcontact.physics.friction import TaborVonMises
    from warpcontact.physics.geometry import Grid, Sphere
    from warpcontact.physics.materials import PAPER_PAIR
    from warpcontact.numerics.model import ContactModel
    from warpcontact.solvers.contact import ContactSolver
    from warpcontact.numerics.state import ContactState

    model = ContactModel(PAPER_PAIR, Sphere(10e-6), Grid(16, 1e-7), fft="scipy")
    solver = ContactSolver(model, TaborVonMises(0.8, 200e6), adhesion=SMC(2e7, 2e7, 5e-12, 5e-12))
    solver.step(ContactState(model), (1e-12, 0.0, 1e-10))


def run(out: Path, workers: int, n: int, size_in_a: float, sigmas, deltas):
    from warpcontact.studies.table2 import K_TAU, DELTA_Z_UM

    out.mkdir(parents=True, exist_ok=True)
    path = out / "cells.jsonl"
    done = set()
    if path.exists():
        for line in path.read_text().splitlines():
            if line.strip():
                done.add(_key(json.loads(line)))
    jobs = [(k, dz, False, None, None, n, size_in_a) for k in K_TAU for dz in DELTA_Z_UM]
    jobs += [(k, dz, True, s, d, n, size_in_a) for s, d in itertools.product(sigmas, deltas)
             for k in K_TAU for dz in DELTA_Z_UM]
    todo = [j for j in jobs if (j[0], j[1], j[2], j[3], j[4], j[5]) not in done]
    print(f"{len(jobs) - len(todo)} of {len(jobs)} cells found in {path}; {len(todo)} to run on {workers} workers",
          flush=True)
    if not todo:
        return
    _warm_up()
    t0 = time.perf_counter()
    with open(path, "a") as fh, ProcessPoolExecutor(max_workers=workers) as pool:
        futures = [pool.submit(_run_cell, j) for j in sorted(todo, key=_cost, reverse=True)]  # longest first
        for i, f in enumerate(as_completed(futures), 1):
            r = f.result()
            fh.write(json.dumps(r) + "\n")
            fh.flush()
            law = r.get("adhesion_law") or {}
            what = (f"dx {r['delta_x_max_um']:.3e} um mu {r['mu']:.4f}" if r.get("converged")
                    else r.get("error", "not converged"))
            print(f"[{i}/{len(todo)} {time.perf_counter() - t0:6.0f} s] k_tau {r['k_tau']:.2f} dz {r['delta_z_um']:.1e} "
                  f"adh {r['adhesion']} sigma {law.get('sigma_max')} dn {law.get('delta_n')}: {what}", flush=True)


def load(out: Path) -> list:
    rows = {}
    for line in (out / "cells.jsonl").read_text().splitlines():
        if line.strip():
            r = json.loads(line)
            if isinstance(r.get("mu"), float) and math.isnan(r["mu"]):
                r["mu"] = None  # records written before mu became None where F_z <= 0
            rows[_key(r)] = r  # the last record of a cell wins
    return list(rows.values())


def fit(records, paper) -> dict:
    """For each parameter pair: RMS difference of the change by adhesion from the paper's, and RMS
    relative difference from the paper's adhesive columns."""
    base = {(r["k_tau"], r["delta_z_um"]): r for r in records if not r["adhesion"] and r.get("converged")}
    pairs = {}
    for r in records:
        if r["adhesion"]:
            law = r["adhesion_law"]
            pairs.setdefault((law["sigma_max"], law["delta_n"]), []).append(r)
    table = []
    for (s, d), rs in sorted(pairs.items()):
        bad = [(r["k_tau"], r["delta_z_um"]) for r in rs if not r.get("converged")]
        tensile = [(r["k_tau"], r["delta_z_um"]) for r in rs if r.get("converged") and r["mu"] is None]
        entry = {"sigma_max": s, "delta_n": d, "cells": len(rs), "unconverged": bad, "mu_undefined": tensile}
        if not bad and not tensile and len(rs) == 12 and all((r["k_tau"], r["delta_z_um"]) in base for r in rs):
            diffs, changes = [], []
            for r in rs:
                k, dz = r["k_tau"], r["delta_z_um"]
                pdx, pmu = paper[(k, dz, True)]
                p0dx, p0mu = paper[(k, dz, False)]
                b = base[(k, dz)]
                diffs += [r["delta_x_max_um"] / pdx - 1.0, r["mu"] / pmu - 1.0]
                changes += [(r["delta_x_max_um"] / b["delta_x_max_um"]) - pdx / p0dx,
                            (r["mu"] / b["mu"]) - pmu / p0mu]
            entry["rms"] = math.sqrt(sum(x * x for x in diffs) / len(diffs))
            entry["max_abs"] = max(abs(x) for x in diffs)
            entry["rms_change"] = math.sqrt(sum(x * x for x in changes) / len(changes))
            entry["max_abs_change"] = max(abs(x) for x in changes)
            entry["work_of_adhesion_J_m2"] = math.e * s * d
        table.append(entry)
    fitted = [e for e in table if "rms" in e]
    best = min(fitted, key=lambda e: e["rms_change"]) if fitted else None
    return {"pairs": table, "best": best}


def trends(records) -> dict:
    """Per parameter pair: does adhesion raise delta_x_max and mu in every cell (the paper: yes)?"""
    base = {(r["k_tau"], r["delta_z_um"]): r for r in records if not r["adhesion"] and r.get("converged")}
    out = {}
    for r in records:
        if not (r["adhesion"] and r.get("converged")) or (r["k_tau"], r["delta_z_um"]) not in base or r["mu"] is None:
            continue
        b = base[(r["k_tau"], r["delta_z_um"])]
        law = r["adhesion_law"]
        e = out.setdefault(f"{law['sigma_max']:.0e}/{law['delta_n']:.0e}", {"raises_dx": 0, "raises_mu": 0, "cells": 0})
        e["cells"] += 1
        e["raises_dx"] += r["delta_x_max_um"] > b["delta_x_max_um"]
        e["raises_mu"] += r["mu"] > b["mu"]
        e.setdefault("change", {})[(r["k_tau"], r["delta_z_um"])] = (r["delta_x_max_um"] / b["delta_x_max_um"] - 1,
                                                                    r["mu"] / b["mu"] - 1)
    for e in out.values():  # the paper's trends: the raise grows with delta_z, falls with k_tau
        ch = e.pop("change")
        ks = sorted({k for k, _ in ch})
        dzs = sorted({dz for _, dz in ch})
        for i, name in enumerate(("dx", "mu")):
            e[f"{name}_raise_grows_with_delta_z"] = sum(
                all(ch[(k, a)][i] < ch[(k, b)][i] for a, b in zip(dzs, dzs[1:]) if (k, a) in ch and (k, b) in ch)
                for k in ks)
            e[f"{name}_raise_falls_with_k_tau"] = sum(
                all(ch[(a, dz)][i] > ch[(b, dz)][i] for a, b in zip(ks, ks[1:]) if (a, dz) in ch and (b, dz) in ch)
                for dz in dzs)
        e["of_k_tau"], e["of_delta_z"] = len(ks), len(dzs)
    return out


def plot(records, paper, path: Path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    base = {(r["k_tau"], r["delta_z_um"]): r for r in records if not r["adhesion"] and r.get("converged")}
    fig, axes = plt.subplots(2, len(PLOT_CELLS), figsize=(4.2 * len(PLOT_CELLS), 7), sharex=True)
    for col, (k, dz) in enumerate(PLOT_CELLS):
        b = base.get((k, dz))
        for row, (name, label) in enumerate((("delta_x_max_um", "delta_x_max"), ("mu", "mu"))):
            ax = axes[row, col]
            if b is None:
                continue
            by_dn = {}
            for r in records:
                if (r["adhesion"] and r.get("converged") and r[name] is not None
                        and (r["k_tau"], r["delta_z_um"]) == (k, dz)):
                    law = r["adhesion_law"]
                    by_dn.setdefault(law["delta_n"], []).append((law["sigma_max"], 100 * (r[name] / b[name] - 1)))
            for dn, pts in sorted(by_dn.items()):
                pts.sort()
                ax.plot([p[0] for p in pts], [p[1] for p in pts], "o-", label=f"delta_n {dn * 1e12:g} pm")
            pdx, pmu = paper[(k, dz, True)]
            p0dx, p0mu = paper[(k, dz, False)]
            ax.axhline(100 * ((pdx / p0dx) if row == 0 else (pmu / p0mu)) - 100, color="k", ls="--", lw=1,
                       label="paper")
            ax.set_xscale("log")
            ax.grid(alpha=0.3)
            ax.set_title(f"k_tau {k:.2f}, delta_z {dz:.1e} um", fontsize=9)
            if col == 0:
                ax.set_ylabel(f"change of {label} by adhesion [%]")
            if row == 1:
                ax.set_xlabel("sigma_max = tau_max [Pa]")
    axes[0, 0].legend(fontsize=7)
    fig.suptitle("SMC adhesion in Table 2 (delta_t = delta_n): change against the adhesionless cell", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def report(out: Path):
    from warpcontact.studies.table2 import paper_table

    records = load(out)
    paper = paper_table()
    f = fit(records, paper)
    f["trends"] = trends(records)
    (out / "fit.json").write_text(json.dumps(f, indent=1))
    plot(records, paper, out / "adhesion_sensitivity.png")
    print("sigma_max   delta_n   w [J/m2]  change: rms   max     value: rms   max     unconverged / F_z <= 0 cells")
    for e in f["pairs"]:
        cols = "".join(f"{100 * e[c]:7.1f} %" if c in e else "     -   "
                       for c in ("rms_change", "max_abs_change", "rms", "max_abs"))
        print(f"{e['sigma_max']:9.1e} {e['delta_n']:9.1e} {math.e * e['sigma_max'] * e['delta_n']:9.2e} {cols}  "
              f"{e['unconverged'] or ''} {e['mu_undefined'] or ''}")
    if f["best"]:
        b = f["best"]
        print(f"best fit of the change by adhesion: sigma_max {b['sigma_max']:.1e} Pa, delta_n {b['delta_n']:.1e} m "
              f"(w {b['work_of_adhesion_J_m2']:.2e} J/m2): RMS {100 * b['rms_change']:.1f} points, "
              f"max {100 * b['max_abs_change']:.1f}; against the paper's adhesive values RMS {100 * b['rms']:.1f} %, "
              f"max {100 * b['max_abs']:.1f} %")
    for k, v in f["trends"].items():
        print(f"{k}: adhesion raises delta_x_max in {v['raises_dx']}/{v['cells']} cells, mu in {v['raises_mu']}/{v['cells']}; "
              f"the raise grows with delta_z for {v['dx_raise_grows_with_delta_z']} (dx) and "
              f"{v['mu_raise_grows_with_delta_z']} (mu) of {v['of_k_tau']} k_tau, falls with k_tau at "
              f"{v['dx_raise_falls_with_k_tau']} (dx) and {v['mu_raise_falls_with_k_tau']} (mu) of {v['of_delta_z']} delta_z")
    print(f"wrote {out / 'fit.json'} and {out / 'adhesion_sensitivity.png'}")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", required=True, type=Path)
    p.add_argument("--workers", type=int, default=max(1, (os.cpu_count() or 2) - 1))
    p.add_argument("--n", type=int, default=64)
    p.add_argument("--size-in-a", type=float, default=3.0)
    p.add_argument("--sigma-max", type=float, nargs="+", default=list(SIGMA_MAX))
    p.add_argument("--delta-n", type=float, nargs="+", default=list(DELTA_N))
    p.add_argument("--plot-only", action="store_true")
    a = p.parse_args(argv)
    if not a.plot_only:
        run(a.out, a.workers, a.n, a.size_in_a, a.sigma_max, a.delta_n)
    report(a.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())

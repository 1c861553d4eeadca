"""Fits of the SMC law to the paper's adhesive Table 2 column under each reading of the paper's text.

    python validation/adhesive_readings.py --out OUT --workers 16                 # every reading
    python validation/adhesive_readings.py --out OUT --readings added:mu_elastic --n 32

The paper gives no SMC parameters, so whether the model reproduces its adhesive column is a
question of whether any parameters do. A reading is where the adhesive shear acts inside the
contact (``adhesion.contact_shear``: "bounded", the contact's shear bounded as a whole, or
"added", the law's shear at h = 0 added on top of it) and which normal force divides F_x in the
friction coefficient (``mu``: the total, adhesion included, or ``mu_elastic``: the contact
pressure's alone). For each reading, ``warpcontact fit`` fits all four SMC parameters (log
scales) to the 12 adhesive cells, delta_x_max and mu both, each with sigma 2 % of its printed value,
every row on the domain a Table 2 cell of its own trial law gets (``grid.size = "table2"``, n
cells over 3 Hertz radii, grown to hold the law's tail). Each reading writes its fit under
``OUT/<reading>/`` (fit.json, fit.png, fitted.toml, evaluations/), and the script prints a table
of the fitted parameters, the RMS and largest misfit (% of the paper's values) and the raise of
delta_x_max and mu by adhesion at the fitted law against the paper's (each against the
adhesionless cell of the same grid, computed once per reading at the fitted law's domains).
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
READINGS = ("bounded:mu", "added:mu", "bounded:mu_elastic", "added:mu_elastic")
#: the fitted SMC parameters: (start, min, max), log scale; starts at the Table 2 defaults
PARAMETERS = {
    "adhesion.sigma_max": (1.0e6, 3.0e4, 1.0e8),
    "adhesion.tau_max": (1.0e6, 1.0e5, 1.0e9),
    "adhesion.delta_n": (5.0e-12, 2.0e-13, 5.0e-11),
    "adhesion.delta_t": (5.0e-12, 1.0e-12, 1.0e-8),
}
SIGMA_SHARE = 0.02


def paper_rows() -> list[dict]:
    from warpcontact.studies.table2 import UM, paper_table

    table = paper_table()
    return [{"k_tau": k, "delta_z": dz * UM, "delta_x_max": table[(k, dz, True)][0] * UM,
             "mu": table[(k, dz, True)][1], "delta_x_max_dry": table[(k, dz, False)][0] * UM,
             "mu_dry": table[(k, dz, False)][1]}
            for (k, dz, adhesive) in sorted(table) if adhesive]


def base_case(n: int, contact_shear: str, device: str) -> str:
    """The paper's pair, Tabor + von Mises, the SMC law at the Table 2 defaults (TOML)."""
    from warpcontact.physics.materials import PAPER_PAIR
    from warpcontact.studies.table2 import RADIUS

    def material(m):
        return f"E = {m.E!r}\nnu = {m.nu!r}\nyield_strength = {m.yield_strength!r}\nhardness = {m.hardness!r}\n"

    law = "\n".join(f"{k.split('.')[1]} = {v[0]!r}" for k, v in PARAMETERS.items())
    return (f"[sphere]\nradius = {RADIUS!r}\n{material(PAPER_PAIR.sphere)}\n[flat]\n{material(PAPER_PAIR.flat)}\n"
            f"[grid]\nn = {n}\nsize = 6.708e-8\n\n[load]\ndelta_z = 5.0e-11\nsteps = 4\n\n"
            f"[friction]\nlaw = \"tabor\"\nk_tau = 0.8\n\n"
            f"[adhesion]\nlaw = \"smc\"\n{law}\ncontact_shear = \"{contact_shear}\"\n\n"
            f"[solver]\ndevice = \"{device}\"\ndtype = \"float64\"\n")


def write_fit(folder: Path, reading: str, n: int, device: str, max_evaluations: int) -> Path:
    """The fit file, its base case and its CSV for ``reading`` ("bounded:mu", ...)."""
    contact_shear, mu_key = reading.split(":")
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "base.toml").write_text(base_case(n, contact_shear, device))
    lines = [f"friction.k_tau,load.delta_z,grid.size,delta_x_max,sigma_delta_x_max,{mu_key},sigma_{mu_key}"]
    for r in paper_rows():
        lines.append(f"{r['k_tau']},{r['delta_z']!r},table2,{r['delta_x_max']!r},{SIGMA_SHARE * r['delta_x_max']!r},"
                     f"{r['mu']!r},{SIGMA_SHARE * r['mu']!r}")
    (folder / "data.csv").write_text("\n".join(lines) + "\n")
    fit = ['base = "base.toml"', "", "[data]", 'file = "data.csv"', "", "[fit]"]
    fit += [f'"{k}" = {{ min = {lo!r}, max = {hi!r}, start = {start!r}, scale = "log" }}'
            for k, (start, lo, hi) in PARAMETERS.items()]
    fit += ["", "[run]", 'task = "gross-slip"', f"max_evaluations = {max_evaluations}"]
    path = folder / "fit.toml"
    path.write_text("\n".join(fit) + "\n")
    return path


def misfit_table(result: dict, mu_key: str) -> list[str]:
    """Per cell: the paper's adhesive delta_x_max and mu, the fitted model's, the misfit (%), and
    the raise by adhesion the fitted model gives against the paper's (the paper's adhesionless
    value as the reference for both: the model's own adhesionless cells agree with the paper's
    within its printed digits at this n, docs/validation.md)."""
    dry = {(r["k_tau"], r["delta_z"]): r for r in paper_rows()}
    lines = [f"| k_tau | delta_z (um) | delta_x_max: paper / model (misfit) | raise: paper / model | "
             f"{mu_key}: paper / model (misfit) | raise: paper / model |", "|---|---|---|---|---|---|"]
    for row in result["rows"]:
        c = row["conditions"]
        k, dz = float(c["friction.k_tau"]), float(c["load.delta_z"])
        ref = dry[(k, dz)]
        cells = [f"{k:.2f}", f"{dz / 1e-6:.1e}"]
        for out, dry_key in (("delta_x_max", "delta_x_max_dry"), (mu_key, "mu_dry")):
            meas, model = row["measured"][out], row["model"][out]
            cells.append(f"{meas:.3g} / {model:.3g} ({100 * (model / meas - 1):+.1f} %)")
            cells.append(f"{100 * (meas / ref[dry_key] - 1):+.1f} / {100 * (model / ref[dry_key] - 1):+.1f} %")
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--readings", nargs="+", default=list(READINGS), choices=READINGS)
    ap.add_argument("--n", type=int, default=48, help="cells over 3 Hertz radii (Table 2's rule)")
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--max-evaluations", type=int, default=30)
    args = ap.parse_args(argv)
    from warpcontact.studies.batch import Placement
    from warpcontact.studies.fit import run_fit
    from warpcontact.studies.fit_spec import load_fit

    out = Path(args.out)
    summary = {}
    for reading in args.readings:
        folder = out / reading.replace(":", "_")
        path = write_fit(folder / "input", reading, args.n, args.device, args.max_evaluations)
        run_fit(load_fit(path), folder, quiet=False, placement=Placement(workers=args.workers))
        result = json.loads((folder / "fit.json").read_text())
        misfits = [100 * (row["model"][k] / row["measured"][k] - 1) for row in result.get("rows", [])
                   for k in row["measured"]]
        summary[reading] = {"parameters": {k: v["value"] for k, v in result["parameters"].items()},
                            "stderr": {k: v.get("stderr") for k, v in result["parameters"].items()},
                            "converged": result.get("converged"),
                            "misfit_rms_percent": math.sqrt(sum(m * m for m in misfits) / len(misfits)) if misfits else None,
                            "misfit_max_percent": max((abs(m) for m in misfits), default=None)}
        (out / "summary.json").write_text(json.dumps(summary, indent=1))
        table = misfit_table(result, reading.split(":")[1]) if result.get("rows") else []
        (folder / "table.md").write_text("\n".join(table) + "\n")
        s = summary[reading]
        print(f"\n## {reading}: " + ", ".join(f"{k.split('.')[1]} {v:.3g}" for k, v in s["parameters"].items())
              + f"; misfit RMS {s['misfit_rms_percent']:.2f} %, largest {s['misfit_max_percent']:.2f} %", flush=True)
        print("\n".join(table), flush=True)


if __name__ == "__main__":
    main()

"""A Hertz solve as a user waits for it: whole processes (interpreter start, imports, set-up, solve,
output), warpcontact's `warpcontact solve` against Tamaas' own solver (or another warpcontact), alternating A B A B.

    python bench/whole_process.py [--n 512] [--rounds 3] [--device cpu] [--tamaas-path DIR]
        [--slippy-python VENV/bin/python] [--no-tamaas] [--other DIR]

warpcontact: `python -m warpcontact.cli solve CASE --out DIR --quiet --fields none` on
examples/hertz.toml with n cells per side (the paper's pair, R = 10 um, delta_z = 1e-4 um,
domain 4a, tolerance 1e-10, float64; the result.json written, no fields). Tamaas 2.9: a script
that imports tamaas, builds the same problem (``bench_normal.time_tamaas``'s set-up: its
PolonskyKeerRey solver with the DC-FFT operator on the same domain and grid, tolerance 1e-10,
driven by the Hertz force) and solves it. ``--tamaas-path``:
a folder put first on PYTHONPATH for the Tamaas process (e.g. ``pip install --target DIR tamaas``).
``--slippy-python``: slippy 0.5.2's interpreter (a venv of its own: ``bench/slippy_hertz.py`` says
how to make it), whose process runs ``bench/slippy_hertz.py N --once`` (the same problem,
displacement-driven, tolerance 1e-10, one solve): a third column.
Each process runs once uncounted first (the kernel caches and the bytecode written, as an installed
package has them: `as_installed`). Prints each run and the medians, and the ratio of the medians.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def case_file(n: int, device: str, folder: str, example: str = "hertz") -> str:
    """examples/EXAMPLE.toml with ``n`` cells per side on ``device``, written into ``folder``."""
    text = open(os.path.join(ROOT, "examples", f"{example}.toml")).read()
    lines = []
    for line in text.splitlines():
        if line.startswith("n = "):
            line = f"n = {n}"
        elif line.startswith("device = "):
            line = f'device = "{device}"'
        lines.append(line)
    path = os.path.join(folder, f"{example}{n}.toml")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")
    return path


# Tamaas' process imports nothing of warpcontact: the problem of bench_normal.time_tamaas, inline
TAMAAS = """
import math
import numpy as np
import tamaas as tm
R, DZ, n = 10e-6, 1.0e-10, {n}
E_STAR = 1.0 / ((1 - 0.33**2) / 106e9 + (1 - 0.31**2) / 205e9)  # the paper's Table 1 pair
L = 4 * math.sqrt(R * DZ)
model = tm.ModelFactory.createModel(tm.model_type.basic_2d, [L, L], [n, n])
model.E = E_STAR
model.nu = 0.0  # with nu = 0 Tamaas' E* equals E
x = (np.arange(n) - 0.5 * (n - 1)) * (L / n)
X, Y = np.meshgrid(x, x, indexing="ij")
tm.ModelFactory.registerNonPeriodic(model, "dcfft")
solver = tm.PolonskyKeerRey(model, -(X**2 + Y**2) / (2 * R), 1e-10)
solver.setIntegralOperator("dcfft")
force = 4.0 / 3.0 * E_STAR * math.sqrt(R) * DZ**1.5  # Hertz
solver.solve(force / L**2)
print(float(np.asarray(model.traction).sum() * (L / n) ** 2 / force - 1.0))
"""


def as_installed(env: dict | None, folder: str) -> dict:
    """``env`` (default: this process's) for a timed process that reads its modules' bytecode as an
    installed package does: written once into ``folder``'s cache by an uncounted first round, where
    PYTHONDONTWRITEBYTECODE (set on some machines) would have every process compile its sources
    again (0.5-0.7 s of a `warpcontact solve` on a GPU machine started with it)."""
    env = dict(os.environ if env is None else env)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    env["PYTHONPYCACHEPREFIX"] = os.path.join(folder, "pycache")
    return env


def timed(cmd, env=None, cwd=None) -> float:
    t0 = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=cwd)
    elapsed = time.perf_counter() - t0
    if r.returncode != 0:
        raise SystemExit(f"{cmd[:3]} failed ({r.returncode}): {r.stderr[-2000:]}")
    return elapsed


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=512)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--tamaas-path", default=None)
    ap.add_argument("--slippy-python", default=None, help="slippy's interpreter: a third column")
    ap.add_argument("--no-tamaas", action="store_true", help="leave Tamaas out (a machine without it)")
    ap.add_argument("--other", default=None, metavar="DIR",
                    help="a folder holding another warpcontact (`pip install --no-deps --target DIR` of an "
                    "earlier commit), put first on PYTHONPATH: a column timed alternating with this one")
    a = ap.parse_args()
    if a.other and not os.path.isfile(os.path.join(a.other, "warpcontact", "__init__.py")):
        raise SystemExit(f"--other {a.other}: no warpcontact package there (pip install --no-deps --target {a.other} TREE)")
    with tempfile.TemporaryDirectory() as folder:
        case = case_file(a.n, a.device, folder)
        ours = [sys.executable, "-m", "warpcontact.cli", "solve", case, "--out", os.path.join(folder, "out"),
                "--quiet", "--fields", "none"]
        env = dict(os.environ)
        if a.tamaas_path:
            env["PYTHONPATH"] = a.tamaas_path + os.pathsep + env.get("PYTHONPATH", "")
        env = as_installed(env, folder)
        runs = [("warpcontact", ours, as_installed(None, folder))]
        if a.other:
            other_env = as_installed(dict(os.environ, PYTHONPATH=os.path.abspath(a.other) + os.pathsep
                                          + os.environ.get("PYTHONPATH", "")), folder)
            runs.append(("other", ours, other_env))
        if not a.no_tamaas:
            runs.append(("tamaas", [sys.executable, "-c", TAMAAS.format(n=a.n)], env))
        if a.slippy_python:
            runs.append(("slippy", [a.slippy_python, os.path.join(HERE, "slippy_hertz.py"), str(a.n), "--once"],
                         as_installed(None, folder)))
        for name, cmd, e in runs:  # uncounted: the kernel caches and the bytecode written
            timed(cmd, e, cwd=folder)
        times = {name: [] for name, _, _ in runs}
        for k in range(a.rounds):
            for name, cmd, e in runs:
                times[name].append(timed(cmd, e, cwd=folder))  # slippy writes its logs where it runs
                print(f"round {k + 1}: {name} {times[name][-1]:.2f} s", flush=True)
    med = {name: statistics.median(t) for name, t in times.items()}
    w = med["warpcontact"]
    peers = ([("other", f"warpcontact from {a.other}")] if a.other else []) + \
        ([] if a.no_tamaas else [("tamaas", "Tamaas 2.9")]) + ([("slippy", "slippy 0.5.2")] if a.slippy_python else [])
    print(f"| n | warpcontact (whole process, median of {a.rounds}) | "
          + " | ".join(f"{label} (whole process) | {label} / warpcontact" for _, label in peers) + " |")
    print("|---|---|" + "---|---|" * len(peers))
    print(f"| {a.n} | {w:.2f} s | " + " | ".join(f"{med[k]:.2f} s | {med[k] / w:.1f}x" for k, _ in peers) + " |")


if __name__ == "__main__":
    main()

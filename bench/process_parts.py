"""A whole ``warpcontact solve`` process broken into its parts: what a user waits for, part by part.

Each round starts a fresh interpreter (the kernel cache and the bytecode cache warm, as on a second run
of an installed package: `whole_process.as_installed`) that imports
numpy, Warp (with ``wp.init()``) and the package's modules a solve loads, then runs the command
line's ``solve`` on examples/hertz.toml (or ``--example NAME``: examples/NAME.toml) with n cells per side, the runner's parts timed where they
are called (the device synchronised at each clock reading): ``model`` (``runner.build``: model,
solvers, state), ``solve`` (the contact solver's steps), ``yield check``
(``yielding.state_yield_check``) and the rest of the command (the case read and checked, the
summaries, result.json). ``interpreter`` is the process's wall time, measured from outside, less
what it measured inside: the interpreter's start and the process's end (``cli.end_process``). Prints the median of each part over the rounds, as a markdown table.

    python bench/process_parts.py --n 512                       # the CPU
    python bench/process_parts.py --n 1024 --device cuda --rounds 5
    python bench/process_parts.py --n 1024 --device cuda --rounds 5 --example figure2c
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

PARTS = ("interpreter", "import numpy", "import warp, wp.init()", "import warpcontact", "model", "solve",
         "yield check", "rest of the command")

# the process timed: its own clock from its first line; the parts it can see from inside
CHILD = r"""
import time
t0 = time.perf_counter()
import numpy
t1 = time.perf_counter()
import warp as wp
wp.config.quiet = True
wp.init()
t2 = time.perf_counter()
import warpcontact.cli, warpcontact.cli.solve, warpcontact.studies.runner as runner
import warpcontact.records.results, warpcontact.solvers.contact as contact, warpcontact.numerics.yielding as yielding
t3 = time.perf_counter()
import sys
sys.path.insert(0, HERE)
from api_parts import part_timer  # bench/, beside this script
spent = {"model": 0.0, "solve": 0.0, "yield check": 0.0}
timed = part_timer(spent, wp.get_device(DEVICE))
runner.build = timed("model", runner.build)
contact.ContactSolver.step = timed("solve", contact.ContactSolver.step)
yielding.state_yield_check = timed("yield check", yielding.state_yield_check)
status = warpcontact.cli.main(["solve", CASE, "--out", OUT, "--quiet", "--fields", "none"])
t4 = time.perf_counter()
import json
print(json.dumps({"status": status, "inside": t4 - t0, "import numpy": t1 - t0, "import warp, wp.init()": t2 - t1,
                  "import warpcontact": t3 - t2, **spent,
                  "rest of the command": (t4 - t3) - sum(spent.values())}))
warpcontact.cli.end_process(status)  # as the command ends
"""


def main():
    from whole_process import as_installed, case_file  # bench/, beside this script

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=512)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--example", default="hertz", help="the case: examples/EXAMPLE.toml with --n and --device")
    a = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        case = case_file(a.n, a.device, folder, a.example)
        code = CHILD.replace("DEVICE", repr(a.device)).replace("CASE", repr(case)).replace(
            "OUT", repr(os.path.join(folder, "out"))).replace("HERE", repr(HERE))
        for k in range(a.rounds + 1):  # the first round, not counted, fills the kernel and bytecode caches
            t0 = time.perf_counter()
            r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=folder,
                               env=as_installed(None, folder))
            wall = time.perf_counter() - t0
            if r.returncode != 0:
                raise SystemExit(f"the process failed ({r.returncode}): {r.stderr[-2000:]}")
            parts = json.loads(r.stdout.strip().splitlines()[-1])
            if parts["status"] != 0:
                raise SystemExit(f"warpcontact solve exited with {parts['status']}: {r.stderr[-2000:]}")
            parts["interpreter"] = wall - parts["inside"]
            parts["whole process"] = wall
            if k:
                rows.append(parts)
            print(f"round {k}{' (not counted)' if not k else ''}: {wall:.2f} s", file=sys.stderr, flush=True)
    med = {p: statistics.median(r[p] for r in rows) for p in (*PARTS, "whole process")}
    print(f"<!-- python bench/process_parts.py --n {a.n} --device {a.device} --rounds {a.rounds} --example {a.example}: "
          "medians -->")
    print("| n | whole process [s] | " + " | ".join(f"{p} [s]" for p in PARTS) + " |")
    print("|---|---|" + "---|" * len(PARTS))
    print(f"| {a.n} | {med['whole process']:.2f} | " + " | ".join(f"{med[p]:.2f}" for p in PARTS) + " |")


if __name__ == "__main__":
    main()

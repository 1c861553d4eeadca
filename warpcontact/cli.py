"""Command line: ``warpcontact solve CASE.toml --out DIR``.

Exit status: 0 success; 2 a mistake in the input (one line on stderr naming it, no traceback);
3 a solve that did not converge (results are written and marked ``converged: false``);
130 interrupted by Ctrl-C (the states finished so far are written).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .errors import InputError, NonFiniteError

EXIT_INPUT = 2
EXIT_NOT_CONVERGED = 3
EXIT_INTERRUPTED = 130

EXAMPLE_SOLVE = """example:
  warpcontact solve examples/hertz.toml --out out/hertz
  warpcontact solve examples/hertz.toml --out out/hertz --device cuda --dtype float32

writes OUT/result.json (forces [N], contact area [m^2] and radius [m], max pressure [Pa],
convergence, timings, the case) and OUT/fields.npz (pressure, shear, gap, slip fields in SI
units for every state of the path, with masks; loads with numpy alone)."""


class Progress:
    """A one-line progress bar on stderr (silent with --quiet or when stderr is not a terminal
    and quiet is asked for)."""

    def __init__(self, quiet: bool, label: str):
        self.quiet, self.label = quiet, label

    def __call__(self, k, total, summary, result=None):
        if self.quiet:
            return
        width = 30
        done = int(width * (k + 1) / total)
        bar = "#" * done + "-" * (width - done)
        msg = (
            f"\r{self.label} [{bar}] {k + 1}/{total}  it {summary['iterations']}"
            f"  res {summary['residual']:.1e}  Fz {summary['force']['z']:.3e} N"
        )
        end = "\n" if k + 1 == total else ""
        print(msg, end=end, file=sys.stderr, flush=True)


def _common(p):
    p.add_argument("--out", required=True, help="output folder (created if needed)")
    p.add_argument("--device", help="override [solver] device: cpu, cuda, cuda:N")
    p.add_argument("--dtype", choices=("float64", "float32"), help="override [solver] dtype")
    p.add_argument("--fft", choices=("auto", "scipy", "cupy", "warp"), help="override [solver] fft")
    p.add_argument("--quiet", action="store_true", help="no progress output")


def _parser():
    parser = argparse.ArgumentParser(
        prog="warpcontact",
        description="Sphere-on-flat contact with friction and adhesion (DC-FFT, conjugate gradients, NVIDIA Warp).",
    )
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser(
        "solve",
        help="solve every state of a case's load path",
        description="Solve every state of the load path of CASE (a TOML file, SI units; see docs/case-files.md).",
        epilog=EXAMPLE_SOLVE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("case", help="case file (TOML)")
    _common(p)
    return parser


def cmd_solve(args) -> int:
    from .case import load_case
    from .results import atomic_write_json, atomic_write_npz
    from .runner import run_path

    case = load_case(args.case).with_overrides(device=args.device, dtype=args.dtype, fft=args.fft)
    out = Path(args.out)
    progress = Progress(args.quiet, "solve")

    def on_state(k, total, summary, result):
        progress(k, total, summary)
        atomic_write_json(out / "result.json", result.summary())  # nothing finished is lost

    result = run_path(case, on_state=on_state)
    if result.states:
        atomic_write_json(out / "result.json", result.summary())
        atomic_write_npz(out / "fields.npz", result.stacked_fields())
    if result.interrupted:
        print(f"interrupted: {len(result.states)} state(s) finished and written to {out}", file=sys.stderr)
        return EXIT_INTERRUPTED
    if not result.converged:
        bad = [i for i, s in enumerate(result.states) if not s["converged"]]
        s = result.states[bad[0]]
        print(
            f"not converged: state {bad[0]} stopped at residual {s['residual']:.3e} after {s['iterations']} "
            f"iterations (tolerance {case.solver.tol:g}); results written to {out} with converged = false",
            file=sys.stderr,
        )
        return EXIT_NOT_CONVERGED
    if not args.quiet:
        last = result.states[-1]
        print(
            f"F = ({last['force']['x']:.4e}, {last['force']['y']:.4e}, {last['force']['z']:.4e}) N, "
            f"contact radius {last['contact_radius']:.4e} m, max pressure {last['max_pressure']:.4e} Pa "
            f"[{result.model.device}, {result.model.dtype_name}, {result.elapsed_s:.2f} s] -> {out}",
            file=sys.stderr,
        )
    return 0


def main(argv=None) -> int:
    args = _parser().parse_args(argv)
    try:
        return {"solve": cmd_solve}[args.command](args)
    except InputError as e:
        print(f"warpcontact: error: {e}", file=sys.stderr)
        return EXIT_INPUT
    except NonFiniteError as e:
        print(f"warpcontact: error: {e}", file=sys.stderr)
        return EXIT_NOT_CONVERGED


if __name__ == "__main__":
    sys.exit(main())

"""Where a whole load path's time goes, by the solvers' parts, and its inner iterations by turn.

A path of bench/paths.py (``figure2c``, ``figure2d``, ``rough``, ...) at each n, timed in one
process after the same path at n = 128 has loaded the kernels (each n's CUDA graphs are captured
inside the timed solve, as a user's first solve captures them). The solvers'
parts are wrapped in timers that synchronise the device before and after (so each part's time is
its own, the asynchronous launches included; the wrapping adds a synchronisation a part, a small
cost against parts of milliseconds): the normal, tangential and adhesive solves, a tangential
solve on a window (``window@m``: m cells per side, its crop and put-back included; the window's
own solver is listed as ``tangential@m`` too) and the search for the window, the turns'
displacement updates, the nested start's coarse steps (``step@n/2`` ...), the yield check. Times
of nested parts are also in their parents' (a window's solve in its tangential solve's, the coarse
steps in the fine step's).

Prints per n: the solve's wall time, a table of parts (seconds, calls, inner iterations, ms per
iteration), and with ``--turns S ...`` each listed state's turns on the finest grid: the normal and
tangential solves' inner iterations and the tolerance each was solved to.

    python bench/path_parts.py --path figure2c --sizes 1024 4096 --device cuda
    python bench/path_parts.py --path figure2c --sizes 512 --device cpu --turns 1 9 16 --set nested=false
    python bench/path_parts.py --path figure2d --sizes 4096 --device cuda --normal-window off
    python bench/path_parts.py --path figure2c --sizes 1024 --device cpu --window-turns off
    python bench/path_parts.py --path hardness --sizes 2048 4096 --device cuda --stall-mixing global
    python bench/path_parts.py --path figure2c --sizes 1024 --device cpu --kernels

``--kernels`` adds a row a kernel (``kernel NAME``: every launch of it, the device synchronised
after each) and a row an FFT library pass by backend, grid and float type (``fft
BACKEND.transform_input NY [periodic] float64``: every forward transform of that grid (periodic:
a preconditioner's, on the grid itself), those whose padded
buffer a solver kernel fills too; ``transform_to_output`` the inverse); they are inside the parts'
times. The synchronisations add to the parts' times, not to a pass's own, and on CUDA the solves run
without their graphs (every launch eager, as it must be to be timed).
"""

from __future__ import annotations

import argparse
import collections
import importlib.util
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def load_paths():
    spec = importlib.util.spec_from_file_location("bench_paths", ROOT / "bench" / "paths.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


class Timers:
    """Seconds, calls and inner iterations by part, from wrapped methods."""

    def __init__(self):
        import warp as wp

        self.wp = wp
        self.seconds = collections.defaultdict(float)
        self.calls = collections.Counter()
        self.iterations = collections.Counter()
        self.on = False
        self.fine = None  # n of the path's grid
        self.step = 0  # the fine grid's step being solved
        self.turns = []  # (step, "normal" / "tangential", iterations, tolerance) on the fine grid
        self._undo = []

    def wrap(self, owner, name, label, grid=lambda self: self.model.grid.n):
        """``owner.name`` (a method, or a module's function of a state) timed under ``label@n``,
        n = ``grid(its first argument)``."""
        original = getattr(owner, name)
        timers = self

        def timed(obj, *args, **kw):
            if not timers.on:
                return original(obj, *args, **kw)
            timers.wp.synchronize()
            t0 = time.perf_counter()
            result = original(obj, *args, **kw)
            timers.wp.synchronize()
            n = grid(obj)
            key = f"{label}@{n}"
            timers.seconds[key] += time.perf_counter() - t0
            timers.calls[key] += 1
            iterations = getattr(result, "iterations", None)
            if iterations is not None:
                timers.iterations[key] += int(iterations)
                if n == timers.fine and label in ("normal", "tangential", "adhesive"):
                    timers.turns.append((timers.step, label, int(iterations), kw.get("tol")))
            return result

        setattr(owner, name, timed)
        self._undo.append((owner, name, original))

    def count_steps(self, owner):
        original = owner.step
        timers = self

        def step(obj, *args, **kw):
            if timers.on and obj.model.grid.n == timers.fine:
                timers.step += 1
            return original(obj, *args, **kw)

        owner.step = step
        self._undo.append((owner, "step", original))

    def restore(self):
        for owner, name, original in reversed(self._undo):
            setattr(owner, name, original)


def instrument(timers: Timers):
    from warpcontact.numerics import yielding
    from warpcontact.solvers import adhesive, contact, normal, tangential

    timers.count_steps(contact.ContactSolver)
    timers.wrap(contact.ContactSolver, "step", "step")
    timers.wrap(normal.NormalSolver, "solve", "normal")
    timers.wrap(tangential.TangentialSolver, "solve", "tangential")
    timers.wrap(tangential._Window, "solve", "window", grid=lambda w: w.cells)
    timers.wrap(tangential.TangentialSolver, "_window_for", "find window")
    timers.wrap(adhesive.AdhesiveNormalSolver, "solve", "adhesive")
    for name in ("update_adhesion", "update_slip", "known_displacements", "relative_change"):
        timers.wrap(contact.ContactSolver, name, name)
    timers.wrap(yielding, "state_yield_check", "yield check", grid=lambda state: state.model.grid.n)


def instrument_kernels(timers: Timers):
    """``--kernels``: every launch through the launch layer (``LaunchCache.launch`` and ``split``,
    outermost only) and every ``wp.launch``, timed by kernel, and the FFT backends' library passes
    by backend, grid and float type, each synchronised after (seconds under ``kernel NAME`` and
    ``fft BACKEND.PASS NY DTYPE``)."""
    import warp as wp

    from warpcontact import fft
    from warpcontact.numerics import launch

    depth = [0]

    def timed(original, key_of):
        def run(*args, **kw):
            if not timers.on or depth[0]:
                return original(*args, **kw)
            depth[0] += 1
            t0 = time.perf_counter()
            try:
                return original(*args, **kw)
            finally:
                wp.synchronize()
                depth[0] -= 1
                key = key_of(args)
                timers.seconds[key] += time.perf_counter() - t0
                timers.calls[key] += 1
        return run

    def replace(owner, name, key_of):
        original = getattr(owner, name)
        setattr(owner, name, timed(original, key_of))
        timers._undo.append((owner, name, original))

    for name in ("launch", "split"):
        replace(launch.LaunchCache, name, lambda args: f"kernel {args[1].key}")
    replace(wp, "launch", lambda args: f"kernel {args[0].key}")
    import importlib
    import pkgutil

    def fft_key(name):
        def key(args):
            backend = args[0]
            dtype = getattr(getattr(backend, "dtype", None), "__name__", "")
            grid = " periodic" if getattr(backend, "periodic", False) else ""  # (a preconditioner's)
            return f"fft {type(backend).__name__}.{name} {getattr(backend, 'ny', '')}{grid} {dtype}".rstrip()
        return key

    # a backend's library passes (``transform_input``, ``transform_to_output``: also those whose
    # padded buffers a solver kernel fills or reads itself); a batch library's forward and inverse
    for info in pkgutil.iter_modules(fft.__path__):
        module = importlib.import_module(f"{fft.__name__}.{info.name}")
        for cls in [c for c in vars(module).values() if isinstance(c, type) and c.__module__ == module.__name__]:
            if hasattr(cls, "transform_input"):  # a backend of one grid (fft.base.FFTBackend)
                passes = [n for n in ("transform_input", "transform_to_output") if n in vars(cls)]
            else:  # a batch's library
                passes = [n for n in ("forward", "inverse") if n in vars(cls)]
            for name in passes:
                replace(cls, name, fft_key(name))


def parse_settings(pairs) -> dict:
    out = {}
    for pair in pairs or []:
        key, _, value = pair.partition("=")
        try:
            out[key] = json.loads(value)
        except json.JSONDecodeError:
            out[key] = value
    return out


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--path", default="figure2c", help="a path of bench/paths.py")
    p.add_argument("--sizes", type=int, nargs="+", default=[256])
    p.add_argument("--device", default="cpu")
    p.add_argument("--set", nargs="*", metavar="KEY=VALUE", help="[solver] settings, e.g. nested=false window=true")
    p.add_argument("--turns", type=int, nargs="*", default=[], help="states (from 1) whose turns to list")
    p.add_argument("--normal-window", choices=("auto", "on", "off"), default="auto",
                   help='with window = "auto": the normal solves on windows as chosen (NORMAL_WINDOW_AUTO_N), '
                        'at every n, or at none (the shear\'s window as chosen either way)')
    p.add_argument("--window-turns", choices=("on", "off"), default="on",
                   help="the later turns' normal solves on the first turn's window, judged once a step (on, the "
                        "default), or each judged on the whole grid (off): SolverSettings.window_turns")
    p.add_argument("--stall-mixing", choices=("local", "global"), default="local",
                   help="the lagged turns' mixing after a stall: each cell's own coefficients (local, as "
                        "shipped: LocalAndersonMixing) or one set for the whole shear (global: "
                        "AndersonMixing, depth 5)")
    p.add_argument("--kernels", action="store_true",
                   help="also time every kernel launch by kernel and every FFT pass by backend, grid and "
                        "float type (the device synchronised after each; on CUDA without the solvers' graphs)")
    args = p.parse_args(argv)
    if args.stall_mixing == "global":
        from warpcontact.solvers import fixed_point, turns

        turns.LaggedTurns.stall_mixing_type = staticmethod(
            lambda model: fixed_point.AndersonMixing(model, 2, beta=1.0, depth=5))
    forced = {}  # solver settings beyond the case's [solver] table
    if args.window_turns == "off":
        forced["window_turns"] = False
    if args.kernels:  # every launch and pass eager, so that each is timed (a graph's replay hides them)
        forced["use_graphs"] = False
    if forced:
        from warpcontact.studies import runner

        build = runner.build
        runner.build = lambda case, model=None, **choices: build(case, model, **forced, **choices)
    if args.normal_window != "auto":
        from warpcontact.solvers import normal

        first = 0 if args.normal_window == "on" else sys.maxsize
        normal.NORMAL_WINDOW_AUTO_N = {kind: first for kind in normal.NORMAL_WINDOW_AUTO_N}
    paths = load_paths()
    import warnings

    import warpcontact as wc

    timers = Timers()
    instrument(timers)
    if args.kernels:
        instrument_kernels(timers)
    for n in args.sizes:
        case = paths.case_dict(args.path)
        case["grid"]["n"] = n
        case.setdefault("solver", {}).update({"device": args.device, **parse_settings(args.set)})
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            warm = paths.case_dict(args.path)
            warm["grid"]["n"] = min(n, 128)
            warm.setdefault("solver", {}).update(case["solver"])
            wc.solve(warm, fields="none")  # the kernels loaded
            timers.seconds.clear(), timers.calls.clear(), timers.iterations.clear()
            timers.turns.clear()
            timers.fine, timers.step, timers.on = n, 0, True
            t0 = time.perf_counter()
            result = wc.solve(case, fields="none")
            wall = time.perf_counter() - t0
            timers.on = False
        states = result.states
        chosen = ((args.set or []) + ([f"normal window {args.normal_window}"] if args.normal_window != "auto" else [])
                  + (["window turns off"] if args.window_turns == "off" else [])
                  + (["stall mixing global"] if args.stall_mixing == "global" else []))
        print(f"\n{args.path}, n = {n}, {args.device}, {chosen or 'as shipped'}: {wall:.2f} s, "
              f"{len(states)} states, all converged: {all(bool(s['converged']) for s in states)}, "
              f"inner iterations {sum(int(s['iterations']) for s in states)} "
              f"(largest state {max(int(s['iterations']) for s in states)}), "
              f"most turns of a state {max(int(s['outer_iterations']) for s in states)}")
        print("| part | s | calls | inner it. | ms / it. |\n|---|---|---|---|---|")
        for key in sorted(timers.seconds, key=lambda k: -timers.seconds[k]):
            it = timers.iterations[key]
            per = f"{1e3 * timers.seconds[key] / it:.2f}" if it else "-"
            print(f"| {key} | {timers.seconds[key]:.3f} | {timers.calls[key]} | {it or '-'} | {per} |")
        for k in args.turns:
            turns = [(label[0], it, tol) for step, label, it, tol in timers.turns if step == k]
            shown = ", ".join(f"{kind} {it}" + (f" @{tol:.0e}" if tol else "") for kind, it, tol in turns)
            print(f"state {k}: {shown}")
    timers.restore()


if __name__ == "__main__":
    sys.exit(main())

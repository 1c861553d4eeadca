"""The stress below the surface of a case: its load path solved (``runner.run_path``), the stress in
both bodies evaluated at one state (``warpcontact.numerics.stress``, the evaluation's numerics; a rigid
body has none) and each body's first yield on the path. ``warpcontact stress`` (cli/stress.py) and ``wc.subsurface_stress``.

    import warpcontact as wc

    result = wc.subsurface_stress(wc.load_case("examples/hertz.toml"), layers=32)
    result.summary()["flat"]["von_mises_max"]         # value [Pa], depth [m], x, y [m]
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..numerics.stress import (
    DEFAULT_LAYERS,
    SubsurfaceStress,
    contact_radius,
    default_depths,
    sliding_axis,
    tractions,
)
from ..numerics.yielding import first_yield
from .tasks import prepare


def _pick_state(n_states: int, state: int) -> int:
    if isinstance(state, bool) or not isinstance(state, (int, np.integer)):
        raise InputError("state", f"must be an integer, got {state!r}")
    k = state + n_states if state < 0 else state
    if not 0 <= k < n_states:
        raise InputError("state", f"the path has {n_states} state(s) (0 to {n_states - 1}, or -1 for the last); "
                                  f"got {state}")
    return k


def subsurface_stress(case, state: int = -1, depths=None, layers: int = DEFAULT_LAYERS, max_depth=None,
                      device=None, dtype=None, fft=None, volume: bool = False, with_first_yield: bool = True,
                      path_result=None):
    """Solve the case's load path (or take ``path_result``, a ``runner.PathResult`` with every
    state's fields) and evaluate the stress in both bodies at state ``state`` (negative: from the
    end). ``depths`` [m] (default: ``layers`` depths down to ``max_depth``, ``default_depths``).
    ``with_first_yield``: also the largest von Mises stress of every state up to ``state``, and
    each body's first yield on the path (``first_yield``). Returns a :class:`StressResult` with
    ``state_index``, ``delta`` and ``first_yield`` set (``summary`` includes them)."""
    from .runner import run_path

    case = prepare(case, device, dtype, fft)
    if path_result is None:
        n_states = len(case.load.path())
        k = _pick_state(n_states, state)  # before the solve: a wrong index costs nothing
        path_result = run_path(case, fields="all")
        if path_result.interrupted:
            raise KeyboardInterrupt
    states = path_result.states
    k = _pick_state(len(states), state)
    if len(path_result.fields) != len(states):
        raise InputError("path_result", "needs every state's fields (run_path with fields='all')")
    fields = path_result.fields[k]
    grid = case.grid
    if depths is None:
        depths = default_depths(contact_radius(fields, grid.cell_area), grid.dx, layers, max_depth)
    s = case.solver
    evaluator = SubsurfaceStress(case.pair, grid, depths, device=s.device, dtype=s.dtype, fft=s.fft, volume=volume)
    delta = states[k]["delta"]
    result = evaluator.evaluate(*tractions(fields), section_axis=sliding_axis(delta))
    result.state_index, result.delta = k, dict(delta)
    result.converged = bool(states[k]["converged"])
    result.first_yield = {}
    if with_first_yield:
        maxima = {name: [] for name in result.bodies}  # the elastic bodies
        light = SubsurfaceStress(case.pair, grid, result.depths, device=s.device, dtype=s.dtype, fft=s.fft) \
            if volume else evaluator
        for j in range(k + 1):
            r = result if j == k else light.evaluate(*tractions(path_result.fields[j]))
            for name in maxima:
                maxima[name].append(r.bodies[name].maximum("von_mises", r.depths)["value"])
        deltas = [states[j]["delta"] for j in range(k + 1)]
        for name in maxima:
            result.first_yield[name] = first_yield(maxima[name], deltas, result.bodies[name].yield_strength)
    return result

"""Whether a solved state stays in the elastic range its results assume: the yield check of every
result (each body's largest von Mises stress against its yield strength, ``yield_check``, its
keys in the results, ``yield_keys``) and a body's first yield on a load path (``first_yield``). The
stresses are evaluated by ``warpcontact.numerics.stress``."""

from __future__ import annotations

import math
from collections import OrderedDict

import numpy as np

from ..errors import InputError
from .resources import allocation_refused
from .stress import (
    BODIES,
    RIGID_REASON,
    SURFACE_DEPTH_IN_CELLS,
    SubsurfaceStress,
    contact_radius,
    depth_maximum,
    tractions,
)


# ---------------------------------------------------------------------------------------------
# First yield on a path (the study that solves the path: warpcontact.studies.stress_study).


def first_yield(maxima: list, deltas: list, yield_strength: float) -> dict | None:
    """The first state of a path at which a body's largest von Mises stress reaches its yield
    strength. ``maxima``: the largest von Mises stress [Pa] at each state in path order;
    ``deltas``: each state's approach {"x", "y", "z"} [m]. Returns None without a finite yield
    strength, else ``reached`` (bool), ``state`` (the first state at or above it, or None),
    ``delta`` (that state's approach) and ``delta_interpolated``: the approach where the ratio von
    Mises / S_Y, interpolated linearly between that state and the one before it (the unloaded
    body, ratio 0 at zero approach, before the first state), crosses 1 [m] (linear in the path's
    steps: refine the steps to narrow it)."""
    if not math.isfinite(yield_strength):
        return None
    prev_ratio, prev_delta = 0.0, {"x": 0.0, "y": 0.0, "z": 0.0}
    for k, (vm, d) in enumerate(zip(maxima, deltas)):
        ratio = vm / yield_strength
        if ratio >= 1.0:
            w = (1.0 - prev_ratio) / (ratio - prev_ratio) if ratio > prev_ratio else 1.0
            return {"reached": True, "state": k, "delta": dict(d),
                    "delta_interpolated": {c: prev_delta[c] + w * (d[c] - prev_delta[c]) for c in "xyz"},
                    "von_mises_max": vm}
        prev_ratio, prev_delta = ratio, d
    return {"reached": False, "state": None, "delta": None, "delta_interpolated": None,
            "von_mises_max": maxima[-1] if maxima else None}


# ---------------------------------------------------------------------------------------------
# The check of the elastic assumption on every result.

#: first depths of ``yield_check`` in contact radii, after the surface (where the maximum lies
#: under sliding friction above mu ~ 0.3): two near it, then down to 2 a (Hertz's maximum lies at
#: 0.45-0.5 a)
YIELD_CHECK_DEPTHS_IN_A = (0.02, 0.06, 0.15, 0.3, 0.5, 0.75, 1.1, 1.5, 2.0)


#: depths at least this many cells deep are evaluated by ``yield_check`` on the grid of half the
#: cells per side, the tractions averaged over 2 x 2 cells (a quarter of the work): the von Mises
#: maxima there lie within 0.14 % of the fine grid's at 8 cells deep and 0.04 % from 12 on (n = 256,
#: the coupled step of bench/scaling.py; -0.37 % at 4 cells, -0.71 % in the flat)
COARSE_STRESS_DEPTH_CELLS = 8
#: ... where the contact radius spans at least this many cells (16 on the half grid): with 21 cells
#: (n = 64) the half grid's maxima lay 0.16-0.31 % under the fine grid's, with 32 (n = 128) and 64
#: (n = 256) 0.04-0.11 %
COARSE_STRESS_MIN_RADIUS_CELLS = 32


def _restrict_mean(t: np.ndarray) -> np.ndarray:
    """The mean of each 2 x 2 block of cells of ``t`` (even shape): the half grid's field. Row
    pairs first, then column pairs: at n = 4096, 0.024 s per field against 0.126 s for numpy's
    mean over a (h, 2, h, 2) view (2-core machine, warm; 0.22 s on the H100's host, 0.65 s of a
    1.32 s yield check)."""
    rows = t[0::2] + t[1::2]
    return 0.25 * (rows[:, 0::2] + rows[:, 1::2])


#: grids of at most this many cells per side keep their stress evaluators between yield checks
#: (``_evaluator``): on them making the evaluator (its arrays and FFT plans) costs as much as a
#: check, and a sweep or fit checks thousands of small cases; larger grids make it each time, so
#: its memory is not held beside the next solve
CACHED_EVALUATOR_MAX_N = 256
_evaluators: OrderedDict = OrderedDict()


def _evaluator(pair, grid, depths, device, dtype, fft) -> SubsurfaceStress:
    """A ``SubsurfaceStress`` of the pair on the grid (the last few of small grids kept:
    ``CACHED_EVALUATOR_MAX_N``; the yield check passes its depths to each evaluation)."""
    if grid.n > CACHED_EVALUATOR_MAX_N:
        return SubsurfaceStress(pair, grid, depths, device=device, dtype=dtype, fft=fft)
    key = (pair, grid, str(device), str(dtype), str(fft))
    stress = _evaluators.get(key)
    if stress is None:
        stress = _evaluators[key] = SubsurfaceStress(pair, grid, depths, device=device, dtype=dtype, fft=fft)
        while len(_evaluators) > 4:
            _evaluators.popitem(last=False)
    _evaluators.move_to_end(key)
    return stress


def _has_half_grid(grid, radius: float) -> bool:
    """Whether the deep depths of a check are evaluated on the half grid (``_YieldEvaluator``)."""
    return grid.n % 2 == 0 and radius >= COARSE_STRESS_MIN_RADIUS_CELLS * grid.dx


def _half_grid(grid):
    from ..physics.geometry import Grid

    return Grid(grid.n // 2, grid.size)


def _deep(depths: np.ndarray, grid, half_grid: bool) -> np.ndarray:
    """Which ``depths`` [m] the half grid evaluates (all False without one)."""
    if not half_grid:
        return np.zeros(len(depths), dtype=bool)
    return depths >= COARSE_STRESS_DEPTH_CELLS * grid.dx


def _restricted(totals: tuple) -> tuple:
    """The half grid's tractions of device ``totals`` (the means of 2 x 2 cells), on their device."""
    import warp as wp

    from warpcontact.kernels import grids as gk

    out = []
    for t in totals:
        if t is None:
            out.append(None)
            continue
        h = t.shape[0] // 2
        c = wp.empty((h, h), dtype=t.dtype, device=t.device)
        wp.launch(gk.restrict_mean, dim=(h, h), inputs=[t, t.dtype(1.0)], outputs=[c], device=t.device)
        out.append(c)
    return tuple(out)


class _YieldEvaluator:
    """The von Mises maxima of one state's tractions at any depths, each on the fine grid or, from
    ``COARSE_STRESS_DEPTH_CELLS`` down and where the contact ``radius`` [m] spans
    ``COARSE_STRESS_MIN_RADIUS_CELLS`` cells, on the half grid (``yield_check``)."""

    def __init__(self, pair, grid, totals, depths, device, dtype, fft, radius: float):
        """``totals``: the total tractions (p, q_x, q_y) as host arrays [Pa] or as Warp arrays on
        ``device`` scaled by E* (``SubsurfaceStress._load_tractions``); None for a zero one."""
        import warp as wp

        self.grid = grid
        self.tractions = totals
        self.fine = _evaluator(pair, grid, depths, device, dtype, fft)
        self.coarse = self.coarse_tractions = None
        if _has_half_grid(grid, radius):
            self.coarse = _evaluator(pair, _half_grid(grid), depths, device, dtype, fft)
            if isinstance(totals[0], wp.array):  # on the device: the half grid's there too
                self.coarse_tractions = _restricted(totals)
            else:
                self.coarse_tractions = tuple(None if t is None else _restrict_mean(np.asarray(t)) for t in totals)

    def maxima(self, depths) -> dict:
        depths = np.asarray(depths, dtype=np.float64)
        deep = _deep(depths, self.grid, self.coarse is not None)
        out = {name: np.zeros((len(depths), 3)) for name in self.fine.bodies}
        for mask, evaluator, tr in ((~deep, self.fine, self.tractions),
                                    (deep, self.coarse, self.coarse_tractions)):
            if mask.any():
                part = evaluator.von_mises_maxima(*tr, depths[mask])
                for name in self.fine.bodies:
                    out[name][mask] = part[name]
        return out


def yield_check(pair, grid, fields: dict, device="cpu", dtype="float64", fft="auto") -> dict:
    """Whether a solved state has left the elastic range in which its results hold: the largest
    von Mises stress in each body against its yield strength. The von Mises maxima are taken at
    ``YIELD_CHECK_DEPTHS_IN_A`` contact radii (16 cells without contact), then at the midpoints
    on either side of each body's largest (``SubsurfaceStress.von_mises_maxima``: the stress and
    von Mises alone; from ``COARSE_STRESS_DEPTH_CELLS`` cells down on the half grid), and the
    maximum refined between depths by a parabola (:func:`depth_maximum`).

    Returns ``yielded`` (True when a body's maximum reaches its yield strength, False when neither
    does, None when no body has a finite yield strength or the check could not run), and per body
    ``von_mises_max`` [Pa], its depth ``z`` [m], ``yield_strength`` [Pa] or None, ``yielded``
    and ``margin`` = yield strength / von Mises max (> 1: elastic); a rigid body is not evaluated:
    ``rigid`` true, each figure None and the ``reason``. The depths put the maximum
    within about 1 % (``reason`` says why the check did not run, when it did not). The surface
    (``SURFACE_DEPTH_IN_CELLS``) is among the depths."""
    return _yield_check(pair, grid, tractions(fields), contact_radius(fields, grid.cell_area), device, dtype, fft)


def state_yield_check(state, friction: bool = True, adhesion: bool = True) -> dict:
    """:func:`yield_check` of one solved ``ContactState`` on its model (pair, grid, device, float
    type, FFT backend), its tractions totalled and loaded on the device (one field, the pressure,
    read on the host for the contact radius). Without ``friction`` the contact shear and without
    ``adhesion`` the adhesive tractions are zero and not read; with neither, the shear is left out
    of the evaluation (None: its terms are not summed).

    It runs after the solve, whose results are the run's: an error of the check itself (a device
    error, say) does not end the run but is returned, ``{"yielded": None, "failed": True,
    "reason": ...}``, for the commands to report in one line and in their exit status
    (``records.guards.check_failure``).

    On CUDA, where a plane of the check fits in ``stress_batch.CHUNK_BYTES``, the check's depths
    are evaluated together (:func:`batch_yield_checks` of this state alone: a few launches a
    pass, where the evaluation depth by depth launches hundreds); elsewhere depth by depth."""
    if checks_by_planes(state.model):
        return batch_yield_checks([state], friction, adhesion)[0]
    return _own_yield_check(state, friction, adhesion)


def checks_by_planes(model) -> bool:
    """Whether the yield checks of states on ``model`` evaluate their depths together
    (``stress_batch.PlaneStress``): on CUDA, where one plane fits in a chunk (n <= 682 in
    float64); depth by depth on the CPU, where the evaluation's launches split over the threads
    and the plane kernels' do not, and on larger grids, where the depth-by-depth evaluation checks
    its memory first."""
    from .stress_batch import PlaneStress

    return model.device.is_cuda and PlaneStress.plane_bytes(model.grid.n, model.dtype) <= PlaneStress.chunk_bytes()


def _own_yield_check(state, friction: bool, adhesion: bool) -> dict:
    """The check of one state, depth by depth (``_YieldEvaluator``); a failure returned."""
    try:
        return _state_yield_check(state, friction, adhesion)
    except Exception as e:  # noqa: BLE001 - reported in the result, the line and the exit status
        return {"yielded": None, "failed": True,
                "reason": f"the yield check failed after the solve ({type(e).__name__}: {e})"}


def _state_yield_check(state, friction: bool, adhesion: bool) -> dict:
    m = state.model
    totals, radius = _state_totals(state, friction, adhesion)
    return _yield_check(m.pair, m.grid, totals, radius, m.device, m.dtype_name, m.fft_name)


def _state_totals(state, friction: bool, adhesion: bool, radius: float | None = None, into=None) -> tuple:
    """((p, q_x, q_y) totals of a state on its device, scaled by E*, None for one left out; the
    contact radius [m]: ``radius`` where given, else counted from the pressure read to the host).
    ``into``: three zeroed (n, n) arrays to make them in (a stack's layers); default: new ones."""
    import warp as wp

    from warpcontact.kernels import adhesion as ak

    m = state.model
    totals = []
    for contact, adhesive, on in ((state.pressure, state.adhesive_pressure, True),
                                  (state.shear_x, state.adhesive_shear_x, friction),
                                  (state.shear_y, state.adhesive_shear_y, friction)):
        if not (on or adhesion):
            totals.append(None)
            continue
        total = m.field() if into is None else into[len(totals)]
        if on:
            wp.copy(total, contact)
        if adhesion:
            m.launch(ak.add_to, dim=m.n_cells, inputs=[adhesive.flatten()], outputs=[total.flatten()])
        totals.append(total)
    if radius is None:
        radius = contact_radius({"pressure": state.pressure.numpy()}, m.grid.cell_area)
    return tuple(totals), radius


def _yield_check(pair, grid, totals, radius: float, device, dtype, fft) -> dict:
    """:func:`yield_check` from the total tractions (host [Pa] or device, scaled: see
    ``_YieldEvaluator``) and the contact radius [m]."""
    unchecked = _unchecked(pair)
    if unchecked is not None:
        return unchecked
    depths = _first_depths(grid, radius)
    try:
        stress = _YieldEvaluator(pair, grid, totals, depths, device, dtype, fft, radius)
        maxima = stress.maxima(depths)
        more = _midpoints(depths, maxima)
        if len(more):
            depths, maxima = _merged(depths, maxima, more, stress.maxima(more))
    except InputError as e:  # the evaluation does not fit beside the solve: say so, do not fail the run
        return {"yielded": None, "reason": str(e)}
    except (MemoryError, RuntimeError) as e:  # an allocation the device refused; any other error is raised
        if not allocation_refused(e):
            raise
        return {"yielded": None, "reason": f"the yield check could not run: {e}"}
    return _verdict(pair, depths, maxima)


def _rigid(pair) -> dict:
    return {name: {"rigid": True, "von_mises_max": None, "z": None, "yield_strength": None, "yielded": None,
                   "margin": None, "reason": RIGID_REASON} for name in BODIES if name not in pair.elastic}


def _unchecked(pair) -> dict | None:
    """The check's answer where no body has a finite yield strength; else None (it runs)."""
    if not any(math.isfinite(m.yield_strength) for m in pair.elastic.values()):
        return {"yielded": None, "reason": "no yield_strength given", **_rigid(pair)}
    return None


def _first_depths(grid, radius: float) -> np.ndarray:
    """The check's first depths [m]: the surface and ``YIELD_CHECK_DEPTHS_IN_A`` contact radii
    (16 cells without contact)."""
    a = radius if radius > 0 else 16.0 * grid.dx / 2.0
    return np.concatenate([[SURFACE_DEPTH_IN_CELLS * grid.dx], np.array(YIELD_CHECK_DEPTHS_IN_A) * a])


def _midpoints(depths: np.ndarray, maxima: dict) -> np.ndarray:
    """The midpoints on either side of each body's largest von Mises stress among ``depths``."""
    extra = set()
    for m in maxima.values():
        k = int(np.argmax(m[:, 0]))
        extra.update(0.5 * (depths[j] + depths[j + 1]) for j in (k - 1, k) if 0 <= j < len(depths) - 1)
    return np.array(sorted(extra))


def _merged(depths, maxima, more, more_maxima) -> tuple:
    """Both sets of depths and maxima, in depth order."""
    order = np.argsort(np.concatenate([depths, more]), kind="stable")
    return np.concatenate([depths, more])[order], {b: np.concatenate([maxima[b], more_maxima[b]])[order]
                                                    for b in maxima}


def _verdict(pair, depths, maxima) -> dict:
    """Each body's maximum refined between depths (:func:`depth_maximum`) against its yield strength."""
    rigid = _rigid(pair)
    out = {}
    for name in BODIES:
        if name in rigid:
            out[name] = rigid[name]
            continue
        vm = depth_maximum(maxima[name], depths)
        sy = pair.elastic[name].yield_strength
        finite = math.isfinite(sy)
        out[name] = {"von_mises_max": vm["value"], "z": vm["z"], "yield_strength": sy if finite else None,
                     "yielded": bool(vm["value"] >= sy) if finite else None,
                     "margin": sy / vm["value"] if finite and vm["value"] > 0 else None}
    out["yielded"] = any(out[b]["yielded"] for b in BODIES)
    return out


def batch_yield_checks(states: list, friction: bool = True, adhesion: bool = True, radii=None) -> list[dict]:
    """:func:`state_yield_check` of many solved states of one grid size, device and float type,
    made together (:func:`stacked_yield_checks` of their total tractions, copied into one stack).
    The same depths, half grid and refinement as each state's own check, so the same answers to
    round-off. ``radii``: each state's contact radius [m] where known already (its summary's
    ``contact_radius``: the same count of cells with p > 0), so that no pressure is read to the
    host for it. Should the batched evaluation fail (a device's refusal, a library's error), each
    state is checked on its own, depth by depth."""
    try:
        return _batch_yield_checks(states, friction, adhesion, radii)
    except Exception:  # noqa: BLE001 - each state's own check then, with its own failure in its place
        return [_own_yield_check(s, friction, adhesion) for s in states]


def _batch_yield_checks(states, friction, adhesion, radii) -> list[dict]:
    import warp as wp

    model = states[0].model
    n = model.grid.n
    stack = wp.zeros((3 * len(states), n, n), dtype=model.dtype, device=model.device)
    loaded, found = [], []
    for c, state in enumerate(states):
        if _unchecked(state.model.pair) is not None:  # nothing to evaluate: no copy
            loaded.append((False,) * 3)
            found.append(0.0)
            continue
        layers = tuple(stack[3 * c + k] for k in range(3))
        totals, radius = _state_totals(state, friction, adhesion, None if radii is None else radii[c], into=layers)
        loaded.append(tuple(t is not None for t in totals))
        found.append(radius)
    return stacked_yield_checks([s.model.pair for s in states], [s.model.grid for s in states], stack, loaded, found)


def stacked_yield_checks(pairs: list, grids: list, stack, loaded: list, radii: list) -> list[dict]:
    """:func:`state_yield_check` of cases of one grid size from their total tractions on the device,
    made together: each pass's depths of every case in one evaluation
    (``stress_batch.PlaneStress``; the half grid's in a second, its tractions restricted from the
    stack in one launch), so a batch of small cases launches a few kernels and transforms where one
    case at a time launches hundreds. ``pairs[c]``: case c's materials; ``grids[c]``: its grid
    (n cells per side, each its own domain); ``stack``: a (3 cases, n,
    n) Warp array, case c's (p, q_x, q_y) scaled by its E* in layers 3 c .. 3 c + 2 (a batched
    solve's rows gathered there, or states' tractions copied); ``loaded[c]``: which of the three
    are loaded; ``radii[c]``: its contact radius [m]. Errors are raised (the callers fall back
    to each case's own check)."""
    import warp as wp

    from warpcontact.kernels import grids as gk

    from .stress_batch import PlaneStress

    checks = [_unchecked(pair) for pair in pairs]
    cases = [c for c, check in enumerate(checks) if check is None]
    if not cases:
        return checks
    levels = {}  # grid level (False: fine, True: half) -> (PlaneStress, the cases' tractions)
    n = grids[cases[0]].n

    def level(half: bool):
        if half not in levels:
            tractions, m = stack, n
            if half:
                m = n // 2
                tractions = wp.empty((stack.shape[0], m, m), dtype=stack.dtype, device=stack.device)
                wp.launch(gk.restrict_mean_stack, dim=tractions.shape, inputs=[stack], outputs=[tractions],
                          device=stack.device)
            levels[half] = (PlaneStress(m, stack.device, stack.dtype), tractions)
        return levels[half]

    def maxima(depth_sets: dict) -> dict:
        """{case: {body: (len(depths), 3) value [Pa], x, y [m]}} at each case's depths."""
        out = {c: {name: np.zeros((len(d), 3)) for name in BODIES} for c, d in depth_sets.items()}
        for half in (False, True):
            planes, where = [], []
            for c, depths in depth_sets.items():
                grid = grids[c]
                deep = _deep(depths, grid, _has_half_grid(grid, radii[c]))
                g = _half_grid(grid) if half else grid
                for k in np.flatnonzero(deep if half else ~deep):
                    planes.append((c, depths[k] / g.dx))
                    where.append((c, k, g))
            if not planes:
                continue
            stress, tractions = level(half)
            values = stress.maxima(pairs, tractions, loaded, planes)
            for (c, k, g), v in zip(where, values):
                for b, name in enumerate(BODIES):
                    out[c][name][k] = (v[b, 0], g.x[int(v[b, 2])], g.y[int(v[b, 1])])
        return {c: {name: m[name] for name in pairs[c].elastic} for c, m in out.items()}

    depths = {c: _first_depths(grids[c], radii[c]) for c in cases}
    first = maxima(depths)
    more = {c: _midpoints(depths[c], first[c]) for c in cases}
    second = maxima(more)
    for c in cases:
        d, m = depths[c], first[c]
        if len(more[c]):
            d, m = _merged(d, m, more[c], second[c])
        checks[c] = _verdict(pairs[c], d, m)
    return checks


def yield_keys(check: dict | None) -> dict:
    """The keys a result carries from a :func:`yield_check` (the one place they are made: solve,
    gross-slip, table2 and sweep results): ``yielded`` (True, False, or None when not checkable),
    ``yield_margin`` (the smaller S_Y / von Mises max of the bodies with a yield strength, or None)
    and ``yield_check`` (the per-body figures). ``check`` None (not run): both None."""
    if check is None:
        return {"yielded": None, "yield_margin": None}
    margins = [b["margin"] for b in check.values() if isinstance(b, dict) and b.get("margin")]
    return {"yielded": check["yielded"], "yield_margin": min(margins) if margins else None, "yield_check": check}


def state_yield_keys(state) -> dict:
    """:func:`yield_keys` of one solved ``ContactState`` on its model (pair, grid, device, float
    type, FFT backend): the check a command makes once, on its final state."""
    return yield_keys(state_yield_check(state))

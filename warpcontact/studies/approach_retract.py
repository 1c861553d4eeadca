"""Approach and retraction under displacement control: force-displacement curve, jumps, pull-off.

The path takes equal steps of delta_z up to the deepest approach and back. Where the contact forms
(approach) or breaks (retraction) between two steps, the step is bisected from the state before it
(``LOCATE_LEVELS`` times) to place the event and to tell a jump from a continuous change: at a jump
(a fold of the equilibrium curve: jump-in, jump-out) the force changes by a finite amount however
narrow the bracket; where the contact grows from or shrinks to a point the change falls with the
bracket. The most tensile state of the retraction is then resolved by ``REFINE_SUBSTEPS`` substeps
of the two steps around it, taken from the state before them, so that the pull-off force does not
depend on where the equal steps happen to fall. Every refining state follows the retraction branch
(each starts from a state of that branch at a larger delta_z): no state of an unstable branch is
used, and none is averaged over.
"""

from __future__ import annotations

import numbers
import time

import numpy as np

from ..errors import InputError
from ..records.guards import warn_if_adhesion_at_edge
from ..records.results import state_summary
from ..numerics.state import ContactState

#: bisections of a step where the contact forms or breaks: the event is placed within 1 / 2^5 of a step
LOCATE_LEVELS = 5
#: a located event is a jump when the force change across the last bracket is at least this fraction
#: of that across the bracket 4x wider (two levels before): a finite jump keeps its size (ratio ~1),
#: a change linear in delta_z falls to 0.25 and a square-root onset to 0.5
JUMP_RATIO = 0.75
#: substeps of the two steps around the most tensile state of the retraction. With F = F_min +
#: F'' (d - d_min)^2 / 2 near the minimum the equal steps (spacing h) miss F_min by up to
#: F'' h^2 / 8; substeps of h / 4 by up to F'' h^2 / 128, 16x less.
REFINE_SUBSTEPS = 8
#: and only when that change is at least this fraction of the most tensile force of the path so far:
#: on a grid the contact forms and breaks one cell at a time, a discrete change that keeps its size
#: too (0.8 % of the pull-off at the DMT example's n = 64: one cell of 5 nm entering contact)
JUMP_SIZE = 0.02
#: times the path's start may be moved out (its distance doubled) while the first state touches
START_MOVES = 3


def tabor_parameter(pair, radius: float, work_of_adhesion: float, length: float) -> float:
    """Tabor's parameter mu = (R w^2 / (E*^2 z0^3))^(1/3) with the law's length z0 [-]."""
    return (radius * work_of_adhesion**2 / (pair.E_star**2 * length**3)) ** (1.0 / 3.0)


def _in_contact(s: dict) -> bool:
    return s["contact_area"] > 0.0


def _interacting(s: dict) -> bool:
    """In contact or within the law's range somewhere (a law with a finite range: Dugdale)."""
    return s["contact_area"] > 0.0 or s["adhesive_area"] > 0.0


#: what an event is about: the elastic contact, or (finite-range laws) any interaction at all
_PREDICATES = {"contact": _in_contact, "interaction": _interacting}


class _Path:
    """The solves of one approach-retract run: the solver, the states it needs and the count."""

    def __init__(self, model, solver, on_state, n_path: int):
        self.model, self.solver, self.on_state = model, solver, on_state
        self.count = 0  # states solved, path and refinement
        self.planned = n_path  # grows as events are found: the progress total
        self.converged = True
        self._spare: list[ContactState] = []  # states for bisections and substeps, made when first needed

    def solve(self, state, dz: float, branch: str, purpose: str = "path", notify: bool = True) -> dict:
        """Solve ``state`` (holding the state before) at ``dz``; its summary, tagged."""
        info = self.solver.step(state, (0.0, 0.0, float(dz)))
        self.converged = self.converged and bool(info.converged)
        s = state_summary(state, self.solver.adhesion)
        s["branch"] = branch
        if purpose != "path":
            s["purpose"] = purpose
        self.count += 1
        if notify:
            self.notify(s)
        return s

    def notify(self, s: dict) -> None:
        if self.on_state is not None:
            self.on_state(self.count - 1, max(self.planned, self.count), s)

    def copy_of(self, state, slot: int) -> ContactState:
        """Spare state number ``slot``, holding a copy of ``state``."""
        while len(self._spare) <= slot:
            self._spare.append(ContactState(self.model))
        self._spare[slot].copy_from(state)
        return self._spare[slot]

    def locate(self, before_state, before: dict, after: dict, of: str, refined: list, scale: float) -> dict:
        """Bisect the step from ``before`` to ``after`` (``of``: "contact" or "interaction", true on
        one side only), each probe solved from the state at the bracket's ``before`` end
        (``before_state`` at first): where it forms or breaks, and whether the force jumps there
        (``JUMP_RATIO``, ``JUMP_SIZE`` of ``scale`` [N])."""
        self.planned += LOCATE_LEVELS
        inside = _PREDICATES[of]
        kind = "forms" if inside(after) else "breaks"
        branch, purpose = after["branch"], f"{of} {kind}"
        lo_state = self.copy_of(before_state, 0)
        lo, hi = before, after
        changes = [abs(hi["force"]["z"] - lo["force"]["z"])]
        for _ in range(LOCATE_LEVELS):
            probe = self.copy_of(lo_state, 1)
            s = self.solve(probe, 0.5 * (lo["delta"]["z"] + hi["delta"]["z"]), branch, purpose)
            refined.append(s)
            if inside(s) == inside(lo):
                lo = s
                self._spare[0], self._spare[1] = probe, lo_state  # the probe is the new 'before' state
                lo_state = probe
            else:
                hi = s
            changes.append(abs(hi["force"]["z"] - lo["force"]["z"]))
        ratio = changes[-1] / changes[-3] if changes[-3] > 0.0 else 0.0
        return {
            "of": of, "kind": kind, "branch": branch,
            "jump": bool(ratio >= JUMP_RATIO and changes[-1] >= JUMP_SIZE * scale), "change_ratio": ratio,
            "delta_z_before": lo["delta"]["z"], "delta_z_after": hi["delta"]["z"],
            "force_before": lo["force"]["z"], "force_after": hi["force"]["z"],
            "contact_radius_before": lo["contact_radius"], "contact_radius_after": hi["contact_radius"],
        }

    def refine(self, start_state, z_from: float, z_to: float, refined: list) -> list:
        """Substeps of the retraction from ``start_state`` (at ``z_from``) towards ``z_to``; their
        summaries."""
        self.planned += REFINE_SUBSTEPS - 1
        state = self.copy_of(start_state, 0)
        substeps = [self.solve(state, z_from + (z_to - z_from) * j / REFINE_SUBSTEPS, "retract", "pull-off")
                    for j in range(1, REFINE_SUBSTEPS)]
        refined.extend(substeps)
        return substeps


def pull_off_fit(states: list) -> tuple[float, float]:
    """The least-squares parabola F_z(delta_z) through ``states`` (the substeps around the most
    tensile state, with the path's states at either end): its lowest value over their span [N]
    and the states' largest distance from it [N]. On a grid the contact edge leaves one ring of
    cells at a time and the retraction's force is jagged (a sawtooth on the continuum's smooth
    curve); the distance measures that, the parabola's minimum is the pull-off with it averaged
    out."""
    z = np.array([c["delta"]["z"] for c in states], dtype=np.float64)
    f = np.array([c["force"]["z"] for c in states], dtype=np.float64)
    zc, zs = z.mean(), max(np.ptp(z), 1e-300)
    coeffs = np.polyfit((z - zc) / zs, f, 2)
    fitted = np.polyval(coeffs, (z - zc) / zs)
    a, b, _ = coeffs
    candidates = [(z.min() - zc) / zs, (z.max() - zc) / zs]
    if a > 0.0 and candidates[0] <= -b / (2.0 * a) <= candidates[1]:
        candidates.append(-b / (2.0 * a))
    lowest = min(float(np.polyval(coeffs, x)) for x in candidates)
    return lowest, float(np.max(np.abs(f - fitted)))


def approach_retract(model, solver, delta_start: float, delta_max: float, delta_end: float, steps: int,
                     on_state=None, refine: bool = True, extend: bool = False) -> dict:
    """Solve delta_z from ``delta_start`` up to ``delta_max`` and back down to ``delta_end`` [m],
    ``steps`` equal steps each way; with ``refine``, locate where the contact forms and breaks and
    resolve the pull-off (module docstring). With ``extend`` (the path's ends are defaults, not
    the user's): a first state in contact (the surfaces jumped together before the path began)
    moves the start out, its distance doubled up to ``START_MOVES`` times, and a retraction still
    in contact at ``delta_end`` goes on by steps of the same size until the contact breaks (up to
    ``steps`` more), so that the curve holds the jump-in and the jump-out.

    Returns ``curve``: the path's states (delta_z [m], total and elastic F_z [N], contact
    and adhesive areas [m^2], ``branch`` approach or retract); ``refined``: the other states
    solved (the bisections and substeps, and first states found in contact), each with its
    ``purpose``; ``contact_events``: each place the contact (``of`` contact) or, for a law with
    a finite range, any interaction (``of`` interaction) forms (``kind`` forms) or breaks, with the delta_z [m], F_z [N] and contact radius [m] on either side of the last
    bracket, ``jump`` (whether F_z jumps there) and ``change_ratio`` (the test of
    ``JUMP_RATIO``); ``jump_in``: the first event of the approach with a jump, ``jump_out`` the
    first of the retraction, or None; ``pull_off_force`` [N] (the most tensile total F_z of the
    retraction, refined) and ``pull_off_delta_z`` [m]; ``pull_off_spacing`` [m]: the delta_z
    spacing of the states around it; ``delta_start``, ``delta_end`` [m]: the path's ends as run;
    ``in_contact_at``: "start" and/or "end" where the path could not leave the contact there;
    ``converged``: every state, path and refinement. Warns once
    (:class:`~warpcontact.records.guards.AdhesionAtEdgeWarning`) when the law's tail reaches the domain's
    edge. ``on_state(k, total, summary)`` is called after every state solved (refinement too)."""
    if isinstance(steps, bool) or not isinstance(steps, numbers.Integral) or steps < 1:
        raise InputError("steps", f"must be an integer >= 1 (steps each way), got {steps!r}")
    t0 = time.perf_counter()
    path = _Path(model, solver, on_state, 2 * steps + 1)
    state = ContactState(model)
    curve, refined, events = [], [], []
    predicates = ("contact", "interaction") if getattr(solver.adhesion, "finite_range", False) else ("contact",)
    touching = _PREDICATES[predicates[-1]]  # what the path's ends must be free of
    start = float(delta_start)
    for move in range(START_MOVES + 1):  # the first state, from rest
        if move:
            state = ContactState(model)
        first = path.solve(state, start, "approach", notify=False)
        if not (extend and touching(first) and start < 0.0 and move < START_MOVES):
            break
        first["purpose"] = "start in contact"  # the surfaces jumped together before the path began
        refined.append(first)
        path.planned += 1
        path.notify(first)
        start *= 2.0
    path.notify(first)
    curve.append(first)
    before_state = ContactState(model) if refine else None  # the state before the current step
    pull_start = ContactState(model) if refine else None  # the state before the most tensile one
    up = np.linspace(start, delta_max, steps + 1)[1:]
    down = np.linspace(delta_max, delta_end, steps + 1)[1:]
    spacing = abs(float(down[0] - delta_max))  # the retraction's step
    edge_warned = warn_if_adhesion_at_edge(state, solver.adhesion, delta_max)  # one warning per curve
    weakest = None  # index of the most tensile retraction state so far
    targets = list(up) + list(down)
    k = 0
    while k < len(targets):
        dz = targets[k]
        k += 1
        if refine:
            before_state.copy_from(state)
        branch = "approach" if k <= steps else "retract"
        s = path.solve(state, dz, branch)
        if not edge_warned:
            edge_warned = warn_if_adhesion_at_edge(state, solver.adhesion, delta_max)
        curve.append(s)
        if extend and k == len(targets) and touching(s) and len(targets) < 3 * steps:
            targets.append(float(dz) - spacing)  # still in contact: retract further
            path.planned += 1
        if not refine:
            continue
        prev = curve[-2]
        if branch == "retract" and (weakest is None or s["force"]["z"] < curve[weakest]["force"]["z"]):
            weakest = len(curve) - 1
            pull_start.copy_from(before_state)
        for of in predicates:
            if _PREDICATES[of](prev) != _PREDICATES[of](s):
                scale = max(abs(min(c["force"]["z"] for c in curve)), abs(s["force"]["z"]))
                events.append(path.locate(before_state, prev, s, of, refined, scale))
    fit = scatter = None  # no refinement: the pull-off lies at an end of the path
    if refine and weakest is not None and weakest + 1 < len(curve):
        substeps = path.refine(pull_start, curve[weakest - 1]["delta"]["z"], curve[weakest + 1]["delta"]["z"], refined)
        spacing *= 2.0 / REFINE_SUBSTEPS
        fit, scatter = pull_off_fit([curve[weakest - 1], *substeps, curve[weakest + 1]])
    retraction = [c for c in curve + refined if c["branch"] == "retract"] or curve
    low = min(retraction, key=lambda c: c["force"]["z"])
    jumps = {branch: next((e for e in events if e["branch"] == branch and e["jump"]), None)
             for branch in ("approach", "retract")}
    stuck = [where for where, c in (("start", curve[0]), ("end", curve[-1])) if touching(c)]
    return {
        "pull_off_force": float(low["force"]["z"]),
        "pull_off_delta_z": low["delta"]["z"],
        "pull_off_spacing": spacing,
        "pull_off_fit": fit,
        "pull_off_scatter": scatter,
        "jump_in": jumps["approach"],
        "jump_out": jumps["retract"],
        "contact_events": events,
        "delta_start": start,
        "delta_end": curve[-1]["delta"]["z"],
        "in_contact_at": stuck,
        "converged": bool(path.converged),
        "curve": curve,
        "refined": refined,
        "elapsed_s": time.perf_counter() - t0,
    }

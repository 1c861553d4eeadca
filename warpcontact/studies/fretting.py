"""Fretting: a cyclic tangential load path (``[load] delta_x_amplitude``, ``cycles``), each whole
cycle's loop, the energy it dissipates and its regime, against Mindlin and Deresiewicz's closed
form where that applies (:func:`~warpcontact.physics.reference.mindlin_deresiewicz`).

The path is solved as any other (:func:`warpcontact.studies.runner.run_path`); what this module
adds is read from the states' summaries alone: :func:`fretting_keys` of the states finished so
far, so a partial result (a stopped run) carries the cycles it finished.
"""

from __future__ import annotations

import math

from ..errors import InputError

#: A cycle's values built on its states: withheld (None) when one of them did not converge.
CYCLE_RESULTS = ("energy", "energy_error", "force_amplitude", "energy_ratio", "regime", "min_stick_area")
#: |Dundurs beta| below which the pair counts as uncoupled (beta = 0 exactly for identical bodies;
#: this allows for a modulus and Poisson ratio written to 12 digits)
BETA_UNCOUPLED = 1e-12


def check_fretting_case(case) -> None:
    """What fretting needs of a case: a [friction] table, a cyclic path (an amplitude) and a
    positive normal approach. InputError naming the key otherwise."""
    if case.friction is None:
        raise InputError("friction", "fretting needs a [friction] table (law = 'coulomb' or 'tabor'): without "
                                     "friction the loop is a line and dissipates nothing")
    if not case.load.cyclic:
        raise InputError("load.delta_x_amplitude", "fretting needs a cyclic path: give load.delta_x_amplitude (or "
                                                   "load.delta_y_amplitude) in m, and load.cycles")
    if not case.load.delta_z > 0.0:
        raise InputError("load.delta_z", f"fretting needs a positive normal approach, got {case.load.delta_z!r}")


def closed_form_note(case) -> str | None:
    """Why Mindlin and Deresiewicz's closed form does not describe the case (None where it does):
    it needs Coulomb friction, an uncoupled pair (Dundurs beta = 0: identical materials, or a rigid
    body on an incompressible one), no adhesion and a sphere's (or paraboloid's) Hertz contact."""
    if case.friction.law != "coulomb":
        return f"the closed form is for Coulomb friction; friction.law is {case.friction.law!r}"
    beta = case.pair.dundurs_beta
    if abs(beta) > BETA_UNCOUPLED:
        return (f"the closed form needs an uncoupled pair (Dundurs beta = 0: identical materials); this pair's beta "
                f"is {beta:.3g}, so the normal and tangential tractions couple")
    if case.adhesion is not None:
        return "the closed form has no adhesion; the case has an [adhesion] table"
    if not case.sphere.hertzian:
        return f"the closed form is a sphere's (Hertz's contact); this case's shape is {case.sphere.description}"
    return None


def amplitude(case) -> float:
    """delta*, the displacement amplitude [m]: the length of (delta_x_amplitude, delta_y_amplitude)."""
    return math.hypot(case.load.delta_x_amplitude or 0.0, case.load.delta_y_amplitude or 0.0)


def _direction(case) -> tuple[float, float]:
    d = amplitude(case)
    return (case.load.delta_x_amplitude or 0.0) / d, (case.load.delta_y_amplitude or 0.0) / d


def loop_work(states) -> tuple[float, float]:
    """The work of the tangential force over states that run down one half cycle and back up the
    other (``states``: 4 q + 1 summaries, from +delta* through -delta* to +delta*, q an integer
    >= 1): the loop integral of F_x d(delta_x) + F_y d(delta_y) [J], by the composite trapezoid and
    Simpson rules on each half (2 q equal steps, an even number). Returns (trapezoid, Simpson)."""
    n = len(states) - 1
    if n < 4 or n % 4:
        raise ValueError(f"a cycle takes 4 q + 1 states, got {len(states)}")
    trapezoid = simpson = 0.0
    for half in (states[: n // 2 + 1], states[n // 2:]):
        for c in "xy":
            f = [s["force"][c] for s in half]
            d = [s["delta"][c] for s in half]
            trapezoid += sum(0.5 * (f[i] + f[i + 1]) * (d[i + 1] - d[i]) for i in range(len(f) - 1))
            simpson += sum((d[i + 2] - d[i]) / 6.0 * (f[i] + 4.0 * f[i + 1] + f[i + 2])
                           for i in range(0, len(f) - 2, 2))
    return trapezoid, simpson


def cycle_record(case, states, first: int, last: int, number: int) -> dict:
    """One whole cycle, states ``first`` to ``last`` (indices into ``states``; both at +delta*):

    - energy [J]: the loop integral of F_x d(delta_x) + F_y d(delta_y) (Simpson's rule on each half
      cycle), the energy the interface dissipates; energy_error [J]: |Simpson - trapezoid|, the
      integration's error estimate (that of the trapezoid, a bound on Simpson's where the loop is
      smooth; it shrinks as tangential_steps grows);
    - force_amplitude Q* [N]: half the range of the tangential force along the displacement's
      direction; displacement_amplitude delta* [m];
    - energy_ratio A = energy / (4 delta* Q*) [-] (Fouvry's: 0.2 at the transition to gross slip for
      the closed form);
    - regime: "gross slip" where some state of the cycle has no stick cell, else "partial slip";
      min_stick_area [m^2];
    - normal_force_min, normal_force_max [N]: F_z over the cycle (constant for an uncoupled pair);
    - converged: every state of the cycle converged; where not, the values above are None and a
      note says so.
    """
    from ..records.guards import withhold_if_unconverged

    cycle = states[first:last + 1]
    ux, uy = _direction(case)
    along = [s["force"]["x"] * ux + s["force"]["y"] * uy for s in cycle]
    trapezoid, simpson = loop_work(cycle)
    d_star = amplitude(case)
    q_star = 0.5 * (max(along) - min(along))
    stick = min(s["stick_area"] for s in cycle)
    record = {
        "cycle": number,
        "first_state": first,
        "last_state": last,
        "energy": simpson,
        "energy_error": abs(simpson - trapezoid),
        "force_amplitude": q_star,
        "displacement_amplitude": d_star,
        "energy_ratio": simpson / (4.0 * d_star * q_star) if q_star > 0.0 else None,
        "regime": "gross slip" if stick == 0.0 else "partial slip",
        "min_stick_area": stick,
        "normal_force_min": min(s["force"]["z"] for s in cycle),
        "normal_force_max": max(s["force"]["z"] for s in cycle),
        "converged": all(s["converged"] for s in cycle),
    }
    return withhold_if_unconverged(record, CYCLE_RESULTS)


def closed_form(case, normal_force: float) -> dict | None:
    """Mindlin and Deresiewicz's loop for the case's amplitude at ``normal_force`` P [N] (the
    model's, at the end of the normal leg), with Hertz's contact radius for P, a = (3 P R / (4
    E*))^(1/3) [m]: :func:`~warpcontact.physics.reference.mindlin_deresiewicz`'s keys plus
    normal_force, contact_radius, mu and compliance (1/G* [1/Pa]). None where it does not apply
    (:func:`closed_form_note`) or P <= 0."""
    from ..physics.reference import mindlin_deresiewicz

    if closed_form_note(case) is not None or not normal_force > 0.0:
        return None
    a = (3.0 * normal_force * case.sphere.radius / (4.0 * case.pair.E_star)) ** (1.0 / 3.0)
    mu, compliance = case.friction.mu, case.pair.mindlin_compliance
    r = mindlin_deresiewicz(normal_force, a, mu, compliance, amplitude(case))
    return {"normal_force": normal_force, "contact_radius": a, "mu": mu, "compliance": compliance, **r}


def fretting_keys(case, states) -> dict:
    """What fretting adds to a result, from the summaries ``states`` finished so far (a prefix of
    the case's path): normal_force [N] (F_z at the end of the normal leg; None before it),
    displacement_amplitude [m], cycles (one :func:`cycle_record` per whole cycle finished, in
    order), closed_form (:func:`closed_form`, or None) and closed_form_note (why not, or None)."""
    k = case.load.normal_leg_steps - 1
    normal_force = states[k]["force"]["z"] if len(states) > k else None
    cycles = [cycle_record(case, states, first, last, i + 1)
              for i, (first, last) in enumerate(case.load.cycle_bounds()) if last < len(states)]
    note = closed_form_note(case)
    reference = closed_form(case, normal_force) if normal_force is not None else None
    if note is None and normal_force is not None and reference is None:
        note = f"the normal force at the end of the normal leg is {normal_force:.4g} N, not compressive"
    return {"normal_force": normal_force, "displacement_amplitude": amplitude(case), "cycles": cycles,
            "closed_form": reference, "closed_form_note": note}


def fretting_summary(case, on_state=None, model=None) -> dict:
    """Solve the case's cyclic path and return its fretting keys (:func:`fretting_keys`) with the
    path's states, converged, elapsed_s [s] and the last state's yield check
    (``yielding.yield_keys``): the result.json of ``warpcontact fretting`` less the run's record
    and the last state's quantities. ``on_state(index, total, summary)`` after each state;
    ``model``: as ``warpcontact.solve``'s. A stop (KeyboardInterrupt) propagates: a path stopped
    part-way is no summary."""
    from ..numerics.yielding import yield_keys
    from .runner import run_path

    check_fretting_case(case)
    callback = None if on_state is None else (lambda k, total, s, result: on_state(k, total, s))
    result = run_path(case, on_state=callback, model=model, fields="none")
    if result.interrupted:
        raise KeyboardInterrupt
    return {**fretting_keys(case, result.states), "states": result.states, "converged": result.converged,
            "elapsed_s": result.elapsed_s, **yield_keys(result.yield_check)}


def fretting_row(summary: dict) -> dict:
    """A fretting summary (:func:`fretting_summary`) as a sweep row: the last whole cycle's values
    at the top (energy [J], energy_error [J], force_amplitude [N], displacement_amplitude [m],
    energy_ratio, regime, min_stick_area [m^2], normal_force_min and normal_force_max [N]: the
    steadiest cycle), n_cycles, n_states, normal_force [N], converged, closed_form (or None) and
    closed_form_note, and the yield check; no list of states or cycles."""
    last = summary["cycles"][-1] if summary["cycles"] else {}
    row = {k: v for k, v in summary.items() if k not in ("states", "cycles", "elapsed_s")}
    row.update({k: v for k, v in last.items() if k not in ("cycle", "first_state", "last_state", "converged")})
    row["n_cycles"] = len(summary["cycles"])
    row["n_states"] = len(summary["states"])
    return row

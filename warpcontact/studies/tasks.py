"""A case's task, from a case to its summary: its load path (``solve``), the gross-slip search or the
approach-retract curve (``pull-off``), with the run's checks. The one builder of each kind of
summary, shared by the Python API (``warpcontact.api``), the command line, the sweeps and fits
(``warpcontact.studies.sweep``, ``warpcontact.studies.fit``) and the stress study (``warpcontact.studies.stress_study``).
"""

from __future__ import annotations

from collections.abc import Mapping
from os import PathLike

from ..records.case import Case, case_from_dict, load_case
from ..errors import InputError

#: What the Python API takes as a case: a Case, a case file's path, or a dict of its tables.
CaseLike = Case | str | PathLike | Mapping

#: What a case may run: its load path, the gross-slip search, the approach-retract curve, a cyclic
#: path's loops (warpcontact.studies.fretting).
TASKS = ("solve", "gross-slip", "pull-off", "fretting")


def prepare(case: CaseLike, device=None, dtype=None, fft=None) -> Case:
    """``case`` with the given solver overrides (None: the case's own): the ``device``, ``dtype``
    and ``fft`` arguments of every function of the Python API. ``case``: a
    :class:`~warpcontact.records.case.Case`, the path of a case file (:func:`load_case`) or a dict
    of its tables (:func:`case_from_dict`); TypeError for anything else."""
    if isinstance(case, (str, PathLike)):
        case = load_case(case)
    elif isinstance(case, Mapping):
        case = case_from_dict(case)
    elif not isinstance(case, Case):
        raise TypeError(f"expected a warpcontact Case, a case file's path or a dict of its tables, "
                        f"got {type(case).__name__}")
    return case.with_overrides(device=device, dtype=dtype, fft=fft)


# ---------------------------------------------------------------------------------------------
# One summary per kind of result: the command line, the Python API, the sweep rows and the fits use these.


def check_gross_slip_case(case: Case) -> None:
    """What a gross-slip search needs of a case: a [friction] table and a positive approach."""
    if case.friction is None:
        raise InputError("friction", "gross-slip needs a [friction] table (law = 'tabor' or 'coulomb')")
    dz = case.load.delta_z_max
    if not dz > 0:
        raise InputError("load.delta_z", f"gross-slip needs a positive normal approach, got {dz!r}")


def check_pull_off_case(case: Case, steps: int = 20, retract_to: float | None = None) -> None:
    """What an approach-retract curve needs: an [adhesion] table, 2 or more steps each way, an end
    below the deepest approach."""
    if case.adhesion is None:
        raise InputError("adhesion", "pull-off needs an [adhesion] table (law = 'smc' or 'dugdale')")
    if isinstance(steps, bool) or not isinstance(steps, int) or steps < 2:
        raise InputError("steps", f"must be an integer of at least 2 (steps each way), got {steps!r}")
    dz_max = case.load.delta_z_max
    if retract_to is not None and not float(retract_to) < dz_max:
        raise InputError("retract_to", f"must lie below the deepest approach {dz_max:g} m, got {retract_to:g}")


def run_gross_slip(case: Case, model, solver, rel_tol: float = 0.01, on_state=None) -> dict:
    """The gross-slip search of ``case`` on a built model and solver, with the run's checks
    (:class:`~warpcontact.records.guards.RunChecks`: resolution and yield, one warning each), as a summary:
    find_gross_slip's result with its results withheld (None, and a ``note``) when a state did
    not converge. The one builder of a gross-slip summary (:func:`gross_slip_search`)."""
    from .slip_search import solve_search

    search, finish = gross_slip_search(case, model, solver.friction, solver.adhesion, rel_tol, on_state)
    return finish(solve_search(search, solver))


def gross_slip_search(case: Case, model, friction, adhesion, rel_tol: float = 0.01, on_state=None):
    """(search, finish): the gross-slip search of ``case`` (a
    :class:`~warpcontact.studies.slip_search.GrossSlipSearch`, whoever solves its states: one at a
    time, or batched with other cases' by ``batch_solve.gross_slip_batch``) with the run's checks
    observing its states, and ``finish(result)``, the summary of its result (checked, its results
    withheld when a state did not converge)."""
    from ..records.guards import GROSS_SLIP_RESULTS, RunChecks, withhold_if_unconverged
    from .slip_search import GrossSlipSearch
    from ..numerics.yielding import state_yield_keys

    checks = RunChecks(case)

    def observe(k, s):
        checks.observe(s, decisive=s.get("kind") == "normal" and checks.decisive(s))
        if on_state is not None:
            on_state(k, s)

    steps = case.load.normal_leg_steps if not case.load.explicit else 4
    search = GrossSlipSearch(model, friction, adhesion, case.load.delta_z_max, normal_steps=steps, rel_tol=rel_tol,
                             on_state=observe, at_max=state_yield_keys)

    def finish(r: dict) -> dict:
        checks.gross_slip(r)
        checks.yielded(r.get("yield_check"), f"at delta_x_max = {r['delta_x_max']:.4g} m")
        return withhold_if_unconverged(r, GROSS_SLIP_RESULTS)

    return search, finish


def run_pull_off(case: Case, model, solver, steps: int = 20, retract_to: float | None = None, on_state=None) -> dict:
    """The approach-retract curve of ``case`` on a built model and solver, with the run's checks,
    as a summary: the curve, pull_off_force [N], pull_off_delta_z [m], work_of_adhesion [J/m^2],
    tabor_parameter [-] (with the law's range), dmt_pull_off = -2 pi R w and jkr_pull_off =
    -1.5 pi R w [N] (None for a shape other than a sphere or paraboloid on a smooth flat, with a
    reference_note saying so), cell_softening [-] (``warpcontact.physics.adhesion.cell_softening``: above 2 a
    warning of lattice trapping); the results withheld when a state did not converge. The one
    builder of a pull-off summary."""
    import math

    from .approach_retract import approach_retract, tabor_parameter
    from ..records.guards import PULL_OFF_RESULTS, RunChecks, withhold_if_unconverged

    checks = RunChecks(case)
    law = solver.adhesion
    dz_max = case.load.delta_z_max
    top_seen = []

    def observe(k, total, s):
        top = not top_seen and checks.decisive(s)  # the deepest approach: the contact is largest there
        if top:
            top_seen.append(k)
        checks.observe(s, decisive=top)
        if on_state is not None:
            on_state(k, total, s)

    from ..physics.adhesion import cell_softening, trapping_warning

    trapping = trapping_warning(law, model)
    if trapping:
        import warnings

        warnings.warn(trapping, stacklevel=2)
    end = -4.0 * law.range if retract_to is None else float(retract_to)
    r = approach_retract(model, solver, -2.0 * law.range, dz_max, end, int(steps), on_state=observe,
                         extend=retract_to is None)
    from ..records.guards import warn_if_jagged_pull_off

    warn_if_jagged_pull_off(r, model.grid.n)
    R, w = case.sphere.radius, law.work_of_adhesion
    if case.sphere.hertzian:
        reference = {"tabor_parameter": tabor_parameter(case.pair, R, w, law.range),
                     "dmt_pull_off": -2.0 * math.pi * R * w, "jkr_pull_off": -1.5 * math.pi * R * w}
    else:  # the closed forms are a sphere's: no number rather than a wrong one
        reference = {"tabor_parameter": None, "dmt_pull_off": None, "jkr_pull_off": None,
                     "reference_note": f"Tabor's parameter and the DMT and JKR pull-off forces are a sphere's; "
                                       f"this case's shape is {case.sphere.description}"}
    result = {**r, "work_of_adhesion": w, **reference, "cell_softening": cell_softening(law, model)}
    return withhold_if_unconverged(result, PULL_OFF_RESULTS)


#: the lists of states a result holds; a sweep row counts them (n_states) instead
STATE_LISTS = ("states", "curve")


def result_row(result: dict) -> dict:
    """A summary as a sweep row: every key of :func:`run_gross_slip`'s, :func:`run_pull_off`'s or
    a solve's last state, less the lists of states (counted in ``n_states``) and the timing (the
    sweep records its own)."""
    from ..numerics.yielding import yield_keys

    row = {**yield_keys(None), **{k: v for k, v in result.items() if k not in STATE_LISTS and k != "elapsed_s"}}
    row["n_states"] = sum(len(result[k]) for k in STATE_LISTS if isinstance(result.get(k), list))
    return row


def gross_slip_summary(case: Case, rel_tol: float = 0.01, on_state=None, model=None) -> dict:
    """:func:`run_gross_slip` of ``case`` on a model and solver built for it (``model``: a
    :class:`~warpcontact.numerics.model.ContactModel` of the case's materials, sphere, grid, device, float
    type and FFT backend to reuse; default: a new one). ``rel_tol``: bisection bracket of
    delta_x_max, relative [-]."""
    from .runner import build

    check_gross_slip_case(case)
    model, solver, _ = build(case, model)
    return run_gross_slip(case, model, solver, rel_tol=rel_tol, on_state=on_state)


def pull_off_summary(case: Case, steps: int = 20, retract_to: float | None = None, on_state=None,
                     model=None) -> dict:
    """:func:`run_pull_off` of ``case`` on a model and solver built for it (``model`` as in
    :func:`gross_slip_summary`); ``steps`` each way, down to ``retract_to`` [m]."""
    from .runner import build

    check_pull_off_case(case, steps, retract_to)
    model, solver, _ = build(case, model)
    return run_pull_off(case, model, solver, steps=steps, retract_to=retract_to, on_state=on_state)


def run_task(task: str, rel_tol: float, case: Case, on_state, model=None) -> dict:
    """Solve one case's ``task`` (one of TASKS) and return its summary as a sweep row: a gross-slip
    or pull-off summary less its lists of states (:func:`result_row`), a fretting summary's last
    whole cycle (``studies.fretting.fretting_row``), or a solve's last state with
    ``converged``, ``n_states`` and the yield check of its last state. ``on_state(index, total or
    None, summary)`` follows its states; ``model``: as in :func:`gross_slip_summary`.
    KeyboardInterrupt propagates (a solve stopped part-way is not a summary)."""
    if task == "gross-slip":
        r = gross_slip_summary(case, rel_tol=rel_tol, on_state=lambda k, s: on_state(k, None, s), model=model)
        return result_row(r)
    if task == "pull-off":
        return result_row(pull_off_summary(case, on_state=on_state, model=model))
    if task == "fretting":
        from .fretting import fretting_row, fretting_summary

        return fretting_row(fretting_summary(case, on_state=on_state, model=model))
    from .runner import run_path

    # the row needs the summaries (reduced on the device) and the last state's yield check alone:
    # no field is kept on the host
    result = run_path(case, on_state=lambda k, total, s, res: on_state(k, total, s), model=model, fields="none")
    if result.interrupted:  # run_path keeps what finished; a sweep records whole cases only
        raise KeyboardInterrupt
    return solve_row(result)


def solve_row(result) -> dict:
    """A solved path (``PathResult``) as a sweep row: its last state with ``converged``,
    ``n_states`` and the yield check of its last state (None when not made)."""
    from ..numerics.yielding import yield_keys

    summary = dict(result.states[-1])
    summary["converged"] = result.converged
    summary["n_states"] = len(result.states)
    summary.update(yield_keys(result.yield_check))
    return summary

"""The Python API, mirroring the command line.

    import warpcontact as wc

    case = wc.load_case("examples/table2_k080_dz5e-5.toml")     # or wc.case_from_dict({...})
    result = wc.solve(case)                                     # every state of the load path
    print(result.states[-1]["force"])                           # N
    for state in wc.path(case):                                 # the same, one state at a time
        print(state["delta"]["z"], state["force"]["z"])
    gs = wc.gross_slip(case)                                    # delta_x_max [m], mu
    po = wc.pull_off(case)                                      # needs [adhesion]: pull_off_force [N]

The dicts returned are the result.json of the matching command less the run's record (device,
software, case, complete): one builder per kind of result (:func:`run_gross_slip`,
:func:`run_pull_off`), shared with the command line and the sweep rows (:func:`result_row`).

Every function takes a :class:`~warpcontact.case.Case` (SI units throughout) and optional
``device``, ``dtype`` and ``fft`` overrides; mistakes raise ``InputError`` (a ValueError) naming the
key.
"""

from __future__ import annotations

from .case import Case
from .errors import InputError


def _prepare(case: Case, device=None, dtype=None, fft=None) -> Case:
    if not isinstance(case, Case):
        raise TypeError(f"expected a warpcontact Case (see load_case / case_from_dict), got {type(case).__name__}")
    return case.with_overrides(device=device, dtype=dtype, fft=fft)


def solve(case: Case, device=None, dtype=None, fft=None, on_state=None, model=None, fields: str = "all"):
    """Solve every state of the case's load path in order.

    Returns a :class:`~warpcontact.runner.PathResult`: ``states`` (one summary dict per state:
    force [N], contact/stick/adhesive areas [m^2], max pressure [Pa], convergence) and
    ``fields`` (per state, numpy arrays (n, n) in SI units: pressure, shear_x, shear_y, gap,
    slip_x, slip_y, ..., contact_mask, stick_mask, adhesive_mask). ``fields``: whose fields are
    brought to the host and kept, every state's ("all"), the last state's ("last") or none
    ("none": the summaries alone, which are reduced on the device; on a GPU at n = 8192 a
    state's fields are about 5 GiB of host memory and most of the call's time).
    ``on_state(index, total, summary, result)`` is called after each state. ``model``: a
    :class:`~warpcontact.model.ContactModel` of the same materials, sphere, grid, device, float
    type and FFT backend to reuse (many cases of one grid: :mod:`warpcontact.batch`).
    """
    from .runner import run_path

    from .runner import FIELDS_CHOICES

    if fields not in FIELDS_CHOICES:
        raise InputError("fields", f"unknown choice {fields!r}; choose one of {', '.join(FIELDS_CHOICES)}")
    return run_path(_prepare(case, device, dtype, fft), on_state=on_state, model=model, fields=fields)


def path(case: Case, device=None, dtype=None, fft=None):
    """Iterate over the solved states of the load path: yields one summary dict per state (as in
    :func:`solve`), each as soon as it is solved; the slip history is carried along. Warns as
    :func:`solve` does (a coarse grid, a pressure above a yield strength: once each)."""
    from .guards import RunChecks
    from .results import state_summary
    from .runner import build

    case = _prepare(case, device, dtype, fft)
    _, solver, state = build(case)
    checks = RunChecks(case)
    for approach in case.load.path():
        solver.step(state, approach)
        summary = state_summary(state, solver.adhesion)
        checks.observe(summary, decisive=checks.decisive(summary))
        yield summary


def gross_slip(case: Case, device=None, dtype=None, fft=None, rel_tol: float = 0.01, on_state=None,
               model=None) -> dict:
    """delta_x at gross slip [m] and the static friction coefficient mu = F_x / F_z there.

    The case needs ``[friction]``; its final delta_z is loaded in ``load.steps`` steps, then
    delta_x rises until no cell sticks, and bisection narrows the bracket to ``rel_tol``.
    Returns the summary of :func:`run_gross_slip` (the keys of ``warpcontact gross-slip``'s
    result.json less the run's record): delta_x_max, delta_x_gross [m], mu, mu_elastic, force,
    force_elastic [N], stick_area, contact_area [m^2], converged, states, elapsed_s [s], and
    whether a body yielded at delta_x_max: yielded, yield_margin, yield_check (``stress.yield_keys``).
    ``on_state(index, summary)`` is called after each state. ``model``: as :func:`solve`'s.
    """
    from .runner import build

    case = _prepare(case, device, dtype, fft)
    check_gross_slip_case(case)
    model, solver, _ = build(case, model)
    return run_gross_slip(case, model, solver, rel_tol=rel_tol, on_state=on_state)


def pull_off(case: Case, steps: int = 20, retract_to: float | None = None, device=None, dtype=None, fft=None,
             on_state=None, model=None) -> dict:
    """Approach to the case's delta_z and retract to ``retract_to`` [m] (default: -4 ranges of the
    adhesion law), ``steps`` steps each way. The case needs ``[adhesion]``. Returns the summary of
    :func:`run_pull_off` (the keys of ``warpcontact pull-off``'s result.json less the run's
    record): pull_off_force [N] (the most tensile total F_z, negative), pull_off_delta_z [m],
    work_of_adhesion [J/m^2], tabor_parameter [-], dmt_pull_off and jkr_pull_off [N], the curve
    (summaries), converged, elapsed_s [s]. ``on_state(index, total, summary)`` after each state.
    ``model``: as :func:`solve`'s."""
    from .runner import build

    case = _prepare(case, device, dtype, fft)
    check_pull_off_case(case, steps, retract_to)
    model, solver, _ = build(case, model)
    return run_pull_off(case, model, solver, steps=steps, retract_to=retract_to, on_state=on_state)


# ---------------------------------------------------------------------------------------------
# One summary per kind of result: the command line, this API and the sweep rows use these.


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
    (:class:`~warpcontact.guards.RunChecks`: resolution and yield, one warning each), as a summary:
    find_gross_slip's result with its results withheld (None, and a ``note``) when a state did
    not converge. The one builder of a gross-slip summary."""
    from .guards import GROSS_SLIP_RESULTS, RunChecks, withhold_if_unconverged
    from .slip_search import find_gross_slip
    from .stress import state_yield_keys

    checks = RunChecks(case)

    def observe(k, s):
        checks.observe(s, decisive=s.get("kind") == "normal" and checks.decisive(s))
        if on_state is not None:
            on_state(k, s)

    steps = case.load.steps if not case.load.explicit else 4
    r = find_gross_slip(model, solver, case.load.delta_z_max, normal_steps=steps, rel_tol=rel_tol, on_state=observe,
                        at_max=state_yield_keys)
    checks.gross_slip(r)
    checks.yielded(r.get("yield_check"), f"at delta_x_max = {r['delta_x_max']:.4g} m")
    return withhold_if_unconverged(r, GROSS_SLIP_RESULTS)


def run_pull_off(case: Case, model, solver, steps: int = 20, retract_to: float | None = None, on_state=None) -> dict:
    """The approach-retract curve of ``case`` on a built model and solver, with the run's checks,
    as a summary: the curve, pull_off_force [N], pull_off_delta_z [m], work_of_adhesion [J/m^2],
    tabor_parameter [-] (with the law's range), dmt_pull_off = -2 pi R w and jkr_pull_off =
    -1.5 pi R w [N], cell_softening [-] (``warpcontact.adhesion.cell_softening``: above 2 a
    warning of lattice trapping); the results withheld when a state did not converge. The one
    builder of a pull-off summary."""
    import math

    from .approach_retract import approach_retract, tabor_parameter
    from .guards import PULL_OFF_RESULTS, RunChecks, withhold_if_unconverged

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

    from .adhesion import cell_softening, trapping_warning

    trapping = trapping_warning(law, model)
    if trapping:
        import warnings

        warnings.warn(trapping, stacklevel=2)
    end = -4.0 * law.range if retract_to is None else float(retract_to)
    r = approach_retract(model, solver, -2.0 * law.range, dz_max, end, int(steps), on_state=observe,
                         extend=retract_to is None)
    from .guards import warn_if_jagged_pull_off

    warn_if_jagged_pull_off(r, model.grid.n)
    R, w = case.sphere.radius, law.work_of_adhesion
    result = {**r, "work_of_adhesion": w, "tabor_parameter": tabor_parameter(case.pair, R, w, law.range),
              "dmt_pull_off": -2.0 * math.pi * R * w, "jkr_pull_off": -1.5 * math.pi * R * w,
              "cell_softening": cell_softening(law, model)}
    return withhold_if_unconverged(result, PULL_OFF_RESULTS)


#: the lists of states a result holds; a sweep row counts them (n_states) instead
STATE_LISTS = ("states", "curve")


def result_row(result: dict) -> dict:
    """A summary as a sweep row: every key of :func:`run_gross_slip`'s, :func:`run_pull_off`'s or
    a solve's last state, less the lists of states (counted in ``n_states``) and the timing (the
    sweep records its own)."""
    from .stress import yield_keys

    row = {**yield_keys(None), **{k: v for k, v in result.items() if k not in STATE_LISTS and k != "elapsed_s"}}
    row["n_states"] = sum(len(result[k]) for k in STATE_LISTS if isinstance(result.get(k), list))
    return row

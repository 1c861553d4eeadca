"""The Python API, mirroring the command line.

    import warpcontact as wc

    case = wc.load_case("examples/table2_k080_dz5e-5.toml")     # or wc.case_from_dict({...})
    result = wc.solve(case)                                     # every state of the load path
    print(result.states[-1]["force"])                           # N
    for state in wc.path(case):                                 # the same, one state at a time
        print(state["delta"]["z"], state["force"]["z"])
    gs = wc.gross_slip(case)                                    # delta_x_max [m], mu
    po = wc.pull_off(case)                                      # needs [adhesion]: pull_off_force [N]
    fr = wc.fretting(case)                                      # a cyclic path: energy per cycle [J]
    results = wc.solve_batch([case_a, case_b, ...])             # many cases solved together

The dicts returned are the result.json of the matching command less the run's record (device,
software, case, complete): one builder per kind of result (:func:`run_gross_slip`,
:func:`run_pull_off`, ``studies.fretting.fretting_summary``), shared with the command line and the sweep rows (:func:`result_row`).

Every function takes a case (SI units throughout): a :class:`~warpcontact.records.case.Case`, the
path of a case file or a dict of its tables; and optional ``device``, ``dtype`` and ``fft`` overrides; mistakes raise ``InputError`` (a ValueError) naming the
key.
"""

from __future__ import annotations

from .errors import InputError

# the builders of a case's task live in the studies (warpcontact.studies.tasks), where the sweeps, the fits
# and the stress study use them too; their names here are those of the Python API and the command line
from .studies.tasks import (
    STATE_LISTS,
    CaseLike,
    check_gross_slip_case,
    check_pull_off_case,
    gross_slip_summary,
    pull_off_summary,
    result_row,
    run_gross_slip,
    run_pull_off,
)
from .studies.tasks import prepare as _prepare


def solve(case: CaseLike, device=None, dtype=None, fft=None, on_state=None, model=None, fields: str = "all"):
    """Solve every state of the case's load path in order.

    Returns a [`PathResult`][warpcontact.studies.runner.PathResult]: ``states`` (one summary dict per state:
    force [N], contact/stick/adhesive areas [m^2], max pressure [Pa], convergence) and
    ``fields`` (per state, numpy arrays (n, n) in SI units: pressure, shear_x, shear_y, gap,
    slip_x, slip_y, ..., contact_mask, stick_mask, adhesive_mask). ``fields``: whose fields are
    brought to the host and kept, every state's ("all"), the last state's ("last") or none
    ("none": the summaries alone, which are reduced on the device; on a GPU at n = 8192 a
    state's fields are about 5 GiB of host memory and most of the call's time).
    ``on_state(index, total, summary, result)`` is called after each state. ``model``: a
    [`ContactModel`][warpcontact.numerics.model.ContactModel] of the same materials, sphere, grid, device, float
    type and FFT backend to reuse (many cases of one grid: `warpcontact.studies.batch`).
    """
    from .studies.runner import FIELDS_CHOICES, run_path

    if fields not in FIELDS_CHOICES:
        raise InputError("fields", f"unknown choice {fields!r}; choose one of {', '.join(FIELDS_CHOICES)}")
    return run_path(_prepare(case, device, dtype, fft), on_state=on_state, model=model, fields=fields)


def solve_batch(cases, device=None, dtype=None, fft=None, fields: str = "none", batch: int | None = None,
                on_case=None) -> list:
    """Solve many cases, together where their solves batch: one entry per case, in order, what
    [`solve`][warpcontact.solve] returns for it.

    Cases of one grid size, device and float type are solved ``batch`` at a time (default on CUDA:
    up to 256 as half the free memory allows; on the CPU one at a time unless ``batch`` is given,
    for there a batch saves the launches' overhead but not their work: docs/performance.md): each
    state of their load paths by
    one batched step whose kernels and transforms are launched once for all of them, each case
    with its own materials, law, load path and convergence: normal contact by
    [`BatchNormalSolver`][warpcontact.solvers.normal_batch.BatchNormalSolver], contact with
    friction (Coulomb or Tabor-von Mises, the hardness cap too), and with friction and the SMC law
    on the DMT side (Maugis parameter under 0.1, the paper's; its contact shear "bounded"), by
    [`BatchContactSolver`][warpcontact.solvers.contact_batch.BatchContactSolver]. Their summaries,
    fields, warnings and yield checks are made as [`solve`][warpcontact.solve] makes them (on CUDA
    the yield checks of the cases that end at a state together, every case's depths evaluated at
    once); the forces agree with it within the solves' tolerance (with adhesion, and cells that
    touch within the law's threshold, to the path's last digits: docs/limits.md). Measured on one
    H200 (Tabor friction, a normal and a tangential step, batches of 128): 290 and 132-144 cases/s
    at n = 128 and 256, 26x and 11-13x one at a time; with the SMC law too, batches of 64: 157 and
    55 cases/s, 20x and 8x (docs/performance.md).

    A case with friction whose batched step does not converge is solved again on its own (with
    what the single solver adds for hard steps): its result is then [`solve`][warpcontact.solve]'s.
    Other cases with adhesion are solved one at a time; so are cases with friction unless ``batch`` is
    given or they run on CUDA, 32 or more of one grid size (``batch_solve.FRICTION_MIN_BATCH``: on
    the CPU a batch pays on small grids only, 1.5x at n = 64 and 0.75x at 256 on 2 cores); so are
    a batch's cases where the batched solve itself fails (a device's refusal, a library's error, no CuPy on CUDA: one
    RuntimeWarning says why). Cases solved one at a time share the model (influence spectra,
    transforms) of the case before where their materials, body, grid, device and float type are
    the same. A case that fails (a contact past its domain's edge) has the exception in its place and
    the others go on; a mistake in a case's
    tables raises ``InputError`` before anything is solved. ``cases``: a list of cases as
    [`solve`][warpcontact.solve] takes them; ``device``, ``dtype``, ``fft``: overrides for all;
    ``fields``: as [`solve`][warpcontact.solve]'s (default "none": the summaries alone);
    ``on_case(index, result)`` as each case ends (in the order they end). A batched case's
    ``elapsed_s`` is its batch's time from its start to the case's end. CUDA needs CuPy (the
    ``gpu`` extra) for the batched transforms."""
    from .studies.batch_solve import solve_batch as run_batch
    from .studies.runner import FIELDS_CHOICES

    if fields not in FIELDS_CHOICES:
        raise InputError("fields", f"unknown choice {fields!r}; choose one of {', '.join(FIELDS_CHOICES)}")
    if batch is not None and (isinstance(batch, bool) or not isinstance(batch, int) or batch < 1):
        raise InputError("batch", f"must be a whole number of cases, at least 1, got {batch!r}")
    prepared = [_prepare(case, device, dtype, fft) for case in cases]
    return run_batch(prepared, fields=fields, batch=batch, on_case=on_case)


def path(case: CaseLike, device=None, dtype=None, fft=None, fields: bool = False):
    """Iterate over the solved states of the load path: yields one summary dict per state (as in
    [`solve`][warpcontact.solve]), each as soon as it is solved; the slip history is carried along. Warns as
    [`solve`][warpcontact.solve] does (a coarse grid, a pressure above a yield strength: once each).
    ``fields=True``: each summary also holds ``"fields"``, the state's fields as
    [`solve`][warpcontact.solve] keeps them (numpy arrays (n, n) in SI units), copied to the host
    state by state."""
    from .records.guards import RunChecks
    from .records.results import state_fields, state_summary
    from .studies.runner import build

    case = _prepare(case, device, dtype, fft)
    _, solver, state = build(case)
    checks = RunChecks(case)
    for approach in case.load.path():
        solver.step(state, approach)
        summary = state_summary(state, solver.adhesion)
        checks.observe(summary, decisive=checks.decisive(summary))
        if fields:
            summary["fields"] = state_fields(state, solver.adhesion, solver.friction)
        yield summary


def gross_slip(case: CaseLike, device=None, dtype=None, fft=None, rel_tol: float = 0.01, on_state=None,
               model=None) -> dict:
    """delta_x at gross slip [m] and the static friction coefficient mu = F_x / F_z there.

    The case needs ``[friction]``; its final delta_z is loaded in ``load.normal_steps`` (default
    ``load.steps``) steps, then delta_x rises until no cell sticks, and bisection narrows the
    bracket to ``rel_tol``.
    Returns the summary of `run_gross_slip` (the keys of ``warpcontact gross-slip``'s
    result.json less the run's record): delta_x_max, delta_x_gross [m], mu, mu_elastic, force,
    force_elastic [N], stick_area, contact_area [m^2], converged, states, elapsed_s [s], and
    whether a body yielded at delta_x_max: yielded, yield_margin, yield_check (``yielding.yield_keys``).
    ``on_state(index, summary)`` is called after each state. ``model``: as [`solve`][warpcontact.solve]'s.
    """
    return gross_slip_summary(_prepare(case, device, dtype, fft), rel_tol=rel_tol, on_state=on_state, model=model)


def pull_off(case: CaseLike, steps: int = 20, retract_to: float | None = None, device=None, dtype=None, fft=None,
             on_state=None, model=None) -> dict:
    """Approach to the case's delta_z and retract to ``retract_to`` [m] (default: -4 ranges of the
    adhesion law), ``steps`` steps each way. The case needs ``[adhesion]``. Returns the summary of
    `run_pull_off` (the keys of ``warpcontact pull-off``'s result.json less the run's
    record): pull_off_force [N] (the most tensile total F_z, negative), pull_off_delta_z [m],
    work_of_adhesion [J/m^2], tabor_parameter [-], dmt_pull_off and jkr_pull_off [N], the curve
    (summaries), converged, elapsed_s [s]. ``on_state(index, total, summary)`` after each state.
    ``model``: as [`solve`][warpcontact.solve]'s."""
    return pull_off_summary(_prepare(case, device, dtype, fft), steps=steps, retract_to=retract_to,
                            on_state=on_state, model=model)


def fretting(case: CaseLike, device=None, dtype=None, fft=None, on_state=None, model=None) -> dict:
    """Solve the case's cyclic path (``[load] delta_x_amplitude`` or ``delta_y_amplitude``,
    ``cycles``; the case needs ``[friction]``) and return each whole cycle's loop: the keys of
    ``warpcontact fretting``'s result.json less the run's record and the last state's quantities.
    ``cycles``: one dict per whole cycle, with energy [J] (the loop integral of F_x d(delta_x) +
    F_y d(delta_y), Simpson's rule), energy_error [J] (|Simpson - trapezoid|), force_amplitude Q*
    [N], displacement_amplitude delta* [m], energy_ratio A = W / (4 delta* Q*) [-], regime
    ("partial slip" or "gross slip": some state of the cycle has no stick cell), min_stick_area
    [m^2], normal_force_min and normal_force_max [N], converged; normal_force [N] (F_z at the end
    of the normal leg); displacement_amplitude [m]; closed_form (Mindlin and Deresiewicz's
    force_amplitude, energy, energy_ratio, regime and delta_gross [m] for this amplitude, where it
    applies: Coulomb friction, Dundurs beta = 0, no adhesion; else None and closed_form_note says
    why); states, converged, elapsed_s [s] and the last state's yield check.
    ``on_state(index, total, summary)`` after each state; ``model``: as [`solve`][warpcontact.solve]'s."""
    from .studies.fretting import fretting_summary

    return fretting_summary(_prepare(case, device, dtype, fft), on_state=on_state, model=model)

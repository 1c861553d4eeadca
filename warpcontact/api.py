"""The Python API, mirroring the command line.

    import warpcontact as wc

    case = wc.load_case("examples/table2_k080_dz5e-5.toml")     # or wc.case_from_dict({...})
    result = wc.solve(case)                                     # every state of the load path
    print(result.states[-1]["force"])                           # N
    for state in wc.path(case):                                 # the same, one state at a time
        print(state["delta"]["z"], state["force"]["z"])
    gs = wc.gross_slip(case)                                    # delta_x_max [m], mu
    po = wc.pull_off(case)                                      # needs [adhesion]: pull_off_force [N]

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


def solve(case: Case, device=None, dtype=None, fft=None, on_state=None, model=None):
    """Solve every state of the case's load path in order.

    Returns a :class:`~warpcontact.runner.PathResult`: ``states`` (one summary dict per state:
    force [N], contact/stick/adhesive areas [m^2], max pressure [Pa], convergence) and
    ``fields`` (per state, numpy arrays (n, n) in SI units: pressure, shear_x, shear_y, gap,
    slip_x, slip_y, ..., contact_mask, stick_mask, adhesive_mask).
    ``on_state(index, total, summary, result)`` is called after each state. ``model``: a
    :class:`~warpcontact.model.ContactModel` of the same materials, sphere, grid, device, float
    type and FFT backend to reuse (many cases of one grid: :mod:`warpcontact.batch`).
    """
    from .runner import run_path

    return run_path(_prepare(case, device, dtype, fft), on_state=on_state, model=model)


def path(case: Case, device=None, dtype=None, fft=None):
    """Iterate over the solved states of the load path: yields one summary dict per state (as in
    :func:`solve`), each as soon as it is solved; the slip history is carried along."""
    from .results import state_summary
    from .runner import build

    case = _prepare(case, device, dtype, fft)
    _, solver, state = build(case)
    for approach in case.load.path():
        solver.step(state, approach)
        yield state_summary(state, solver.adhesion)


def gross_slip(case: Case, device=None, dtype=None, fft=None, rel_tol: float = 0.01, on_state=None,
               model=None) -> dict:
    """delta_x at gross slip [m] and the static friction coefficient mu = F_x / F_z there.

    The case needs ``[friction]``; its final delta_z is loaded in ``load.steps`` steps, then
    delta_x rises until no cell sticks, and bisection narrows the bracket to ``rel_tol``.
    Returns delta_x_max, delta_x_gross [m], mu, force [N], converged, states. ``model``: as
    :func:`solve`'s.
    """
    from .slip_search import find_gross_slip
    from .runner import build

    case = _prepare(case, device, dtype, fft)
    if case.friction is None:
        raise InputError("friction", "gross_slip needs a [friction] table")
    model, solver, _ = build(case, model)
    steps = case.load.steps if not case.load.explicit else 4
    return find_gross_slip(model, solver, case.load.delta_z_max, normal_steps=steps, rel_tol=rel_tol, on_state=on_state)


def pull_off(case: Case, steps: int = 20, retract_to: float | None = None, device=None, dtype=None, fft=None,
             on_state=None) -> dict:
    """Approach to the case's delta_z and retract to ``retract_to`` [m] (default: -4 ranges of the
    adhesion law), ``steps`` steps each way. Returns pull_off_force [N] (the most tensile total
    F_z), its delta_z, the curve (summaries) and converged. The case needs ``[adhesion]``."""
    from .approach_retract import approach_retract
    from .runner import build

    case = _prepare(case, device, dtype, fft)
    if case.adhesion is None:
        raise InputError("adhesion", "pull_off needs an [adhesion] table")
    model, solver, _ = build(case)
    law = solver.adhesion
    end = -4.0 * law.range if retract_to is None else float(retract_to)
    return approach_retract(model, solver, -2.0 * law.range, case.load.delta_z_max, end, int(steps), on_state=on_state)

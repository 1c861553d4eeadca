"""Many cases solved together: the batched solves behind ``warpcontact.solve_batch``.

Cases of one grid size, device and float type are solved in batches of B: normal contact by
[`BatchNormalSolver`][warpcontact.solvers.normal_batch.BatchNormalSolver], contact with friction
(Coulomb or Tabor-von Mises, with or without the hardness cap), and with friction and the SMC
law where the single solver's turns are lagged (``batchable``), by
[`BatchContactSolver`][warpcontact.solvers.contact_batch.BatchContactSolver]. Their load paths
walk in step, state k of every case solved by one batched step (warm-started from each case's
state k - 1, as a path is), each case stopping when its own path ends. Each solved state then
goes through what a single path does with it ([`PathRecorder`][warpcontact.studies.runner.PathRecorder]:
the summary, the fields asked for, the checks and their warnings, the last state's yield check),
on a state of the case's own model, so a case's result is what ``warpcontact.solve`` returns for
it, up to the solves' tolerance. A case with friction whose batched step does not converge (its
turns did not settle within ``BATCH_MAX_TURNS``, or an inner solve within its limit) is solved
again on its own (``run_path``), with what the single solver adds for hard steps (mixed turns,
the nested start, the minimised turns of adhesion): its result is then its own solve's. Cases
with other adhesion (adhesion without friction, other laws, the SMC law past the DMT side or
with its shear added in the contact) are solved one at a time (``run_path``).
"""

from __future__ import annotations

import math
import time
import warnings
from collections import OrderedDict
from dataclasses import replace

import numpy as np
import warp as wp

from ..errors import InputError
from ..numerics.device import resolve_device, resolve_dtype
from ..numerics.state import ContactState, check_contact_fits
from ..solvers.base import default_tolerance
from ..fft.batch import release_transforms
from ..solvers.contact_batch import BatchContactSolver, adhesion_parameters, law_parameters
from ..solvers.normal_batch import BatchNormalSolver
from .runner import PathRecorder, adhesion_law, build_model, friction_law, pressure_cap, run_path

#: cases a batch holds at most where ``batch`` does not say: on CUDA, bounded by the device's free
#: memory too; on the CPU batched solves run only where ``batch`` asks, at its size (the CPU's
#: value bounds a group that a caller forms without it)
DEFAULT_BATCH = {"cpu": 8, "cuda": 256}
#: values a case of a batch takes per cell, at most: seven fields, the padded grid of the transform
#: and of its inverse (four values a cell each), their spectrum (about four) and the library's work
#: area; times the float type's bytes
BYTES_PER_CELL = 27
#: the same with friction: the normal solve's, 22 fields of the tangential solve and the turns,
#: eight influence spectra of the case's pair (16 values a cell), the padded grids and spectra of a
#: pair of fields and of a pressure (about 28) and the work area
FRICTION_BYTES_PER_CELL = 100
#: what adhesion adds to it: the adhesive tractions, their displacements and a scratch field (7
#: fields), their mixing's residual, last residual and iterate (9) and its history of 5
#: differences of both (30)
ADHESION_BYTES_PER_CELL = 46
#: turns of a batched step with friction; a case whose turns have not settled by then is solved on
#: its own, where stalled turns are mixed (the Table 2 cells at n = 128 took 2-12 turns a step)
BATCH_MAX_TURNS = 60
#: cases with friction of one grid size are batched, where ``batch`` does not ask for it, on CUDA
#: and from this many on (``friction_batched``): the batch pays where many cases share the device
#: (one H200, a normal and a tangential step, batches of 128: 21x one case at a time at n = 128,
#: 8.5x at 256), and few searches only on small grids (``FEW_SEARCHES_MAX_N``). On the CPU never
#: by default: on 2 cores 16 cases batched took 1.5x one case at a time's rate at n = 64, 0.95x
#: at 128 and 0.75x at 256 (docs/performance.md, "Many cases with friction solved together")
FRICTION_MIN_BATCH = 32
#: fewer gross-slip searches than ``FRICTION_MIN_BATCH`` pay batched on CUDA on small grids: a Table 2
#: column's 12 cells (``warpcontact table2``'s default, ``few_searches_batched``), one H200, whole
#: processes, two runs each: n = 128 3.6-3.9 s batched against 5.9-6.3 s one at a time, n = 256
#: 5.7-6.8 s against 7.0-8.7 s, n = 512 14.1-14.9 s against 9.9 s (docs/performance.md)
FEW_SEARCHES_MAX_N = 256


def normal_batched(is_cuda: bool, batch: int | None) -> bool:
    """Whether cases of normal contact of one grid size are solved by batched solves: where
    ``batch`` asks (not 0), else on CUDA. On the CPU not by default: there a batch saves the
    launches' overhead but not their work, and its passes go over every case of the batch until
    the last has converged (2 CPU cores, 32 Hertz cases at n = 256: their solves 2.3-3.6 s batched by
    8 or 32 against 1.3-2.1 s one at a time; docs/performance.md, "Many cases of normal contact
    solved together")."""
    if batch is not None:
        return batch > 0
    return is_cuda


def friction_batched(count: int, is_cuda: bool, batch: int | None) -> bool:
    """Whether ``count`` cases with friction of one grid size are solved by batched steps: where
    ``batch`` asks (not 0), else on CUDA from ``FRICTION_MIN_BATCH`` cases on."""
    if batch is not None:
        return batch > 0
    return is_cuda and count >= FRICTION_MIN_BATCH


def few_searches_batched(n: int, device) -> bool:
    """Whether a few gross-slip searches (fewer than ``FRICTION_MIN_BATCH``) of n cells per side
    are batched where nothing asks: on CUDA up to ``FEW_SEARCHES_MAX_N``."""
    return resolve_device(device).is_cuda and n <= FEW_SEARCHES_MAX_N


def batchable(case) -> bool:
    """Whether a case's states are solved by a batched solve: normal contact, contact with
    friction, and contact with friction and an adhesion law that ``lagged_smc`` admits."""
    if case.adhesion is None:
        return True
    return case.friction is not None and lagged_smc(adhesion_law(case), case.sphere.radius, case.pair.E_star,
                                                    math.isfinite(pressure_cap(case)))


def lagged_smc(adhesion, radius: float, e_star: float, capped: bool) -> bool:
    """Whether the batched turns carry an adhesion law (with friction): the SMC law, its contact
    shear "bounded", where the single solver's turns are lagged (``ContactSolver.turns``: a
    hardness cap (``capped``), or the DMT side of the law's Maugis parameter on a sphere of
    ``radius`` [m] and a pair of ``e_star`` [Pa])."""
    from ..physics.adhesion import SMC
    from ..solvers.contact import turns_of

    if not isinstance(adhesion, SMC) or adhesion.contact_shear != "bounded":
        return False
    return capped or turns_of(adhesion, radius, e_star) == "lagged"


def batch_size(n: int, device, dtype, cases: int, batch: int | None = None, friction: bool = False,
               adhesion: bool = False) -> int:
    """B for ``cases`` cases of an n x n grid: ``batch`` if given, else the device's default
    (``DEFAULT_BATCH``), on CUDA at most what half its free memory holds (``friction``: cases
    with friction, ``adhesion``: with adhesion too, which hold more a cell)."""
    if batch is not None:
        return max(1, min(int(batch), cases))
    device = wp.get_device(device)
    size = DEFAULT_BATCH["cpu" if device.is_cpu else "cuda"]
    if device.is_cuda:
        per_cell = (FRICTION_BYTES_PER_CELL + ADHESION_BYTES_PER_CELL * adhesion) if friction else BYTES_PER_CELL
        per_case = per_cell * n * n * (8 if dtype == wp.float64 else 4)
        size = min(size, max(1, int(0.5 * device.free_memory // per_case)))
    return max(1, min(size, cases))


def solve_batch(cases: list, fields: str = "none", batch: int | None = None, on_case=None) -> list:
    """Solve every state of each case's load path (prepared cases: ``studies.tasks.prepare``).

    Returns one entry per case, in order: a [`PathResult`][warpcontact.studies.runner.PathResult],
    or the exception the case raised (an ``InputError`` for a contact past the domain's edge),
    so that one case's failure leaves the others' results. ``fields``: as ``run_path``'s.
    ``batch``: cases per batched solve (default: ``batch_size``). ``on_case(index, result)`` is
    called as each case ends; an error it raises ends the solve and is raised as it was."""
    return _callers_raised(lambda: _solve_all(cases, fields, batch, on_case))


class _CallerError(Exception):
    """An error raised by a batched call's ``on_case`` (a caller's write that failed, say), carried
    past the batched solve's fallback to one case at a time."""

    def __init__(self, error: Exception):
        super().__init__(str(error))
        self.error = error


def _callers_raised(run):
    """``run()``, an error of the caller's ``on_case`` raised as it was (``_CallerError``)."""
    try:
        return run()
    except _CallerError as e:  # on_case's own error, not the batch's
        raise e.error from None


class _Outcomes:
    """The entry of each case of a batched call, those ended, and the caller's ``on_case(index,
    entry)`` as each ends (its error carried as ``_CallerError``)."""

    def __init__(self, count: int, on_case):
        self.results: list = [None] * count
        self.ended: set = set()
        self.on_case = on_case

    def done(self, index: int, entry) -> None:
        self.results[index] = entry
        self.ended.add(index)
        if self.on_case is not None:
            try:
                self.on_case(index, entry)
            except Exception as e:  # noqa: BLE001 - the caller's, raised by the call as it was
                raise _CallerError(e) from e


def _solve_all(cases: list, fields: str, batch: int | None, on_case) -> list:
    outcomes = _Outcomes(len(cases), on_case)
    done, results, ended = outcomes.done, outcomes.results, outcomes.ended

    kept: dict = {}  # the model of the last case solved on its own, for the next one on the same

    def alone(index):  # one case as solve solves it, on the model of the one before where it is the same
        case = cases[index]
        try:
            key = (_model_key(case, index), str(resolve_device(case.solver.device)), case.solver.dtype)
            model = kept.get(key)
            if model is None:
                kept.clear()  # (its memory first)
                model = kept[key] = build_model(case)
            result = run_path(case, fields=fields, model=model)
        except Exception as e:  # noqa: BLE001 (the case's failure is its result)
            result = e
        done(index, result)

    groups: OrderedDict = OrderedDict()
    for index, case in enumerate(cases):
        s = case.solver
        if not batchable(case):
            alone(index)
            continue
        key = (case.grid.n, str(resolve_device(s.device)), s.dtype, case.friction is not None, case.adhesion is not None)
        groups.setdefault(key, []).append(index)
    for (n, device, dtype, friction, adhesion), indices in groups.items():
        is_cuda = wp.get_device(device).is_cuda
        if not (friction_batched(len(indices), is_cuda, batch) if friction else normal_batched(is_cuda, batch)):
            for index in indices:
                alone(index)
            continue
        kept.clear()  # (the device's memory for the batch)
        try:
            size = batch_size(n, device, resolve_dtype(dtype), len(indices), batch, friction, adhesion)
            kind = BatchContactSolver if friction else BatchNormalSolver
            solver = kind(n, size, device, resolve_dtype(dtype))
            for start in range(0, len(indices), size):
                chunk = indices[start:start + size]
                for index, result in _solve_chunk(solver, [cases[i] for i in chunk], chunk, fields):
                    done(index, result)
            solver = None  # its buffers and the transforms' work areas, for what comes next
            release_transforms(device)
        except _CallerError:
            raise
        except (RuntimeError, MemoryError, OSError, InputError) as e:  # the batched solve itself failed (a
            # device's refusal, a library's error or absence: no CuPy on CUDA): the cases it had not
            # ended are solved one at a time, each as solve solves it (its own error in its place)
            left = [i for i in indices if i not in ended]
            warnings.warn(f"the batched solve of {len(left)} case(s) at n = {n} on {device} failed "
                          f"({type(e).__name__}: {e}); they are solved one at a time", RuntimeWarning, stacklevel=3)
            for index in left:
                alone(index)
    return results


def _normal(solver):
    """The batched normal solver of a batch's solver (itself without friction)."""
    return solver.normal if isinstance(solver, BatchContactSolver) else solver


def _rows_fields(solver) -> dict:
    """The state's fields by name, and the batch's arrays that hold them (one row a case)."""
    normal = _normal(solver)
    out = {"pressure": normal.pressure, "gap": normal.gap, "disp_z": normal.displacement}
    if isinstance(solver, BatchContactSolver):
        s = solver
        out.update(shear_x=s.shear[0], shear_y=s.shear[1], status=s.status, disp_x=s.disp[0], disp_y=s.disp[1],
                   slip_x=s.slip[0], slip_y=s.slip[1])
        if s.adhesion is not None:
            a = s.adhesion
            out.update(adhesive_pressure=a.pressure, adhesive_shear_x=a.shear[0], adhesive_shear_y=a.shear[1])
    return out


class _RowSummaries:
    """The summaries' sums of every row of a batch's solver, ``kernels/summary.py``'s slots: one
    launch (``batch_summary_sums``) and one read a step, where each case's own summary and edge
    check would launch and read for each row."""

    def __init__(self, solver, members: list):
        from warpcontact.kernels import summary as sk

        from ..records.results import summary_buffers

        normal = _normal(solver)
        self.kernel, self.launches = sk.batch_summary_sums, normal.launches
        self.sums, self.start = summary_buffers(normal.device, normal.batch)
        if normal is solver:  # without friction: no shear (the pressure stands in, unread) and no status
            shear, status = (normal.pressure, normal.pressure), wp.zeros((1, 1), dtype=wp.int32, device=normal.device)
        else:
            shear, status = (solver.shear[0], solver.shear[1]), solver.status
        adhesion = getattr(solver, "adhesion", None)
        scale, reach = np.zeros(normal.batch), np.zeros(normal.batch)  # each row's dx [m] and law's range [m]
        for m in members:
            if m.adhesion is not None:
                scale[m.row], reach[m.row] = m.model.length_scale, m.adhesion.range
        adhesive = (adhesion.pressure, adhesion.shear[0], adhesion.shear[1]) if adhesion is not None else (normal.pressure,) * 3
        self.inputs = [normal.pressure, *shear, normal.gap, status, *adhesive,
                       wp.array(scale, dtype=wp.float64, device=normal.device),
                       wp.array(reach, dtype=wp.float64, device=normal.device), int(normal is not solver),
                       int(adhesion is not None), normal.n, normal.n]

    def __call__(self) -> np.ndarray:
        """(B, N_SUMMARY) float64 on the host: each row's sums, as ``results.summary_sums``'s."""
        wp.copy(self.sums, self.start)
        self.launches.reduce(self.kernel, self.inputs, [self.sums])
        return self.sums.numpy().copy()  # a copy: on the CPU numpy() is a view of the buffer


def _solve_chunk(solver, cases: list, indices: list, fields: str):
    """Walk the paths of ``cases`` (at most the solver's B) in step; yields (index, result) as
    each case ends."""
    t0 = time.perf_counter()
    models: dict = {}
    members = []
    for row, case in enumerate(cases):
        key = _model_key(case, row)
        if key not in models:  # cases of one body and grid share a model (a sweep over loads)
            models[key] = build_model(case)
        model = models[key]
        members.append(_Member(row, indices[row], case, model, fields))
    friction = _normal(solver) is not solver
    rows = len(members)
    tol, max_iter, max_turns = _load_rows(solver, members)
    arrays, summaries = _rows_fields(solver), _RowSummaries(solver, members)
    for k in range(max(len(m.path) for m in members)):
        running = [m for m in members if m.error is None and not m.alone and k < len(m.path)]
        if not running:
            break
        approach = np.zeros((rows, 3))
        active = np.zeros(rows, dtype=bool)
        for m in running:
            approach[m.row] = np.asarray(m.path[k], dtype=np.float64) / m.model.length_scale
            active[m.row] = True
        if friction:
            infos = solver.step(approach, tol, 100 * tol, max_iter, max_turns, active)
        else:
            infos = solver.solve(approach[:, 2], tol, max_iter, active=active)
        sums = summaries()
        for m in running:
            if friction and not infos[m.row].converged:  # solved again on its own (module docstring)
                m.alone = True
                continue
            m.record(arrays, k, infos[m.row], sums[m.row])
        ended = [m for m in running if m.error is None and not m.alone and k == len(m.path) - 1]
        checks = _yield_checks(ended, arrays)
        for m in running:
            if m.alone:
                continue
            if m.error is not None or k == len(m.path) - 1:
                yield m.index, m.finish(time.perf_counter() - t0, checks.get(m.row))
    for m in members:
        if m.alone:
            try:
                result = run_path(m.case, fields=fields)
            except Exception as e:  # noqa: BLE001 (the case's failure is its result)
                result = e
            yield m.index, result


def _load_rows(solver, members) -> tuple:
    """A chunk's start: each member's initial gap in its row, the rows' tractions (and with
    friction statuses and slip) zeroed, with friction each row's pair, law and pressure cap (the
    members' ``row``, ``model``, ``law``, ``cap``); returns each row's tolerance and iteration
    limit, and the chunk's turn limit (from the members' ``tol``, ``max_iter``, ``max_turns``)."""
    normal = _normal(solver)
    normal.pressure.zero_()
    for m in members:
        wp.copy(normal.initial_gap, m.model.initial_gap.flatten(), dest_offset=m.row * normal.n_cells)
    if normal is not solver:
        solver.set_cases([m.model.pair for m in members],
                         [law_parameters(m.law, m.model.traction_scale) for m in members], [m.cap for m in members],
                         [adhesion_parameters(m.adhesion, m.model) for m in members])
        solver.clear()
    tol = np.array([m.tol or default_tolerance(normal.dtype) for m in members])
    max_iter = np.array([m.max_iter for m in members])
    return tol, max_iter, min(BATCH_MAX_TURNS, *(m.max_turns for m in members))


def _copy_row(arrays: dict, row: int, state) -> None:
    """A row's fields (``arrays``: name -> the batch's array, ``_rows_fields``) into ``state``."""
    for name, source in arrays.items():
        cells = source.shape[1]
        wp.copy(getattr(state, name).flatten(), source, src_offset=row * cells, count=cells)


def _yield_checks(ended: list, arrays: dict) -> dict:
    """{row: yield check} of the cases whose paths ended at this state, made together where
    ``yielding.checks_by_planes`` says (CUDA, a plane that fits a chunk: a few launches for them
    all, where each case's own check launches hundreds: ``_Member.checked_together``), from their
    rows of the batch's ``arrays`` (``_rows_fields``) gathered on the device, the adhesive
    tractions added where the batch has them (the totals the check of one state takes,
    ``yielding._state_totals``); elsewhere none: each case checks its own state at ``finish`` (on
    2 CPU cores 3 cases at n = 256 took 2.4 s one at a time, 4.6 s batched). Should the
    evaluation together fail, the rows are copied into the cases' states for their own checks."""
    from warpcontact.kernels import grids as gk

    from ..numerics.yielding import stacked_yield_checks

    ended = [m for m in ended if m.checked_together]  # (``checks_by_planes``)
    if not ended:
        return {}
    model = ended[0].model
    friction = ended[0].case.friction is not None  # (a batch's cases all have friction, or none has)
    # each case's contact radius from its last summary: the count the check would read it for
    radii = [m.recorder.result.states[-1]["contact_radius"] for m in ended]
    names = ("pressure", "shear_x", "shear_y") if friction else ("pressure",)
    # a batch with adhesion has friction (``batchable``); its rows without adhesion hold zeros there
    adhesive = ("adhesive_pressure", "adhesive_shear_x", "adhesive_shear_y") if "adhesive_pressure" in arrays else ()
    try:
        n_cells = model.n_cells
        stack = wp.zeros((3 * len(ended), model.grid.n, model.grid.n), dtype=model.dtype, device=model.device)
        rows = wp.array(np.array([m.row for m in ended], dtype=np.int32), dtype=wp.int32, device=model.device)
        flat = stack.reshape((3 * len(ended), n_cells))
        for accumulate, layers in ((0, names), (1, adhesive)):
            for layer, name in enumerate(layers):
                wp.launch(gk.gather_rows, dim=(len(ended), n_cells), inputs=[arrays[name], rows, layer, 3, accumulate],
                          outputs=[flat], device=model.device)
        loaded = [(True, friction, friction)] * len(ended)
        checks = stacked_yield_checks([m.model.pair for m in ended], [m.model.grid for m in ended], stack, loaded,
                                      radii)
    except Exception:  # noqa: BLE001 - each case's own check at ``finish``, from its state
        for m in ended:
            m.copy_fields(arrays)
        return {}
    return {m.row: check for m, check in zip(ended, checks)}


def _model_key(case, row: int):
    """What makes two cases' models the same (materials, body, grid, FFT backend); a body that
    does not hash (a height map's array) gets a model of its own."""
    key = (case.pair, case.sphere, case.grid, case.solver.fft)
    try:
        hash(key)
    except TypeError:
        return ("own", row)
    return key


class _Member:
    """One case of a batch: its state on its model and what its path keeps."""

    def __init__(self, row: int, index: int, case, model, fields: str):
        from ..numerics.yielding import checks_by_planes

        self.row, self.index, self.case, self.model = row, index, case, model
        self.path = case.load.path()
        self.state = ContactState(model)
        #: its shear-limit law (None without friction), its adhesion law (or None), its pressure cap
        #: / E* and its solves' settings
        self.law, self.adhesion = friction_law(case), adhesion_law(case)
        self.cap = pressure_cap(case) / model.traction_scale
        self.tol, self.max_iter, self.max_turns = case.solver.tol, case.solver.max_iter, case.solver.max_turns
        self.recorder = PathRecorder(case, model, fields, adhesion=self.adhesion, friction=self.law)
        self.error: Exception | None = None
        #: its batched step did not converge: the case is solved again on its own
        self.alone = False
        self.warnings: list[str] = []  # the messages of the warnings its checks gave
        #: its last state's yield check is made with the other cases', from the batch's rows
        #: (``_yield_checks``): the rows need not be copied into its state for it
        self.checked_together = checks_by_planes(model)

    def copy_fields(self, arrays: dict):
        """This case's row of the batch's ``arrays`` (name -> the batch's array, ``_rows_fields``)
        into its state."""
        _copy_row(arrays, self.row, self.state)

    def _issued(self, caught):
        """Keep the messages of the warnings ``caught`` and issue them again (for the caller)."""
        for w in caught:
            self.warnings.append(str(w.message))
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)

    def record(self, arrays: dict, k: int, info, sums: np.ndarray):
        """State ``k`` from the batch's row, recorded from its summary's ``sums`` (its row of
        ``_RowSummaries``). The row's fields (``arrays``: name -> the batch's array,
        ``_rows_fields``) are copied into this case's state where something reads them: fields
        kept, the path's last state where its yield check is its own, a body that is not a sphere
        (its patches are counted on the host)."""
        from warpcontact.kernels.summary import S_EDGE_CONTACT

        state = self.state
        if (self.recorder.fields != "none" or not self.model.sphere.hertzian or self.adhesion is not None
                or (k == len(self.path) - 1 and not self.checked_together)):
            self.copy_fields(arrays)
        state.approach = tuple(float(a) for a in self.path[k])
        # a step of normal contact is one turn, as a path counts it
        state.info = info if info.outer_iterations else replace(info, outer_iterations=1)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                check_contact_fits(state, edge_contact=sums[S_EDGE_CONTACT])
                self.recorder.record(k, state, sums)
            except Exception as e:  # noqa: BLE001 (the case's failure is its result)
                self.error = e
        self._issued(caught)

    def finish(self, elapsed: float, check: dict | None = None):
        """This case's result (or its error) once its path has ended; ``check``: its yield check,
        made with other cases' (``_yield_checks``), else made here."""
        if self.error is not None:
            return self.error
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            self.recorder.finish(self.state, check)
        self._issued(caught)
        result = self.recorder.result
        result.elapsed_s = elapsed
        result.warnings = list(dict.fromkeys(self.warnings))
        return result


def gross_slip_batch(cases: list, rel_tol: float = 0.01, batch: int | None = None, on_case=None) -> list:
    """The gross-slip search of each case (prepared cases with ``[friction]``), the searches of
    cases without adhesion of one grid size, device and float type walking together
    (:func:`search_batch`). Returns one entry per case, in order: (summary, warnings), the summary
    what ``tasks.gross_slip_summary`` returns for it (the same checks; the forces within the
    solves' tolerance) and the messages of the warnings its checks gave, or the exception the case
    raised. Cases with adhesion are searched on their own, and so are groups that
    ``friction_batched`` leaves alone. ``on_case(index, entry)`` as each case ends."""
    from .tasks import check_gross_slip_case, gross_slip_search, gross_slip_summary

    entries = []
    for index, case in enumerate(cases):
        s = case.solver
        if case.friction is None or not batchable(case):
            entries.append(SearchEntry(alone=lambda c=case: gross_slip_summary(c, rel_tol=rel_tol)))
            continue
        try:
            check_gross_slip_case(case)
        except InputError:  # (the search on its own raises it: the case's error in its place)
            entries.append(SearchEntry(alone=lambda c=case: gross_slip_summary(c, rel_tol=rel_tol)))
            continue

        def start(model, case=case):
            law = friction_law(case)
            search, finish = gross_slip_search(case, model, law, adhesion_law(case), rel_tol)
            return search, finish, law, pressure_cap(case) / model.traction_scale

        entries.append(SearchEntry(alone=lambda c=case: gross_slip_summary(c, rel_tol=rel_tol), start=start,
                                   model_key=_model_key(case, index), build=lambda c=case: build_model(c),
                                   tol=s.tol, max_iter=s.max_iter, max_turns=s.max_turns,
                                   adhesive=case.adhesion is not None))
    return search_batch(entries, batch, on_case)


class SearchEntry:
    """One gross-slip search for :func:`search_batch`.

    Args:
        alone: runs the search on its own and returns its summary (a case that is not batched, or
            whose batched step did not converge).
        start: ``start(model)`` -> (``GrossSlipSearch``, finish, friction law, pressure cap / E*)
            on the search's model: ``finish(result)`` makes its summary; None: not batched.
        model_key: what makes two searches' models the same (they share one); build: makes it.
        tol, max_iter, max_turns: its solves' settings (tol None: the float type's default).
        adhesive: whether its search has adhesion (its batch holds more a case).
    """

    def __init__(self, alone, start=None, model_key=None, build=None, tol=None, max_iter=None, max_turns=None,
                 adhesive: bool = False):
        from ..solvers.settings import SolverSettings

        defaults = SolverSettings()
        self.alone, self.start, self.model_key, self.build = alone, start, model_key, build
        self.adhesive = bool(adhesive)
        self.tol = tol
        self.max_iter = defaults.max_iter if max_iter is None else max_iter
        self.max_turns = defaults.max_turns if max_turns is None else max_turns


def search_batch(entries: list, batch: int | None = None, on_case=None) -> list:
    """Run gross-slip searches (``SearchEntry``), those with a ``start`` of one grid size, device
    and float type together (where ``friction_batched`` says: ``batch``, else on CUDA from
    ``FRICTION_MIN_BATCH`` searches on): at each batched step every search's next state (its own approach,
    from its own last stick state in the bisection) is solved by one ``BatchContactSolver.step``.
    Returns one entry per search, in order: (summary, warnings) or the exception it raised. A
    search whose batched step does not converge is run again on its own (``alone``), where hard
    steps have the single solver's help. ``on_case(index, entry)`` as each ends."""
    return _callers_raised(lambda: _search_all(entries, batch, on_case))


def _search_all(entries: list, batch: int | None, on_case) -> list:
    outcomes = _Outcomes(len(entries), on_case)
    done, results, ended = outcomes.done, outcomes.results, outcomes.ended

    def alone(index):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                entry = (entries[index].alone(), _messages(caught))
            except Exception as e:  # noqa: BLE001 (the case's failure is its result)
                entry = e
        done(index, entry)

    models: dict = {}
    groups: OrderedDict = OrderedDict()
    for index, entry in enumerate(entries):
        if entry.start is None:
            alone(index)
            continue
        try:
            model = models.get(entry.model_key)
            if model is None:
                model = models[entry.model_key] = entry.build()
        except Exception as e:  # noqa: BLE001 (the case's failure is its result)
            done(index, e)
            continue
        groups.setdefault((model.grid.n, str(model.device), model.dtype_name, entry.adhesive), []).append((index, model))
    for (n, device, dtype, adhesive), members in groups.items():
        if not friction_batched(len(members), wp.get_device(device).is_cuda, batch):
            for index, _ in members:
                alone(index)
            continue
        try:
            size = batch_size(n, device, resolve_dtype(dtype), len(members), batch, friction=True, adhesion=adhesive)
            solver = BatchContactSolver(n, size, device, resolve_dtype(dtype))
            for first in range(0, len(members), size):
                chunk = members[first:first + size]
                searches = [_Search(row, index, entries[index], model) for row, (index, model) in enumerate(chunk)]
                for index, entry in _search_chunk(solver, searches):
                    if entry is None:
                        alone(index)
                    else:
                        done(index, entry)
            solver = None
            release_transforms(device)
        except _CallerError:
            raise
        except (RuntimeError, MemoryError, OSError, InputError) as e:  # the batched steps themselves failed
            # (as _solve_all's): the searches not ended run on their own, each with its own failure
            left = [index for index, _ in members if index not in ended]
            warnings.warn(f"the batched gross-slip searches of {len(left)} case(s) at n = {n} on {device} failed "
                          f"({type(e).__name__}: {e}); they are run one at a time", RuntimeWarning, stacklevel=2)
            for index in left:
                alone(index)
    return results


def _messages(caught) -> list:
    return list(dict.fromkeys(str(w.message) for w in caught))


class _Search:
    """One search of a batch: its model, states, checks and the warnings they gave."""

    def __init__(self, row: int, index: int, entry: SearchEntry, model):
        self.row, self.index, self.entry, self.model = row, index, entry, model
        self.warnings: list = []
        self.state, self.last_stick = ContactState(model), ContactState(model)
        self.search, self.finish, self.law, self.cap = self.checked(lambda: entry.start(model))
        self.adhesion = self.search.adhesion
        self.tol, self.max_iter, self.max_turns = entry.tol, entry.max_iter, entry.max_turns

    def checked(self, work):
        """``work()`` with the warnings it gives kept as this search's."""
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                return work()
            finally:
                self.warnings += _messages(caught)


def _search_chunk(solver: BatchContactSolver, members: list):
    """Walk the searches ``members`` (at most the solver's B) in step; yields (index, entry) as
    each ends, entry None for a search to run again on its own."""
    rows = len(members)
    tol, max_iter, max_turns = _load_rows(solver, members)
    arrays = _rows_fields(solver)
    pending = list(members)
    while pending:
        approach = np.zeros((rows, 3))
        active, restore = np.zeros(rows, dtype=bool), np.zeros(rows, dtype=bool)
        for m in list(pending):
            try:
                step = m.checked(m.search.next)
                if step is None:
                    pending.remove(m)
                    yield m.index, (m.checked(lambda: m.finish(m.search.result(m.last_stick))), m.warnings)
                    continue
            except Exception as e:  # noqa: BLE001 (the case's failure is its result)
                pending.remove(m)
                yield m.index, e
                continue
            approach[m.row] = np.asarray(step[0], dtype=np.float64) / m.model.length_scale
            active[m.row], restore[m.row] = True, step[1]
        if not active.any():
            break
        if restore.any():
            solver.restore(restore)
        infos = solver.step(approach, tol, 100 * tol, max_iter, max_turns, active)
        keep = np.zeros(rows, dtype=bool)
        for m in [m for m in pending if active[m.row]]:
            info = infos[m.row]
            if not info.converged:  # run again on its own, where hard steps have more help
                pending.remove(m)
                yield m.index, None
                continue
            _copy_row(arrays, m.row, m.state)
            m.state.approach = tuple(a * m.model.length_scale for a in approach[m.row])
            m.state.info = info
            try:
                check_contact_fits(m.state)  # a contact past the domain's edge: the case's error
                if m.checked(lambda: m.search.record(m.state, info)):
                    keep[m.row] = True
                    m.last_stick.copy_from(m.state)
            except Exception as e:  # noqa: BLE001 (the case's failure is its result)
                pending.remove(m)
                yield m.index, e
        if keep.any():
            solver.keep(keep)

"""Displacement-driven normal contact against Hertz (MODEL.md section 8)."""

import math

import numpy as np
import pytest
import warp as wp

from conftest import NEEDS_FFTW

from warpcontact.physics.geometry import Grid, Sphere
from warpcontact.physics.materials import PAPER_PAIR
from warpcontact.numerics.model import ContactModel
from warpcontact.physics.reference import hertz
from warpcontact.solvers import NormalSolver
from warpcontact.numerics.state import ContactState

R = 10e-6
DELTA_Z = 1.0e-10
A = math.sqrt(R * DELTA_Z)


def count_convolutions(model):
    """Count the calls of ``model.operator.normal`` (K p) from now on, in the list it returns
    (one entry; calls, not executions: a CUDA graph's replay makes none)."""
    calls = [0]
    apply = model.operator.normal

    def counted(*args, **kw):
        calls[0] += 1
        return apply(*args, **kw)

    model.operator.normal = counted
    return calls


def solve_hertz(n, device="cpu", dtype="float64", fft="auto", profile="paraboloid"):
    model = ContactModel(PAPER_PAIR, Sphere(R, profile), Grid(n, 4 * A), device=device, dtype=dtype, fft=fft)
    state = ContactState(model)
    info = NormalSolver(model).solve(state, DELTA_Z)
    p = state.to_numpy_si()["pressure"]
    dA = model.grid.cell_area
    ref = hertz(PAPER_PAIR, R, DELTA_Z)
    radius = math.sqrt((p > 0).sum() * dA / math.pi)
    return {
        "info": info,
        "force_err": p.sum() * dA / ref["force"] - 1.0,
        "p0_err": p.max() / ref["p0"] - 1.0,
        "radius_err_cells": (radius - ref["a"]) / model.grid.dx,
    }


def test_hertz_256(device):
    """F_z and p0 within 0.5 %, contact radius within one cell, relative residual under 1e-10."""
    r = solve_hertz(256, device)
    assert r["info"].converged and r["info"].residual < 1e-10, r["info"]
    assert abs(r["force_err"]) < 5e-3, f"F_z off Hertz by {r['force_err']:.2e}"
    assert abs(r["p0_err"]) < 5e-3, f"p0 off Hertz by {r['p0_err']:.2e}"
    assert abs(r["radius_err_cells"]) < 1.0, f"contact radius off by {r['radius_err_cells']:.2f} cells"


def test_hertz_errors_fall_with_grid_refinement():
    """Discretisation errors of F_z and p0 fall as the grid is refined (32 -> 64 -> 128 cells)."""
    errs = [solve_hertz(n) for n in (32, 64, 128)]
    f = [abs(e["force_err"]) for e in errs]
    p = [abs(e["p0_err"]) for e in errs]
    assert f[0] > f[1] > f[2], f"F_z errors {f}"
    assert p[0] > p[1] > p[2], f"p0 errors {p}"
    # the piecewise-constant discretisation converges at least linearly in the cell size
    assert f[2] < 0.5 * f[0] and p[2] < 0.5 * p[0]


def test_hertz_exact_sphere_matches_paraboloid():
    """At a / R = 3e-3 the exact sphere and the paraboloid differ by O((a/R)^2): invisible here."""
    a = solve_hertz(64, profile="sphere")
    b = solve_hertz(64, profile="paraboloid")
    assert abs(a["force_err"] - b["force_err"]) < 1e-4


@pytest.mark.parametrize("n", [63, 64])
def test_float32_close_to_float64(n, device):
    """float32 meets Hertz as well as float64 does, to its rounding: within 1e-4 of the float64
    force (the float32 residual floor is about 1e-6, times the conditioning of the sums)."""
    r64 = solve_hertz(n, device, "float64")
    r32 = solve_hertz(n, device, "float32")
    assert r32["info"].converged, r32["info"]
    assert abs(r32["force_err"] - r64["force_err"]) < 1e-4
    assert abs(r32["p0_err"] - r64["p0_err"]) < 1e-3


def test_first_guess_is_hertz(device):
    """The first guess from rest (``max_iter = 0``: the solve returns it) is c sqrt(max(b - b_max / 2,
    0)) with the least-squares c, computed here on the host from the same operator, and for the
    paraboloid it is Hertz's pressure to within the grid's own error: contact radius within half
    a cell, F_z and p0 within 0.1 % at n = 128 (measured 2.2e-4 and 5.0e-4; the converged solve's
    F_z error there is about 7e-5, the README's validation table)."""
    n = 128
    model = ContactModel(PAPER_PAIR, Sphere(R, "paraboloid"), Grid(n, 4 * A), device=device)
    state = ContactState(model)
    info = NormalSolver(model, max_iter=0).solve(state, DELTA_Z)
    assert info.iterations == 0
    interference = np.maximum(DELTA_Z / model.length_scale - model.initial_gap.numpy(), 0.0)
    shape = np.sqrt(np.maximum(interference - 0.5 * interference.max(), 0.0))
    response = model.field()
    model.operator.normal(model.field(shape), response)
    ks, support = response.numpy(), shape > 0
    c = (ks[support] * interference[support]).sum() / (ks[support] ** 2).sum()
    got = state.pressure.numpy()
    assert np.abs(got - c * shape).max() < 1e-12 * np.abs(c * shape).max()
    p = state.to_numpy_si()["pressure"]
    ref = hertz(PAPER_PAIR, R, DELTA_Z)
    dA = model.grid.cell_area
    assert abs(p.sum() * dA / ref["force"] - 1) < 1e-3
    assert abs(p.max() / ref["p0"] - 1) < 1e-3
    assert abs(math.sqrt(support.sum() * dA / math.pi) - ref["a"]) < 0.5 * model.grid.dx


@pytest.mark.parametrize("cap_over_p0", [math.inf, 0.8])
def test_first_exact_gap_from_the_guess_is_the_convolved_one(device, cap_over_p0):
    """A solve from rest takes K p of its first guess p = c s as c K s, from the convolution that
    fitted c, instead of convolving p again; with a cap the guess reaches (0.8 p0), p is not c s
    and it convolves p. The residual of the guess the solve records first (``history[0]``, from
    that gap) must equal the one of a solve stopped at the guess (``max_iter = 0``), made exact
    by a convolution of p at its end. They differ by rounding only (c K s against K (c s);
    measured 1.7e-14 of the residual, 9e-4, at n = 64), so 1e-12 is a bound with room; the capped
    guess's gap taken as c K s would miss by 98 %."""
    cap = cap_over_p0 * hertz(PAPER_PAIR, R, DELTA_Z)["p0"]
    model = ContactModel(PAPER_PAIR, Sphere(R, "paraboloid"), Grid(64, 4 * A), device=device)
    stopped = NormalSolver(model, max_iter=0, pressure_cap=cap).solve(ContactState(model), DELTA_Z)
    solved = NormalSolver(model, pressure_cap=cap).solve(ContactState(model), DELTA_Z)
    assert solved.converged and solved.iterations > 0 and stopped.residual > 1e-4
    assert abs(solved.history[0] / stopped.residual - 1) < 1e-12, (solved.history[0], stopped.residual)


def test_hertz_from_rest_takes_few_iterations():
    """A guard on the first guess and the preconditioner: from rest, a Hertz solve at n = 256
    converges (relative residual 1e-10) in 51-52 iterations here without the preconditioner; the
    guess before (c times the interference) took 125. Preconditioned (the default): 12. The
    bounds, 70 and 20, leave room for rounding to move the solver's recompute decisions (they moved
    the plain count by 4 between versions)."""
    model = ContactModel(PAPER_PAIR, Sphere(R, "paraboloid"), Grid(256, 4 * A))
    plain = NormalSolver(model, normal_preconditioner=False).solve(ContactState(model), DELTA_Z)
    assert plain.converged and plain.iterations <= 70, plain.iterations
    info = solve_hertz(256)["info"]
    assert info.converged and info.iterations <= 20, info.iterations


@pytest.mark.parametrize("cap_over_p0", [math.inf, 0.8])
def test_preconditioned_solve_matches_plain(device, cap_over_p0):
    """The preconditioned solve (the circulant inverse of K on the free set) and the plain
    Polonsky-Keer solve reach the same pressure: to 100 times the residual tolerance of its peak
    (both meet 1e-10; the cellwise error can be about 100 times the residual), free or capped at
    0.8 p0 (where the free set excludes the cells at the cap). The preconditioned one in at most
    half the iterations (n = 96: 8 against 26 free, 18 against 43 capped, here): a wrong
    preconditioner (the identity, an inverse off by a factor) would not converge faster."""
    cap = cap_over_p0 * hertz(PAPER_PAIR, R, DELTA_Z)["p0"]
    model = ContactModel(PAPER_PAIR, Sphere(R, "paraboloid"), Grid(96, 4 * A), device=device)
    results = {}
    for preconditioned in (True, False):
        state = ContactState(model)
        info = NormalSolver(model, pressure_cap=cap, normal_preconditioner=preconditioned).solve(state, DELTA_Z)
        assert info.converged and info.residual < 1e-10, info
        results[preconditioned] = (state.pressure.numpy(), info.iterations)
    (p1, it1), (p2, it2) = results[True], results[False]
    assert np.abs(p1 - p2).max() < 100 * 1e-10 * p2.max()
    assert it1 <= 0.5 * it2, (it1, it2)


@pytest.mark.parametrize("cap_over_p0", [math.inf, 0.8])
def test_a_float32_preconditioner_reaches_the_same_pressure(device, cap_over_p0):
    """``preconditioner_float32`` in a float64 model (the circulant inverse transformed in float32,
    1e-7 of M g): the solve still meets 1e-10, its pressure within 100 tolerances of its peak of
    the float64 preconditioner's (the bound above: two solves that meet 1e-10), free or capped,
    in at most a fifth more iterations plus two (n = 96: measured the same counts)."""
    cap = cap_over_p0 * hertz(PAPER_PAIR, R, DELTA_Z)["p0"]
    model = ContactModel(PAPER_PAIR, Sphere(R, "paraboloid"), Grid(96, 4 * A), device=device)
    results = {}
    for float32 in (False, True):
        state = ContactState(model)
        solver = NormalSolver(model, pressure_cap=cap, preconditioner_float32=float32)
        assert solver.float32_preconditioner == float32
        info = solver.solve(state, DELTA_Z)
        assert info.converged and info.residual < 1e-10, info
        results[float32] = (state.pressure.numpy(), info.iterations)
    (p64, it64), (p32, it32) = results[False], results[True]
    assert np.abs(p32 - p64).max() < 100 * 1e-10 * p64.max()
    assert it32 <= 1.2 * it64 + 2, (it32, it64)


def test_warm_start_at_the_solution_makes_one_convolution(device):
    """A solve that starts at its solution (the later turns of a coupled or adhesive step) makes
    no iteration, leaves the fields as they were, and makes one convolution (K p, for its exact
    residual), not a second for a final residual of an iterate that did not change. Counted
    where the launches run eagerly (``use_graphs=False``: every convolution calls the operator);
    on CUDA the same solve replayed from captured graphs too (same fields and residual)."""
    for use_graphs in [False] + ([None] if wp.get_device(device).is_cuda else []):
        model = ContactModel(PAPER_PAIR, Sphere(R, "paraboloid"), Grid(64, 4 * A), device=device)
        solver = NormalSolver(model, use_graphs=use_graphs)
        state = ContactState(model)
        first = solver.solve(state, DELTA_Z)
        fields = {k: getattr(state, k).numpy().copy() for k in ("pressure", "gap", "disp_z")}
        calls = count_convolutions(model)
        again = solver.solve(state, DELTA_Z)
        assert first.converged and again.converged and again.iterations == 0, (use_graphs, first, again)
        assert again.residual < solver.tol
        for k, v in fields.items():
            np.testing.assert_array_equal(getattr(state, k).numpy(), v, err_msg=f"{k}, use_graphs={use_graphs}")
        if not solver.use_graphs:
            assert calls[0] == 1, calls


def test_no_contact_gives_zero_pressure():
    model = ContactModel(PAPER_PAIR, Sphere(R), Grid(16, 4 * A))
    state = ContactState(model)
    info = NormalSolver(model).solve(state, -1e-11)
    assert info.converged and not np.any(state.pressure.numpy() != 0)


def test_pressure_cap_at_hardness(device):
    """With the pressure capped (elastic-perfectly-plastic surface) at 0.8 p0: p <= cap, cells at
    the cap penetrate (g <= 0), free contact cells close (g = 0), and the force falls below Hertz."""
    ref = hertz(PAPER_PAIR, R, DELTA_Z)
    cap = 0.8 * ref["p0"]
    model = ContactModel(PAPER_PAIR, Sphere(R, "paraboloid"), Grid(64, 4 * A), device=device)
    state = ContactState(model)
    info = NormalSolver(model, pressure_cap=cap).solve(state, DELTA_Z)
    assert info.converged, info
    f = state.to_numpy_si()
    p, g = f["pressure"], f["gap"]
    at_cap = p >= cap * (1 - 1e-12)
    free = (p > 0) & ~at_cap
    assert p.max() <= cap * (1 + 1e-12) and at_cap.sum() > 10
    assert g[at_cap].max() <= 1e-9 * DELTA_Z and g[at_cap].min() < -1e-3 * DELTA_Z  # plastic penetration
    assert np.abs(g[free]).max() < 1e-6 * DELTA_Z
    assert p.sum() * model.grid.cell_area < ref["force"]


def test_one_convolution_mode_matches_two(device):
    """Carrying K p incrementally (one convolution per iteration) gives the same pressure as
    recomputing it (two per iteration) to the solver tolerance, with fewer convolutions."""
    results = {}
    for one_conv in (True, False):
        model = ContactModel(PAPER_PAIR, Sphere(R, "paraboloid"), Grid(96, 4 * A), device=device)
        calls = count_convolutions(model)
        padded = model.operator.normal_padded  # K t of the iteration's direction

        def counted_padded(*args, **kw):
            calls[0] += not kw.get("inverse", False)  # the preconditioner's product is no K t
            return padded(*args, **kw)

        model.operator.normal_padded = counted_padded
        state = ContactState(model)
        # eager launches: the count is of Python calls, which a CUDA graph's replay does not make
        info = NormalSolver(model, one_convolution=one_conv, use_graphs=False).solve(state, DELTA_Z)
        assert info.converged
        results[one_conv] = (state.pressure.numpy(), calls[0], info.iterations)
    p1, c1, it1 = results[True]
    p2, c2, it2 = results[False]
    assert np.abs(p1 - p2).max() < 1e-8 * p2.max()  # both within 1e-10 relative residual of the solution
    assert c1 < 0.8 * c2, f"convolutions: {c1} (one-conv) vs {c2}"


def _backends_by_device():
    """(fft, device) for each FFT backend on each device here: scipy and warp on the CPU; warp and
    (with CuPy) cupy on each CUDA device."""
    from warpcontact.fft import cupy_backend

    out = [pytest.param("fftw", "cpu", marks=NEEDS_FFTW), ("scipy", "cpu"), ("warp", "cpu")]
    for i in range(wp.get_cuda_device_count()):
        ffts = ["warp"] + (["cupy"] if cupy_backend.available() else [])
        out += [pytest.param(fft, f"cuda:{i}", marks=pytest.mark.gpu) for fft in ffts]
    return out


@pytest.mark.parametrize("dtype", ["float64", "float32"])
@pytest.mark.parametrize("fft,device", _backends_by_device())
def test_step_sums_in_fourier_space_match_the_pass_after(fft, device, dtype):
    """The two ways of summing g . t and (K t) . t (``fourier_step_sums``: in the direction's pass
    and the spectral product, by Parseval; or in ``normal_step_sums`` after the convolution)
    differ by rounding only: the same pressure to 100 times the residual tolerance of its peak
    (both solves meet the tolerance, 1e-10 in float64, 1e-5 in float32; the pressure's condition
    makes the cellwise error up to about 100 times the residual), and the same iterations within
    2 (a last-digit difference can move the residual across the tolerance one iteration earlier
    or later)."""
    results = {}
    for fourier in (True, False):
        model = ContactModel(PAPER_PAIR, Sphere(R, "paraboloid"), Grid(80, 4 * A), device=device, dtype=dtype, fft=fft)
        solver = NormalSolver(model, fourier_step_sums=fourier)
        state = ContactState(model)
        info = solver.solve(state, DELTA_Z)
        assert info.converged, info
        results[fourier] = (state.pressure.numpy().astype(np.float64), info.iterations)
    (p1, it1), (p2, it2) = results[True], results[False]
    assert np.abs(p1 - p2).max() < 100 * solver.tol * p2.max()
    assert abs(it1 - it2) <= 2, (it1, it2)


def test_column_norm_bounds_one_cells_displacement():
    """||K e_j||_2 over the grid stays under ``operator.column_norm("zz")`` (the norm over every
    offset of the padded grid) for a cell at the centre and at a corner, and the centre's, which
    sees the most offsets, comes within 10 % of it: the bound the deferred recompute relies on."""
    model = ContactModel(PAPER_PAIR, Sphere(R, "paraboloid"), Grid(64, 4 * A))
    bound = model.operator.column_norm("zz")
    norms = {}
    for name, cell in (("centre", (32, 32)), ("corner", (0, 0))):
        unit = np.zeros((64, 64))
        unit[cell] = 1.0
        u = model.field()
        model.operator.normal(model.field(unit), u)
        norms[name] = np.linalg.norm(u.numpy())
        assert norms[name] <= bound * (1 + 1e-12), (name, norms[name], bound)
    assert norms["centre"] > 0.9 * bound, (norms, bound)


def _advance(correction, deferred, violation, it, rhs=1.0, tol=1e-10, column_norm=2.0, deferral=0.1, exact_every=50,
             exact=0.0, max_iter=2000, chunk=64, extra=None):
    """One launch of kernels/normal.py's normal_advance on the CPU, at the end of iteration
    ``it`` (1-based): (recompute flag, deferred after, loop flag, sums after, refresh flag, inner
    loop flag). The
    updated iterate's sums (S_NEXT_*) are the start's unless ``extra`` sets them."""
    from warpcontact.kernels import normal as nk

    sums = np.zeros(nk.N_SUMS)
    sums[nk.S_CORRECTION], sums[nk.S_VIOL], sums[nk.S_RHS] = correction, violation, rhs
    sums[nk.S_NEXT_VIOL], sums[nk.S_NEXT_RHS] = violation, rhs
    for slot, value in (extra or {}).items():
        sums[slot] = value
    scalars = np.zeros(nk.N_SCALARS)
    scalars[nk.C_ITER] = it - 1
    parameters = np.zeros(nk.N_PARAMETERS)
    parameters[[nk.P_TOL, nk.P_MAX_ITER, nk.P_CHUNK, nk.P_EXACT]] = tol, max_iter, chunk, exact
    held = wp.array([deferred], dtype=wp.float64, device="cpu")
    flag, refresh, inner = (wp.zeros(1, dtype=wp.int32, device="cpu") for _ in range(3))
    loop = wp.ones(1, dtype=wp.int32, device="cpu")  # as loop_start leaves it: the kernel only stops the loop
    sums_wp = wp.array(sums, dtype=wp.float64, device="cpu")
    wp.launch(nk.normal_advance, dim=1, device="cpu",
              inputs=[sums_wp, wp.array(parameters, dtype=wp.float64, device="cpu"), exact_every,
                      wp.float64(column_norm), wp.float64(deferral)],
              outputs=[wp.array(scalars, dtype=wp.float64, device="cpu"),
                       wp.zeros(max_iter + 1, dtype=wp.float64, device="cpu"), held, flag, loop, refresh, inner])
    flags = [int(a.numpy()[0]) for a in (flag, loop, refresh, inner)]
    return flags[0], float(held.numpy()[0]), flags[1], sums_wp.numpy(), flags[2], flags[3]


def _recompute_flag(correction, deferred, violation, it, **kw):
    """(flag, deferred after) of :func:`_advance`."""
    return _advance(correction, deferred, violation, it, **kw)[:2]


def test_recompute_flag_follows_the_bound():
    """The device's decision to recompute K p: not while nothing changed; a change whose bound
    (column norm x accumulated L1 change) stays under 0.1 of the violation's norm is carried and
    remembered; once the accumulated bound passes it, recompute and forget; near convergence
    (violation under (4 tol)^2 of the right-hand side) any change recomputes; every 50 iterations
    regardless; at every iteration in the two-convolution mode (settings P_EXACT = 1)."""
    assert _recompute_flag(0.0, 0.0, 1.0, it=3) == (0, 0.0)
    assert _recompute_flag(0.04, 0.0, 1.0, it=3) == (0, 0.04)  # bound 0.08 < 0.1
    assert _recompute_flag(0.02, 0.04, 1.0, it=3) == (1, 0.0)  # bound 2 x 0.06 = 0.12 > 0.1
    assert _recompute_flag(1e-30, 0.0, 1e-21, it=3) == (1, 0.0)  # bound 2e-30 is tiny, but near convergence
    assert _recompute_flag(0.0, 0.0, 1e-21, it=3) == (0, 0.0)  # near convergence, nothing changed
    assert _recompute_flag(0.0, 0.0, 1.0, it=50) == (1, 0.0)
    assert _recompute_flag(0.0, 0.0, 1.0, it=3, exact=1.0) == (1, 0.0)


def test_advance_moves_the_new_iterates_sums_and_sets_the_loop_flag():
    """normal_advance leaves the sums of the updated iterate (S_NEXT_*, with the carried gap) in
    slots S_G, S_VIOL, S_RHS for the next iteration and zeroes the rest; the loop goes on (flag 1)
    unless the residual the iteration started from is under the tolerance or not finite, or the
    iteration count reaches the limit or a multiple of the launch length."""
    from warpcontact.kernels import normal as nk

    nxt = {nk.S_NEXT_G: 3.0, nk.S_NEXT_VIOL: 4.0, nk.S_NEXT_RHS: 5.0, nk.S_GT: 7.0, nk.S_RT: 8.0, nk.S_IOL: 2.0}
    sums = _advance(0.1, 0.0, 1.0, it=3, extra=nxt)[3]
    np.testing.assert_array_equal(sums[[nk.S_G, nk.S_VIOL, nk.S_RHS]], [3.0, 4.0, 5.0])
    assert not np.any(sums[nk.S_GT:]), sums
    loop_refresh = lambda *a, **kw: tuple(_advance(*a, **kw)[i] for i in (2, 4))  # noqa: E731
    assert loop_refresh(0.0, 0.0, 1.0, it=3) == (1, 0)  # residual 1
    assert loop_refresh(0.0, 0.0, 1e-22, it=3) == (0, 1)  # residual 1e-11 < tol 1e-10: settled
    assert loop_refresh(0.0, 0.0, math.nan, it=3) == (0, 1)
    assert loop_refresh(0.0, 0.0, 1.0, it=10, max_iter=10) == (0, 1)
    assert loop_refresh(0.0, 0.0, 1.0, it=9, max_iter=10, chunk=3) == (0, 0)  # the launch's end: not settled
    assert loop_refresh(0.0, 0.0, 1.0, it=8, max_iter=10, chunk=3) == (1, 0)
    # the updated iterate converged: settled at once when no cell was projected since the last
    # exact gap (its carried gap is exact), not when one was (the next iteration starts exact)
    converged_next = {nk.S_NEXT_VIOL: 1e-22, nk.S_NEXT_RHS: 1.0}
    assert loop_refresh(0.0, 0.0, 1.0, it=3, extra=converged_next) == (0, 1)
    assert loop_refresh(1e-9, 0.0, 1.0, it=3, extra=converged_next) == (1, 0)


def test_inner_loop_flag_stops_for_a_recompute_or_the_loops_end():
    """The solver's inner device loop (``ProjectedCG._run``'s prelude) goes on only while the
    loop does and no recompute of K p is due: it stops for a recompute (the outer loop then makes
    it and enters the inner loop again), at the launch's end and when the solve settles."""
    flags = lambda *a, **kw: tuple(_advance(*a, **kw)[i] for i in (0, 2, 5))  # noqa: E731  (recompute, loop, inner)
    assert flags(0.0, 0.0, 1.0, it=3) == (0, 1, 1)
    assert flags(0.0, 0.0, 1.0, it=50) == (1, 1, 0)  # exact_every
    assert flags(0.02, 0.04, 1.0, it=3) == (1, 1, 0)  # the deferral's bound
    assert flags(0.0, 0.0, 1.0, it=9, chunk=3) == (0, 0, 0)  # the launch's end
    assert flags(0.0, 0.0, 1e-22, it=3) == (0, 0, 0)  # settled


@pytest.mark.parametrize("profile", ["sphere", "paraboloid"])
@pytest.mark.parametrize("dtype", ["float64", "float32"])
def test_initial_gap_on_the_device_is_the_host_gap(device, dtype, profile):
    """The model's gap before deformation: on CUDA made by ``kernels/geometry.py``, on the CPU by
    ``Sphere.initial_gap`` (numpy). The kernel, launched here on the CPU too, against the host's
    field: within 4 ulp of the largest value in float64 (cell units against metres: the same
    expression, rounded in another order; measured 4.7e-16), and to the same rounded values in
    float32 (both computed in float64). A domain past the exact sphere's radius is refused on
    either path."""
    from warpcontact.kernels import geometry
    from warpcontact.errors import InputError

    grid, sphere = Grid(300, 4 * A), Sphere(R, profile)
    model = ContactModel(PAPER_PAIR, sphere, grid, device=device, dtype=dtype)
    ref = (sphere.initial_gap(grid) / grid.dx).astype(model.np_dtype)
    own = wp.zeros(grid.shape, dtype=model.dtype, device=device)
    wp.launch(geometry.sphere_gap, dim=grid.shape, inputs=[grid.n, wp.float64(R / grid.dx), int(profile == "paraboloid")],
              outputs=[own], device=device)
    for gap in (own.numpy(), model.initial_gap.numpy()):
        if dtype == "float64":
            assert np.abs(gap - ref).max() < 4 * np.finfo(np.float64).eps * ref.max()
        else:
            assert np.array_equal(gap, ref) or np.abs(gap - ref).max() <= np.spacing(ref.max())
    if profile == "sphere":
        with pytest.raises(InputError, match="beyond the sphere's radius"):
            ContactModel(PAPER_PAIR, sphere, Grid(16, 2 * R), device=device, dtype=dtype)

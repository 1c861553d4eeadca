"""The preconditioned tangential solve: its preconditioner, its answers against the plain
(Chen & Wang) iteration, one operator application per iteration, iterations nearly flat in n."""

import math

import numpy as np
import pytest
import warp as wp

from warpcontact.physics.friction import Coulomb, TaborVonMises
from warpcontact.physics.geometry import Grid, Sphere
from warpcontact.physics.influence import influence_coefficients
from warpcontact.kernels import tangential as tk
from warpcontact.physics.materials import COPPER, PAPER_PAIR, MaterialPair
from warpcontact.numerics.model import ContactModel
from warpcontact.physics.reference import mindlin
from warpcontact.records.results import state_summary
from warpcontact.solvers.contact import ContactSolver
from warpcontact.solvers.tangential import TangentialSolver
from warpcontact.numerics.state import ContactState

R, DZ, MU = 10e-6, 1.0e-10, 0.3
A = math.sqrt(R * DZ)
SAME = MaterialPair(COPPER, COPPER)
DTYPES = ["float64", "float32"]


def reference_inverse(pair, n, dx, gx, gy, eigen_floor):
    """M g in NumPy: the 2x2 blocks of K_tt's spectrum on the padded grid diagonalised by
    ``np.linalg.eigh``, eigenvalues floored, inverted (independent of the kernel's closed form)."""
    coeffs = influence_coefficients(pair, n, n, dx, dx)
    scale = pair.E_star / dx
    kxx, kyy, kxy = (np.fft.rfft2(coeffs[k] * scale).real for k in ("xx", "yy", "xy"))
    blocks = np.stack([np.stack([kxx, kxy], -1), np.stack([kxy, kyy], -1)], -2)
    values, vectors = np.linalg.eigh(blocks)
    inverse = np.einsum("...ik,...k,...jk->...ij", vectors, 1.0 / np.maximum(values, eigen_floor), vectors)
    fx, fy = (np.fft.rfft2(g, s=(2 * n, 2 * n)) for g in (gx, gy))
    zx = np.fft.irfft2(inverse[..., 0, 0] * fx + inverse[..., 0, 1] * fy, s=(2 * n, 2 * n))[:n, :n]
    zy = np.fft.irfft2(inverse[..., 1, 0] * fx + inverse[..., 1, 1] * fy, s=(2 * n, 2 * n))[:n, :n]
    return zx, zy, float(values[..., 0].min())


@pytest.mark.parametrize("dtype", DTYPES)
def test_preconditioner_is_the_floored_inverse_of_the_tangential_block(device, dtype):
    """``ElasticOperator.tangential_inverse`` against the NumPy reference on a random shear, and
    its sum g . M g (Parseval) against the sum over the cells: within 1e-12 (float64) and 1e-5
    (float32) of the largest entry, 1e-11 and 1e-4 of the sum: the transforms' rounding (measured
    3e-16 and 1.6e-7, 4e-16 and 8e-7). The floor matters: K_tt's smallest eigenvalue on the
    padded grid is negative (about -0.03 here; with a floor of 1e-3 instead, M g moves by 6 times
    its largest entry)."""
    n = 32
    model = ContactModel(PAPER_PAIR, Sphere(R), Grid(n, 4 * A), device=device, dtype=dtype)
    solver = TangentialSolver(model)
    rng = np.random.default_rng(1)
    gx, gy = rng.standard_normal((2, n, n))
    zx, zy, smallest = reference_inverse(PAPER_PAIR, n, model.grid.dx, gx, gy, solver.eigen_floor)
    assert smallest < 0 < solver.eigen_floor
    out_x, out_y, energy = model.field(), model.field(), model.scalars(2)
    model.operator.tangential_inverse(model.field(gx), model.field(gy), out_x, out_y, energy, 1, solver.eigen_floor)
    rel = 1e-12 if dtype == "float64" else 1e-5
    scale = max(np.abs(zx).max(), np.abs(zy).max())
    assert np.abs(out_x.numpy() - zx).max() < rel * scale, np.abs(out_x.numpy() - zx).max() / scale
    assert np.abs(out_y.numpy() - zy).max() < rel * scale, np.abs(out_y.numpy() - zy).max() / scale
    g_mg = float(np.sum(gx * zx + gy * zy))
    assert energy.numpy()[0] == 0 and abs(energy.numpy()[1] / g_mg - 1) < rel * 10, (energy.numpy(), g_mg)


def test_slip_cells_keep_their_circle_when_the_limit_grows(device):
    """``tangential_classify`` with ``keep_slip``: a cell that ended the last solve in slip stays
    slip on its new, larger circle (same direction); a stick cell stays stick; a slip cell with
    q = 0 (zeroed tractions) becomes stick; a cell out of contact is zeroed. Without
    ``keep_slip`` (the plain iteration) the slip cell inside its disk becomes stick."""
    limit = np.array([2.0, 2.0, 2.0, 0.0])
    shear = np.array([[0.6, 0.8], [0.1, 0.0], [0.0, 0.0], [0.5, 0.5]])
    status = np.array([tk.SLIP, tk.STICK, tk.SLIP, tk.SLIP], dtype=np.int32)
    for keep, first in ((1, tk.SLIP), (0, tk.STICK)):
        arrays = [wp.array(a, dtype=wp.float64, device=device) for a in (limit, shear[:, 0], shear[:, 1])]
        st = wp.array(status, dtype=wp.int32, device=device)
        wp.launch(tk.tangential_classify, 4, [arrays[0], keep], [arrays[1], arrays[2], st], device=device)
        qx, qy, s = arrays[1].numpy(), arrays[2].numpy(), st.numpy()
        assert list(s) == [first, tk.STICK, tk.STICK, tk.OUT], (keep, s)
        expected = (1.2, 1.6) if keep else (0.6, 0.8)
        np.testing.assert_allclose((qx[0], qy[0]), expected, rtol=1e-15)
        assert (qx[1], qy[1], qx[3], qy[3]) == (0.1, 0.0, 0.0, 0.0)


@pytest.mark.parametrize("preconditioned", [False, True])
def test_a_reversing_slip_cell_waits_for_the_proportioning_test(device, preconditioned):
    """One step of the update kernels on four cells: a slip cell whose slip would reverse
    (g . q > 0), a stick cell with a large gradient, and two cells out of contact. The reversing
    cell is released into stick only where its squared reversal is over RELEASE_RATIO^2 times the
    rest of the violation (slots S_REVERSAL and S_VIOL as the residual left them), or where the
    relative residual is under RELEASE_NEAR times the tolerance; otherwise it stays slip on its
    circle. Either kernel (plain and carried) follows the rule, and counts the released cell."""
    from warpcontact.kernels import reduce as rk
    from warpcontact.numerics.launch import ReductionLaunch

    kernel = tk.tangential_carried_update if preconditioned else tk.tangential_update
    limit = np.array([1.0, 1.0, 0.0, 0.0])
    q = np.array([[1.0, 0.0], [0.2, 0.0], [0.0, 0.0], [0.0, 0.0]])
    reversal = 0.5  # g . e of the slip cell: its slip would reverse
    tol = 1e-10

    def run(stick_gradient, rhs):
        g = np.array([[reversal, 0.0], [stick_gradient, 0.0], [0.0, 0.0], [0.0, 0.0]])
        sums = np.zeros(tk.N_SUMS_PRECONDITIONED)
        sums[tk.S_REVERSAL] = reversal ** 2
        sums[rk.S_VIOL] = reversal ** 2 + stick_gradient ** 2
        sums[rk.S_RHS] = rhs
        sums[rk.S_GT], sums[rk.S_RT] = 1.0, 1e6  # a tiny step: the stick cell stays stick
        parameters = np.zeros(rk.N_PARAMETERS)
        parameters[rk.P_TOL] = tol
        f = lambda a: wp.array(np.ascontiguousarray(a), dtype=wp.float64, device=device)  # noqa: E731
        qx, qy, gx, gy = f(q[:, 0]), f(q[:, 1]), f(g[:, 0]), f(g[:, 1])
        zeros = f(np.zeros(4))
        status = wp.array(np.array([tk.SLIP, tk.STICK, tk.OUT, tk.OUT], dtype=np.int32), device=device)
        s = f(sums)
        launch = ReductionLaunch.for_cells(4, wp.get_device(device))
        one = wp.float64(1.0)
        inputs = [gx, gy, zeros, zeros, f(limit), one, f(parameters)]
        outputs = [qx, qy, status, s]
        if preconditioned:
            inputs = [zeros, zeros, zeros, zeros, f(limit), one, one, f(parameters)]
            outputs = [qx, qy, status, gx, gy, s]
        wp.launch_tiled(kernel, dim=launch.num_blocks, inputs=[*inputs, *launch.args(4)], outputs=outputs,
                        block_dim=launch.block_dim, device=device)
        return int(status.numpy()[0]), s.numpy()[rk.S_RESTART]

    ratio = float(tk.RELEASE_RATIO)
    far = 1.0  # the relative residual is about 1: far from the tolerance
    assert run(2.0 * reversal / ratio, far) == (tk.SLIP, 0.0)  # the rest dominates: it waits
    assert run(0.5 * reversal / ratio, far) == (tk.STICK, 1.0)  # the reversal dominates: released
    near = (reversal ** 2 + (2.0 * reversal / ratio) ** 2) / (0.5 * float(tk.RELEASE_NEAR) * tol) ** 2
    assert run(2.0 * reversal / ratio, near) == (tk.STICK, 1.0)  # near the tolerance: released


def test_a_slip_cells_step_sum_takes_the_tangent_part_of_its_gradient(device):
    """``tangential_step_sums`` on one slip cell near a solution: g = -lambda e + g_t with the
    slip increment lambda = 1e-3 and g_t = 1e-13 (relative residuals near 1e-10), the direction
    t tangent but for a normal part of 1e-19 (t's rounding: lambda eps |t| / |g_t| with |t| =
    2e-13). Slot S_GT must hold g_t . t = 2e-26 (to 1e-5: g_t taken from g carries a few ulps of
    lambda, lambda eps / |g_t| = 2e-6 of it), not g . t,
    where lambda times the normal part (-1e-22) swamps it, the step length tau turns negative and
    the iteration wanders (it did for hundreds of iterations at a fretting reversal); slot S_RT
    holds t . K t plus the constraint's curvature (lambda / q_max) |t|^2."""
    from warpcontact.kernels import reduce as rk
    from warpcontact.numerics.launch import ReductionLaunch

    lam, g_t, t_normal, t_tangent, q_max, response = 1e-3, 1e-13, 1e-19, 2e-13, 5e-4, 7e-13
    e = np.array([0.6, 0.8])  # the slip cell's direction, q = q_max e
    perp = np.array([-0.8, 0.6])
    g = -lam * e + g_t * perp
    t = t_normal * e + t_tangent * perp
    f = lambda a: wp.array(np.ascontiguousarray(a, dtype=np.float64), device=device)  # noqa: E731
    cells = [np.array([v, 0.0]) for v in (g[0], g[1], t[0], t[1], response, 0.0, q_max * e[0], q_max * e[1],
                                          q_max)]
    status = wp.array(np.array([tk.SLIP, tk.OUT], dtype=np.int32), device=device)
    sums = f(np.zeros(tk.N_SUMS_PRECONDITIONED))
    launch = ReductionLaunch.for_cells(2, wp.get_device(device))
    wp.launch_tiled(tk.tangential_step_sums, dim=launch.num_blocks,
                    inputs=[*(f(c) for c in cells), status, *launch.args(2)], outputs=[sums],
                    block_dim=launch.block_dim, device=device)
    gt, rt = sums.numpy()[rk.S_GT], sums.numpy()[rk.S_RT]
    assert abs(gt / (g_t * t_tangent) - 1.0) < 1e-5, (gt, g_t * t_tangent)  # (pytest.approx's abs floor is 1e-12)
    expected_rt = response * t[0] + lam / q_max * (t @ t)
    assert abs(rt / expected_rt - 1.0) < 1e-12, (rt, expected_rt)


def mindlin_step(n, device, dtype, preconditioned, tol=None, **choices):
    """Identical copper bodies, Coulomb mu = 0.3: delta_z, then delta_x at Q / (mu P) = 0.5: one
    tangential solve from zero shear (``choices``: more solver settings). Returns (state,
    tangential SolveInfo, model)."""
    model = ContactModel(SAME, Sphere(R, "paraboloid"), Grid(n, 3 * A), device=device, dtype=dtype)
    solver = ContactSolver(model, Coulomb(MU), tol=tol, tangential_preconditioner=preconditioned, **choices)
    state = ContactState(model)
    assert solver.step(state, (0.0, 0.0, DZ)).converged
    infos = []
    solve = solver.tangential.solve
    solver.tangential.solve = lambda *a, **k: infos.append(solve(*a, **k)) or infos[-1]
    assert solver.step(state, (mindlin(SAME, R, DZ, MU, 0.5)["delta_x"], 0.0, DZ)).converged
    return state, infos[-1], model


def coupled_step(device, dtype, preconditioned, **choices):
    """The coupled problem of bench/scaling.py at n = 48: copper on steel, Tabor + von Mises k_tau = 0.8, delta_z =
    1e-10 m then delta_x = 2e-11 m, domain 4a (the normal-tangential turns)."""
    model = ContactModel(PAPER_PAIR, Sphere(R), Grid(48, 4 * A), device=device, dtype=dtype)
    solver = ContactSolver(model, TaborVonMises(0.8, PAPER_PAIR.softer.yield_strength),
                           tangential_preconditioner=preconditioned, **choices)
    state = ContactState(model)
    for approach in ((0.0, 0.0, DZ), (2.0e-11, 0.0, DZ)):
        assert solver.step(state, approach).converged
    return state


@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("case", ["mindlin", "coupled"])
def test_preconditioned_and_plain_reach_the_same_shear(case, dtype, device):
    """Both iterations meet the relative residual (1e-10 in float64, 1e-5 in float32), so their
    shears differ by that residual amplified by the conditioning of K_tt on the stick area (its
    eigenvalues span 0.7 to 2.2 n, scaled): allowed 1000 tolerances of the largest |q| cell by
    cell (measured: float64 5e-9 and 6e-9, float32 4e-4 and 1.4e-4, Mindlin n = 64 and coupled
    n = 48); the force F_x averages the misfit out: 10 tolerances (measured 4e-11 and 8e-11,
    6e-6 and 2e-6). The stick and slip cells are the same."""
    run = (lambda pre: mindlin_step(64, device, dtype, pre)[0]) if case == "mindlin" else (
        lambda pre: coupled_step(device, dtype, pre))
    plain, preconditioned = run(False), run(True)
    tol = 1e-10 if dtype == "float64" else 1e-5
    q0 = np.stack([plain.shear_x.numpy(), plain.shear_y.numpy()]).astype(np.float64)
    q1 = np.stack([preconditioned.shear_x.numpy(), preconditioned.shear_y.numpy()]).astype(np.float64)
    field = np.abs(q1 - q0).max() / np.abs(q0).max()
    assert field < 1000 * tol, f"shear differs by {field:.2e} of its maximum"
    f0, f1 = (state_summary(s)["force"]["x"] for s in (plain, preconditioned))
    assert abs(f1 / f0 - 1) < 10 * tol, f"F_x {f1:.6e} vs {f0:.6e}"
    assert np.array_equal(plain.status.numpy(), preconditioned.status.numpy())


@pytest.mark.parametrize("case", ["mindlin", "coupled"])
def test_a_float32_preconditioner_reaches_the_same_shear(case, device):
    """``preconditioner_float32`` in a float64 model: the preconditioner's transforms and spectral
    product in float32 change the directions, not the problem, so the solves still meet 1e-10,
    and the shear, forces and statuses agree with the float64 preconditioner's as any two
    iterations that meet it do (the bounds of the test above: 1000 and 10 tolerances; measured
    7.8e-10 of the largest |q| on the Mindlin step at n = 64). Its rounding (1e-7 of M g) costs
    iterations only where it matters: at most a fifth more plus two on the Mindlin solve
    (measured 27 against 25)."""
    tol = 1e-10
    if case == "mindlin":
        (a, info_a, _), (b, info_b, _) = (mindlin_step(64, device, "float64", True, preconditioner_float32=f)
                                          for f in (False, True))
        assert info_b.converged and info_b.iterations <= 1.2 * info_a.iterations + 2, (info_a, info_b)
    else:
        a, b = (coupled_step(device, "float64", True, preconditioner_float32=f) for f in (False, True))
    assert_same_shear(a, b, tol)


def assert_same_shear(a, b, tol: float):
    """Two states of solves that met ``tol`` with different preconditioners: the shear within 1000
    tolerances of its largest cell, F_x and F_z within 10, the same stick and slip cells (the
    bounds of ``test_preconditioned_and_plain_reach_the_same_shear``)."""
    q0 = np.stack([a.shear_x.numpy(), a.shear_y.numpy()])
    q1 = np.stack([b.shear_x.numpy(), b.shear_y.numpy()])
    assert np.abs(q1 - q0).max() < 1000 * tol * np.abs(q0).max()
    f0, f1 = (state_summary(s)["force"] for s in (a, b))
    assert abs(f1["x"] / f0["x"] - 1) < 10 * tol and abs(f1["z"] / f0["z"] - 1) < 10 * tol, (f0, f1)
    assert np.array_equal(a.status.numpy(), b.status.numpy())


def test_one_operator_application_per_iteration():
    """The preconditioned iteration applies K_tt once (K t) and its inverse once: with the exact
    K q at the start, at the end and where the device asks for it (a released cell, the bound on
    the projections' changes, convergence judged on the exact g), under 1.6 applications per
    iteration on the Mindlin solve (measured 40 for 28 iterations at n = 64, 58 for 42 at 256);
    the plain iteration makes two per iteration plus two."""
    counts = {}
    for preconditioned in (False, True):
        model = ContactModel(SAME, Sphere(R, "paraboloid"), Grid(64, 3 * A))
        op = model.operator
        calls = {"tangential": 0, "tangential_inverse_product": 0}
        for name in calls:
            method = getattr(op, name)

            def counted(*args, _method=method, _name=name, **kwargs):
                calls[_name] += 1
                return _method(*args, **kwargs)

            setattr(op, name, counted)
        # counted on this operator (a window solves with its own)
        solver = ContactSolver(model, Coulomb(MU), tangential_preconditioner=preconditioned, window=False)
        state = ContactState(model)
        solver.step(state, (0.0, 0.0, DZ))
        calls.update(tangential=0, tangential_inverse_product=0)
        infos = []
        solve = solver.tangential.solve
        solver.tangential.solve = lambda *a, **k: infos.append(solve(*a, **k)) or infos[-1]
        solver.step(state, (mindlin(SAME, R, DZ, MU, 0.5)["delta_x"], 0.0, DZ))
        counts[preconditioned] = (infos[-1].iterations, dict(calls))
    it, calls = counts[False]
    assert calls == {"tangential": 2 * it + 2, "tangential_inverse_product": 0}, counts
    it, calls = counts[True]
    assert calls["tangential_inverse_product"] == it and calls["tangential"] < 1.6 * it, counts


@pytest.mark.parametrize("dtype", DTYPES)
def test_iterations_nearly_flat_in_n(dtype, device):
    """One tangential solve from rest (the Mindlin step) at n = 64 and 256, to the default
    tolerances (1e-10 in float64, 1e-5 in float32). Measured on the CPU: preconditioned 25 and
    38 (float64), 12 and 17 (float32); plain 64 and 97, 26 and 32. Guards: the preconditioned
    counts under 35 and 55 (float64), 18 and 25 (float32), the count at 256 under twice that at
    64, and at 256 under 0.7 times the plain one (measured 0.39 and 0.53)."""
    tol = None
    bounds = {64: 35, 256: 55} if dtype == "float64" else {64: 18, 256: 25}
    its = {n: mindlin_step(n, device, dtype, True, tol)[1].iterations for n in bounds}
    for n, bound in bounds.items():
        assert its[n] < bound, f"n = {n}: {its[n]} iterations (guard {bound})"
    assert its[256] < 2 * its[64], its
    plain = mindlin_step(256, device, dtype, False, tol)[1].iterations
    assert its[256] < 0.7 * plain, (its[256], plain)

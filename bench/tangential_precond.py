"""Side by side: the partial-slip solve as Chen & Wang publish it and with one operator
application per iteration and an FFT preconditioner, prototyped in NumPy and run by the Warp
solver.

The tangential problem of a load step is min 1/2 q.K q - q.b under |q_i| <= q_max_i (the
bounded conjugate gradients of ``kernels/tangential.py``). The inputs of every tangential solve
of a real step (its starting shear and statuses, right-hand side, limits, tolerance) are recorded
from the Warp solver (plain iteration, CPU, float64), then each is solved again by the variants:

- ``plain``: Chen & Wang's iteration (``TangentialSolver(preconditioned=False)``): the exact
  gradient g = K q - b and the step's K t at every iteration (two applications of K_tt),
  Jacobi scaling by the self-influence (plus lambda / q_max on slip cells);
- ``plain-keep``: the same, slip cells kept on their circle at the start where q_max grew (or
  rounding left them inside: ``tangential_classify``'s ``keep_slip``); every variant below
  keeps them;
- ``carried``: ``plain-keep`` with g carried (g <- g - tau K t) and made exact again after a
  released cell, every 50 iterations, when the bound on what the projections changed passes 0.1
  of the violation, and where the carried g says "converged" but the bound does not make it
  certain (``tangential_advance``): one application per iteration and a few more;
- ``stick-fft`` (the solver's ``preconditioned`` iteration): ``carried``, with z = M g on the
  stick cells, M the block-circulant inverse of K_tt (per wavenumber the 2x2 block [[K_xx,
  K_xy], [K_xy, K_yy]] on the padded grid inverted, eigenvalues floored at a quarter of the
  self-influence), applied to g on the stick cells and read there; slip cells keep the Jacobi
  scaling of their tangent component;
- ``stick-fft-exact``: ``stick-fft`` with the exact gradient at every iteration (two
  applications and the inverse): what carrying g costs in iterations;
- ``free-fft`` (opt in: slow): M applied to the projected gradient of stick and slip cells (the
  slip cells' tangent component) and read back projected; it ignores the slip cells' curvature
  lambda / q_max, and took 88, 325 and 2000+ (not converged) iterations at n = 64, 128, 256 on
  the Mindlin solve;
- ``warp-plain``, ``warp-preconditioned``: the Warp ``TangentialSolver`` (CPU, float64) on the
  same inputs.

Cases: ``mindlin`` (identical copper bodies, Coulomb mu = 0.3, R = 10 um, delta_z = 1e-10 m in
two steps, domain 3a, then delta_x at Q / (mu P) = 0.5: one uncoupled tangential solve from zero
shear); ``issue`` (copper on steel, Tabor + von Mises k_tau = 0.8, delta_z = 1e-10 m then delta_x
= 2e-11 m, domain 4a: every turn's tangential solve of the coupled step, each replayed from the
start the plain Warp solver gave it, so the turns are the plain solver's).

    python bench/tangential_precond.py --sizes 64 128 256 --cases mindlin issue
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
from scipy import fft as sfft

from warpcontact.physics.friction import Coulomb, TaborVonMises
from warpcontact.physics.geometry import Grid, Sphere
from warpcontact.physics.influence import influence_coefficients
from warpcontact.physics.materials import COPPER, PAPER_PAIR, MaterialPair
from warpcontact.numerics.model import ContactModel
from warpcontact.physics.reference import mindlin
from warpcontact.solvers.contact import ContactSolver
from warpcontact.solvers.tangential import TangentialSolver
from warpcontact.numerics.state import ContactState

R, DZ, MU = 10e-6, 1.0e-10, 0.3
A = math.sqrt(R * DZ)
SAME = MaterialPair(COPPER, COPPER)
OUT, STICK, SLIP = 0, 1, 2


class TangentialOperatorNP:
    """K_tt on the n x n grid by DC-FFT (zero-padded to 2n x 2n), scaled units (tractions / E*,
    lengths / dx), and the circulant inverse of its 2x2 block per wavenumber on the padded grid,
    eigenvalues floored at ``eig_floor`` times the self-influence."""

    def __init__(self, pair, n, dx, eig_floor=0.25):
        coeffs = influence_coefficients(pair, n, n, dx, dx)
        scale = pair.E_star / dx
        self.n = n
        self.kxx, self.kyy, self.kxy = (sfft.rfft2(coeffs[k] * scale).real for k in ("xx", "yy", "xy"))
        self.k_self = 0.5 * (coeffs["xx"][0, 0] + coeffs["yy"][0, 0]) * scale
        half_trace = 0.5 * (self.kxx + self.kyy)
        spread = np.sqrt(0.25 * (self.kxx - self.kyy) ** 2 + self.kxy ** 2)
        low, high = half_trace - spread, half_trace + spread
        self.min_eig = float(low.min())
        floor = eig_floor * self.k_self
        # M = P+ / max(l+, floor) + P- / max(l-, floor), P+ = (K - l- I) / (l+ - l-), P- = I - P+
        inv_high, inv_low = 1.0 / np.maximum(high, floor), 1.0 / np.maximum(low, floor)
        safe = np.where(spread > 0, 2 * spread, 1.0)
        pxx = np.where(spread > 0, (self.kxx - low) / safe, 0.5)
        pyy = np.where(spread > 0, (self.kyy - low) / safe, 0.5)
        pxy = np.where(spread > 0, self.kxy / safe, 0.0)
        self.mxx = pxx * inv_high + (1 - pxx) * inv_low
        self.myy = pyy * inv_high + (1 - pyy) * inv_low
        self.mxy = pxy * (inv_high - inv_low)
        col = [np.linalg.norm(coeffs[k]) * abs(scale) for k in ("xx", "yy", "xy")]
        self.column_norm = math.sqrt(col[0] ** 2 + col[1] ** 2 + 2 * col[2] ** 2)
        self.applications = 0
        self.inverses = 0

    def _product(self, ax, ay, mxx, mxy, myy):
        n = self.n
        fx = sfft.rfft2(ax, s=(2 * n, 2 * n))
        fy = sfft.rfft2(ay, s=(2 * n, 2 * n))
        ux = sfft.irfft2(mxx * fx + mxy * fy, s=(2 * n, 2 * n))[:n, :n]
        uy = sfft.irfft2(mxy * fx + myy * fy, s=(2 * n, 2 * n))[:n, :n]
        return ux, uy

    def apply(self, qx, qy):
        self.applications += 1
        return self._product(qx, qy, self.kxx, self.kxy, self.kyy)

    def inverse(self, gx, gy):
        self.inverses += 1
        return self._product(gx, gy, self.mxx, self.mxy, self.myy)


def unit(qx, qy):
    qn = np.hypot(qx, qy)
    inv = np.where(qn > 0, 1.0 / np.where(qn > 0, qn, 1.0), 0.0)
    return qx * inv, qy * inv


def project_disk(qx, qy, qmax):
    norm = np.hypot(qx, qy)
    s = np.where(norm > qmax, qmax / np.maximum(norm, qmax * (1 + 1e-30) + 1e-300), 1.0)
    return qx * s, qy * s


NUMPY_VARIANTS = ("plain", "plain-keep", "carried", "stick-fft", "stick-fft-exact", "free-fft")


def solve(op, rec, variant, max_iter=2000, restart_every=100, exact_every=50, deferral=0.1):
    """One tangential solve of ``rec`` by the NumPy ``variant``; returns (qx, qy, status, info)."""
    qx, qy = rec["qx"].copy(), rec["qy"].copy()
    lim = rec["limit"]
    bx, by = rec["target_x"] - rec["known_x"], rec["target_y"] - rec["known_y"]
    tol = rec["tol"]
    carried = variant in ("carried", "stick-fft", "free-fft")
    keep_slip = variant != "plain"
    pre = {"stick-fft": "stick", "stick-fft-exact": "stick", "free-fft": "free"}.get(variant, "jacobi")
    out = lim <= 0
    qx[out] = 0
    qy[out] = 0
    on = np.hypot(qx, qy) >= lim
    if keep_slip:  # slip cells stay on their circle as q_max changes
        on |= (rec["status"] == SLIP) & (np.hypot(qx, qy) > 0)
    on &= ~out
    px, py = unit(qx, qy)
    qx, qy = np.where(on, lim * px, qx), np.where(on, lim * py, qy)
    st = np.where(out, OUT, np.where(on, SLIP, STICK))
    k = op.k_self
    a0, i0 = op.applications, op.inverses
    ux, uy = op.apply(qx, qy)
    tx, ty = np.zeros_like(qx), np.zeros_like(qx)
    g_old, delta, deferred, it = 0.0, 0.0, 0.0, 0
    hist = []
    rhs = float(np.sum((bx ** 2 + by ** 2)[st != OUT]))
    while True:
        gx, gy = ux - bx, uy - by
        stick, slip = st == STICK, st == SLIP
        ex, ey = unit(qx, qy)
        gn = gx * ex + gy * ey
        gtx, gty = gx - gn * ex, gy - gn * ey
        viol = float(np.sum((gx ** 2 + gy ** 2)[stick]) + np.sum((gtx ** 2 + gty ** 2 + np.maximum(gn, 0) ** 2)[slip]))
        res = math.sqrt(viol / rhs) if rhs > 0 else (0.0 if viol == 0 else 1.0)
        bound = op.column_norm * deferred
        if carried and deferred > 0 and res < tol and not math.sqrt(viol) + bound < tol * math.sqrt(rhs):
            ux, uy = op.apply(qx, qy)  # converged with the carried g, not certainly with the exact one
            deferred = 0.0
            continue
        if res < tol or it >= max_iter:
            break
        hist.append(res)
        lam = np.where(slip, np.maximum(-gn, 0), 0.0)
        curv = np.where(slip, lam / np.where(lim > 0, lim, 1.0), 0.0)
        # the projected gradient P g: stick cells whole, slip cells' tangent component
        pgx = np.where(stick, gx, np.where(slip, gtx, 0.0))
        pgy = np.where(stick, gy, np.where(slip, gty, 0.0))
        jx, jy = pgx / np.where(slip, k + curv, k), pgy / np.where(slip, k + curv, k)
        if pre == "jacobi":
            zx, zy = jx, jy
        elif pre == "stick":
            mx, my = op.inverse(np.where(stick, gx, 0.0), np.where(stick, gy, 0.0))
            zx, zy = np.where(stick, mx, jx), np.where(stick, my, jy)
        else:
            mx, my = op.inverse(pgx, pgy)
            mn = mx * ex + my * ey
            zx = np.where(stick, mx, np.where(slip, mx - mn * ex, 0.0))
            zy = np.where(stick, my, np.where(slip, my - mn * ey, 0.0))
        G = float(np.sum(gx * zx + gy * zy))
        beta = delta * G / g_old if g_old > 0 else 0.0
        tn = tx * ex + ty * ey
        tx = np.where(stick, zx + beta * tx, np.where(slip, zx + beta * (tx - tn * ex), 0.0))
        ty = np.where(stick, zy + beta * ty, np.where(slip, zy + beta * (ty - tn * ey), 0.0))
        rx, ry = op.apply(tx, ty)
        gt = float(np.sum(gx * tx + gy * ty))
        rt = float(np.sum(rx * tx + ry * ty) + np.sum(curv * (tx ** 2 + ty ** 2)))
        tau = gt / rt if rt > 0 else 0.0
        tau_rel = tau if tau > 0 else 1.0 / k
        free_x, free_y = qx - tau * tx, qy - tau * ty
        nqx, nqy, nst = free_x.copy(), free_y.copy(), st.copy()
        rel = slip & (gx * qx + gy * qy > 0)
        px, py = project_disk(qx - tau_rel * gx, qy - tau_rel * gy, lim)
        inside = np.hypot(px, py) < lim
        nqx, nqy = np.where(rel, px, nqx), np.where(rel, py, nqy)
        nst = np.where(rel & inside, STICK, nst)
        released = int(np.sum(rel & inside))
        sl = slip & ~rel
        fx, fy = unit(free_x, free_y)
        nqx, nqy = np.where(sl, lim * fx, nqx), np.where(sl, lim * fy, nqy)
        cross = stick & (np.hypot(free_x, free_y) >= lim)
        px, py = project_disk(free_x, free_y, lim)
        nqx, nqy = np.where(cross, px, nqx), np.where(cross, py, nqy)
        nst = np.where(cross, SLIP, nst)
        nqx[st == OUT] = 0
        nqy[st == OUT] = 0
        corr = float(np.sum(np.hypot(nqx - free_x, nqy - free_y)[st != OUT]))
        qx, qy, st = nqx, nqy, nst
        it += 1
        g_old = 0.0 if it % restart_every == 0 else G
        delta = 0.0 if released > 0 else 1.0
        if carried:
            ux, uy = ux - tau * rx, uy - tau * ry
            deferred += corr
            if released > 0 or it % exact_every == 0 or op.column_norm * deferred > deferral * math.sqrt(viol):
                ux, uy = op.apply(qx, qy)
                deferred = 0.0
        else:
            ux, uy = op.apply(qx, qy)
    info = {"iterations": it, "residual": res, "applications": op.applications - a0,
            "inverses": op.inverses - i0, "history": hist}
    return qx, qy, st, info


def solve_warp(model, solver, rec):
    """One recorded solve by the Warp ``solver``: (qx, qy, status, info) as :func:`solve` gives."""
    state = ContactState(model)
    for name, key in (("shear_x", "qx"), ("shear_y", "qy"), ("status", "status")):
        getattr(state, name).assign(rec[key])
    op = model.operator
    calls = {"tangential": 0, "tangential_inverse_product": 0}
    originals = {name: getattr(op, name) for name in calls}

    def counted(name):
        def call(*args, **kwargs):
            calls[name] += 1
            return originals[name](*args, **kwargs)
        return call

    for name in calls:
        setattr(op, name, counted(name))
    try:
        f = model.field
        info = solver.solve(state, f(rec["target_x"]), f(rec["target_y"]), f(rec["limit"]), f(rec["known_x"]),
                            f(rec["known_y"]), tol=rec["tol"])
    finally:
        for name, method in originals.items():
            setattr(op, name, method)
    return (state.shear_x.numpy(), state.shear_y.numpy(), state.status.numpy(),
            {"iterations": info.iterations, "residual": info.residual, "applications": calls["tangential"],
             "inverses": calls["tangential_inverse_product"]})


def build_case(case, n, device="cpu", dtype="float64"):
    """(model, solver, state, steps): the case's model, Warp solver and the approaches of its steps."""
    if case == "mindlin":
        model = ContactModel(SAME, Sphere(R, "paraboloid"), Grid(n, 3 * A), device=device, dtype=dtype)
        solver = ContactSolver(model, Coulomb(MU))
        dx = mindlin(SAME, R, DZ, MU, 0.5)["delta_x"]
        steps = [(0.0, 0.0, DZ / 2), (0.0, 0.0, DZ), (dx, 0.0, DZ)]
    else:
        model = ContactModel(PAPER_PAIR, Sphere(R), Grid(n, 4 * A), device=device, dtype=dtype)
        solver = ContactSolver(model, TaborVonMises(0.8, PAPER_PAIR.softer.yield_strength))
        steps = [(0.0, 0.0, DZ), (2.0e-11, 0.0, DZ)]
    return model, solver, ContactState(model), steps


def record(case, n):
    """The tangential solves of the case's last step as the plain Warp solver (CPU, float64) met
    them; (model, records, step summary)."""
    model, solver, state, steps = build_case(case, n)
    tangential = solver.tangential
    tangential.preconditioned = False
    calls = []
    original = tangential.solve

    def recording(st, target_x, target_y, shear_limit, known_x=None, known_y=None, tol=None):
        rec = {"status": st.status.numpy().copy(), "qx": st.shear_x.numpy().copy(), "qy": st.shear_y.numpy().copy(),
               "target_x": target_x.numpy().copy(), "target_y": target_y.numpy().copy(),
               "limit": shear_limit.numpy().copy(),
               "known_x": np.zeros((n, n)) if known_x is None else known_x.numpy().copy(),
               "known_y": np.zeros((n, n)) if known_y is None else known_y.numpy().copy(),
               "tol": tangential.tol if tol is None else float(tol)}
        info = original(st, target_x, target_y, shear_limit, known_x, known_y, tol)
        rec["warp_iterations"] = info.iterations
        calls.append(rec)
        return info

    for approach in steps[:-1]:
        solver.step(state, approach)
    tangential.solve = recording
    info = solver.step(state, steps[-1])
    return model, calls, {"step_iterations": info.iterations, "turns": info.outer_iterations}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", type=int, nargs="+", default=[64, 128, 256])
    ap.add_argument("--cases", nargs="+", default=["mindlin", "issue"], choices=["mindlin", "issue"])
    every = [*NUMPY_VARIANTS, "warp-plain", "warp-preconditioned"]
    ap.add_argument("--variants", nargs="+", default=[v for v in every if v != "free-fft"], choices=every)
    args = ap.parse_args()
    print("| case | n | variant | solves | iterations (sum) | first solve | K applications | inverse products "
          "| transforms per solve | max abs(q - q_plain) / max q | time [s] |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for case in args.cases:
        for n in args.sizes:
            model, calls, step = record(case, n)
            op = TangentialOperatorNP(model.pair, n, model.grid.dx)
            ref = None
            print(f"<!-- {case} n={n}: plain Warp step {step}, its tangential iterations "
                  f"{[c['warp_iterations'] for c in calls]}; K_tt's smallest eigenvalue on the padded grid "
                  f"{op.min_eig:.3e} (scaled) -->")
            for variant in args.variants:
                if variant.startswith("warp"):
                    solver = TangentialSolver(model, preconditioned=variant == "warp-preconditioned")
                    run = lambda rec: solve_warp(model, solver, rec)  # noqa: E731
                    run(calls[0])  # compile and load before the clock starts
                else:
                    run = lambda rec: solve(op, rec, variant)  # noqa: E731
                its, apps, invs, first = 0, 0, 0, None
                t0 = time.perf_counter()
                finals = []
                for rec in calls:
                    qx, qy, st, info = run(rec)
                    its += info["iterations"]
                    apps += info["applications"]
                    invs += info["inverses"]
                    first = info["iterations"] if first is None else first
                    finals.append((qx, qy))
                wall = time.perf_counter() - t0
                if ref is None:
                    ref = finals
                scale = max(np.abs(r[0]).max() + np.abs(r[1]).max() for r in ref) or 1.0
                diff = max(max(np.abs(a[0] - b[0]).max(), np.abs(a[1] - b[1]).max()) for a, b in zip(finals, ref))
                transforms = 4 * (apps + invs) / len(calls)
                print(f"| {case} | {n} | {variant} | {len(calls)} | {its} | {first} | {apps} | {invs} "
                      f"| {transforms:.0f} | {diff / scale:.1e} | {wall:.2f} |", flush=True)


if __name__ == "__main__":
    main()

"""The fit's numerics: the model's noise, the difference step, the covariance of the estimate."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .fit_spec import Fit, _row_case


def model_noise(fit: Fit) -> float:
    """The relative noise of the model's outputs [-], what the difference step must rise above.

    gross-slip: delta_x_max is the lower end of a bisection bracket of relative width rel_tol, and
    mu = F_x / F_z is read at that end, so both are known to rel_tol: a parameter change that moves
    the bracket's last decision shifts them by up to rel_tol (between such decisions they are
    smooth: at n = 32, k_tau 0.68 to 0.72, mu / mu_b varied by 2e-4 with no jump). solve and
    pull-off: the iterative solvers stop at the relative residual ``solver.tol``."""
    start = {p.key: p.start for p in fit.parameters}
    case = _row_case(fit.base_dict, fit.rows[0], start, fit.overrides, Path(fit.data_file).name)
    tol = float(case.solver.tol)  # every row's: the tol follows the dtype, which a row cannot set apart
    return max(fit.rel_tol, tol) if fit.task == "gross-slip" else tol


def difference_step(fit: Fit) -> float:
    """The forward-difference step, relative to each parameter (linear scale: of its value; log
    scale: of its logarithm) [-]: ``[run] diff_step``, else sqrt(model_noise).

    A forward difference of outputs carrying relative noise eps over a relative step h errs by
    about 2 eps / h (the noise) + h / 2 (the curvature over one unit of the parameter); the sum is
    least at h ~ sqrt(eps). A step much smaller than that divides the noise by a small number and
    gives a garbage Jacobian; at eps = rel_tol = 1e-3 the step is 3.2 % (k_tau = 0.7: 0.022)."""
    if fit.diff_step is not None:
        return fit.diff_step
    return math.sqrt(model_noise(fit))


def _unit_steps(fit: Fit, u: np.ndarray, rel_step: float) -> np.ndarray:
    """Per parameter, the signed step in unit parameters at ``u``: forward, or backward where the
    forward step would leave the bounds."""
    steps = []
    for p, ui in zip(fit.parameters, u):
        value = p.from_unit(ui)
        if p.scale == "log":
            h = rel_step / math.log(p.max / p.min)
        else:
            typical = max(abs(value), 0.1 * (p.max - p.min))  # a parameter near 0: a step of the span
            h = rel_step * typical / (p.max - p.min)
        h = min(h, 0.5)
        steps.append(h if ui + h <= 1.0 else -h)
    return np.array(steps)


def covariance(J: np.ndarray, r: np.ndarray, rescale: bool) -> tuple[np.ndarray, float, list]:
    """The parameters' covariance from the weighted Jacobian ``J`` (dr/dparameter, m x p) and the
    weighted residuals ``r`` at the optimum: (J^T J)^-1, times the reduced chi-square
    s^2 = r.r / (m - p) where ``rescale``. Directions J cannot see (singular values under
    max(m, p) * machine epsilon * the largest) give infinite variance to every parameter with a
    share in them. Returns (covariance, s^2 used (1 without rescaling), the singular values)."""
    m, p = J.shape
    s2 = 1.0
    if rescale:
        s2 = float(r @ r) / (m - p) if m > p else math.inf
    if p == 0:
        return np.zeros((0, 0)), s2, []
    U, S, Vt = np.linalg.svd(J, full_matrices=False)
    cut = max(m, p) * np.finfo(float).eps * (S[0] if S.size else 0.0)
    keep = S > cut
    V = Vt.T
    cov = (V[:, keep] / S[keep] ** 2) @ V[:, keep].T * s2
    blind = V[:, ~keep]
    if blind.size:
        share = np.sqrt((blind ** 2).sum(axis=1))
        for j in np.nonzero(share > 1e-6)[0]:
            cov[j, :] = cov[:, j] = math.inf
    if not math.isfinite(s2):
        cov[:] = math.inf
    return cov, s2, [float(s) for s in S]


def _correlation(cov: np.ndarray) -> list:
    p = cov.shape[0]
    out = []
    for i in range(p):
        row = []
        for j in range(p):
            c, a, b = cov[i, j], cov[i, i], cov[j, j]
            ok = all(math.isfinite(x) for x in (c, a, b)) and a > 0 and b > 0
            row.append(float(c / math.sqrt(a * b)) if ok else None)
        out.append(row)
    return out

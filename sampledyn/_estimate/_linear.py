"""Linear l_p regression: ``min_theta || b - A theta ||_p`` for p in [1, inf].

Used by :func:`sampledyn.estimate` for structures in which the one-step error is linear
in the unknowns (Adams-Bashforth with a model linear in its parameters, or the AB
weights with the parameters fixed).

* p = 2: least squares (``numpy.linalg.lstsq``).
* p = 1 and p = inf: linear programs solved by HiGHS (``scipy.optimize.linprog``).
* any other p > 1: iteratively reweighted least squares (IRLS) on a smoothed objective,
  with a line search that makes every step decrease it (see :func:`_irls`).

Every solver works on a rescaled copy of the problem: columns of A divided by their
largest magnitude, and the unknowns measured from the least-squares solution in units
of its largest residual. The LP tolerances of HiGHS are absolute (about 1e-7), so
without this the tiny residuals of noise-free data would be below them.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from ..exceptions import ConvergenceError

__all__ = [
    "LinearSolution",
    "check_identifiable",
    "covariance",
    "lp_objective",
    "solve_linear",
]

# Smoothing of |r|^p in IRLS, relative to the largest least-squares residual.
IRLS_EPS = 1e-7


@dataclass(frozen=True)
class LinearSolution:
    """Minimiser of ``||b - A theta||_p`` and how it was found.

    Attributes
    ----------
    theta : ndarray, shape (k,)
    residuals : ndarray, shape (m,)
        ``b - A theta``.
    objective : float
        ``sum |r_i|**p`` for finite p, ``max |r_i|`` for p = inf.
    iterations : int
        IRLS iterations (0 for a direct or LP solve).
    converged : bool
    solver : str
        "lstsq", "linprog-highs" or "irls".
    """

    theta: np.ndarray
    residuals: np.ndarray
    objective: float
    iterations: int
    converged: bool
    solver: str


def lp_objective(r: np.ndarray, p: float) -> float:
    """``sum |r|**p`` for finite p, ``max |r|`` for p = inf (0 for an empty r)."""
    a = np.abs(np.asarray(r, dtype=float))
    if a.size == 0:
        return 0.0
    if math.isinf(p):
        return float(a.max())
    return float(np.sum(a**p))


def lp_norm(r: np.ndarray, p: float) -> float:
    """The l_p norm ``(sum |r|**p)**(1/p)``, or ``max |r|``."""
    obj = lp_objective(r, p)
    return obj if math.isinf(p) else obj ** (1.0 / p)


def _column_scale(a: np.ndarray) -> np.ndarray:
    c = np.abs(a).max(axis=0) if a.shape[0] else np.ones(a.shape[1])
    return np.where(c > 0, c, 1.0)


def solve_linear(
    a: np.ndarray, b: np.ndarray, p: float, *, tol: float = 1e-10, max_iter: int = 500
) -> LinearSolution:
    """``argmin_theta ||b - A theta||_p``.

    Parameters
    ----------
    a : ndarray, shape (m, k)
        Regressor matrix of full column rank (check with :func:`check_identifiable`).
    b : ndarray, shape (m,)
    p : float
        1 <= p <= inf.
    tol, max_iter
        IRLS stopping rule: stop when the smoothed objective decreases by less than
        ``tol`` times its value in one iteration, or after ``max_iter`` iterations.
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    c = _column_scale(a)
    an = a / c
    z_ls = np.linalg.lstsq(an, b, rcond=None)[0]
    theta_ls = z_ls / c
    r_ls = b - a @ theta_ls
    if p == 2:
        return LinearSolution(theta_ls, r_ls, lp_objective(r_ls, 2.0), 0, True, "lstsq")
    sigma = float(np.abs(r_ls).max()) if r_ls.size else 0.0
    if sigma == 0.0:
        # An exact fit minimises every norm.
        return LinearSolution(theta_ls, r_ls, 0.0, 0, True, "lstsq")
    rn = r_ls / sigma
    if p == 1 or math.isinf(p):
        dz = _lp_l1(an, rn) if p == 1 else _lp_inf(an, rn)
        iterations, converged, solver = 0, True, "linprog-highs"
    else:
        dz, iterations, converged = _irls(an, rn, p, tol, max_iter)
        solver = "irls"
    theta = theta_ls + sigma * dz / c
    r = b - a @ theta
    return LinearSolution(theta, r, lp_objective(r, p), iterations, converged, solver)


def _check_lp(res: object, what: str) -> np.ndarray:
    status = getattr(res, "status", -1)
    if status != 0:
        raise ConvergenceError(
            f"the {what} linear program failed (HiGHS status {status}: "
            f"{getattr(res, 'message', '')})."
        )
    return np.asarray(res.x, dtype=float)  # type: ignore[attr-defined]


def _lp_l1(a: np.ndarray, r: np.ndarray) -> np.ndarray:
    """min sum |r - A z|: ``A z + s+ - s- = r``, ``s+-`` >= 0, minimise ``sum(s+ + s-)``."""
    import scipy.sparse as sp  # here: SciPy's optimisers load only when they run
    from scipy.optimize import linprog

    m, k = a.shape
    eye = sp.identity(m, format="csr")
    a_eq = sp.hstack([sp.csr_matrix(a), eye, -eye], format="csr")
    cost = np.concatenate([np.zeros(k), np.ones(2 * m)])
    bounds = [(None, None)] * k + [(0.0, None)] * (2 * m)
    res = linprog(cost, A_eq=a_eq, b_eq=r, bounds=bounds, method="highs")
    return _check_lp(res, "l1")[:k]


def _lp_inf(a: np.ndarray, r: np.ndarray) -> np.ndarray:
    """min max |r - A z|: minimise tau with ``-tau <= r - A z <= tau``."""
    from scipy.optimize import linprog

    m, k = a.shape
    ones = np.ones((m, 1))
    a_ub = np.vstack([np.hstack([a, -ones]), np.hstack([-a, -ones])])
    b_ub = np.concatenate([r, -r])
    cost = np.zeros(k + 1)
    cost[-1] = 1.0
    bounds = [(None, None)] * k + [(0.0, None)]
    res = linprog(cost, A_ub=a_ub, b_ub=b_ub, bounds=bounds, method="highs")
    return _check_lp(res, "l-infinity")[:k]


def _irls(
    a: np.ndarray, r0: np.ndarray, p: float, tol: float, max_iter: int
) -> tuple[np.ndarray, int, bool]:
    """IRLS for ``min_z J(z) = sum (r_i(z)**2 + eps**2)**(p/2)``, ``r(z) = r0 - A z``.

    ``eps = IRLS_EPS`` (residuals are in units of the largest least-squares residual,
    so this is relative); it keeps the weights finite for p < 2 where a residual
    vanishes, and moves the minimiser by a negligible amount when the residuals are
    much larger than eps.

    Each iteration solves the weighted least-squares problem with weights
    ``w_i = (r_i**2 + eps**2)**((p - 2)/2)`` for a direction d. For p < 2 the full step
    minimises a quadratic majoriser of J (``(q + eps**2)**(p/2)`` is concave in
    ``q = r**2``), so J never increases; for p > 2 the step ``d / (p - 1)`` is the
    Newton step. A backtracking line search (halving) guards both cases, so J
    decreases monotonically and, being smooth and strictly convex for a full-rank A,
    converges to its unique minimiser.

    Stopping rule: ``J_old - J_new <= tol * J_old``; at most ``max_iter`` iterations.

    Returns (z, iterations, converged).
    """
    eps2 = IRLS_EPS**2

    def smoothed(res: np.ndarray) -> float:
        return float(np.sum((res * res + eps2) ** (0.5 * p)))

    z = np.zeros(a.shape[1])
    r = r0.copy()
    j_old = smoothed(r)
    step0 = 1.0 if p < 2 else 1.0 / (p - 1.0)
    for it in range(1, max_iter + 1):
        sw = (r * r + eps2) ** (0.25 * (p - 2.0))  # sqrt of the weights
        d = np.linalg.lstsq(a * sw[:, None], r * sw, rcond=None)[0]
        lam = step0
        while True:
            z_new = z + lam * d
            r_new = r0 - a @ z_new
            j_new = smoothed(r_new)
            if j_new <= j_old or lam < 1e-12:
                break
            lam *= 0.5
        if j_new > j_old:  # no descent left at machine precision
            return z, it, True
        z, r = z_new, r_new
        if j_old - j_new <= tol * j_old:
            return z, it, True
        j_old = j_new
    return z, max_iter, False


def check_identifiable(
    a: np.ndarray,
    names: tuple[str, ...],
    *,
    argument: str = "measured",
    cond_warn: float = 1e8,
    stacklevel: int = 2,
) -> float:
    """Raise if the columns of ``a`` are (numerically) dependent; return the
    condition number of ``a`` with its columns scaled to unit 2-norm.

    The condition number is that of the column-equilibrated matrix, so it does not
    depend on the units of the parameters.

    Raises
    ------
    ValueError
        naming the parameters that are not identifiable: those with an identically
        zero column, and those that weigh in a null-space direction of the
        equilibrated matrix (singular values below ``max(m, k) * machine eps`` times
        the largest, as ``numpy.linalg.matrix_rank``).

    Warns
    -----
    UserWarning
        if the condition number exceeds ``cond_warn``.
    """
    m, k = a.shape
    norms = np.sqrt((a * a).sum(axis=0))
    zero = [names[j] for j in range(k) if not norms[j] > 0]
    if zero:
        raise ValueError(
            f"parameter(s) {', '.join(zero)} not identifiable from `{argument}`: their "
            "regressors are identically zero over the estimation window (the data do not "
            "excite them). Use data that excite them, or keep them fixed by leaving them "
            "out of `params`."
        )
    an = a / norms
    _, sv, vt = np.linalg.svd(an, full_matrices=False)
    cond = float(sv[0] / sv[-1]) if sv[-1] > 0 else math.inf
    tol = sv[0] * max(m, k) * np.finfo(float).eps
    null = vt[sv <= tol]
    if null.shape[0]:
        involved = np.abs(null).max(axis=0) >= 0.1
        combos = []
        for v in null:
            big = np.abs(v) >= 0.1
            terms = " ".join(f"{v[j]:+.2f}*{names[j]}" for j in np.flatnonzero(big))
            combos.append(terms)
        raise ValueError(
            f"parameters {', '.join(n for n, bad in zip(names, involved, strict=True) if bad)} "
            f"not identifiable from `{argument}`: the regression is rank deficient "
            f"(condition number {cond:.3g}); the data do not separate the combination(s) "
            f"{'; '.join(combos)} (columns scaled to unit norm). Use data that excite them "
            "independently, or keep some fixed by leaving them out of `params`."
        )
    if cond > cond_warn:
        worst = vt[-1]
        weak = [names[j] for j in np.flatnonzero(np.abs(worst) >= 0.1)]
        warnings.warn(
            f"the regression is badly conditioned: condition number {cond:.3g} > "
            f"{cond_warn:.3g} (columns scaled to unit norm); the estimates of "
            f"{', '.join(weak)} are poorly determined by `{argument}` (see `std_errors`). "
            "Use longer or more exciting data.",
            UserWarning,
            stacklevel=stacklevel,
        )
    return cond


def covariance(a: np.ndarray, residuals: np.ndarray) -> np.ndarray:
    """Least-squares covariance ``s**2 (A^T A)^-1``, ``s**2 = RSS / (m - k)``, shape
    (k, k). Assumes independent, equal-variance residuals."""
    m, k = a.shape
    norms = np.sqrt((a * a).sum(axis=0))
    norms = np.where(norms > 0, norms, 1.0)
    _, sv, vt = np.linalg.svd(a / norms, full_matrices=False)
    s2 = float(residuals @ residuals) / (m - k) if m > k else math.nan
    inv = (vt.T / sv**2) @ vt
    return s2 * inv / np.outer(norms, norms)

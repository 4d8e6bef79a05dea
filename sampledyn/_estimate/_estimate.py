"""Parameter estimation by minimising an l_p norm of one-step local errors (Ee, ABe_s).

The paper's estimated models (section 4.2: "identification in the stationary state,
minimizing a Lebesgue series norm for the local error") fit the parameters theta of
the continuous-time model so that a discretisation rule predicts the measured
samples one step ahead as well as possible. For Adams-Bashforth of order s with
weights a_0..a_{s-1} (newest first) the one-step error at sample k is

    e_k(theta) = x_k - x_{k-1} - h sum_i a_i f(t_{k-1-i}, x_{k-1-i}, u_{k-1-i}; theta)

and for a model linear in theta, f = Phi theta + f0 (``model.regressors``), this is
affine in theta: ``e_k = b_k - A_k theta`` with

    A_k = h sum_i a_i Phi_{k-1-i},    b_k = x_k - x_{k-1} - h sum_i a_i f0_{k-1-i}.

Stacking the rows of all samples in the window gives a linear l_p regression, solved
exactly (:mod:`sampledyn._estimate._linear`). Other structures (RK_s, Tustin) and
parameters that enter f nonlinearly are fitted by ``scipy.optimize.least_squares``
(p = 2 only).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np

from .. import _checks as checks
from .._predict import check_measured
from .._trajectory import Trajectory
from ..methods import Estimator, Predictor, get_method, get_predictor
from ..methods._adams import ab_filter
from ..methods._base import fixed_step, uniform_step
from ..models._base import ParametricModel
from ._linear import check_identifiable, covariance, lp_norm, solve_linear

__all__ = ["EstimationResult", "estimate", "estimate_and_predict"]


def _readonly(a: Any) -> np.ndarray:
    a = np.array(a, dtype=float, copy=True)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class EstimationResult:
    """Parameters that minimise an l_p norm of one-step local errors.

    Attributes
    ----------
    params : Mapping[str, float]
        Estimated (free) parameters by name.
    units : Mapping[str, str]
        Their units.
    model : Model
        The model with the estimates (``model.with_params(**params)``); usable
        everywhere a model is.
    structure : str
        The rule whose one-step errors were minimised, e.g. "AB2".
    p : float
        The norm, 1 <= p <= inf.
    n_samples : int
        Number of one-step errors (predicted samples) in the window.
    n_rows : int
        Rows of the stacked regression: ``n_samples * len(components)``.
    residual_norm : float
        l_p norm of the stacked, scaled one-step errors at the estimate (the
        minimised value; in state units when ``component_scale`` is None).
    std_errors : Mapping[str, float] or None
        For p = 2: standard errors ``sqrt(diag(s**2 (A^T A)^-1))`` assuming
        independent, equal-variance residuals. With measurement noise the AB
        residuals are correlated over s + 1 samples (the increment differences the
        noise), so these are only indicative: for white noise they overstate the
        spread of the estimates (by about 10x for the AUV-like model), and they do
        not include the errors-in-variables bias (see :func:`estimate`). None for
        p != 2.
    condition_number : float
        Condition number of the regression matrix (or of the Jacobian, for the
        nonlinear fits) with columns scaled to unit norm.
    weights : ndarray, shape (s,) or None
        AB weights newest first: the exact coefficients, or the estimates with
        ``free_weights=True``; None for RK_s and Tustin.
    weight_std_errors : ndarray, shape (s,) or None
        For free weights and p = 2.
    components : tuple of str
        State components whose one-step errors were stacked.
    scale : ndarray, shape (len(components),)
        Divisor of each component's errors (state units), 1 for ``component_scale``
        None.
    residuals : ndarray, shape (n_samples, len(components))
        One-step errors at the estimate (state units, unscaled).
    t : ndarray, shape (n_samples,)
        Times of the predicted samples (s).
    after : float or None
        Start of the window (s).
    solver : str
        "lstsq", "linprog-highs", "irls" or "least_squares".
    iterations : int
        Iterations of IRLS or function evaluations of least_squares (0 otherwise).
    converged : bool
    bounds : Mapping[str, tuple[float, float]]
        The physical bounds the estimates were checked against (those the model
        declares for the free parameters).
    left_out : int
        One-step errors left out because the rule's history straddles a change of the
        sampled input (``skip_input_jumps``).
    straddling : int
        One-step errors whose history straddles such a change and that were counted
        (``skip_input_jumps=False``, or a continuously varying input).

    The property :attr:`flags` says, per parameter, what makes its estimate mean
    little.
    """

    params: Mapping[str, float]
    units: Mapping[str, str]
    model: ParametricModel
    structure: str
    p: float
    n_samples: int
    n_rows: int
    residual_norm: float
    std_errors: Mapping[str, float] | None
    condition_number: float
    weights: np.ndarray | None
    weight_std_errors: np.ndarray | None
    components: tuple[str, ...]
    scale: np.ndarray = field(repr=False)
    residuals: np.ndarray = field(repr=False)
    t: np.ndarray = field(repr=False)
    after: float | None
    solver: str
    iterations: int
    converged: bool
    bounds: Mapping[str, tuple[float, float]] = field(default_factory=lambda: MappingProxyType({}))
    left_out: int = 0
    straddling: int = 0

    @property
    def flags(self) -> dict[str, tuple[str, ...]]:
        """Per parameter (only those flagged): "loose", its standard error is >= its
        magnitude (the data hardly excite the term: sign and size undetermined; the
        "(*)" of the printed estimate); "bounds", it lies outside the physical bounds
        the model declares (``model.param_bounds``: a negative damping or added mass
        of a vehicle, a SymbolicModel's ``param_bounds``): the fit absorbed noise or
        forces the model lacks (the "(!)")."""
        return _flags(self.params, self.std_errors, self.bounds)

    def __str__(self) -> str:
        lines = [
            f"{self.structure} estimate, l_{self.p:g} norm, {self.n_samples} samples, "
            f"solver {self.solver}, residual norm {self.residual_norm:.4g}, "
            f"condition number {self.condition_number:.3g}"
        ]
        for name, value in self.params.items():
            se = "" if self.std_errors is None else f" +- {self.std_errors[name]:.3g}"
            line = f"  {name} = {value:.8g}{se} {self.units.get(name, '')}".rstrip()
            marks = self.flags.get(name, ())
            line += "".join(f"  ({_MARKS[f]})" for f in marks)
            lines.append(line)
        shown = {f for marks in self.flags.values() for f in marks}
        if "loose" in shown:
            lines.append(
                "  (*) standard error >= |value|: this log hardly excites the term (sign and "
                "size undetermined); the standard errors assume independent residuals, so "
                "they are indicative only"
            )
        if "bounds" in shown:
            spans = ", ".join(
                f"{n} in [{lo:g}, {hi:g}]"
                for n, (lo, hi) in self.bounds.items()
                if "bounds" in self.flags.get(n, ())
            )
            lines.append(
                f"  (!) outside the model's physical bounds ({spans}): the fit absorbed noise "
                "or forces the model lacks; the value means nothing as that parameter"
            )
        if self.left_out:
            lines.append(
                f"  {self.left_out} one-step errors whose history straddles an input jump "
                "left out (skip_input_jumps)"
            )
        elif self.straddling:
            lines.append(
                f"  {self.straddling} one-step errors whose history straddles an input jump "
                "counted (they bias the estimate by O(h); skip_input_jumps=True leaves them "
                "out)"
            )
        if self.weights is not None:
            lines.append(f"  weights = {np.array2string(self.weights, precision=6)}")
        return "\n".join(lines)


_MARKS = {"loose": "*", "bounds": "!"}


def _flags(
    values: Mapping[str, float],
    std: Mapping[str, float] | None,
    bounds: Mapping[str, tuple[float, float]],
) -> dict[str, tuple[str, ...]]:
    """The flags of :attr:`EstimationResult.flags`."""
    out: dict[str, tuple[str, ...]] = {}
    for name, value in values.items():
        marks = []
        if std is not None and not std[name] < abs(value):
            marks.append("loose")
        lo, hi = bounds.get(name, (-math.inf, math.inf))
        if not lo <= value <= hi:
            marks.append("bounds")
        if marks:
            out[name] = tuple(marks)
    return out


# ---------------------------------------------------------------------------------
# checks


def _check_p(p: Any) -> float:
    if isinstance(p, str) and p.strip().lower() in ("inf", "infinity"):
        return math.inf
    if isinstance(p, bool) or not isinstance(p, int | float | np.integer | np.floating):
        raise TypeError(f"`p` must be a number >= 1 or inf, got {type(p).__name__}.")
    p = float(p)
    if not p >= 1.0:
        raise ValueError(f"`p` must be >= 1 (the l_p norm is not convex below 1), got {p}.")
    return p


def _linear_form(model: ParametricModel, data: Trajectory) -> Any:
    fn = getattr(model, "regressors", None)
    if fn is None:
        return None
    try:
        return fn(data.t, data.x, data.u)
    except NotImplementedError:
        return None


def _free_params(
    model: ParametricModel, params: Any, lf: Any, free_weights: bool
) -> tuple[str, ...]:
    for attr in ("param_names", "params", "with_params"):
        if not hasattr(model, attr):
            raise TypeError(
                f"`model` must expose `{attr}` to be estimated; {type(model).__name__} does not."
            )
    names = tuple(model.param_names)
    if params is None:
        return tuple(lf.names) if lf is not None else names
    if isinstance(params, str):
        params = (params,)
    free = tuple(params)
    unknown = [n for n in free if n not in names]
    if unknown:
        raise ValueError(f"`params` names unknown parameter(s) {unknown}; valid: {list(names)}.")
    if len(set(free)) != len(free):
        raise ValueError(f"`params` lists a parameter twice: {list(free)}.")
    if not free and not free_weights:
        raise ValueError("`params` is empty: nothing to estimate (or set `free_weights=True`).")
    return free


def _window(
    data: Trajectory, history: int, after: float | None, skip_input_jumps: bool | None
) -> tuple[np.ndarray, int, int]:
    """``(k, left_out, straddling)``: indices k of the predicted samples used (k >=
    history, t_k >= after), how many were left out because u is not identical on
    samples k-history..k-1, and how many such were kept; with ``skip_input_jumps``
    None, they are left out only where the input is piecewise constant (they are
    fewer than half), see :func:`estimate`."""
    k = np.arange(history, data.n_samples)
    if after is not None:
        if not math.isfinite(after):
            raise ValueError(f"`after` must be a finite time (s) or None, got {after}.")
        k = k[checks.at_or_after(data.t[k], after)]
    if history < 2 or k.size == 0:
        return k, 0, 0
    same = np.ones(k.size, dtype=bool)
    for i in range(1, history):
        same &= (data.u[k - i] == data.u[k - 1 - i]).all(axis=1)
    straddling = int((~same).sum())
    if skip_input_jumps is False or (skip_input_jumps is None and same.sum() < 0.5 * k.size):
        return k, 0, straddling  # kept (a continuous input changes at most samples)
    return k[same], straddling, 0


def _components(
    model: ParametricModel, data: Trajectory, free: tuple[str, ...], lf: Any, free_weights: bool
) -> np.ndarray:
    """State components whose f depends on the free parameters (all, for free weights)."""
    if free_weights:
        return np.arange(data.nx)
    if lf is not None and set(free) <= set(lf.names):
        idx = [list(lf.names).index(n) for n in free]
        dep = (np.asarray(lf.phi)[:, :, idx] != 0).any(axis=(0, 2))
    else:
        f0 = model.f(data.t, data.x, data.u)
        dep = np.zeros(data.nx, dtype=bool)
        for name in free:
            v = float(model.params[name])
            f1 = model.with_params(**{name: v + 1e-3 * (abs(v) + 1.0)}).f(data.t, data.x, data.u)
            dep |= (f1 != f0).any(axis=0)
    comps = np.flatnonzero(dep)
    if comps.size == 0:
        raise ValueError(f"f does not depend on `params` {list(free)} on these data.")
    return comps


def _scale(component_scale: Any, data: Trajectory, k: np.ndarray, comps: np.ndarray) -> np.ndarray:
    if component_scale is None:
        return np.ones(comps.size)
    if isinstance(component_scale, str):
        if component_scale != "increments":
            raise ValueError(
                f"`component_scale` must be None, 'increments' or an array of shape "
                f"({data.nx},), got {component_scale!r}."
            )
        dx = data.x[k][:, comps] - data.x[k - 1][:, comps]
        rms = np.sqrt(np.mean(dx * dx, axis=0)) if k.size else np.ones(comps.size)
        return np.where(rms > 0, rms, 1.0)
    sc = np.asarray(component_scale, dtype=float)
    if sc.shape != (data.nx,) or not (np.isfinite(sc).all() and (sc > 0).all()):
        raise ValueError(
            f"`component_scale` must be positive and finite with shape ({data.nx},) "
            f"(state units), got {component_scale!r}."
        )
    return sc[comps]


def _check_count(n_rows: int, n_unknowns: int, n_samples: int, after: float | None) -> None:
    if n_rows <= n_unknowns:
        raise ValueError(
            f"too few samples: {n_samples} one-step errors ({n_rows} rows) at "
            f"t >= after={after} for {n_unknowns} unknowns; need more rows than unknowns. "
            "Lengthen the record or lower `after`."
        )


# ---------------------------------------------------------------------------------
# the estimator


def estimate(
    model: ParametricModel,
    measured: Trajectory,
    structure: Any = "AB2",
    p: float = 2,
    after: float | None = None,
    params: Sequence[str] | str | None = None,
    *,
    free_weights: bool = False,
    signal: Any = None,
    skip_input_jumps: bool | None = None,
    component_scale: Any = None,
    tol: float = 1e-10,
    max_iter: int = 500,
    cond_warn: float = 1e8,
) -> EstimationResult:
    """Parameters that minimise the l_p norm of a rule's one-step errors (Ee, ABe_s).

    Parameters
    ----------
    model : Model
        Continuous-time model with ``params``, ``param_names``, ``with_params`` and,
        for the exact linear fits, ``regressors(t, x, u)`` returning a LinearForm
        (f = phi @ theta + f0, phi shape (N, nx, n_theta)). Its parameter values are
        the fixed values of the parameters not estimated, and the starting point of
        the nonlinear fits.
    measured : Trajectory
        Sampled (possibly noisy) data, N samples, uniform or not (a jittered log: the
        AB_s regression then uses the weights of the actual nodes, as the rule's
        prediction does; free weights need a uniform grid); NaN or inf is an error.
    structure : str or method object
        The rule: "E" (= AB1), "AB<s>", "RK<s>", "T".
    p : float
        1 <= p <= inf (``math.inf`` or "inf"). p = 2 least squares; p = 1 least
        absolute deviations (robust to a few outliers); p = inf minimax.
    after : float, optional
        Use the one-step errors of the samples with ``t >= after`` (s) only, e.g.
        to estimate in the stationary state.
    params : sequence of str, optional
        Names of the parameters to estimate; the others stay at the model's values
        (their contribution moves into the constant part). Default: those the
        model's ``regressors`` is linear in (all ``param_names`` for a model without
        ``regressors``).
    free_weights : bool
        AB only. Estimate the s weights of the rule too (with theta when ``params``
        is not empty, else instead of it), see Notes.
    signal : Signal, optional
        Continuous-time input for the RK stages (see :func:`sampledyn.predict`).
    skip_input_jumps : bool or None
        AB only: leave out the samples whose AB history straddles a change of the
        sampled input (u not identical on samples k-s..k-1). With a piecewise
        constant input, f jumps with u, the interpolating polynomial over the jump is
        wrong by O(h * jump), and those rows, a fraction (s - 1) h / h_u of the data,
        bias the estimate by O(h) (for s = 4 on the AUV-like model, delta = -12.3
        instead of 0.5 on exact samples). None (default): leave them out when the
        input is piecewise constant, i.e. when they are fewer than half of the rows (a
        continuously varying input changes at every sample and leaves nothing to
        skip); True: always; False: never (the paper's estimator, every sample).
        ``EstimationResult.left_out`` counts them.
    component_scale : None, "increments" or ndarray of shape (nx,)
        How to weigh the one-step errors of state components of different units
        (e.g. m/s and rad/s of a vehicle) in one norm: None uses them as they are
        (state units, like :func:`sampledyn.error_norm`); "increments" divides each
        component by the RMS of its measured increment ``x_k - x_{k-1}`` over the
        window (dimensionless, every component weighs alike); an array gives the
        divisors (state units), e.g. the noise level of each component, which for
        p = 2 makes the fit a weighted least squares.
    tol, max_iter : float, int
        Stopping rule of IRLS (p not in {1, 2, inf}): stop when the (smoothed)
        objective decreases by less than ``tol`` times its value in one iteration;
        a warning if ``max_iter`` iterations do not reach it. ``tol`` is also the
        ``ftol``/``xtol``/``gtol`` of least_squares.
    cond_warn : float
        Warn when the condition number of the (column-equilibrated) regression
        exceeds this.

    Returns
    -------
    EstimationResult

    Raises
    ------
    ValueError
        NaN or inf in ``measured`` (naming the first bad sample); as many rows as
        unknowns or fewer in the window; a rank-deficient regression (naming the
        parameters that are not identifiable, e.g. delta of the AUV-like model when
        its position stays at 0 so that sin(x)**2 = 0); p != 2 where only least
        squares is available.

    Notes
    -----
    **Rows.** Only the state components of f that depend on the free parameters
    contribute one-step errors (for the AUV-like model, the velocity y); with free
    weights every component does. The one-step error of sample k has the structure
    of the rule: k >= s for AB_s, k >= 1 for RK_s and T.

    **Solvers.** AB_s (and E) with parameters that f is linear in: exact, p = 2 by
    ``numpy.linalg.lstsq``; p = 1 and p = inf by linear programming (HiGHS); other p by
    IRLS with smoothing ``|r| -> sqrt(r**2 + eps**2)``, eps = 1e-7 times the largest
    least-squares residual, and a monotone line search (converges; see
    :mod:`sampledyn._estimate._linear`). RK_s, T, or parameters entering f
    nonlinearly: ``scipy.optimize.least_squares`` from the model's values, p = 2.

    **Accuracy on exact samples.** The one-step errors of AB_s are O(h**(s+1)) per
    step against a regressor of size O(h), so the estimate is biased by O(h**s); the
    Euler estimate (Ee) by O(h). ABe_s thus absorbs the discretisation error into
    the parameters.

    **Measurement noise (errors in variables).** With white noise d_k of variance
    sigma**2 on a state, the regressors are evaluated on noisy states, and the
    noise of sample k-1 appears both in the increment ``x_k - x_{k-1}`` and in the
    newest regressor ``a_0 h Phi_{k-1}``. To first order in sigma**2 the p = 2
    estimate does not converge to theta for long records but to theta + bias,

        bias = -E[psi psi^T]^-1 ( (a_0 sigma**2 / h) E[dPhi_{k-1}]
                                  + sigma**2 sum_i a_i**2 E[dPhi dPhi^T] theta ),

    with psi = sum_i a_i Phi_{k-1-i} the regressor row divided by h and dPhi its
    derivative with respect to the noisy state (expectations are sample means over
    the window; the first term only for the noise of the component whose one-step
    error is fitted). The first term grows like 1/h and with a_0 (1, 3/2, 23/12,
    55/24 for s = 1..4): with noisy data a smaller h or a higher order makes the
    estimate worse, not better (cf. the paper's Fig. 2, where ABe does not improve
    with s); the second is the classical attenuation. Measured for the AUV-like
    model (AB2, h = 0.05 s, T = 4000 s, uniform noise of half-width 0.1 on y and
    0.02 on x, sigma_y**2 = 3.3e-3): bias of beta +0.0127 (25 % of |beta| = 0.05),
    of alpha -0.0015, of gamma -0.0042, each within 5 % of the formula; see
    ``tests/estimate/test_estimate.py``. A larger h, or instruments (not implemented), reduce
    it.

    **Free weights** (``free_weights=True``). With theta fixed the one-step error is
    linear in the weights, any p; jointly it is bilinear and is fitted by
    least_squares (p = 2) from the AB coefficients and the fixed-weight estimate.
    Buys: the weights absorb what the fixed interpolation gets wrong, the input
    jumping between samples (intersample behaviour) and model error, so the
    in-sample one-step errors can only decrease. Costs: the rule loses the exactness
    on polynomials of degree < s (hence consistency: the error no longer vanishes
    like h**(s+1) as h -> 0), s more unknowns (more variance), and poor
    identifiability: f changes by O(h) between samples, so only about the sum of
    the weights is well determined, and jointly the weights trade off against the
    scale of theta (exactly so when f0 is zero). Expect a large condition number.
    """
    check_measured(model, measured)
    p = _check_p(p)
    rule = get_method(structure)
    if isinstance(rule, Estimator) or not isinstance(rule, Predictor):
        raise ValueError(
            f"`structure` must be a fixed rule (E, AB<s>, RK<s>, T), got {rule.name!r}."
        )
    if free_weights or not rule.variable_step:
        uniform_step(measured, rule.name)
    # A rule that is a fixed filter of f at the samples (AB_s, Euler) gives one-step
    # errors affine in theta for models linear in theta.
    ab_weights = rule.sample_weights
    if free_weights and ab_weights is None:
        raise ValueError(
            f"`free_weights=True` needs an Adams-Bashforth `structure`, got {rule.name!r}."
        )
    history = len(ab_weights) if ab_weights is not None else rule.history
    lf = _linear_form(model, measured)
    free = _free_params(model, params, lf, free_weights)
    skip = skip_input_jumps if ab_weights is not None else False
    k, left_out, straddling = _window(measured, history, after, skip)
    comps = _components(model, measured, free, lf, free_weights)
    scale = _scale(component_scale, measured, k, comps)
    linear = lf is not None and set(free) <= set(lf.names)
    ctx = _Context(
        model, measured, rule, k, comps, scale, free, after, tol, max_iter, cond_warn,
        left_out, straddling,
    )  # fmt: skip

    if free_weights:
        assert ab_weights is not None
        if not free:
            return _fit_weights(ctx, ab_weights, p)
        if p != 2:
            raise ValueError(
                f"joint estimation of parameters and AB weights is bilinear and is done by "
                f"least squares only: use p=2 (got p={p:g}), or fix the parameters "
                "(`params=()`) to estimate the weights alone with any p."
            )
        return _fit_joint(ctx, ab_weights, lf if linear else None)
    if ab_weights is not None and linear:
        return _fit_linear(ctx, ab_weights, lf, p)
    if p != 2:
        why = (
            f"parameter(s) {[n for n in free if lf is None or n not in lf.names]} enter f "
            "nonlinearly"
            if not linear
            else f"the one-step error of {rule.name} is nonlinear in f"
        )
        raise ValueError(
            f"{why}, so only least squares (p=2) is available; got p={p:g}. Use an "
            "Adams-Bashforth `structure` with parameters f is linear in for p != 2."
        )
    return _fit_nonlinear(ctx, signal)


@dataclass(frozen=True)
class _Context:
    model: ParametricModel
    data: Trajectory
    rule: Any
    k: np.ndarray
    comps: np.ndarray
    scale: np.ndarray
    free: tuple[str, ...]
    after: float | None
    tol: float
    max_iter: int
    cond_warn: float
    left_out: int = 0
    straddling: int = 0

    @property
    def n_rows(self) -> int:
        return int(self.k.size * self.comps.size)

    def increments(self) -> np.ndarray:
        """x_k - x_{k-1} on the window, shape (n_samples, nc)."""
        x = self.data.x
        return x[self.k][:, self.comps] - x[self.k - 1][:, self.comps]

    def units(self) -> dict[str, str]:
        pu = getattr(self.model, "param_units", {}) or {}
        return {n: str(pu.get(n, "")) for n in self.free}

    def bounds(self) -> dict[str, tuple[float, float]]:
        declared = getattr(self.model, "param_bounds", {}) or {}
        return {
            n: (float(declared[n][0]), float(declared[n][1])) for n in self.free if n in declared
        }

    def step_weights(self, weights: np.ndarray) -> np.ndarray:
        """``h_n beta_{n,i}`` of the predicted samples k, shape (len(k), s): the fixed
        ``h a_i`` on a uniform grid, the weights of the actual nodes otherwise (as the
        rule predicts, :meth:`sampledyn.methods.AdamsBashforth.step_weights`)."""
        d, s = self.data, len(weights)
        h = fixed_step(d)
        if h is not None:
            return np.broadcast_to(h * weights, (self.k.size, s))
        if hasattr(self.rule, "step_weights"):
            return np.asarray(self.rule.step_weights(d, None))[self.k - s]
        return np.diff(d.t)[self.k - 1][:, None] * weights[None, :]  # one-step (RK1)

    def result(
        self,
        theta: np.ndarray,
        residuals: np.ndarray,
        p: float,
        *,
        cond: float,
        std: np.ndarray | None,
        weights: np.ndarray | None,
        weight_std: np.ndarray | None,
        solver: str,
        iterations: int,
        converged: bool,
    ) -> EstimationResult:
        values = {n: float(v) for n, v in zip(self.free, theta, strict=True)}
        model = self.model.with_params(**values) if values else self.model
        std_map = (
            None
            if std is None
            else MappingProxyType({n: float(s) for n, s in zip(self.free, std, strict=True)})
        )
        bounds = self.bounds()
        res = residuals.reshape(self.k.size, self.comps.size)
        names = tuple(self.data.state_names[c] for c in self.comps)
        return EstimationResult(
            params=MappingProxyType(values),
            units=MappingProxyType(self.units()),
            model=model,
            structure=str(self.rule.name),
            p=p,
            n_samples=int(self.k.size),
            n_rows=self.n_rows,
            residual_norm=lp_norm((res / self.scale).ravel(), p),
            std_errors=std_map,
            condition_number=float(cond),
            weights=None if weights is None else _readonly(weights),
            weight_std_errors=None if weight_std is None else _readonly(weight_std),
            components=names,
            scale=_readonly(self.scale),
            residuals=_readonly(res),
            t=_readonly(self.data.t[self.k]),
            after=self.after,
            solver=solver,
            iterations=int(iterations),
            converged=bool(converged),
            bounds=MappingProxyType(bounds),
            left_out=int(self.left_out),
            straddling=int(self.straddling),
        )


def _weighted_lagged_sum(g: np.ndarray, k: np.ndarray, hw: np.ndarray) -> np.ndarray:
    """sum_i hw[r, i] * g[k_r - 1 - i] per row r (hw shape (len(k), s)), over the
    leading axis of g; the trailing axes of g broadcast."""
    extra = (slice(None),) + (None,) * (g.ndim - 1)
    out = hw[:, 0][extra] * g[k - 1]
    for i in range(1, hw.shape[1]):
        out = out + hw[:, i][extra] * g[k - 1 - i]
    return out


def _lagged_sum(g: np.ndarray, k: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """sum_i weights[i] * g[k - 1 - i], over the leading axis."""
    out = weights[0] * g[k - 1]
    for i in range(1, len(weights)):
        out = out + weights[i] * g[k - 1 - i]
    return out


def _split_linear(ctx: _Context, lf: Any) -> tuple[np.ndarray, np.ndarray]:
    """Regressors of the free parameters, shape (N, nc, n_free), and the constant part
    f0 + Phi_fixed theta_fixed, shape (N, nc), on the selected components."""
    names = list(lf.names)
    phi = np.asarray(lf.phi, dtype=float)[:, ctx.comps, :]
    f0 = np.asarray(lf.f0, dtype=float)[:, ctx.comps]
    idx_free = [names.index(n) for n in ctx.free]
    fixed = [j for j, n in enumerate(names) if n not in ctx.free]
    if fixed:
        values = np.array([float(ctx.model.params[names[j]]) for j in fixed])
        f0 = f0 + phi[:, :, fixed] @ values
    return phi[:, :, idx_free], f0


def _warn_unconverged(ok: bool, what: str, n: int) -> None:
    if not ok:
        warnings.warn(
            f"{what} did not meet its stopping rule in {n} iterations; the estimate may "
            "not be the minimiser. Raise `max_iter` or `tol`.",
            UserWarning,
            stacklevel=4,
        )


def _fit_linear(ctx: _Context, weights: np.ndarray, lf: Any, p: float) -> EstimationResult:
    phi, f0 = _split_linear(ctx, lf)
    n_free = len(ctx.free)
    _check_count(ctx.n_rows, n_free, int(ctx.k.size), ctx.after)
    h = fixed_step(ctx.data)
    if h is not None:  # the fixed coefficients, in the order of the uniform-grid rule
        a3 = h * _lagged_sum(phi, ctx.k, weights)
        b2 = ctx.increments() - h * _lagged_sum(f0, ctx.k, weights)
    else:
        hw = ctx.step_weights(weights)
        a3 = _weighted_lagged_sum(phi, ctx.k, hw)
        b2 = ctx.increments() - _weighted_lagged_sum(f0, ctx.k, hw)
    a3 = a3 / ctx.scale[None, :, None]
    b2 = b2 / ctx.scale[None, :]
    a = a3.reshape(-1, n_free)
    b = b2.ravel()
    cond = check_identifiable(a, ctx.free, cond_warn=ctx.cond_warn, stacklevel=4)
    sol = solve_linear(a, b, p, tol=ctx.tol, max_iter=ctx.max_iter)
    _warn_unconverged(sol.converged, "IRLS", sol.iterations)
    std = np.sqrt(np.diag(covariance(a, sol.residuals))) if p == 2 else None
    residuals = (sol.residuals.reshape(b2.shape) * ctx.scale[None, :]).ravel()
    return ctx.result(
        sol.theta,
        residuals,
        p,
        cond=cond,
        std=std,
        weights=weights,
        weight_std=None,
        solver=sol.solver,
        iterations=sol.iterations,
        converged=sol.converged,
    )


def _weight_names(s: int) -> tuple[str, ...]:
    return tuple(f"a_{i}" for i in range(s))


def _fit_weights(ctx: _Context, ab_weights: np.ndarray, p: float) -> EstimationResult:
    """Weights only, theta fixed at the model's values: linear in the weights."""
    d = ctx.data
    s = len(ab_weights)
    _check_count(ctx.n_rows, s, int(ctx.k.size), ctx.after)
    f = d.h * ctx.model.f(d.t, d.x, d.u)[:, ctx.comps] / ctx.scale[None, :]
    a = np.stack([f[ctx.k - 1 - i] for i in range(s)], axis=-1).reshape(-1, s)
    b = (ctx.increments() / ctx.scale[None, :]).ravel()
    cond = check_identifiable(a, _weight_names(s), cond_warn=ctx.cond_warn, stacklevel=4)
    sol = solve_linear(a, b, p, tol=ctx.tol, max_iter=ctx.max_iter)
    _warn_unconverged(sol.converged, "IRLS", sol.iterations)
    wstd = np.sqrt(np.diag(covariance(a, sol.residuals))) if p == 2 else None
    residuals = (sol.residuals.reshape(-1, ctx.comps.size) * ctx.scale[None, :]).ravel()
    return ctx.result(
        np.zeros(0),
        residuals,
        p,
        cond=cond,
        std=None if p != 2 else np.zeros(0),
        weights=sol.theta,
        weight_std=wstd,
        solver=sol.solver,
        iterations=sol.iterations,
        converged=sol.converged,
    )


def _fit_joint(ctx: _Context, ab_weights: np.ndarray, lf: Any) -> EstimationResult:
    """Parameters and weights together (bilinear): least_squares, p = 2."""
    from scipy.optimize import least_squares  # SciPy's optimisers load when a fit runs

    d = ctx.data
    s = len(ab_weights)
    n_free = len(ctx.free)
    _check_count(ctx.n_rows, n_free + s, int(ctx.k.size), ctx.after)
    inc = ctx.increments() / ctx.scale[None, :]
    sc = ctx.scale[None, :]

    if lf is not None:
        phi, f0 = _split_linear(ctx, lf)
        phi = d.h * phi / ctx.scale[None, :, None]
        f0 = d.h * f0 / sc

        def hf(theta: np.ndarray) -> np.ndarray:
            return phi @ theta + f0

        # Start from the fixed-weight linear least-squares estimate.
        a0 = _lagged_sum(phi, ctx.k, ab_weights).reshape(-1, n_free)
        b0 = (inc - _lagged_sum(f0, ctx.k, ab_weights)).ravel()
        theta0 = solve_linear(a0, b0, 2.0).theta
    else:
        model = ctx.model

        def hf(theta: np.ndarray) -> np.ndarray:
            m = model.with_params(**dict(zip(ctx.free, theta, strict=True)))
            return d.h * m.f(d.t, d.x, d.u)[:, ctx.comps] / sc

        theta0 = np.array([float(model.params[n]) for n in ctx.free])

    def residual(z: np.ndarray) -> np.ndarray:
        theta, w = z[:n_free], z[n_free:]
        return (inc - _lagged_sum(hf(theta), ctx.k, w)).ravel()

    def jacobian(z: np.ndarray) -> np.ndarray:
        theta, w = z[:n_free], z[n_free:]
        g = hf(theta)
        jw = -np.stack([g[ctx.k - 1 - i] for i in range(s)], axis=-1).reshape(-1, s)
        jt = -_lagged_sum(phi, ctx.k, w).reshape(-1, n_free)
        return np.hstack([jt, jw])

    z0 = np.concatenate([theta0, ab_weights])
    sol = least_squares(
        residual,
        z0,
        jac=jacobian if lf is not None else "3-point",
        method="trf",
        x_scale="jac",
        ftol=ctx.tol,
        xtol=ctx.tol,
        gtol=ctx.tol,
    )
    names = ctx.free + _weight_names(s)
    cond = check_identifiable(sol.jac, names, cond_warn=ctx.cond_warn, stacklevel=4)
    std = np.sqrt(np.diag(covariance(np.asarray(sol.jac), sol.fun)))
    residuals = (sol.fun.reshape(-1, ctx.comps.size) * ctx.scale[None, :]).ravel()
    return ctx.result(
        sol.x[:n_free],
        residuals,
        2.0,
        cond=cond,
        std=std[:n_free],
        weights=sol.x[n_free:],
        weight_std=std[n_free:],
        solver="least_squares",
        iterations=int(sol.nfev),
        converged=bool(sol.status > 0),
    )


def _fit_nonlinear(ctx: _Context, signal: Any) -> EstimationResult:
    """Any rule, any parameters: least_squares on the rule's one-step errors, p = 2."""
    from scipy.optimize import least_squares

    d = ctx.data
    n_free = len(ctx.free)
    _check_count(ctx.n_rows, n_free, int(ctx.k.size), ctx.after)
    target = d.x[ctx.k][:, ctx.comps]

    def residual(theta: np.ndarray) -> np.ndarray:
        m = ctx.model.with_params(**dict(zip(ctx.free, theta, strict=True)))
        x_hat = np.asarray(ctx.rule.predict(m, d, signal))
        return ((target - x_hat[ctx.k][:, ctx.comps]) / ctx.scale[None, :]).ravel()

    theta0 = np.array([float(ctx.model.params[n]) for n in ctx.free])
    sol = least_squares(
        residual,
        theta0,
        jac="3-point",
        method="trf",
        x_scale="jac",
        ftol=ctx.tol,
        xtol=ctx.tol,
        gtol=ctx.tol,
    )
    cond = check_identifiable(sol.jac, ctx.free, cond_warn=ctx.cond_warn, stacklevel=4)
    std = np.sqrt(np.diag(covariance(np.asarray(sol.jac), sol.fun)))
    residuals = (sol.fun.reshape(-1, ctx.comps.size) * ctx.scale[None, :]).ravel()
    ab = ctx.rule.sample_weights
    return ctx.result(
        sol.x,
        residuals,
        2.0,
        cond=cond,
        std=std,
        weights=ab,
        weight_std=None,
        solver="least_squares",
        iterations=int(sol.nfev),
        converged=bool(sol.status > 0),
    )


def estimate_and_predict(
    model: ParametricModel,
    measured: Trajectory,
    structure: Any = "AB2",
    signal: Any = None,
    **kwargs: Any,
) -> tuple[np.ndarray, EstimationResult]:
    """Estimate on ``measured`` (:func:`estimate`, keyword arguments passed on), then
    predict it one step ahead with the same rule and the estimated model (and the
    estimated weights, with ``free_weights=True``).

    Returns
    -------
    x_hat : ndarray, shape (N, nx)
        As :func:`sampledyn.predict`; NaN where the rule lacks history.
    result : EstimationResult
    """
    result = estimate(model, measured, structure, signal=signal, **kwargs)
    if kwargs.get("free_weights") and result.weights is not None:
        f = result.model.f(measured.t, measured.x, measured.u)
        x_hat = ab_filter(measured.x, f, measured.h, np.asarray(result.weights))
    else:
        x_hat = np.asarray(get_predictor(structure).predict(result.model, measured, signal))
    return x_hat, result

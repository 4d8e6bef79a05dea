"""Adams-Bashforth rules of any order s, with exact coefficients.

    x_{n+1} = x_n + h * sum_{i=0}^{s-1} a_i f(t_{n-i}, x_{n-i}, u_{n-i})

In backward-difference form (Hairer, Norsett & Wanner, Solving ODEs I, Sec. III.1)
``x_{n+1} = x_n + h sum_{j<s} gamma_j nabla^j f_n`` with

    gamma_0 = 1,   gamma_m + gamma_{m-1}/2 + ... + gamma_0/(m+1) = 1,

so ``a_i = (-1)^i sum_{j=i}^{s-1} binom(j, i) gamma_j`` (the integrals over [0, 1] of the
Lagrange basis polynomials on the nodes 0, -1, ..., -(s-1), in units of h), and the
local error is ``gamma_s h^{s+1} x^{(s+1)} + O(h^{s+2})``: gamma_s is the error
constant. Coefficients are exact ``Fraction``s, newest first.

Stability. The coefficients alternate in sign, so on the negative real axis the root
of ``zeta^s - zeta^{s-1} - z sum_i a_i zeta^{s-1-i}`` that leaves the unit circle first
does so at zeta = -1, where ``z = -2 / a_s`` with ``a_s = sum_i |a_i|``: the real
stability interval of AB_s is ``[-2/a_s, 0]`` (2, 1, 0.545, 0.3, 0.163, 0.0877 for
s = 1..6, then about halving with every order; cf. the stability domains in Hairer &
Wanner, Solving ODEs II, Sec. V.1). The same a_s is the rule's noise gain.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from fractions import Fraction
from functools import lru_cache
from math import comb
from typing import Any, ClassVar

import numpy as np
from numba import njit

from .. import _checks as checks
from .._sums import fir_rows
from .._trajectory import Trajectory
from ..models import Model
from ._base import (
    FixedRule,
    check_gain_args,
    check_ratio,
    fixed_step,
    sample_f,
    sample_jacobian,
    time_steps,
    uniform_stencils,
)
from ._nodes import corner_patterns, history_nodes, lagrange_integrals, pattern_nodes
from ._program import Combination, Stage, StepProgram
from ._stability import multistep_amplification

__all__ = [
    "STABILITY_INTERVAL_MIN",
    "AdamsBashforth",
    "AdamsRule",
    "Euler",
    "ab_coefficients",
    "ab_error_constant",
    "ab_filter",
    "ab_gain_factor",
    "ab_stability_interval",
    "fill_lagged",
    "lagged_jacobians",
    "warn_if_unstable",
]

# Shortest real stability interval [-2/a_s, 0] accepted without a warning: h |lambda|
# = 0.05 is a sampling period of 1/20 of the fastest time constant. AB6 (0.0877) is
# the last order above it; AB7 has 0.0465.
STABILITY_INTERVAL_MIN = 0.05


def _check_order(s: Any) -> int:
    s = checks.count(s, "s", what="order")
    checks.check_ab_order(s)  # the coefficients' cost and their stability
    return s


@lru_cache(maxsize=64)
def _gammas(s: int) -> tuple[Fraction, ...]:
    """gamma_0, ..., gamma_s of the backward-difference form (see the module docstring)."""
    g: list[Fraction] = []
    for m in range(s + 1):
        g.append(1 - sum((g[m - 1 - k] / (k + 2) for k in range(m)), Fraction(0)))
    return tuple(g)


@lru_cache(maxsize=64)
def ab_coefficients(s: int) -> tuple[Fraction, ...]:
    """Adams-Bashforth coefficients (a_0, ..., a_{s-1}), newest first, exact.

    >>> ab_coefficients(2)
    (Fraction(3, 2), Fraction(-1, 2))
    """
    s = _check_order(s)
    g = _gammas(s)
    return tuple(
        (-1) ** i * sum((comb(j, i) * g[j] for j in range(i, s)), Fraction(0)) for i in range(s)
    )


def ab_error_constant(s: int) -> Fraction:
    """Error constant gamma_s of AB_s: local error ``gamma_s h^{s+1} x^{(s+1)} + ...``.

    (1/2, 5/12, 3/8, 251/720, 95/288, 19087/60480 for s = 1..6.)
    """
    return _gammas(_check_order(s))[s]


def ab_stability_interval(s: int) -> float:
    """Length 2 / a_s of the real stability interval [-2/a_s, 0] of AB_s (h lambda units)."""
    return 2.0 / float(sum((abs(a) for a in ab_coefficients(s)), Fraction(0)))


def warn_if_unstable(s: int, name: str, stacklevel: int = 4) -> None:
    """Warn when the real stability interval of AB_s is below STABILITY_INTERVAL_MIN."""
    beta = ab_stability_interval(s)
    if beta >= STABILITY_INTERVAL_MIN:
        return
    a_s = 2.0 / beta
    warnings.warn(
        f"{name}: Adams-Bashforth of order {s} is stable on the negative real axis only "
        f"for h*lambda in [-{beta:.3g}, 0] (= -2/a_s, a_s = sum|a_i| = {a_s:.4g}; Hairer & "
        f"Wanner, Solving ODEs II, Sec. V.1): below {STABILITY_INTERVAL_MIN}, i.e. any mode "
        f"sampled fewer than {1.0 / beta:.0f} times per time constant makes it unstable as a "
        f"discrete-time model, and one-step predictions amplify noise and input jumps by "
        f"a_s. Orders above 6 fall below that limit (the interval halves with every "
        f"order); use s <= 6.",
        UserWarning,
        stacklevel=stacklevel,
    )


def ab_filter(x: np.ndarray, f: np.ndarray, h: float, weights: np.ndarray) -> np.ndarray:
    """One-step AB prediction as a short FIR filter over precomputed f values.

    Parameters
    ----------
    x : ndarray, shape (N, nx)
        Sampled states.
    f : ndarray, shape (N, nx)
        f(t_n, x_n, u_n) for every sample.
    h : float
        Sampling period (s).
    weights : ndarray, shape (s,)
        a_0..a_{s-1}, newest first.

    Returns
    -------
    ndarray, shape (N, nx): row k predicts x[k] from samples k-1, ..., k-s; the first
    s rows are NaN.
    """
    hw = (float(h) * np.asarray(weights, dtype=float))[None, :]  # one row: every k
    return ab_filter_steps(x, f, hw)


def ab_filter_steps(x: np.ndarray, f: np.ndarray, hw: np.ndarray) -> np.ndarray:
    """:func:`ab_filter` with weights per prediction: row k (k >= s) is
    ``x[k-1] + sum_i hw[k-s, i] f[k-1-i]``; ``hw``, shape (N - s, s), holds
    ``h_n beta_{n,i}`` (:meth:`AdamsRule.step_weights`), or shape (1, s) for the same
    weights on every row. Shape (N, nx), NaN rows 0..s-1.
    """
    n, nx = x.shape
    s = hw.shape[1]
    if n <= s:
        return np.full((n, nx), np.nan)
    out = np.empty((n, nx))
    out[:s] = np.nan  # rows s.. are written by the filter
    _ab_fir(
        np.ascontiguousarray(x, dtype=float),
        np.ascontiguousarray(f, dtype=float),
        np.ascontiguousarray(hw, dtype=float),
        out,
    )
    return out


@njit(cache=True)
def _ab_fir(x, f, hw, out):  # pragma: no cover - compiled
    """out[k] = x[k-1] + sum_i hw[k-s, i] f[k-1-i] for k >= s (hw[0] on every row if hw
    has one row): :func:`sampledyn._sums.fir_rows` over every row."""
    fir_rows(x, f, hw, hw.shape[1], x.shape[0], out, 0)


def fill_lagged(block: np.ndarray, lagged: list[np.ndarray], hw: np.ndarray) -> None:
    """``block[r, i] = [i == 0] I + hw[r, i] J_i[r]`` in place, block shape (R, s, nx, nx),
    ``lagged[i]`` shape (R, nx, nx), ``hw`` shape (R, s)."""
    for i in range(hw.shape[1]):
        block[:, i] = hw[:, i, None, None] * lagged[i]
    block[:, 0] += np.eye(block.shape[-1])


def lagged_jacobians(lagged: list[np.ndarray], hw: np.ndarray, n: int, nx: int) -> np.ndarray:
    """``phi[k, i] = [i == 0] I + hw[k - s, i] J_i[k - s]`` for rows k >= s, NaN above.

    ``lagged[i]`` (shape (N - s, nx, nx)) is df/dx at the point the rule evaluates
    for history lag i of the predictions of rows s..N-1 (empty for N <= s); ``hw``,
    shape (N - s, s) (or anything broadcasting to it, (s,) for N <= s), the step
    weights ``h_n beta_{n,i}``. Shape (N, s, nx, nx).
    """
    s = np.shape(hw)[-1]
    phi = np.full((n, s, nx, nx), np.nan)
    if n <= s:
        return phi
    fill_lagged(phi[s:], lagged, np.broadcast_to(hw, (n - s, s)))
    return phi


@lru_cache(maxsize=128)
def ab_gain_factor(s: int, ratio: float) -> float:
    """``sup h_n sum_i |beta_{n,i}|`` over the step patterns whose s steps (the predicted
    step and the s - 1 history steps) lie in [h_max / ratio, h_max], in units of h_max:
    the noise gain of the variable-step AB_s is this times ``h_max L``. Equal to a_s
    for ratio = 1 (see :mod:`sampledyn.methods._nodes` for why the corners suffice)."""
    tau, hn = pattern_nodes(corner_patterns(s, ratio))
    return float((hn * np.abs(lagrange_integrals(tau, 0.0, 1.0)).sum(axis=1)).max())


@dataclass(frozen=True)
class AdamsRule(FixedRule):
    """What the rules that weight an f-history with the AB_s coefficients share (AB_s,
    ABu_s, ABj_s): order s, history s, coefficients, noise gain a_s, error constant
    gamma_s, the stability warning past s = 6. Subclasses set ``FAMILY`` (also the
    prefix of their default name) and say how the f-history is made."""

    FAMILY: ClassVar[str] = "AB"

    order: int
    name: str = ""
    coefficients: tuple[Fraction, ...] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "coefficients", ab_coefficients(self.order))
        if not self.name:
            object.__setattr__(self, "name", f"{self.FAMILY}{self.order}")
        warn_if_unstable(self.order, self.name)

    @property
    def family(self) -> str:
        return self.FAMILY

    @property
    def history(self) -> int:
        """Number of past samples the rule needs: s."""
        return self.order

    @property
    def intersample(self) -> bool:
        """False: f only at the sample times, the input held over the interval."""
        return False

    @property
    def a_s(self) -> Fraction:
        """sum of |a_i|, the noise gain of eqs. (24)-(25)."""
        return sum((abs(a) for a in self.coefficients), Fraction(0))

    @property
    def weights(self) -> np.ndarray:
        """Coefficients as floats, newest first, shape (s,)."""
        return np.array([float(a) for a in self.coefficients])

    @property
    def first_order_gain(self) -> Fraction:
        """a_s = sum |a_i|: the noise gain is ``h a_s L`` (eqs. (11)-(12), (24)-(25))."""
        return self.a_s

    @property
    def error_constant(self) -> Fraction:
        """gamma_s: local error ``gamma_s h^{s+1} x^{(s+1)}`` where the history is smooth."""
        return ab_error_constant(self.order)

    @property
    def step_rule(self) -> str:
        return "Adams weights of the actual nodes (Lagrange integrals over [t_n, t_n+1])"

    def step_weights(self, data: Trajectory, h: float | None) -> np.ndarray:
        """``h_n beta_{n,i}`` of the predictions of rows s..N-1 (n = s-1..N-2), shape
        (N - s, s), newest first (N > s).

        ``h`` is :func:`fixed_step` of ``data``: on a uniform grid every row is
        ``h a_i`` (the fixed coefficients, exactly as the fixed-step rule forms them);
        otherwise the Lagrange weights of the actual nodes (:mod:`._nodes`).
        """
        s, n = self.order, data.n_samples
        if h is not None:
            return np.broadcast_to(h * self.weights, (n - s, s))
        time_steps(data)  # strictly increasing, or a named error
        tau, hn = history_nodes(data.t, s, np.arange(s - 1, n - 1))
        return hn[:, None] * lagrange_integrals(tau, 0.0, 1.0)

    def amplification(self, z: Any) -> np.ndarray:
        """Largest |zeta| of ``zeta^s - zeta^(s-1) - z sum_i a_i zeta^(s-1-i)`` at each
        z = h lambda (the stability region of the AB_s recursion; ABu_s and ABj_s
        weight their f-history with the same coefficients, so the homogeneous
        recursion, and its region, is the same)."""
        return multistep_amplification(self.coefficients, z)

    def noise_gain(self, h: float, lipschitz: Any, ratio: float = 1.0) -> np.ndarray:
        """``G = h a_s L`` on a uniform grid (eqs. (11)-(12), (24)-(25); the printed (11)
        lacks the factor h, which the dimensions require). With steps up to h within a
        factor ``ratio`` of each other in every stencil: ``h A_s(ratio) L`` with
        A_s = :func:`ab_gain_factor` (the worst step pattern; A_s(1) = a_s)."""
        h, L = check_gain_args(h, lipschitz)
        if check_ratio(ratio) == 1.0:
            return h * float(self.a_s) * L
        return h * ab_gain_factor(self.order, check_ratio(ratio)) * L


@dataclass(frozen=True)
class AdamsBashforth(AdamsRule):
    """Adams-Bashforth rule of order s (explicit, s-step), family "AB" (Euler is AB1).

    Attributes
    ----------
    order : int
        s >= 1; AB1 is Euler. Orders above 6 warn (stability interval below 0.05,
        see the module docstring).
    coefficients : tuple of Fraction
        a_0..a_{s-1}, newest first; they sum to 1.
    a_s : Fraction
        sum of |a_i|, the noise gain of eqs. (24)-(25).
    """

    @property
    def sample_weights(self) -> np.ndarray:
        return self.weights

    def predict(
        self,
        model: Model,
        data: Trajectory,
        signal: Any = None,
        *,
        cache: dict[Any, Any] | None = None,
    ) -> np.ndarray:
        """One-step-ahead predictions, shape (N, nx), NaN in the first s rows; f is
        evaluated once per sample (shared through ``cache``). On a non-uniform grid the
        weights are those of the actual nodes (:meth:`step_weights`).

        ``signal`` is not used: AB needs no input between samples.
        """
        return ab_filter_steps(data.x, *self.sample_filter(model, data, cache=cache))

    def sample_filter(
        self, model: Model, data: Trajectory, *, cache: dict[Any, Any] | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(f, hw)`` of :meth:`predict` = :func:`ab_filter_steps` ``(data.x, f, hw)``: f at
        the samples, shape (N, nx), and the weights ``h_n beta_{n,i}``, shape (1, s) on a
        uniform grid (``h a_i``, as :func:`ab_filter` forms them) or (N - s, s). A caller
        that needs only some rows of the prediction, or its errors, forms them from
        these (:meth:`sampledyn._local_errors.ErrorWindow.norms_of_sets`)."""
        f = sample_f(model, data, cache)
        h = fixed_step(data)
        if h is None and data.n_samples > self.order:
            return f, self.step_weights(data, None)
        step = data.h if h is None else h  # N <= s: NaN rows only
        return f, (float(step) * self.weights)[None, :]

    def prediction_jacobians(
        self,
        model: Model,
        data: Trajectory,
        signal: Any = None,
        *,
        cache: dict[Any, Any] | None = None,
    ) -> np.ndarray:
        """``Phi_{k,0} = I + h a_0 F(x_{k-1})``, ``Phi_{k,i} = h a_i F(x_{k-1-i})``,
        shape (N, s, nx, nx) (F = df/dx at the samples; ``h_n beta_{n,i}`` in place of
        ``h a_i`` on a non-uniform grid)."""
        n, s = data.n_samples, self.order
        if n <= s:
            return lagged_jacobians([], self.weights, n, data.nx)
        hw = self.step_weights(data, fixed_step(data))
        jac = sample_jacobian(model, data, cache)
        lagged = [jac[s - 1 - i : n - 1 - i] for i in range(s)]
        return lagged_jacobians(lagged, hw, n, data.nx)

    def truncation_differences(
        self,
        model: Model,
        data: Trajectory,
        signal: Any = None,
        *,
        cache: dict[Any, Any] | None = None,
    ) -> np.ndarray:
        """``nabla^s f`` along the samples, shape (M, nx): every stencil (M = N - s) on a
        uniform grid, else the stencils whose s steps all equal ``data.h``."""
        d = np.diff(sample_f(model, data, cache), n=self.order, axis=0)
        return d if fixed_step(data) is not None else d[uniform_stencils(data, self.order)]

    # ---- discrete-time state-space form (used by sampledyn.discretize) ----------

    @property
    def discrete_step(self) -> StepProgram:
        """z = (x_n, f_{n-1}, ..., f_{n-s+1}) (f at the samples, with their inputs):
        ``x_{n+1} = x_n + sum_i (h a_i) f_{n-i}`` with f_n = f(t_n, x_n, u_n), in the
        order of :func:`ab_filter` (one step from the z of sampled data is the
        one-step prediction, bit for bit), then the f-history shifted by one."""
        s, w = self.order, [float(v) for v in self.weights]
        terms = ((w[0], ("k", 0)), *((w[i], ("z", i)) for i in range(1, s)))
        return StepProgram(
            self.name,
            (("x", 0), *(("f", i) for i in range(1, s))),
            (Stage(0.0, ("z", 0)),),
            Combination(("z", 0), terms),
            (("k", 0), *(("z", i) for i in range(1, s - 1)))[: s - 1],
        )


def Euler() -> AdamsBashforth:  # noqa: N802 - reads as a class in user code
    """Forward Euler, ``x_{n+1} = x_n + h f(t_n, x_n, u_n)``: the rule AB1 (= RK1)."""
    return AdamsBashforth(1, name="E")

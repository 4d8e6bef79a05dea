"""What the sampled-data rules answer: small protocols, and the pieces the rules share.

A *method* (a rule) turns a continuous-time model x' = f(t, x, u) and sampled data
(t_n, x_n, u_n) into one-step-ahead predictions x^_{n+1}, or a model and a period h
into a discrete-time system z+ = F(z, u). Everything that depends on which rule it is
lives in the rule's own class; every other layer asks the object, and asks what it
can do with ``isinstance`` against these runtime-checkable protocols (one question,
one way):

:class:`Method` (every registered rule)
    ``name`` (registry name, e.g. "AB4", "RK2", "T", "ABu3", "ABe2", "ZOH"),
    ``family`` ("AB" (Euler is AB1), "ABu", "ABj", "RK", "T", "ABe", "ZOH"),
    ``order`` (s: local error O(h^{s+1}) on smooth data; None for the exact map ZOH,
    which has no truncation error), ``history`` (samples x_n, ..., x_{n-history+1}
    one step uses), ``label`` (display text).
:class:`Predictor` (rules that predict on sampled data: all but ZOH)
    ``predict(model, data, signal=None, *, cache=None)``: x^ for every sample, shape
    (N, nx), NaN rows where history lacks; ``intersample``: True if f is evaluated
    between samples (RK stages with c > 0, Tustin's end point), so the input inside
    the interval matters (from ``signal``); ``variable_step``: True if ``predict``
    takes non-uniform sample times (steps ``h_n = t_{n+1} - t_n`` as they come),
    False if it refuses them (:func:`uniform_step`); ``step_rule``: how it uses the
    actual steps, for printing; ``sample_weights``: w with x^_{n+1} = x_n + h sum_i
    w_i f(t_{n-i}, x_{n-i}, u_{n-i}) exactly on a uniform grid, newest first (AB_s,
    Euler, RK1), else None.
:class:`NoiseAnalysis` (the fixed predictors: a noise bound and error constant)
    ``noise_gain(h, L, ratio)``: G of the disturbed-error bound (24)-(25), h the
    largest step, ratio the largest step ratio in a stencil (:func:`stencil_steps`; 1
    on a uniform grid); ``first_order_gain``: c of G = c h L + O((h L)^2) (a_s =
    sum |a_i| for AB_s); ``prediction_jacobians``: d x^_{n+1} / d x_{n-i}, i <
    history, the linearisation used by the path-based noise prediction;
    ``error_constant``: C of the leading local error C h^{s+1} x^{(s+1)}, None where
    the rule has no single constant (RK_s, s >= 2); ``truncation_differences``: the
    s-th backward differences of the derivative values the rule extrapolates
    (leading local error = C h times them), or None.
:class:`Estimator` (Ee, ABe_s: the rule fits the model's parameters on the data it
predicts, so it has no noise bound and no fixed discrete-time map)
    ``estimate_and_predict(model, data, signal=None, *, after=None)``.
:class:`Stability` (every rule but the estimated ones)
    ``amplification(z)``: how much the rule multiplies the mode y' = lambda y per step
    at z = h lambda, all z of an array at once: |R(z)| of a one-step rule (its
    stability function), the largest root modulus of a multistep rule's
    characteristic polynomial; stable where <= 1 (:mod:`sampledyn.methods._stability`,
    :func:`largest_stable_steps`).
:class:`DiscreteTimeSystem` (every fixed rule but ABj_s, and ZOH)
    ``discrete_step``: the step z+ = F(z, u) as data (:class:`DiscreteStep`:
    :class:`sampledyn.methods.StepProgram` for the rules built of f evaluations,
    their coefficients or tableau, from which the compiled step, the numpy/CasADi
    blocks and the exact linearisation are derived in one place; the exact flow for
    ZOH), used by :func:`sampledyn.discretize`. A rule that is no such system says
    why in its ``no_discrete_step`` text (ABj_s: a switch on past inputs).

Prediction takes the sample times ``data.t`` as they come: a rule decides itself
whether it can work on a non-uniform grid, and nobody else checks the grid. On a grid
that is uniform to the rounding of t (:func:`fixed_step`) every rule runs its
fixed-step code (fixed coefficients, one h); elsewhere the variable-step rules use
the actual steps (AB_s family: the Lagrange weights of the actual nodes,
:mod:`sampledyn.methods._nodes`; one-step rules: h_n per interval), and the others
raise naming the step (:func:`uniform_step`).

The ``cache`` argument of ``predict`` and ``prediction_jacobians`` is a plain dict the
caller may pass and keep for several rules on the same data: f (and df/dx) at the
samples are then computed once and shared, e.g. by every AB order of a study.
"""

from __future__ import annotations

from collections.abc import Callable
from fractions import Fraction
from typing import Any, Protocol, runtime_checkable

import numpy as np

from .. import _checks as checks
from .._trajectory import Trajectory, steps_on_grid, uniform_grid
from ..models import Model

__all__ = [
    "DiscreteStep",
    "DiscreteTimeSystem",
    "Estimator",
    "Method",
    "NoiseAnalysis",
    "Predictor",
    "Stability",
    "check_gain_args",
    "check_ratio",
    "fixed_step",
    "grid_steps",
    "sample_f",
    "sample_jacobian",
    "stage_inputs",
    "stencil_steps",
    "time_steps",
    "uniform_grid",
    "uniform_stencils",
    "uniform_step",
]


@runtime_checkable
class Method(Protocol):
    """What every registered rule answers (see the module docstring)."""

    @property
    def name(self) -> str: ...

    @property
    def family(self) -> str: ...

    @property
    def order(self) -> int | None: ...

    @property
    def history(self) -> int: ...

    @property
    def label(self) -> str: ...


@runtime_checkable
class Predictor(Method, Protocol):
    """A rule that predicts x_{n+1} from sampled data (see the module docstring)."""

    @property
    def order(self) -> int: ...

    @property
    def intersample(self) -> bool: ...

    @property
    def variable_step(self) -> bool: ...

    @property
    def step_rule(self) -> str: ...

    @property
    def sample_weights(self) -> np.ndarray | None: ...

    def predict(
        self,
        model: Model,
        data: Trajectory,
        signal: Any = None,
        *,
        cache: dict[Any, Any] | None = None,
    ) -> np.ndarray:
        """x_hat[k] predicts data.x[k] from samples before k, shape (N, nx); NaN rows
        where the history is missing (the first ``history`` rows)."""
        ...


@runtime_checkable
class NoiseAnalysis(Protocol):
    """A fixed predictor's noise gain, linearisation on data and error constant."""

    @property
    def first_order_gain(self) -> Fraction: ...

    @property
    def error_constant(self) -> Fraction | None: ...

    def noise_gain(self, h: float, lipschitz: Any, ratio: float = 1.0) -> np.ndarray:
        """Noise gain G, shape (k, k), of the bound (24)-(25) for blockwise Lipschitz
        constants ``lipschitz`` (k, k): h (s) the sampling period, or on a non-uniform
        grid its largest step; ``ratio`` >= 1 the largest ratio of the longest to the
        shortest step in one prediction's stencil (:func:`stencil_steps`)."""
        ...

    def prediction_jacobians(
        self,
        model: Model,
        data: Trajectory,
        signal: Any = None,
        *,
        cache: dict[Any, Any] | None = None,
    ) -> np.ndarray:
        """``phi[k, i] = d x_hat[k] / d x[k - 1 - i]``, shape (N, history, nx, nx);
        NaN rows where ``predict`` has NaN rows."""
        ...

    def truncation_differences(
        self,
        model: Model,
        data: Trajectory,
        signal: Any = None,
        *,
        cache: dict[Any, Any] | None = None,
    ) -> np.ndarray | None:
        """s-th backward differences of the extrapolated derivative values, one row
        per prediction with a full difference stencil (possibly none); None without an
        error constant."""
        ...


@runtime_checkable
class Stability(Protocol):
    """A rule's linear stability on y' = lambda y (see the module docstring)."""

    def amplification(self, z: Any) -> np.ndarray:
        """Growth per step at ``z = h lambda`` (complex array, any shape; result of that
        shape): |R(z)| for a one-step rule, the largest |zeta| of the characteristic
        polynomial for a multistep one. Stable where <= 1."""
        ...


@runtime_checkable
class Estimator(Predictor, Protocol):
    """A rule that estimates the model's parameters on the data it predicts."""

    def estimate_and_predict(
        self, model: Model, data: Trajectory, signal: Any = None, *, after: float | None = None
    ) -> tuple[np.ndarray, Any]:
        """``(x_hat, EstimationResult)``: the estimate on ``data`` and the predictions."""
        ...


@runtime_checkable
class DiscreteStep(Protocol):
    """A rule's step z+ = F(z, u) as data, and what is derived from it.

    ``layout``: the blocks of z, each nx long: ("x", lag) a past state, ("f", lag) f
    at a past sample (with its input); ``kernels``: the model kernels the compiled
    step calls ("rhs", "jac", or "flow", the exact flow over one interval, which
    :func:`sampledyn.discretize` provides); ``takes_f0``: the source also defines
    ``step_f(t, z, f0, u, p, h, out)``, the step given f0 = f(t, x_n, u);
    ``source()``: numba source of ``step(t, z, u, p, h, out)``; ``blocks(f, t,
    blocks, u, h, solver)``: the step in vector arithmetic (numpy or CasADi);
    ``linearize(model, t, z, u, h, solver)``: (A_d, B_d), exact (ZOH's asks the
    ``solver`` for the flow's variational equations); ``steady_state(model, x,
    u, t)``: z of a constant history.
    """

    @property
    def layout(self) -> tuple[tuple[str, int], ...]: ...

    @property
    def kernels(self) -> frozenset[str]: ...

    @property
    def takes_f0(self) -> bool: ...

    def source(self) -> str:
        """The numba source of the compiled step (see the class docstring)."""
        ...

    def blocks(
        self, f: Any, t: Any, blocks: list[Any], u: Any, h: float, solver: Any = None
    ) -> list[Any]:
        """The next state's blocks from the current ones, on numpy or CasADi values."""
        ...

    def linearize(
        self,
        model: Model,
        t: float,
        z: np.ndarray,
        u: np.ndarray,
        h: float,
        solver: Any = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(A_d, B_d)`` of z+ = F(z, u) at ``(z, u)``, exact (``solver``: what the
        caller integrates with, as for ``blocks``)."""
        ...

    def steady_state(self, model: Model, x: np.ndarray, u: np.ndarray, t: float = 0.0) -> Any:
        """The state z of a constant history at ``(x, u)``."""
        ...


@runtime_checkable
class DiscreteTimeSystem(Method, Protocol):
    """A rule that is a discrete-time state-space system z+ = F(z, u)."""

    @property
    def discrete_step(self) -> DiscreteStep: ...


class FixedRule:
    """Defaults of the fixed predictors (every :class:`Predictor` but Ee / ABe_s)."""

    name: str

    @property
    def label(self) -> str:
        return self.name

    @property
    def sample_weights(self) -> np.ndarray | None:
        """None unless the rule is a fixed filter of f at the samples."""
        return None

    @property
    def variable_step(self) -> bool:
        """True: the fixed rules here predict on non-uniform time stamps too."""
        return True

    def truncation_differences(
        self,
        model: Model,
        data: Trajectory,
        signal: Any = None,
        *,
        cache: dict[Any, Any] | None = None,
    ) -> np.ndarray | None:
        """None unless the rule's leading error is read off differences of f."""
        return None


# ---------------------------------------------------------------------------------
# shared pieces


def uniform_stencils(data: Trajectory, width: int) -> np.ndarray:
    """Per window of ``width`` consecutive steps (N - width windows, the r-th starting
    at t_r): True where all of them equal ``data.h`` (as :func:`uniform_grid`)."""
    on = steps_on_grid(data.t, data.h) if data.n_samples > 1 else np.zeros(0, dtype=bool)
    if on.size < width:
        return np.zeros(0, dtype=bool)
    return np.asarray(np.lib.stride_tricks.sliding_window_view(on, width).all(axis=1))


def fixed_step(data: Trajectory) -> float | None:
    """``data.h`` if ``data.t`` is uniform with that step (:func:`uniform_grid`), else
    None (then a rule predicts on the steps of :func:`time_steps`)."""
    return float(data.h) if data.on_uniform_grid else None


def grid_steps(data: Trajectory) -> tuple[float | None, np.ndarray]:
    """``(h, steps)``: what a one-step rule needs to step each interval, steps shape
    (N - 1,). On a uniform grid (:func:`fixed_step`) h and every step equal ``data.h``
    exactly (so ``steps * c`` gives the bits of ``h * c``); otherwise h is None and
    the steps are the actual ones (:func:`time_steps`)."""
    h = fixed_step(data)
    if h is not None:
        return h, np.full(max(data.n_samples - 1, 0), h)
    return None, time_steps(data)


def time_steps(data: Trajectory) -> np.ndarray:
    """The steps ``h_n = t_{n+1} - t_n`` (s), shape (N - 1,).

    Raises
    ------
    ValueError
        if the times do not increase strictly (naming the first such sample).
    """
    steps = np.diff(data.t)
    bad = np.flatnonzero(~(steps > 0))
    if bad.size:
        n = int(bad[0])
        raise ValueError(
            f"`data.t` must increase strictly: t[{n + 1}] = {data.t[n + 1]:.9g} s does not "
            f"follow t[{n}] = {data.t[n]:.9g} s. Sort the samples by time and remove "
            "duplicate stamps."
        )
    return steps


def stencil_steps(data: Trajectory, history: int) -> tuple[float, float]:
    """``(h_max, ratio)`` of ``data`` for a rule that looks ``history`` samples back: the
    largest step (s), and the largest ratio of the longest to the shortest step among
    the ``history`` steps ``h_{n-history+1}, ..., h_n`` one prediction spans (its
    history steps and the predicted step). ``(data.h, 1.0)`` on a uniform grid
    (:func:`uniform_grid`). These are the arguments of :meth:`Method.noise_gain`.
    """
    if fixed_step(data) is not None:
        return float(data.h), 1.0
    steps = time_steps(data)
    w = min(max(int(history), 1), steps.size)
    windows = np.lib.stride_tricks.sliding_window_view(steps, w)
    return float(steps.max()), float((windows.max(axis=1) / windows.min(axis=1)).max())


def check_ratio(ratio: Any) -> float:
    """``ratio`` of :meth:`Method.noise_gain`, checked (a finite number >= 1)."""
    if not (
        isinstance(ratio, int | float | np.floating | np.integer)
        and np.isfinite(ratio)
        and ratio >= 1.0
    ):
        raise ValueError(
            f"step `ratio` must be a finite number >= 1 (longest / shortest step in a "
            f"stencil, 1 on a uniform grid), got {ratio!r}."
        )
    return float(ratio)


def uniform_step(data: Trajectory, method: str) -> float:
    """The sampling period of ``data``, after checking that ``data.t`` is uniform.

    Raises
    ------
    ValueError
        naming the step that deviates most from ``data.h`` (relative tolerance 1e-6),
        for rules that predict on a uniform grid only.
    """
    h = float(data.h)
    steps = np.diff(data.t)
    if steps.size:
        dev = np.abs(steps - h)
        n = int(np.argmax(dev))
        if dev[n] > 1e-6 * h:
            raise ValueError(
                f"the data are not uniformly sampled with h={h} s: t[{n + 1}] - t[{n}] = "
                f"{steps[n]:g} s, {dev[n]:.3g} s from h (the largest deviation). {method} "
                "predicts on a uniform grid only; resample the data to a uniform grid."
            )
    return h


def _cached(
    kind: str,
    model: Model,
    data: Trajectory,
    cache: dict[Any, Any] | None,
    compute: Callable[[], Any],
) -> np.ndarray:
    """``compute()`` once per (kind, model, data) in ``cache``; the value is read-only.

    Entries keep the model and the data they belong to and are used only for those
    very objects, so one cache may serve several data sets without mixing them up.
    """
    if cache is None:
        return np.asarray(compute())
    key = (kind, id(model), id(data))
    hit = cache.get(key)
    if hit is not None and hit[0] is model and hit[1] is data:
        return hit[2]
    # A read-only copy: whoever returned the array (a model's own buffer, a view of
    # it) may still write to it. The copy costs about 1 ms for 50,001 x 12 samples.
    value = np.array(compute(), dtype=float)
    value.setflags(write=False)
    cache[key] = (model, data, value)
    return value


def sample_f(model: Model, data: Trajectory, cache: dict[Any, Any] | None = None) -> np.ndarray:
    """``f(t_n, x_n, u_n)`` for every sample, shape (N, nx), shared through ``cache``."""
    return _cached("f", model, data, cache, lambda: model.f(data.t, data.x, data.u))


def sample_jacobian(
    model: Model, data: Trajectory, cache: dict[Any, Any] | None = None
) -> np.ndarray:
    """``df/dx (t_n, x_n, u_n)`` for every sample, shape (N, nx, nx), shared through
    ``cache``."""
    return _cached("jac", model, data, cache, lambda: model.jacobian(data.t, data.x, data.u))


def stage_inputs(
    data: Trajectory, signal: Any, c: float, steps: np.ndarray | None = None
) -> np.ndarray:
    """Input at ``t_n + c h_n`` for every interval n = 0..N-2, shape (N - 1, nu).

    ``steps`` are the steps h_n, shape (N - 1,), on a non-uniform grid; None on a
    uniform one (then ``signal.intersample`` gets the one offset ``c data.h``, as the
    Signal protocol has it; a non-uniform grid needs a signal that takes an array of
    offsets, as :class:`sampledyn.signals.Signal` does). From ``signal`` (its held
    part taken at ``t_n``) when given, else from the signal the data remember
    (``data.signal``, set by :func:`sampledyn.simulate`), else the sampled input held
    over the interval (zero-order hold).
    """
    if signal is None:
        signal = getattr(data, "signal", None)
    if signal is None or c == 0.0:
        return data.u[:-1]
    tau = c * data.h if steps is None else c * steps
    u = np.asarray(signal.intersample(data.t[:-1], tau), dtype=float)
    if u.shape != (data.n_samples - 1, data.nu):
        raise ValueError(
            f"`signal` gives inputs of shape {u.shape[1:]}, the data have nu = {data.nu}."
        )
    return u


def check_gain_args(h: Any, lipschitz: Any) -> tuple[float, np.ndarray]:
    """``(h, L)`` for :meth:`Method.noise_gain`, checked.

    Raises
    ------
    ValueError
        if ``lipschitz`` is not a finite non-negative square array, or h is not > 0.
    """
    L = np.asarray(lipschitz, dtype=float)
    if (
        L.ndim != 2
        or L.shape[0] != L.shape[1]
        or L.size == 0
        or (L < 0).any()
        or not np.isfinite(L).all()
    ):
        raise ValueError(
            f"`lipschitz` must be a finite non-negative square array (2x2: eta and v "
            f"blocks), got {lipschitz!r}."
        )
    return checks.period(h), L


def nan_rows(data: Trajectory, shape: tuple[int, ...] = ()) -> np.ndarray:
    """An (N, *shape) array of NaN, the frame every prediction is written into."""
    return np.full((data.n_samples, *shape), np.nan)

"""Estimated Adams-Bashforth rules, Ee (= ABe1) and ABe_s (paper, section 4.2).

A rule of this family first estimates the model's parameters on the data it is asked
to predict, minimising the l_p norm of the AB_s one-step errors
(:func:`sampledyn.estimate`), then predicts with AB_s and the estimated model. The
object itself holds only settings (frozen); the estimate is returned by
:meth:`EstimatedAdamsBashforth.estimate` or :func:`sampledyn.estimate_and_predict`.

The method registry lists the family as a lazy entry ("Ee", "ABe<s>" ->
:func:`estimated_euler`, :class:`EstimatedAdamsBashforth`), imported on first use:
nothing here writes into the registry below.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._trajectory import Trajectory
from ..methods import ab_coefficients
from ..methods._adams import warn_if_unstable
from ..methods._stability import multistep_amplification
from ..models._base import ParametricModel
from ._estimate import EstimationResult, estimate_and_predict

__all__ = ["EstimatedAdamsBashforth", "estimated_euler"]


@dataclass(frozen=True)
class EstimatedAdamsBashforth:
    """ABe_s: Adams-Bashforth of order s with parameters estimated on the data.

    Parameters
    ----------
    order : int
        s >= 1; order 1 is "Ee", estimated Euler.
    name : str
        Defaults to "ABe<s>".
    p : float
        Norm of the one-step errors minimised, 1 <= p <= inf. Default 2.
    after_fraction : float, optional
        Estimate on the samples with ``t >= t_0 + after_fraction (t_end - t_0)``
        only (the "stationary state"); None uses every sample. Predictions are made
        for every sample either way.
    params : tuple of str, optional
        Parameters to estimate (default: those ``model.regressors`` is linear in).
    free_weights : bool
        Estimate the s AB weights too (see :func:`sampledyn.estimate`; a uniform grid
        only).
    skip_input_jumps : bool or None
        Leave out the one-step errors whose history straddles an input jump (None: when
        the input is piecewise constant; see :func:`sampledyn.estimate`). Default
        False: the rule as the paper defines it, every one-step error counted (its
        Fig. 2); the estimate says how many straddle a jump.
    """

    order: int
    name: str = ""
    p: float = 2.0
    after_fraction: float | None = None
    params: tuple[str, ...] | None = None
    free_weights: bool = False
    skip_input_jumps: bool | None = False

    def __post_init__(self) -> None:
        ab_coefficients(self.order)  # validates the order
        if not self.name:
            object.__setattr__(self, "name", f"ABe{self.order}")
        warn_if_unstable(self.order, self.name)
        if self.after_fraction is not None and not (0.0 <= self.after_fraction < 1.0):
            raise ValueError(
                f"`after_fraction` must be in [0, 1) or None, got {self.after_fraction}."
            )
        if not (self.p >= 1.0 or math.isinf(self.p)):
            raise ValueError(f"`p` must be >= 1, got {self.p}.")
        if self.params is not None:
            object.__setattr__(self, "params", tuple(self.params))

    # -- what the rule is (the Predictor and Estimator protocols) ---------------------

    @property
    def family(self) -> str:
        return "ABe"

    @property
    def history(self) -> int:
        return self.order

    @property
    def label(self) -> str:
        return self.name if self.p == 2 else f"{self.name} (l_{self.p:g})"

    @property
    def intersample(self) -> bool:
        return False

    @property
    def sample_weights(self) -> None:
        """None: the rule is AB_s only after its parameters have been fitted."""
        return None

    @property
    def variable_step(self) -> bool:
        """True unless the weights are estimated: the regression and the prediction use
        the weights of the actual nodes on a non-uniform grid, as AB_s does."""
        return not self.free_weights

    @property
    def step_rule(self) -> str:
        if self.free_weights:
            return "uniform grid only (estimated weights)"
        return "estimated on, and predicting with, the Adams weights of the actual nodes"

    def amplification(self, z: Any) -> np.ndarray:
        """The AB_s recursion's largest root modulus at z = h lambda (it predicts with
        AB_s; lambda are then eigenvalues of the estimated model's Jacobian)."""
        return multistep_amplification(ab_coefficients(self.order), z)

    # -- estimation --------------------------------------------------------------------

    @property
    def structure(self) -> str:
        """The fixed rule whose one-step errors are minimised, "AB<s>"."""
        return f"AB{self.order}"

    def _after(self, data: Trajectory) -> float | None:
        if self.after_fraction is None:
            return None
        t0, t1 = float(data.t[0]), float(data.t[-1])
        return t0 + self.after_fraction * (t1 - t0)

    def estimate_and_predict(
        self,
        model: ParametricModel,
        data: Trajectory,
        signal: Any = None,
        *,
        after: float | None = None,
    ) -> tuple[np.ndarray, EstimationResult]:
        """``(x_hat, EstimationResult)``: the estimate on ``data`` and the one-step
        predictions of AB_s with it, x_hat shape (N, nx).

        ``after`` (s), when given, starts the estimation window there instead of at
        ``after_fraction``.
        """
        return estimate_and_predict(
            model,
            data,
            self.structure,
            signal=signal,
            p=self.p,
            after=self._after(data) if after is None else after,
            params=self.params,
            free_weights=self.free_weights,
            skip_input_jumps=self.skip_input_jumps,
        )

    def estimate(
        self, model: ParametricModel, data: Trajectory, signal: Any = None
    ) -> EstimationResult:
        """The :class:`~sampledyn.EstimationResult` this rule predicts with."""
        return self.estimate_and_predict(model, data, signal)[1]

    def predict(
        self, model: ParametricModel, data: Trajectory, signal: Any = None, *, cache: Any = None
    ) -> np.ndarray:
        """Estimate on ``data``, then x_hat[n + 1] for every n, shape (N, nx); NaN in
        the first s rows. ``model`` supplies the structure and the fixed parameters;
        ``cache`` is not used (f changes with the estimate)."""
        return self.estimate_and_predict(model, data, signal)[0]


def estimated_euler() -> EstimatedAdamsBashforth:
    """Ee: estimated Euler, ABe1 under its own name."""
    return EstimatedAdamsBashforth(1, name="Ee")

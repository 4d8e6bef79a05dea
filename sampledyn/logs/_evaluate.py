"""Local errors of sampled-data models on a real (validated) log."""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import error_norm, local_errors
from ..estimate import EstimationResult
from ..methods import get_method
from ..noise import NOISE_REFERENCE
from ..predict import predict
from ._read import LogData

__all__ = ["LogEvaluation", "evaluate_log"]


@dataclass(frozen=True)
class LogEvaluation:
    """Result of :func:`evaluate_log`.

    Attributes
    ----------
    rows : list of dict
        One per method: ``method``, ``order``, ``err_eta``, ``err_v``, ``err_all``
        (the norm over position/angle, rate and all components) and ``samples``.
    estimation : EstimationResult or None
        The parameters estimated for an ABe_s / Ee row.
    warnings : tuple of str
    """

    rows: list[dict[str, Any]]
    estimation: EstimationResult | None
    warnings: tuple[str, ...]


def _mask(valid: np.ndarray, history: int) -> np.ndarray:
    """True at k if rows k - history .. k are all valid."""
    ok = valid.copy()
    for lag in range(1, history + 1):
        ok[lag:] &= valid[:-lag]
        ok[:lag] = False
    return ok


def _norms(
    err: np.ndarray, data: LogData, where: np.ndarray, norm: str, after: float | None
) -> dict[str, Any]:
    kind = np.array([NOISE_REFERENCE.get(u, ("", 0.0))[0] for u in data.traj.state_units])
    t = data.traj.t
    out: dict[str, Any] = {}
    for name, idx in (
        ("err_eta", np.flatnonzero(kind == "eta")),
        ("err_v", np.flatnonzero(kind == "v")),
    ):
        out[name] = error_norm(err, t, norm, after, idx, where=where) if idx.size else float("nan")
    out["err_all"] = error_norm(err, t, norm, after, where=where)
    keep = where & ~np.isnan(err).any(axis=1)
    if after is not None:
        keep &= t >= after
    out["samples"] = int(keep.sum())
    return out


def evaluate_log(
    model: Any,
    data: LogData,
    methods: Sequence[str],
    *,
    norm: str = "rms",
    after: float | None = None,
) -> LogEvaluation:
    """Disturbed local errors (section 5.1) of each method on the log.

    Parameters
    ----------
    model : Model
    data : LogData
        From :func:`read_log`.
    methods : sequence of str
        Registry names ("E", "AB2", "RK4", "T", ...). Runge-Kutta stages use the
        logged input held over each interval (zero-order hold). An estimated rule
        ("Ee", "ABe<s>") first estimates the model's parameters on the log (l_2 norm
        of the AB_s one-step errors on t >= after), then predicts with them.
    norm : str
        See :func:`sampledyn.error_norm`.
    after : float, optional
        Count the errors on t >= after (s, log time) only.

    Returns
    -------
    LogEvaluation
    """
    if not methods:
        raise ValueError("`methods` must name at least one method, e.g. ['E', 'AB2'].")
    rows: list[dict[str, Any]] = []
    estimation = None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for name in methods:
            method: Any = get_method(name)
            if method.estimates_params:
                x_hat, estimation = method.estimate_and_predict(model, data.traj, after=after)
            else:
                x_hat = predict(method, model, data.traj)
            err = local_errors(x_hat, data.traj)
            row = {"method": name, "order": int(method.order)}
            row.update(_norms(err, data, _mask(data.valid, method.history), norm, after))
            rows.append(row)
    msgs = tuple(dict.fromkeys(str(w.message) for w in caught))
    return LogEvaluation(rows, estimation, msgs)

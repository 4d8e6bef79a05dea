"""Which sampled-data model to use: rank the rules for a vehicle, h and noise level.

For each rule the advice gives

* the **predicted** largest disturbed local errors (first order in the noise, along a
  reference run: :func:`path_prediction`), by which the rules are ranked;
* the **guaranteed** bound (24)-(25) over the domain of that run
  (:func:`disturbed_error_bound`), never below the measured errors but loose for
  Runge-Kutta and Tustin once h L >~ 1;
* the **measured** largest (and rms) errors on noisy copies of the run, when
  ``validate``;
* the largest h whose prediction (and whose bound) stays under a tolerance.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._trajectory import Trajectory
from ..noise import add_noise, noise_amplitudes
from ._bound import jacobian_pair, subsample
from ._curves import ErrorCurves, error_curves, h_grid
from ._domain import Domain, check_vehicle, pitch_guard
from ._gains import first_order_gain, supported_method
from ._inputs import gentle_input
from ._jacobians import JacobianReport
from ._validate import measured_errors

__all__ = ["DEFAULT_METHODS", "TIE", "Advice", "AdviceRow", "advise", "largest_h"]

DEFAULT_METHODS = ("E", "AB2", "AB3", "AB4", "AB5", "AB6", "RK2", "RK3", "RK4", "T")
TIE = 0.10  # relative margin within which predicted errors count as equal
_RANK_BY = ("max", "eta", "v")


@dataclass(frozen=True)
class AdviceRow:
    """One rule in the advice. Errors are maxima over samples of per-sample Euclidean
    norms: eta in (m, rad) mixed, v in (m/s, rad/s) mixed.

    Attributes
    ----------
    method : str
    order : int
    first_order_gain : float
        a_s for AB_s, 1 for RK_s and T (noise gain ``~ c h L``).
    predicted_eta, predicted_v : float
        First-order path prediction.
    bound_eta, bound_v : float
        Guaranteed bound (24)-(25) over the domain.
    truncation_eta, truncation_v : float
        Undisturbed local error (noise-free part).
    measured_eta, measured_v, measured_rms_eta, measured_rms_v : float
        Monte Carlo maxima and rms (NaN without validation).
    h_max, h_max_guaranteed : float or None
        Largest h (s) of the search grid whose prediction / bound meets the tolerance
        (None: no tolerance given, or not even the smallest h meets it).
    rank : int
        1 = smallest predicted error.
    near_best : bool
        Predicted error within ``TIE`` (10 %) of the best: as good, for practical purposes
        (the prediction is a first-order worst case, not an exact value).
    measured_rank : int or None
        Rank by the measured maxima.
    """

    method: str
    order: int
    first_order_gain: float
    predicted_eta: float
    predicted_v: float
    bound_eta: float
    bound_v: float
    truncation_eta: float
    truncation_v: float
    measured_eta: float
    measured_v: float
    measured_rms_eta: float
    measured_rms_v: float
    h_max: float | None
    h_max_guaranteed: float | None
    rank: int
    measured_rank: int | None
    near_best: bool = False


@dataclass(frozen=True)
class Advice:
    """Ranked rules for one vehicle, sampling period and noise level.

    Attributes
    ----------
    vehicle : str
    h, eta_pct, v_pct : float
    tolerance : tuple of float or None
        (eta, v) tolerance used for ``h_max``.
    rank_by : {"max", "eta", "v"}
    rows : tuple of AdviceRow
        Sorted by predicted error (best first).
    domain : Domain
        Box of the reference run (the Jacobian maxima's domain).
    jacobians : JacobianReport
    curves : ErrorCurves
        Truncation / noise against h for every rule (for :func:`plot_crossing`).
    rank_agreement : float or None
        Kendall tau between the predicted and the measured orders (1 = same order).
    seeds : int
        Monte Carlo repetitions (0 without validation).
    """

    vehicle: str
    h: float
    eta_pct: float
    v_pct: float
    tolerance: tuple[float, float] | None
    rank_by: str
    rows: tuple[AdviceRow, ...]
    domain: Domain
    jacobians: JacobianReport
    curves: ErrorCurves
    rank_agreement: float | None
    seeds: int

    @property
    def best(self) -> str:
        """The rule with the smallest predicted error."""
        return self.rows[0].method

    @property
    def near_best(self) -> tuple[str, ...]:
        """The rules predicted within ``TIE`` (10 %) of the best, best first."""
        return tuple(r.method for r in self.rows if r.near_best)

    def row(self, method: str) -> AdviceRow:
        """The row of ``method`` (by name)."""
        for r in self.rows:
            if r.method == method:
                return r
        raise KeyError(
            f"no method {method!r} in this advice; have {[r.method for r in self.rows]}."
        )

    def table(self) -> str:
        """The ranked table as plain text."""

        def g(x: float) -> str:
            return (
                "     -   "
                if x is None or (isinstance(x, float) and math.isnan(x))
                else f"{x:9.3g}"
            )

        head = (
            f"{'rank':>4s} {'method':6s} {'gain':>6s} | {'pred eta':>9s} {'meas eta':>9s} "
            f"{'bound eta':>9s} | {'pred v':>9s} {'meas v':>9s} {'bound v':>9s}"
        )
        if self.tolerance is not None:
            head += f" | {'h_max':>7s} {'h_max_g':>7s}"
        lines = [
            f"{self.vehicle}: h = {self.h:g} s, noise (eta, v) = ({self.eta_pct:g} %, "
            f"{self.v_pct:g} %); ranked by predicted {self.rank_by} error",
            f"domain: {self.domain.describe()}",
            head,
        ]
        for r in self.rows:
            line = (
                f"{r.rank:3d}{'*' if r.near_best else ' '} {r.method:6s} "
                f"{r.first_order_gain:6.3g} | {g(r.predicted_eta)} "
                f"{g(r.measured_eta)} {g(r.bound_eta)} | {g(r.predicted_v)} "
                f"{g(r.measured_v)} {g(r.bound_v)}"
            )
            if self.tolerance is not None:
                hm = "-" if r.h_max is None else f"{r.h_max:.3g}"
                hg = "-" if r.h_max_guaranteed is None else f"{r.h_max_guaranteed:.3g}"
                line += f" | {hm:>7s} {hg:>7s}"
            lines.append(line)
        lines.append(f"* predicted within {TIE:.0%} of the best: as good in practice")
        if self.rank_agreement is not None:
            lines.append(
                f"measured over {self.seeds} noise seeds; Kendall tau (predicted vs measured "
                f"order) = {self.rank_agreement:.2f}"
            )
        if self.tolerance is not None:
            lines.append(
                f"h_max: largest h (s) whose predicted (h_max) / guaranteed (h_max_g) error "
                f"stays <= tolerance (eta, v) = {self.tolerance}"
            )
        return "\n".join(lines)


def _key(eta: float, v: float, rank_by: str) -> float:
    if rank_by == "eta":
        return eta
    if rank_by == "v":
        return v
    return max(eta, v)


def _meets(values: np.ndarray, tol: tuple[float, float], rank_by: str) -> np.ndarray:
    ok_eta = values[:, 0] <= tol[0]
    ok_v = values[:, 1] <= tol[1]
    if rank_by == "eta":
        return ok_eta
    if rank_by == "v":
        return ok_v
    return ok_eta & ok_v


def largest_h(
    curves: ErrorCurves,
    method: str,
    tolerance: float | tuple[float, float],
    *,
    rank_by: str = "max",
    which: str = "predicted",
) -> float | None:
    """Largest h of the curves' grid such that the error at every grid h' <= h meets
    the tolerance (so the answer never grows when the tolerance shrinks).

    Parameters
    ----------
    curves : ErrorCurves
    method : str
    tolerance : float or (float, float)
        On the eta and v errors (one number: both).
    rank_by : {"max", "eta", "v"}
        Which blocks must meet it: both, or one.
    which : {"predicted", "bound"}

    Returns
    -------
    float (s), or None when even the smallest h fails.
    """
    tol = _tolerance(tolerance)
    if which not in ("predicted", "bound"):
        raise ValueError(f"`which` must be 'predicted' or 'bound', got {which!r}.")
    values = (curves.predicted if which == "predicted" else curves.bound)[method]
    ok = _meets(values, tol, rank_by)
    if not ok[0]:
        return None
    first_bad = np.flatnonzero(~ok)
    last = int(first_bad[0]) - 1 if first_bad.size else ok.size - 1
    return float(curves.h[last])


def _tolerance(tolerance: Any) -> tuple[float, float]:
    t = np.atleast_1d(np.asarray(tolerance, dtype=float))
    if t.size == 1:
        t = np.repeat(t, 2)
    if t.shape != (2,) or not np.isfinite(t).all() or (t <= 0).any():
        raise ValueError(
            f"`tolerance` must be a positive number or a pair (eta, v), got {tolerance!r}."
        )
    return float(t[0]), float(t[1])


def advise(
    vehicle: Any,
    h: float,
    eta_pct: float,
    v_pct: float,
    methods: Sequence[str] = DEFAULT_METHODS,
    domain: Domain | None = None,
    tolerance: float | tuple[float, float] | None = None,
    validate: bool = True,
    *,
    signal: Any = None,
    reference: Trajectory | None = None,
    T: float = 60.0,
    x0: Any = None,
    seeds: int = 3,
    base_seed: int = 0,
    rank_by: str = "max",
    h_max_search: float | None = None,
    samples: int = 5000,
) -> Advice:
    """Rank sampled-data rules by their predicted one-step error on noisy data.

    Parameters
    ----------
    vehicle : Vehicle
        The 6-DoF vehicle (no thruster lag).
    h : float
        Sampling period (s).
    eta_pct, v_pct : float
        Uniform noise levels, % of 1 m / 30 deg and 1 m/s / 30 deg/s.
    methods : sequence of str
        Rules to compare ("E", "AB<s>", "RK<s>", "T").
    domain : Domain, optional
        Box for the guaranteed bound; default: the box of the reference run.
    tolerance : float or (float, float), optional
        Error tolerance on eta (m, rad) and v (m/s, rad/s); gives ``h_max`` per rule.
    validate : bool
        Also measure the errors on ``seeds`` noisy copies of the reference run.
    signal : Signal, optional
        Thruster input of the reference run; default :func:`gentle_input`.
    reference : Trajectory, optional
        Exact samples at a period dividing h (instead of simulating).
    T : float
        Duration of the simulated reference run (s).
    x0 : ndarray, shape (12,), optional
        Its initial state.
    seeds, base_seed : int
        Monte Carlo repetitions, seeded ``SeedSequence([base_seed, k])``.
    rank_by : {"max", "eta", "v"}
        Rank by the larger of the two blocks' errors, or by one block.
    h_max_search : float, optional
        Largest h (s) tried for ``h_max`` (default max(2 s, 4 h)).
    samples : int
        Random samples of the Jacobian check.

    Returns
    -------
    Advice
    """
    check_vehicle(vehicle)
    if rank_by not in _RANK_BY:
        raise ValueError(f"`rank_by` must be one of {_RANK_BY}, got {rank_by!r}.")
    if not (isinstance(h, int | float) and math.isfinite(h) and h > 0):
        raise ValueError(f"sampling period `h` must be > 0 s, got {h!r}.")
    if isinstance(seeds, bool) or not isinstance(seeds, int) or seeds < 1:
        raise ValueError(f"`seeds` must be an int >= 1, got {seeds!r}.")
    ms = [supported_method(m, "methods") for m in methods]
    if not ms:
        raise ValueError("`methods` is empty; give at least one rule, e.g. ('E', 'AB4').")
    tol = None if tolerance is None else _tolerance(tolerance)
    amp = noise_amplitudes(vehicle.state_units, eta_pct, v_pct)

    if reference is None:
        from ..simulate import simulate

        signal = gentle_input(vehicle) if signal is None else signal
        h0, ks = h_grid(h, h_max=h_max_search)
        n_int = max(1, round(T / h))
        base = simulate(vehicle, signal, T=n_int * h, h=h0, x0=x0)
    else:
        if not isinstance(reference, Trajectory):
            raise TypeError(f"`reference` must be a Trajectory, got {type(reference).__name__}.")
        base = reference.clean if reference.clean is not None else reference
        m_ratio = round(h / base.h)
        if m_ratio < 1 or abs(m_ratio * base.h - h) > 1e-9 * h:
            raise ValueError(
                f"`h` = {h} s must be an integer multiple of the reference period {base.h} s."
            )
        h0 = base.h
        top = max(2.0, 4.0 * h) if h_max_search is None else h_max_search
        ks = sorted(
            {int(round(k)) for k in np.geomspace(1, max(m_ratio, top / h0), 25)} | {m_ratio}
        )
    k_h = int(round(h / h0))
    if domain is None:
        domain = Domain.from_trajectory(base, vehicle.n_max, signal)
    elif not isinstance(domain, Domain):
        raise TypeError(f"`domain` must be a sensitivity.Domain, got {type(domain).__name__}.")
    pitch_guard(vehicle, domain.theta_max_deg, "domain.theta_max_deg", stacklevel=3)
    jac, _ = jacobian_pair(vehicle, domain, amp, samples)
    curves = error_curves(vehicle, ms, base, ks, eta_pct, v_pct, domain, signal, samples=samples)
    at = int(np.argmin(np.abs(curves.h - h)))
    if abs(curves.h[at] - h) > 1e-9 * h:
        raise ValueError(f"the reference run is too short for h = {h} s; raise `T`.")

    measured: dict[str, tuple[float, float, float, float]] = {}
    if validate:
        clean = subsample(base, k_h)
        runs: dict[str, list[tuple[np.ndarray, np.ndarray]]] = {m.name: [] for m in ms}
        for k in range(seeds):
            noisy = add_noise(clean, eta_pct, v_pct, np.random.SeedSequence([base_seed, k]))
            for name, errs in measured_errors(vehicle, ms, noisy, signal).items():
                runs[name].append(errs)
        for name, lst in runs.items():
            e_eta = np.concatenate([r[0] for r in lst])
            e_v = np.concatenate([r[1] for r in lst])
            keep = ~(np.isnan(e_eta) | np.isnan(e_v))
            e_eta, e_v = e_eta[keep], e_v[keep]
            measured[name] = (
                float(e_eta.max()),
                float(e_v.max()),
                float(np.sqrt(np.mean(e_eta**2))),
                float(np.sqrt(np.mean(e_v**2))),
            )

    pred_key = {
        m.name: _key(
            float(curves.predicted[m.name][at, 0]), float(curves.predicted[m.name][at, 1]), rank_by
        )
        for m in ms
    }
    order = sorted(pred_key, key=lambda n: pred_key[n])
    meas_order: list[str] = []
    tau = None
    if validate:
        meas_key = {n: _key(measured[n][0], measured[n][1], rank_by) for n in measured}
        meas_order = sorted(meas_key, key=lambda n: meas_key[n])
        if len(ms) > 1:
            from scipy.stats import kendalltau

            tau = float(kendalltau([pred_key[n] for n in order], [meas_key[n] for n in order])[0])
    nan4 = (math.nan,) * 4
    rows = []
    for rank, name in enumerate(order, start=1):
        m = next(mm for mm in ms if mm.name == name)
        pe, pv = curves.predicted[name][at]
        be, bv = curves.bound[name][at]
        te, tv = curves.truncation[name][at]
        me, mv, re, rv = measured.get(name, nan4)
        rows.append(
            AdviceRow(
                method=name,
                order=int(m.order),
                first_order_gain=float(first_order_gain(m)),
                predicted_eta=float(pe),
                predicted_v=float(pv),
                bound_eta=float(be),
                bound_v=float(bv),
                truncation_eta=float(te),
                truncation_v=float(tv),
                measured_eta=me,
                measured_v=mv,
                measured_rms_eta=re,
                measured_rms_v=rv,
                h_max=None if tol is None else largest_h(curves, name, tol, rank_by=rank_by),
                h_max_guaranteed=None
                if tol is None
                else largest_h(curves, name, tol, rank_by=rank_by, which="bound"),
                rank=rank,
                measured_rank=meas_order.index(name) + 1 if validate else None,
                near_best=pred_key[name] <= pred_key[order[0]] * (1.0 + TIE),
            )
        )
    return Advice(
        vehicle=getattr(vehicle, "name", "vehicle"),
        h=float(h),
        eta_pct=float(eta_pct),
        v_pct=float(v_pct),
        tolerance=tol,
        rank_by=rank_by,
        rows=tuple(rows),
        domain=domain,
        jacobians=jac,
        curves=curves,
        rank_agreement=tau,
        seeds=seeds if validate else 0,
    )

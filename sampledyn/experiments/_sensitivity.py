"""The study behind ``docs/sensitivity.md``: each claim of the paper's section 5
checked on a vehicle, its measured errors computed on the engine.

:func:`sensitivity_study` returns the numbers and the data of each figure;
:func:`sampledyn.report.sensitivity_report` draws the figures and writes the JSON.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._noise import noise_amplitudes
from ..sensitivity import (
    Domain,
    gentle_input,
    jacobian_bounds,
    path_prediction,
    pitch_input,
    pitch_sensitivity,
)
from ..sensitivity._curves import ErrorCurves
from ..sensitivity._domain import pitch_guard
from ..sensitivity._jacobians import attitude_jacobian, spectral_norm
from ..sensitivity._sweeps import PitchSensitivity
from ._advise import advise
from ._bounds import (
    InertiaSensitivity,
    MonteCarloRow,
    inertia_sensitivity,
    measure_noisy,
    monte_carlo_check,
    reference_samples,
)

__all__ = ["SensitivityStudy", "sensitivity_study"]

AB_METHODS = ("E", "AB2", "AB3", "AB4", "AB5", "AB6")
PITCH_BINS_DEG = np.arange(0.0, 80.0 + 1e-9, 5.0)


@dataclass(frozen=True)
class SensitivityStudy:
    """Numbers and figure data of :func:`sensitivity_study`.

    Attributes
    ----------
    vehicle : str
        The vehicle's name.
    numbers : dict
        Every number quoted in ``docs/sensitivity.md`` (JSON-able).
    noise_growth : list of dict
        ``h``, ``s``, ``bound_noise`` (2,), ``measured`` (2,) per AB order and h.
    tightness : list of MonteCarloRow
        The AB rules at h = 0.1 s on the gentle input, every noise level.
    pitch : PitchSensitivity
    pitch_measured : dict label -> (upper bin edges (deg), largest errors)
    inertia : list of InertiaSensitivity
        E and AB4.
    boundary : tuple (phi (deg), theta (deg), values)
        ``||M^-1 dg/deta||`` over a (phi, theta) grid.
    crossing : ErrorCurves
        Truncation vs noise against h at noise (2 %, 2 %).
    """

    vehicle: str
    numbers: dict[str, Any]
    noise_growth: list[dict[str, Any]]
    tightness: list[MonteCarloRow]
    pitch: PitchSensitivity
    pitch_measured: dict[str, tuple[np.ndarray, np.ndarray]]
    inertia: list[InertiaSensitivity]
    boundary: tuple[np.ndarray, np.ndarray, np.ndarray]
    crossing: ErrorCurves


def _ratio(a: float, b: float) -> float:
    return float(a / b) if b > 0 else math.inf


def _noise_growth(
    veh: Any, sig: Any, T: float, seeds: int, workers: int | None
) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    rows: list[dict[str, Any]] = []
    mc_all: list[Any] = []
    for h in (0.05, 0.1, 0.2, 0.5):
        mc = monte_carlo_check(
            veh, AB_METHODS, h, [(2.0, 2.0)], signal=sig, T=T, seeds=seeds, workers=workers
        )
        mc_all.extend(mc)
        for s, r in enumerate(mc, start=1):
            rows.append(
                {
                    "h": h,
                    "s": s,
                    "bound_noise": (r.bound.eta.noise, r.bound.v.noise),
                    "measured": (r.noise_eta, r.noise_v),
                }
            )

    def pick(h: float, s: int) -> dict[str, Any]:
        return next(r for r in rows if r["h"] == h and r["s"] == s)

    summary: dict[str, Any] = {}
    for h in (0.05, 0.1, 0.2, 0.5):
        summary[f"h={h:g}"] = {
            "measured_noise_AB6_over_AB1": [
                _ratio(pick(h, 6)["measured"][b], pick(h, 1)["measured"][b]) for b in (0, 1)
            ],
            "bound_noise_AB6_over_AB1": [
                _ratio(pick(h, 6)["bound_noise"][b], pick(h, 1)["bound_noise"][b]) for b in (0, 1)
            ],
            "measured_noise_eta_v": [list(pick(h, s)["measured"]) for s in range(1, 7)],
            "bound_noise_eta_v": [list(pick(h, s)["bound_noise"]) for s in range(1, 7)],
        }
    summary["AB4_measured_noise_h0.5_over_h0.05"] = [
        _ratio(pick(0.5, 4)["measured"][b], pick(0.05, 4)["measured"][b]) for b in (0, 1)
    ]
    summary["AB1_measured_noise_h0.5_over_h0.05"] = [
        _ratio(pick(0.5, 1)["measured"][b], pick(0.05, 1)["measured"][b]) for b in (0, 1)
    ]
    summary["violations"] = int(sum(r.violations for r in mc_all))
    return summary, rows


def _tightness(
    veh: Any, runs: dict[str, Any], T: float, seeds: int, workers: int | None
) -> tuple[dict[str, Any], list[MonteCarloRow]]:
    levels = [(0.5, 0.0), (0.0, 0.5), (2.0, 2.0), (10.0, 10.0), (20.0, 20.0)]
    methods = (*AB_METHODS, "RK2", "RK4", "T")
    table: list[dict[str, Any]] = []
    plot_rows = []
    violations = 0
    checked = 0
    path_ratio: list[float] = []
    for run, sig in runs.items():
        for h in (0.1, 0.5):
            clean, _ = reference_samples(veh, h, sig, None, T)
            mc = monte_carlo_check(
                veh, methods, h, levels, reference=clean, signal=sig, seeds=seeds, workers=workers
            )
            for r in mc:
                violations += r.violations
                checked += r.samples * r.seeds
                if (r.eta_pct, r.v_pct) != (0.0, 0.0):
                    amp = noise_amplitudes(veh.state_units, r.eta_pct, r.v_pct)
                    p = path_prediction(veh, r.method, clean, amp, sig)
                    path_ratio.extend([p.eta / r.measured_eta, p.v / r.measured_v])
                table.append(
                    {
                        "run": run,
                        "h": h,
                        "noise": [r.eta_pct, r.v_pct],
                        "method": r.method,
                        "bound": [r.bound.eta.total, r.bound.v.total],
                        "measured_max": [r.measured_eta, r.measured_v],
                        "tightness": [r.tightness_eta, r.tightness_v],
                    }
                )
                if run == "gentle" and h == 0.1 and r.method in AB_METHODS:
                    plot_rows.append(r)

    def span(sel: list[dict[str, Any]]) -> list[float]:
        vals = [t for r in sel for t in r["tightness"] if math.isfinite(t)]
        return [min(vals), max(vals)] if vals else [math.nan, math.nan]

    ab = [r for r in table if r["method"] in AB_METHODS]
    one = [r for r in table if r["method"] not in AB_METHODS]
    numbers = {
        "samples_checked": checked,
        "path_prediction_over_measured": [min(path_ratio), max(path_ratio)],
        "violations": violations,
        "AB_tightness_range": span(ab),
        "AB_tightness_range_h0.1": span([r for r in ab if r["h"] == 0.1]),
        "RK_T_tightness_range_h0.1": span([r for r in one if r["h"] == 0.1]),
        "RK_T_tightness_range_h0.5": span([r for r in one if r["h"] == 0.5]),
        "T_infinite_at_h0.5": any(
            r["method"] == "T" and r["h"] == 0.5 and not math.isfinite(r["bound"][0]) for r in table
        ),
        "table": table,
    }
    return numbers, plot_rows


def _pitch(
    veh: Any, T: float, seeds: int, workers: int | None
) -> tuple[dict[str, Any], PitchSensitivity, dict[str, tuple[np.ndarray, np.ndarray]]]:
    sig = pitch_input(veh, pitch_frac=0.22)
    h, method = 0.1, "AB4"
    clean, _ = reference_samples(veh, h, sig, None, T)
    dom = Domain.from_trajectory(clean, veh.n_max, sig)
    theta = np.degrees(np.abs(clean.x[:, 4]))
    bins = PITCH_BINS_DEG
    noise = (0.0, 10.0)
    # The error of row k predicts sample k from samples k-1 .. k-4: the mask pitch_deg
    # bins it by the largest |theta| over that window (5 samples).
    norms = [
        f"max{units}@pitch_deg({lo:g},{hi:g},5)"
        for lo, hi in zip(bins[:-1], bins[1:], strict=True)
        for units in ("", "[rad]")
    ]
    found = measure_noisy(
        veh, (method,), clean, sig, h, [noise], seeds, 7, norms, workers=workers
    )  # fmt: skip
    worst = np.zeros((2, bins.size - 1))  # all of eta; the Euler angles only
    for b, (lo, hi) in enumerate(zip(bins[:-1], bins[1:], strict=True)):
        for q, units in enumerate(("", "[rad]")):
            values = found[(*noise, method, f"max{units}@pitch_deg({lo:g},{hi:g},5)")][:, 0]
            worst[q, b] = float(np.nanmax(values)) if np.isfinite(values).any() else 0.0
    have = worst[0] > 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ps = pitch_sensitivity(
            veh,
            np.arange(0.0, 90.0),
            method=method,
            h=h,
            eta_pct=noise[0],
            v_pct=noise[1],
            domain=dom,
        )
    upper = bins[1:][have]
    measured = {
        "measured max, all of eta": (upper, worst[0][have]),
        "measured max, Euler angles only": (upper, worst[1][have]),
    }
    angles = {int(t): float(ps.J_norm[int(t)]) for t in (0, 20, 40, 60, 70, 80, 85, 89)}
    try:
        pitch_guard(veh, 89.9, "theta_deg")
        raised = ""
    except ValueError as exc:
        raised = str(exc)

    def ratio_at(q: int, lo: float, hi: float) -> float:
        sel_hi = have & (bins[1:] > lo) & (bins[1:] <= hi)
        base = worst[q, :2][worst[q, :2] > 0]
        if not sel_hi.any() or base.size == 0:
            return math.nan
        return float(worst[q][sel_hi].max() / base.max())

    numbers = {
        "max_abs_theta_deg_of_run": float(theta.max()),
        "J_norm": angles,
        "dJ_norm": {int(t): float(ps.dJ_norm[int(t)]) for t in angles},
        "bound_noise_eta": {int(t): float(ps.noise_bound_eta[int(t)]) for t in angles},
        "measured_bins_upper_deg": upper.tolist(),
        "measured_max_eta": worst[0][have].tolist(),
        "measured_max_angles": worst[1][have].tolist(),
        "eta_growth_35_45_vs_0_10": ratio_at(0, 35.0, 45.0),
        "eta_growth_55_65_vs_0_10": ratio_at(0, 55.0, 65.0),
        "eta_growth_70_80_vs_0_10": ratio_at(0, 70.0, 80.0),
        "angles_growth_35_45_vs_0_10": ratio_at(1, 35.0, 45.0),
        "angles_growth_55_65_vs_0_10": ratio_at(1, 55.0, 65.0),
        "angles_growth_70_80_vs_0_10": ratio_at(1, 70.0, 80.0),
        "error_at_89.9_deg": raised,
    }
    return numbers, ps, measured


def _inertia(
    veh: Any, sig: Any, T: float, seeds: int, workers: int | None
) -> tuple[dict[str, Any], list[InertiaSensitivity]]:
    res: dict[str, Any] = {}
    items = []
    for method in ("E", "AB4"):
        ins = inertia_sensitivity(
            veh,
            (0.25, 0.5, 1.0, 2.0, 4.0),
            method=method,
            h=0.1,
            signal=sig,
            T=T,
            seeds=2 * seeds,
            workers=workers,
        )
        items.append(ins)
        res[method] = {
            "scales": ins.scales.tolist(),
            "minv_norm": ins.minv_norm.tolist(),
            "L_v_v": ins.lipschitz[:, 1, 1].tolist(),
            "noise_bound_fixed_domain_v": ins.noise_bound_fixed[:, 1].tolist(),
            "noise_bound_fixed_domain_eta": ins.noise_bound_fixed[:, 0].tolist(),
            "measured_noise_v": ins.measured_noise[:, 1].tolist(),
            "measured_rms_v": ins.measured_rms[:, 1].tolist(),
            "measured_max_v": ins.measured[:, 1].tolist(),
            "predicted_v": ins.predicted[:, 1].tolist(),
            "bound_v": ins.bound[:, 1].tolist(),
        }
    return res, items


def _boundary(
    veh: Any, domains: dict[str, Domain]
) -> tuple[dict[str, Any], tuple[np.ndarray, np.ndarray, np.ndarray]]:
    res: dict[str, Any] = {}
    for name, dom in domains.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            rep = jacobian_bounds(veh, dom, samples=5000)
        res[name] = {
            "domain": dom.describe(),
            "failures": list(rep.failures),
            "blocks": {
                k: {
                    "max": b.maximum,
                    "search_max": b.search_max,
                    "paper": b.paper_value,
                    "relation": b.paper_relation,
                    "interior_max": b.interior_max,
                    "boundary_max": b.boundary_max,
                    "at_paper_point": b.at_paper_point,
                    "claim_holds": b.claim_holds,
                    "exact": b.exact,
                    "argmax": {
                        a: (list(v) if isinstance(v, tuple) else v) for a, v in b.argmax.items()
                    },
                    "note": b.note,
                }
                for k, b in rep.blocks.items()
            },
            "table": rep.table(),
        }
    wide = domains["wide"]
    phis = np.linspace(-wide.phi_max_deg, wide.phi_max_deg, 81)
    thetas = np.linspace(-wide.theta_max_deg, wide.theta_max_deg, 161)
    P, Th = np.meshgrid(np.radians(phis), np.radians(thetas), indexing="ij")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        j = attitude_jacobian(veh, P.ravel(), Th.ravel(), np.zeros(6), np.zeros(veh.nu))
    vals = spectral_norm(j[:, 6:12, 0:6]).reshape(P.shape)
    return res, (phis, thetas, vals)


def _advice(veh: Any, sig: Any, workers: int | None) -> tuple[dict[str, Any], ErrorCurves]:
    res: dict[str, Any] = {}
    crossing = None
    for h in (0.1, 0.5):
        for noise in ((0.0, 0.0), (0.5, 0.5), (2.0, 2.0), (10.0, 10.0), (20.0, 20.0)):
            a = advise(
                veh, h, *noise, signal=sig, tolerance=0.2 if noise != (0, 0) else 1e-3,
                workers=workers,
            )  # fmt: skip
            key = f"h={h:g} noise={noise}"
            res[key] = {
                "ranked": [r.method for r in a.rows],
                "measured_ranked": sorted(
                    (r.method for r in a.rows), key=lambda n: a.row(n).measured_rank or 0
                ),
                "kendall_tau": a.rank_agreement,
                "table": a.table(),
            }
            if h == 0.1 and noise == (0.0, 0.0):
                # empirical order of the largest undisturbed local error, h in [0.02, 0.16] s
                c = a.curves
                sel = (c.h >= 0.019) & (c.h <= 0.161)
                res["truncation_slopes_eta_v"] = {
                    m: np.polyfit(np.log(c.h[sel]), np.log(c.truncation[m][sel]), 1)[0].tolist()
                    for m in c.methods
                }
            if h == 0.1 and noise == (2.0, 2.0):
                crossing = a.curves
                res["crossings_h=0.1_noise=2,2"] = {
                    m: list(a.curves.crossing(m)) for m in a.curves.methods
                }
    assert crossing is not None
    return res, crossing


def sensitivity_study(
    vehicle: Any = "bluerov2_heavy",
    *,
    T: float = 100.0,
    seeds: int = 5,
    workers: int | None = None,
) -> SensitivityStudy:
    """Check the paper's section-5 claims on a vehicle (noise growth with s and h,
    tightness of the bound, pitch, inertia, where the Jacobian maxima sit, advice);
    every measured error comes from the engine.

    Parameters
    ----------
    vehicle : str or Vehicle
        Built-in name, TOML path or a Vehicle (4 vertical and 4 horizontal thrusters:
        the runs use :func:`sampledyn.sensitivity.gentle_input` and ``pitch_input``).
    T : float
        Duration of each reference run (s).
    seeds : int
        Monte Carlo noise realisations per cell.
    workers : int, optional
        Local worker processes of the engine (default: in this process).

    Returns
    -------
    SensitivityStudy. Takes a few minutes.
    """
    from ..models import Vehicle, load_vehicle

    veh = vehicle if isinstance(vehicle, Vehicle) else load_vehicle(vehicle)
    gentle = gentle_input(veh)
    pitch = pitch_input(veh)
    g_run, _ = reference_samples(veh, 0.1, gentle, None, T)
    p_run, _ = reference_samples(veh, 0.1, pitch, None, T)
    domains = {
        "gentle_run": Domain.from_trajectory(g_run, veh.n_max, gentle),
        "pitch_run": Domain.from_trajectory(p_run, veh.n_max, pitch),
        "wide": Domain(
            v_max=(0.5, 0.3, 0.3, 1.0, 1.0, 1.0), phi_max_deg=40.0, theta_max_deg=80.0, rpm_frac=0.5
        ),
    }
    numbers: dict[str, Any] = {"vehicle": veh.name, "T": T, "seeds": seeds}
    numbers["noise_growth"], growth = _noise_growth(veh, gentle, T, seeds, workers)
    numbers["tightness"], tight = _tightness(
        veh, {"gentle": gentle, "pitch": pitch}, T, seeds, workers
    )
    numbers["pitch"], ps, pitch_measured = _pitch(veh, T, seeds, workers)
    numbers["inertia"], inertia = _inertia(veh, gentle, T, seeds, workers)
    numbers["boundary"], boundary = _boundary(veh, domains)
    numbers["advice"], crossing = _advice(veh, gentle, workers)
    return SensitivityStudy(
        vehicle=veh.name,
        numbers=numbers,
        noise_growth=growth,
        tightness=tight,
        pitch=ps,
        pitch_measured=pitch_measured,
        inertia=inertia,
        boundary=boundary,
        crossing=crossing,
    )

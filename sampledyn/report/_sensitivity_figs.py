"""Figures of the sensitivity analysis (matplotlib, object API: no global state), and
the report behind ``docs/sensitivity.md``."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..methods import get_predictor
from ..sensitivity._curves import ErrorCurves

__all__ = [
    "plot_boundary_map",
    "plot_crossing",
    "plot_inertia",
    "plot_noise_growth",
    "plot_pitch",
    "plot_tightness",
    "sensitivity_report",
]

_BLOCK_LABELS = ("position error eta (m, rad)", "velocity error v (m/s, rad/s)")


def _figure(rows: int, cols: int, size: tuple[float, float]) -> Any:
    from matplotlib.figure import Figure

    fig = Figure(figsize=size, layout="constrained")
    axes = fig.subplots(rows, cols, squeeze=False)
    return fig, axes


def _save(fig: Any, path: str | Path) -> Path:
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(p, dpi=110)
    return p


def _family(name: str) -> int:
    """Row of the figure: 0 for rules that use f at the samples only (E, AB_s, ...),
    1 for those that evaluate f between samples (RK_s, T)."""
    return int(get_predictor(name).intersample)


def plot_crossing(
    curves: ErrorCurves,
    path: str | Path,
    *,
    h_mark: float | None = None,
    title: str | None = None,
) -> Path:
    """Truncation error (solid, ~h^(s+1)) and noise term (dashed, growing with the noise
    gain) against h, per rule; dots where they cross.

    Top row: rules that use f at the samples only (E, AB_s); bottom row: rules that
    evaluate f between samples (RK_s, T), skipped when none is present.
    Columns: the position and the velocity block. ``h_mark`` draws a vertical line.

    Returns
    -------
    Path of the PNG written.
    """
    from matplotlib import colormaps

    fams = sorted({_family(m) for m in curves.methods})
    fig, axes = _figure(len(fams), 2, (11.0, 4.2 * len(fams)))
    cmap = colormaps["viridis"]
    for row, fam in enumerate(fams):
        names = [m for m in curves.methods if _family(m) == fam]
        for col in (0, 1):
            ax = axes[row, col]
            for i, name in enumerate(names):
                color = cmap(i / max(1, len(names) - 1) * 0.9)
                tr = curves.truncation[name][:, col]
                nz = curves.predicted_noise[name][:, col]
                ax.loglog(curves.h, np.maximum(tr, 1e-300), "-", color=color, label=f"{name}")
                if np.any(nz > 0):
                    ax.loglog(curves.h, nz, "--", color=color)
                hx = curves.crossing(name)[col]
                if hx is not None:
                    y = float(np.exp(np.interp(np.log(hx), np.log(curves.h), np.log(nz))))
                    ax.plot([hx], [y], "o", color=color, ms=6)
            if h_mark is not None:
                ax.axvline(h_mark, color="grey", lw=0.8, ls=":")
            ax.set_xlabel("sampling period h (s)")
            ax.set_ylabel(f"max {_BLOCK_LABELS[col]}")
            ax.grid(True, which="both", alpha=0.3)
            ax.legend(
                fontsize=7, ncol=2, title="solid: truncation, dashed: noise", title_fontsize=7
            )
            ax.set_ylim(bottom=max(1e-9, ax.get_ylim()[0]))
    fig.suptitle(
        title
        or f"Truncation vs noise term, noise ({curves.eta_pct:g} %, {curves.v_pct:g} %): "
        "dots where they cross"
    )
    return _save(fig, path)


def plot_pitch(
    pitch: Any,
    path: str | Path,
    *,
    measured: dict[str, tuple[np.ndarray, np.ndarray]] | None = None,
    title: str | None = None,
) -> Path:
    """Left: ||J||, ||dJ/deta|| and the eta-row Jacobian maxima against the pitch.
    Right: the noise part of the position-error bound against the pitch limit, with
    ``measured = {label: (theta_deg, error)}`` (e.g. binned maxima) if given."""
    fig, axes = _figure(1, 2, (11.0, 4.2))
    ax = axes[0, 0]
    ax.semilogy(pitch.theta_deg, pitch.J_norm, label="||J(eta)||  (22)")
    ax.semilogy(pitch.theta_deg, pitch.dJ_norm, label="||dJ/deta||  (23)")
    ax.semilogy(pitch.theta_deg, pitch.L_eta_eta, label="max ||df_eta/deta|| over domain")
    ax.axvline(40.0, color="grey", ls=":", lw=0.8)
    ax.set_xlabel("|theta| (deg)")
    ax.set_ylabel("norm")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    ax = axes[0, 1]
    ax.semilogy(
        pitch.theta_deg,
        pitch.noise_bound_eta,
        label=f"bound, noise part ({pitch.method}, h={pitch.h:g} s)",
    )
    for label, (th, val) in (measured or {}).items():
        ax.semilogy(th, val, "o-", ms=4, label=label)
    ax.axvline(40.0, color="grey", ls=":", lw=0.8)
    ax.set_xlabel("|theta| (deg)")
    ax.set_ylabel("position error (m, rad)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.suptitle(
        title
        or f"Pitch sensitivity, noise ({pitch.eta_pct:g} %, {pitch.v_pct:g} %): "
        "J(eta) is singular at 90 deg"
    )
    return _save(fig, path)


def plot_inertia(
    inertia: Any | Sequence[Any], path: str | Path, *, title: str | None = None
) -> Path:
    """Velocity errors against the inertia scale, one colour per rule.

    Left: the noise part of the bound over the common domain (only M differs).
    Right: measured largest noise contribution ``||eps~ - eps||`` (solid) and rms
    error (dashed) on each scaled vehicle's own run, when measured.

    ``inertia``: one :class:`InertiaSensitivity` or several (e.g. E and AB4).
    """
    from matplotlib.ticker import NullLocator

    items: list[Any] = list(inertia) if isinstance(inertia, list | tuple) else [inertia]
    fig, axes = _figure(1, 2, (11.0, 4.2))
    for k, ins in enumerate(items):
        c = f"C{k}"
        axes[0, 0].loglog(ins.scales, ins.noise_bound_fixed[:, 1], "s-", color=c, label=ins.method)
        if np.isfinite(ins.measured_noise[:, 1]).all():
            axes[0, 1].loglog(
                ins.scales, ins.measured_noise[:, 1], "o-", color=c, label=f"{ins.method} max"
            )
            axes[0, 1].loglog(
                ins.scales, ins.measured_rms[:, 1], "o--", color=c, ms=3, label=f"{ins.method} rms"
            )
    for ax, what in zip(
        axes[0], ("bound, noise part (common domain)", "measured noise contribution"), strict=True
    ):
        ax.set_xlabel("inertia scale k (M -> k M)")
        ax.set_ylabel("velocity error (m/s, rad/s)")
        ax.set_title(what, fontsize=10)
        ax.xaxis.set_minor_locator(NullLocator())
        ax.set_xticks(items[0].scales, [f"{k:g}" for k in items[0].scales])
        ax.grid(True, which="major", alpha=0.3)
        ax.legend(fontsize=8)
    first = items[0]
    fig.suptitle(
        title
        or f"Inertia sensitivity, h={first.h:g} s, noise ({first.eta_pct:g} %, {first.v_pct:g} %)"
    )
    return _save(fig, path)


def plot_noise_growth(
    rows: Sequence[dict[str, Any]], path: str | Path, *, title: str | None = None
) -> Path:
    """Bound noise part and measured maxima against the order s, one colour per h.

    ``rows``: dicts with ``h``, ``s``, ``bound_noise`` (2,), ``measured`` (2,).
    """
    from matplotlib import colormaps

    fig, axes = _figure(1, 2, (11.0, 4.2))
    hs = sorted({r["h"] for r in rows})
    cmap = colormaps["plasma"]
    for col in (0, 1):
        ax = axes[0, col]
        for i, h in enumerate(hs):
            sel = sorted((r for r in rows if r["h"] == h), key=lambda r: r["s"])
            s = [r["s"] for r in sel]
            c = cmap(i / max(1, len(hs) - 1) * 0.85)
            ax.semilogy(
                s, [r["bound_noise"][col] for r in sel], "-", color=c, label=f"bound h={h:g}"
            )
            ax.semilogy(
                s,
                [r["measured"][col] for r in sel],
                "o--",
                color=c,
                ms=4,
                label=f"measured h={h:g}",
            )
        ax.set_xlabel("Adams-Bashforth order s")
        ax.set_ylabel(f"max {_BLOCK_LABELS[col]}")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7, ncol=2)
    fig.suptitle(title or "Noise contribution against s and h")
    return _save(fig, path)


def plot_tightness(rows: Sequence[Any], path: str | Path, *, title: str | None = None) -> Path:
    """Bound / measured maximum (>= 1) against the order, one line per noise level.

    ``rows``: :class:`MonteCarloRow` of AB rules.
    """
    fig, axes = _figure(1, 2, (11.0, 4.2))
    levels = list(dict.fromkeys((r.eta_pct, r.v_pct) for r in rows))
    for col, attr in enumerate(("tightness_eta", "tightness_v")):
        ax = axes[0, col]
        for lev in levels:
            sel = [r for r in rows if (r.eta_pct, r.v_pct) == lev]
            ax.semilogy(
                [r.bound.first_order_gain for r in sel],
                [getattr(r, attr) for r in sel],
                "o-",
                ms=4,
                label=f"({lev[0]:g} %, {lev[1]:g} %)",
            )
        ax.axhline(1.0, color="k", lw=0.8)
        ax.set_xscale("log")
        ax.set_xlabel("noise gain a_s (AB1..AB6)")
        ax.set_ylabel("bound / measured max " + ("(eta)" if col == 0 else "(v)"))
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7, title="noise (eta, v)", title_fontsize=7)
    fig.suptitle(title or "Tightness of the bound (24)-(25)")
    return _save(fig, path)


def plot_boundary_map(
    grid_phi: np.ndarray,
    grid_theta: np.ndarray,
    values: np.ndarray,
    path: str | Path,
    *,
    label: str,
    title: str | None = None,
) -> Path:
    """Heat map of a Jacobian norm over (phi, theta) with its maximiser marked."""
    fig, axes = _figure(1, 1, (7.0, 4.8))
    ax = axes[0, 0]
    mesh = ax.pcolormesh(grid_phi, grid_theta, values.T, shading="auto", cmap="viridis")
    fig.colorbar(mesh, ax=ax, label=label)
    # ties (a flat ridge) are broken towards the centre of the map
    dist = np.hypot(*np.meshgrid(grid_phi, grid_theta, indexing="ij"))
    top = values >= values.max() * (1 - 1e-9)
    k = np.unravel_index(int(np.argmin(np.where(top, dist, np.inf))), values.shape)
    ax.plot([grid_phi[k[0]]], [grid_theta[k[1]]], "r*", ms=12, label="maximum")
    ax.plot([grid_phi[-1]], [grid_theta[-1]], "wo", ms=7, label="paper's boundary point")
    ax.set_xlabel("phi (deg)")
    ax.set_ylabel("theta (deg)")
    ax.legend(fontsize=8, loc="lower left")
    ax.set_title(title or label, fontsize=10)
    return _save(fig, path)


def sensitivity_report(
    out_dir: str | Path,
    *,
    vehicle: Any = "bluerov2_heavy",
    T: float = 100.0,
    seeds: int = 5,
    workers: int | None = None,
) -> dict[str, Any]:
    """Check the paper's section-5 claims on a vehicle
    (:func:`sampledyn.experiments.sensitivity_study`); write figures and numbers.

    Writes into ``out_dir``: ``sensitivity_noise_growth.png`` (noise term vs s and h),
    ``sensitivity_tightness.png`` (bound / measured), ``sensitivity_pitch.png``
    (J, dJ/deta and position errors vs pitch), ``sensitivity_inertia.png`` (errors vs
    inertia scale), ``sensitivity_boundary.png`` (where the Jacobian of (20) peaks),
    ``sensitivity_crossing.png`` (truncation vs noise against h) and
    ``sensitivity_numbers.json`` (every number quoted in docs/sensitivity.md).

    Parameters
    ----------
    out_dir : str or Path
    vehicle : str or Vehicle
        Built-in name, TOML path or a Vehicle.
    T : float
        Duration of each reference run (s).
    seeds : int
        Monte Carlo noise realisations per cell.
    workers : int, optional
        Local worker processes of the engine.

    Returns
    -------
    dict of the numbers (also in the JSON file). Takes a few minutes.
    """
    import json
    import math

    from ..experiments import sensitivity_study

    study = sensitivity_study(vehicle, T=T, seeds=seeds, workers=workers)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    name = study.vehicle
    plot_noise_growth(
        study.noise_growth,
        out / "sensitivity_noise_growth.png",
        title=f"Noise contribution max ||eps~ - eps|| vs s and h, noise (2 %, 2 %), {name}, "
        "gentle input: bound (lines) and measured (dots)",
    )
    plot_tightness(
        study.tightness,
        out / "sensitivity_tightness.png",
        title=f"Bound (24)-(25) / measured max, {name}, gentle input, h = 0.1 s",
    )
    ps = study.pitch
    plot_pitch(
        ps,
        out / "sensitivity_pitch.png",
        measured=study.pitch_measured,
        title=f"Pitch sensitivity, {name}, {ps.method}, h = {ps.h:g} s, noise "
        f"({ps.eta_pct:g} %, {ps.v_pct:g} %): bound vs measured max per 5-deg bin of |theta|",
    )
    plot_inertia(study.inertia, out / "sensitivity_inertia.png")
    phis, thetas, vals = study.boundary
    plot_boundary_map(
        phis,
        thetas,
        vals,
        out / "sensitivity_boundary.png",
        label="||df_v/deta|| = ||M^-1 dg/deta|| (1/s^2)",
        title=f"Eq. (20) on {name}: ||M^-1 dg/deta|| over (phi, theta)",
    )
    plot_crossing(
        study.crossing,
        out / "sensitivity_crossing.png",
        h_mark=0.1,
        title=f"{name}, noise (2 %, 2 %): truncation (solid) vs noise (dashed) against h; "
        "dots where they cross",
    )

    def clean(o: Any) -> Any:
        if isinstance(o, dict):
            return {str(k): clean(v) for k, v in o.items()}
        if isinstance(o, list | tuple):
            return [clean(v) for v in o]
        if isinstance(o, float | np.floating):
            return float(o) if math.isfinite(o) else str(float(o))
        if isinstance(o, np.integer | np.bool_):
            return o.item()
        return o

    numbers: dict[str, Any] = clean(study.numbers)
    (out / "sensitivity_numbers.json").write_text(json.dumps(numbers, indent=1))
    return numbers

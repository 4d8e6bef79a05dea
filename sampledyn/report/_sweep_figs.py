"""Figures of a sweep report: error against order, and AB_s/AB1 ratio maps.

Both take the per-cell means over seeds of one study (a pandas DataFrame with
columns h, eta_pct, v_pct, method, order, err_eta, err_v) and write a PNG. They use
``matplotlib.figure.Figure`` directly, so no pyplot state or GUI backend is touched.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..methods import get_method

__all__ = [
    "ab_orders",
    "baseline",
    "block_units",
    "plot_order",
    "plot_ratio_maps",
    "sorted_pairs",
]

QUANTITIES = (("err_eta", "position/angle error eta"), ("err_v", "rate error v"))


def ab_orders(methods: Any) -> dict[int, str]:
    """Order -> name of the fixed Adams-Bashforth rules among ``methods`` (E is AB1;
    of two names of one order, the first in sorted order, "AB1" before "E")."""
    out: dict[int, str] = {}
    for name in sorted({str(m) for m in methods}):
        try:
            m = get_method(name)
        except ValueError:  # a name no longer registered: not one of the AB rules
            continue
        if m.family == "AB" and m.order is not None:
            out.setdefault(m.order, name)
    return dict(sorted(out.items()))


def baseline(methods: Any) -> str | None:
    """The AB1 rule of a study ("AB1", else "E"), or None."""
    return ab_orders(methods).get(1)


def noise_label(eta: float, v: float) -> str:
    return f"({eta:g}%, {v:g}%)"


def sorted_pairs(frame: Any) -> list[tuple[float, float]]:
    """The noise pairs (eta %, v %) of a frame, sorted (by eta, then v)."""
    return sorted(set(zip(frame["eta_pct"], frame["v_pct"], strict=True)))


def block_units(norm: str) -> tuple[str, str]:
    """The units of the eta and v numbers of a stored norm, e.g. ("m and rad", "m/s and
    rad/s") for "rms", ("m", "m/s") for "rms[m,m/s]"."""
    from ..experiments.sweep._norms import parse_norm

    try:
        units = parse_norm(norm).units
    except ValueError:
        units = None
    eta = [u for u in ("m", "rad") if units is None or u in units]
    v = [u for u in ("m/s", "rad/s") if units is None or u in units]
    return " and ".join(eta) or "-", " and ".join(v) or "-"


# Margins in inches (fixed, not constrained layout, which costs seconds on figures
# with many log axes): the figure title above the panel titles, the legend below the
# x labels, room for the y labels.
_TITLE_IN = 0.5
_PANEL_TITLE_IN = 0.32
_XLABEL_IN = 0.55
_YLABEL_IN = 0.95


def _grid(rows: int, cols: int, ax_w: float, ax_h: float, legend_in: float) -> tuple[Any, Any]:
    from matplotlib.figure import Figure

    width = _YLABEL_IN + cols * ax_w + (cols - 1) * _YLABEL_IN + 0.25
    height = (
        _TITLE_IN
        + _PANEL_TITLE_IN
        + rows * ax_h
        + (rows - 1) * (_XLABEL_IN + _PANEL_TITLE_IN)
        + _XLABEL_IN
        + legend_in
    )
    fig = Figure(figsize=(width, height))
    fig.subplots_adjust(
        left=_YLABEL_IN / width,
        right=1 - 0.25 / width,
        top=1 - (_TITLE_IN + _PANEL_TITLE_IN) / height,
        bottom=(_XLABEL_IN + legend_in) / height,
        hspace=(_XLABEL_IN + _PANEL_TITLE_IN) / ax_h,
        wspace=_YLABEL_IN / ax_w,
    )
    return fig, fig.subplots(rows, cols, squeeze=False)


def plot_order(means: Any, path: Path, title: str, norm: str = "norm") -> Path:
    """Error norm against the order s, one panel per h and quantity, one line per
    noise pair (AB rules, pairs sorted); other rules (RK_s, T, ...) as markers at their
    order. ``norm`` (the stored norm, e.g. "rms[m,m/s]") labels the y axes with their
    units."""
    hs = sorted(means["h"].unique())
    pairs = sorted_pairs(means)
    orders = ab_orders(means["method"].unique())
    others = sorted(set(means["method"]) - set(orders.values()))
    units = dict(zip(("err_eta", "err_v"), block_units(norm), strict=True))
    n_labels = len(pairs) + len(others)
    ncol = min(6, max(1, n_labels))
    legend_in = 0.45 + 0.2 * -(-n_labels // ncol)
    fig, axes = _grid(len(hs), 2, 3.9, 2.4, legend_in)
    colors = _palette(len(pairs))
    markers = "osD^v<>pPX*h"
    for i, h in enumerate(hs):
        for j, (q, qname) in enumerate(QUANTITIES):
            ax = axes[i][j]
            sub = means[means["h"] == h]
            for k, (e, v) in enumerate(pairs):
                pts = sub[(sub["eta_pct"] == e) & (sub["v_pct"] == v)]
                xs, ys = [], []
                for s, name in orders.items():
                    row = pts[pts["method"] == name]
                    if len(row) and np.isfinite(float(row[q].iloc[0])):
                        xs.append(s)
                        ys.append(float(row[q].iloc[0]))
                if xs:
                    ax.plot(xs, ys, "-o", color=colors[k], ms=3, lw=1.2, label=noise_label(e, v))
                for m_i, name in enumerate(others):
                    row = pts[pts["method"] == name]
                    if len(row) and row["order"].notna().iloc[0]:
                        ax.plot(
                            [float(row["order"].iloc[0])],
                            [float(row[q].iloc[0])],
                            markers[(m_i + 1) % len(markers)],
                            color=colors[k],
                            mfc="none",
                            ms=6,
                            label=name if k == 0 else None,
                        )
            ax.set_yscale("log")
            ax.set_title(f"h = {h:g} s: {qname} ({units[q]})", fontsize=9)
            ax.set_xlabel("order s", fontsize=8)
            ax.set_ylabel(f"{norm}, mean over seeds\n({units[q]})", fontsize=8)
            ax.set_xticks(sorted({*orders, *(int(o) for o in sub["order"].dropna())}))
            ax.grid(True, alpha=0.3)
    labels: dict[str, Any] = {}
    for ax in axes.ravel():
        for handle, label in zip(*ax.get_legend_handles_labels(), strict=True):
            labels.setdefault(label, handle)
    if labels:
        fig.legend(
            list(labels.values()),
            list(labels),
            loc="lower center",
            bbox_to_anchor=(0.5, 0.0),
            ncol=ncol,
            fontsize=8,
            title="noise (eta %, v %); hollow markers: other rules",
            title_fontsize=8,
        )
    fig.suptitle(title, fontsize=10, y=1 - 0.12 / fig.get_figheight(), va="top")
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.is_symlink():  # replace a link at this name, never write through it
        path.unlink()
    fig.savefig(path, dpi=90)
    return path


def _palette(n: int) -> list[Any]:
    from matplotlib import colormaps

    cmap = colormaps["viridis" if n > 10 else "tab10"]
    return [cmap(i / max(1, n - 1)) if n > 10 else cmap(i) for i in range(n)]


def plot_ratio_maps(means: Any, path: Path, title: str, norm: str = "norm") -> Path | None:
    """Maps of AB_s / AB1 over (noise pair, h), one row per s >= 2, one column per
    quantity; blue where AB_s is better, red where AB1 is. None if the study has no
    AB1 (or E) and no higher AB order."""
    from matplotlib.colors import TwoSlopeNorm
    from matplotlib.figure import Figure

    orders = ab_orders(means["method"].unique())
    base = orders.get(1)
    highs = [s for s in orders if s >= 2]
    units = dict(zip(("err_eta", "err_v"), block_units(norm), strict=True))
    if base is None or not highs:
        return None
    hs = sorted(means["h"].unique())
    pairs = sorted_pairs(means)
    idx = {(r.h, r.eta_pct, r.v_pct, r.method): r for r in means.itertuples(index=False)}
    ax_h = 0.22 * len(pairs) + 0.1
    ax_w = 0.9 + 0.8 * len(hs)
    left, gap, right = 1.2, 1.3, 1.1  # y tick labels (noise pairs); colour bar
    width = left + 2 * ax_w + gap + right
    height = _TITLE_IN + _PANEL_TITLE_IN + len(highs) * ax_h
    height += (len(highs) - 1) * (_XLABEL_IN + _PANEL_TITLE_IN) + _XLABEL_IN
    fig = Figure(figsize=(width, height))
    fig.subplots_adjust(
        left=left / width,
        right=1 - right / width,
        top=1 - (_TITLE_IN + _PANEL_TITLE_IN) / height,
        bottom=_XLABEL_IN / height,
        hspace=(_XLABEL_IN + _PANEL_TITLE_IN) / ax_h,
        wspace=gap / ax_w,
    )
    axes = fig.subplots(len(highs), 2, squeeze=False)
    scale = TwoSlopeNorm(vcenter=0.0, vmin=-1.0, vmax=1.0)
    image = None
    for i, s in enumerate(highs):
        for j, (q, qname) in enumerate(QUANTITIES):
            grid = np.full((len(pairs), len(hs)), np.nan)
            for a, (e, v) in enumerate(pairs):
                for b, h in enumerate(hs):
                    lo, hi = idx.get((h, e, v, base)), idx.get((h, e, v, orders[s]))
                    if lo is not None and hi is not None:
                        num, den = getattr(hi, q), getattr(lo, q)
                        if num > 0 and den > 0:
                            grid[a, b] = np.log10(num / den)
            ax = axes[i][j]
            image = ax.imshow(np.clip(grid, -1, 1), cmap="RdBu_r", norm=scale, aspect="auto")
            for a in range(len(pairs)):
                for b in range(len(hs)):
                    if np.isfinite(grid[a, b]):
                        r = 10 ** grid[a, b]
                        ax.text(
                            b,
                            a,
                            f"{r:.0f}" if r >= 10 else f"{r:.2g}",
                            ha="center",
                            va="center",
                            fontsize=7,
                            color="white" if abs(grid[a, b]) > 0.6 else "black",
                        )
            ax.set_xticks(range(len(hs)), [f"{h:g}" for h in hs], fontsize=8)
            ax.set_yticks(range(len(pairs)), [noise_label(e, v) for e, v in pairs], fontsize=7)
            ax.set_xlabel("h (s)", fontsize=8)
            ax.set_title(f"{orders[s]} / {base}: {qname} ({units[q]})", fontsize=9)
    if image is not None:
        cax = fig.add_axes((1 - 0.85 / width, 0.2, 0.15 / width, 0.6))
        bar = fig.colorbar(image, cax=cax, label="log10 ratio (clipped at +-1)")
        bar.ax.tick_params(labelsize=7)
    fig.suptitle(title, fontsize=10, y=1 - 0.12 / height, va="top")
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.is_symlink():  # replace a link at this name, never write through it
        path.unlink()
    fig.savefig(path, dpi=90)
    return path

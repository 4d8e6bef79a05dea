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

__all__ = ["ab_orders", "baseline", "plot_order", "plot_ratio_maps"]

QUANTITIES = (("err_eta", "position/angle error (eta)"), ("err_v", "velocity error (v)"))


def ab_orders(methods: Any) -> dict[int, str]:
    """Order -> name of the fixed Adams-Bashforth rules among ``methods`` (E is AB1;
    of two names of one order, the first in sorted order, "AB1" before "E")."""
    out: dict[int, str] = {}
    for name in sorted({str(m) for m in methods}):
        try:
            m = get_method(name)
        except ValueError:  # a name no longer registered: not one of the AB rules
            continue
        if m.family == "AB":
            out.setdefault(int(m.order), name)
    return dict(sorted(out.items()))


def baseline(methods: Any) -> str | None:
    """The AB1 rule of a study ("AB1", else "E"), or None."""
    return ab_orders(methods).get(1)


def noise_label(eta: float, v: float) -> str:
    return f"({eta:g}%, {v:g}%)"


def plot_order(means: Any, path: Path, title: str) -> Path:
    """Error norm against the order s, one panel per h and quantity, one line per
    noise pair (AB rules); other rules (RK_s, T, ...) as markers at their order."""
    from matplotlib.figure import Figure

    hs = sorted(means["h"].unique())
    pairs = list(dict.fromkeys(zip(means["eta_pct"], means["v_pct"], strict=True)))
    orders = ab_orders(means["method"].unique())
    others = sorted(set(means["method"]) - set(orders.values()))
    height = 3.0 * len(hs) + 1.4
    fig = Figure(figsize=(10.0, height))
    # Fixed margins: constrained layout costs seconds on figures with many log axes.
    fig.subplots_adjust(
        left=0.08, right=0.98, top=1 - 0.55 / height, bottom=1.15 / height, hspace=0.45, wspace=0.18
    )
    axes = fig.subplots(len(hs), 2, squeeze=False)
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
                    if len(row):
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
            ax.set_title(f"h = {h:g} s: {qname}", fontsize=9)
            ax.set_xlabel("order s")
            ax.set_xticks(sorted({*orders, *(int(o) for o in sub["order"].dropna())}))
            ax.grid(True, alpha=0.3)
    handles, labels = axes[0][0].get_legend_handles_labels()
    if handles:
        fig.legend(
            handles,
            labels,
            loc="lower center",
            ncol=min(6, len(labels)),
            fontsize=8,
            title="noise (eta %, v %); hollow markers: other rules",
            title_fontsize=8,
        )
    fig.suptitle(title, fontsize=10)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90)
    return path


def _palette(n: int) -> list[Any]:
    from matplotlib import colormaps

    cmap = colormaps["viridis" if n > 10 else "tab10"]
    return [cmap(i / max(1, n - 1)) if n > 10 else cmap(i) for i in range(n)]


def plot_ratio_maps(means: Any, path: Path, title: str) -> Path | None:
    """Maps of AB_s / AB1 over (noise pair, h), one row per s >= 2, one column per
    quantity; blue where AB_s is better, red where AB1 is. None if the study has no
    AB1 (or E) and no higher AB order."""
    from matplotlib.colors import TwoSlopeNorm
    from matplotlib.figure import Figure

    orders = ab_orders(means["method"].unique())
    base = orders.get(1)
    highs = [s for s in orders if s >= 2]
    if base is None or not highs:
        return None
    hs = sorted(means["h"].unique())
    pairs = list(dict.fromkeys(zip(means["eta_pct"], means["v_pct"], strict=True)))
    idx = {(r.h, r.eta_pct, r.v_pct, r.method): r for r in means.itertuples(index=False)}
    height = 1.0 + len(highs) * (0.6 + 0.22 * len(pairs))
    fig = Figure(figsize=(3.5 + 2.4 * len(hs), height))
    fig.subplots_adjust(
        left=0.14,
        right=0.86,
        top=1 - 0.5 / height,
        bottom=0.45 / height,
        hspace=0.9 / (0.6 + 0.22 * len(pairs)),
        wspace=0.45,
    )
    axes = fig.subplots(len(highs), 2, squeeze=False)
    norm = TwoSlopeNorm(vcenter=0.0, vmin=-1.0, vmax=1.0)
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
            image = ax.imshow(np.clip(grid, -1, 1), cmap="RdBu_r", norm=norm, aspect="auto")
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
            ax.set_title(f"{orders[s]} / {base}: {qname}", fontsize=9)
    if image is not None:
        cax = fig.add_axes((0.9, 0.2, 0.015, 0.6))
        bar = fig.colorbar(image, cax=cax, label="log10 ratio (clipped at +-1)")
        bar.ax.tick_params(labelsize=7)
    fig.suptitle(title, fontsize=10)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90)
    return path

"""Fig. 7: the paper-layout table, the norm evidence and the figure."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..experiments import PAPER_FIG7
from ..methods import get_method

__all__ = ["fig7_table", "norm_evidence", "plot_fig7", "ratio_phrase"]


def ratio_phrase(ab1: float, ab4: float) -> str:
    """The paper's comparison wording: "AB1 ~ 75xAB4", "3.2xAB1 ~ AB4", "AB1 ~ AB4"."""
    if not (ab1 > 0 and ab4 > 0):
        return "n/a"
    r = ab1 / ab4
    big = max(r, 1.0 / r)
    if round(big, 1) <= 1.0:
        return "AB1 ~ AB4"
    txt = f"{big:.2g}"
    return f"AB1 ~ {txt}xAB4" if r > 1 else f"{txt}xAB1 ~ AB4"


def _cell(ab1: float, ab4: float) -> str:
    return f"{ratio_phrase(ab1, ab4)} ({ab1:.1e}, {ab4:.1e})"


def _lookup(summary: Sequence[dict[str, Any]]) -> dict[tuple[Any, ...], dict[str, Any]]:
    return {(r["h"], r["eta_pct"], r["v_pct"], r["method"]): r for r in summary}


def fig7_table(summary: Sequence[dict[str, Any]], norm: str = "l2_over_n") -> str:
    """Text table in the paper's layout, ours above the paper's numbers."""
    look = _lookup(summary)
    hs = sorted({r["h"] for r in summary})
    pairs = list(dict.fromkeys((r["eta_pct"], r["v_pct"]) for r in summary))
    heads = [f"h={h:g} s {q}" for h in hs for q in ("position", "velocity")]
    width = 36
    lines = ["noise (eta%, v%)       " + "".join(hd.ljust(width) for hd in heads)]
    lines.append("-" * len(lines[0]))
    for e, v in pairs:
        ours, paper = [], []
        for h in hs:
            r1, r4 = look.get((h, e, v, "AB1")), look.get((h, e, v, "AB4"))
            for q in ("pos", "vel"):
                ours.append(_cell(r1[f"{q}_{norm}"], r4[f"{q}_{norm}"]) if r1 and r4 else "-")
                ref = PAPER_FIG7.get((h, e, v))
                paper.append(_cell(*ref[0 if q == "pos" else 1]) if ref else "-")
        label = f"({e:g}%, {v:g}%)"
        lines.append(f"{label:14s} ours   " + "".join(c.ljust(width) for c in ours))
        lines.append(f"{'':14s} paper  " + "".join(c.ljust(width) for c in paper))
    return "\n".join(lines)


def norm_evidence(summary: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Which norm is the paper's "quadratic norm"?

    Two tests over the cells present in both: (1) the geometric mean and spread of
    ours / paper over all AB1 and AB4 numbers, per norm; (2) in noise-dominated cells
    (eta >= 10 %, position error), the growth from h = 0.1 to h = 0.5, which is
    sqrt(5) = 2.24 for l2/N (N shrinks 5x, the rms does not change) and 1 for the rms.
    """
    look = _lookup(summary)
    out: dict[str, Any] = {}
    for norm in ("l2_over_n", "rms"):
        logs = []
        for (h, e, v), ((p1, p4), (v1, v4)) in PAPER_FIG7.items():
            for method, q, ref in (
                ("AB1", "pos", p1),
                ("AB4", "pos", p4),
                ("AB1", "vel", v1),
                ("AB4", "vel", v4),
            ):
                r = look.get((h, e, v, method))
                if r is not None and r[f"{q}_{norm}"] > 0:
                    logs.append(math.log10(r[f"{q}_{norm}"] / ref))
        growth = []
        for (h, e, v), _ in PAPER_FIG7.items():
            if h != 0.1 or e < 10:
                continue
            a, b = look.get((0.1, e, v, "AB1")), look.get((0.5, e, v, "AB1"))
            if a and b:
                growth.append(b[f"pos_{norm}"] / a[f"pos_{norm}"])
        out[norm] = {
            "cells": len(logs),
            "geo_mean_ratio": 10 ** float(np.mean(logs)) if logs else math.nan,
            "median_abs_log10": float(np.median(np.abs(logs))) if logs else math.nan,
            "growth_h01_to_h05": float(np.mean(growth)) if growth else math.nan,
        }
    paper_growth = [
        PAPER_FIG7[(0.5, e, v)][0][0] / PAPER_FIG7[(0.1, e, v)][0][0]
        for (h, e, v) in PAPER_FIG7
        if h == 0.1 and e >= 10
    ]
    out["paper_growth_h01_to_h05"] = float(np.mean(paper_growth))
    return out


def plot_fig7(
    summary: Sequence[dict[str, Any]], path: str | Path, norm: str = "l2_over_n", title: str = ""
) -> Path:
    """Position and velocity errors per noise pair, one panel per (quantity, h), with
    the seed spread as error bars and the paper's AB1/AB4 numbers as open markers."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    look = _lookup(summary)
    hs = sorted({r["h"] for r in summary})
    pairs = list(dict.fromkeys((r["eta_pct"], r["v_pct"]) for r in summary))
    methods = list(dict.fromkeys(r["method"] for r in summary))
    xs = np.arange(len(pairs))
    colors = {m: plt.get_cmap("tab10")(k % 10) for k, m in enumerate(methods)}
    fig, axes = plt.subplots(2, len(hs), figsize=(6.5 * len(hs), 7.5), squeeze=False, sharex=True)
    for col, h in enumerate(hs):
        for row, (q, label) in enumerate((("pos", "position"), ("vel", "velocity"))):
            ax = axes[row][col]
            # The y range follows the rules that use f at the samples only (AB_s)
            # and the paper; a rule far off that range (RK4 when h |lambda| leaves
            # its stability region) is drawn as triangles on the top edge.
            inside = [
                look[(h, e, v, m)][f"{q}_{norm}"]
                for e, v in pairs
                for m in methods
                if not get_method(m).intersample
            ] + [
                r[0 if q == "pos" else 1][j]
                for r in (PAPER_FIG7.get((h, e, v)) for e, v in pairs)
                if r
                for j in (0, 1)
            ]
            lo, hi = min(inside) / 3.0, max(inside) * 10.0
            for k, m in enumerate(methods):
                ys = np.array([look[(h, e, v, m)][f"{q}_{norm}"] for e, v in pairs])
                es = np.array([look[(h, e, v, m)][f"{q}_{norm}_std"] for e, v in pairs])
                off = ys > hi
                shift = xs + 0.06 * (k - len(methods) / 2)
                ys_in = np.where(off, np.nan, ys)
                ax.errorbar(
                    shift,
                    ys_in,
                    yerr=np.where(off, np.nan, es),
                    fmt=".-",
                    color=colors[m],
                    label=m,
                    lw=1,
                    ms=5,
                    capsize=2,
                )
                if off.any():
                    ax.plot(
                        shift[off],
                        np.full(off.sum(), hi * 0.8),
                        "^",
                        color=colors[m],
                        ms=7,
                        label=f"{m} off scale (up to {ys[off].max():.0e})",
                    )
            for m, j, mk in (("AB1", 0, "o"), ("AB4", 1, "s")):
                ref = [PAPER_FIG7.get((h, e, v)) for e, v in pairs]
                ys = np.array([r[0 if q == "pos" else 1][j] if r else np.nan for r in ref])
                ax.plot(xs, ys, mk, mfc="none", color=colors.get(m, "k"), ms=8, label=f"paper {m}")
            ax.set_yscale("log")
            ax.set_ylim(lo, hi)
            ax.set_title(f"{label} error, h = {h:g} s", fontsize=10)
            ax.grid(True, which="both", alpha=0.3)
            if col == 0:
                ax.set_ylabel(f"{norm} of disturbed local errors")
            if row == 1:
                ax.set_xticks(xs, [f"({e:g},{v:g})" for e, v in pairs], rotation=60, fontsize=8)
                ax.set_xlabel("noise (eta %, v %)")
    for ax in axes.ravel():
        ax.legend(fontsize=6, ncol=2)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path

"""Fig. 7: the paper-layout table, the norm evidence and the figure."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..experiments._paper_fig7 import PAPER_FIG7
from ..methods import get_predictor

__all__ = ["fig7_table", "norm_evidence", "plot_fig7", "prepare_fig7_report", "ratio_phrase"]

#: Resolution of fig7.png (dots per inch).
_DPI = 110


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
    if not (math.isfinite(ab1) and math.isfinite(ab4)):
        return "n/a (a cell failed)"
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


#: Panels of the figure: column prefix -> quantity with its unit. The paper's norm adds
#: m and rad (m/s and rad/s) in one Euclidean norm; the figure splits it by unit.
FIG7_PANELS = (
    ("lin_pos", "position error (m)"),
    ("ang_pos", "attitude error (rad)"),
    ("lin_vel", "linear velocity error (m/s)"),
    ("ang_vel", "angular rate error (rad/s)"),
)
_MIXED_PANELS = (
    ("pos", "eta error\n(m and rad mixed, the paper's norm)"),
    ("vel", "v error\n(m/s and rad/s mixed, the paper's norm)"),
)


def sorted_pairs(rows: Sequence[dict[str, Any]]) -> list[tuple[float, float]]:
    """The noise pairs (eta %, v %) of ``rows``, sorted (by eta, then v)."""
    return sorted({(float(r["eta_pct"]), float(r["v_pct"])) for r in rows})


def _figure(
    summary: Sequence[dict[str, Any]], norm: str, title: str, dpi: float | None = None
) -> Any:
    from matplotlib import colormaps
    from matplotlib.figure import Figure

    look = {(r["h"], float(r["eta_pct"]), float(r["v_pct"]), r["method"]): r for r in summary}
    hs = sorted({r["h"] for r in summary})
    pairs = sorted_pairs(summary)
    methods = list(dict.fromkeys(r["method"] for r in summary))
    panels = [p for p in FIG7_PANELS if f"{p[0]}_{norm}" in summary[0]] or list(_MIXED_PANELS)
    xs = np.arange(len(pairs))
    cmap = colormaps["tab10"]
    colors = {m: cmap(k % 10) for k, m in enumerate(methods)}
    fig = Figure(figsize=(5.8 * len(hs) + 0.6, 2.7 * len(panels) + 1.9), dpi=dpi)
    axes = fig.subplots(len(panels), len(hs), squeeze=False, sharex=True)
    for col, h in enumerate(hs):
        for row, (q, label) in enumerate(panels):
            ax = axes[row][col]
            key = f"{q}_{norm}"
            # The y range follows the rules that use f at the samples only (AB_s); a
            # rule far off it (RK4 when h |lambda| leaves its stability region) is drawn
            # as triangles on the top edge, with its largest value in the legend.
            values = [
                (look[(h, e, v, m)][key], get_predictor(m).intersample)
                for e, v in pairs
                for m in methods
                if (h, e, v, m) in look
            ]
            values = [(y, i) for y, i in values if math.isfinite(y) and y > 0]
            inside = [y for y, i in values if not i]
            lo = min(y for y, _ in values) / 3.0 if values else None
            hi = max(inside) * 10.0 if inside else None
            for k, m in enumerate(methods):
                ys = np.array([look.get((h, e, v, m), {}).get(key, np.nan) for e, v in pairs])
                es = np.array(
                    [look.get((h, e, v, m), {}).get(f"{key}_std", np.nan) for e, v in pairs]
                )
                off = ys > hi if hi is not None else np.zeros(ys.shape, dtype=bool)
                shift = xs + 0.06 * (k - len(methods) / 2)
                if np.isfinite(np.where(off, np.nan, ys)).any():
                    ax.errorbar(
                        shift, np.where(off, np.nan, ys), yerr=np.where(off, np.nan, es),
                        fmt=".-", color=colors[m], label=m, lw=1, ms=5, capsize=2,
                    )  # fmt: skip
                if off.any() and hi is not None:
                    ax.plot(
                        shift[off], np.full(off.sum(), hi * 0.8), "^", color=colors[m], ms=7,
                        label=f"{m} off scale (drawn at the top edge; see fig7.csv)",
                    )  # fmt: skip
            ax.set_yscale("log")
            if lo is not None:
                ax.set_ylim(lo, hi)
            # y = 1 is where matplotlib puts a title when no tick labels are above the
            # axes; given, it spares the search for them at every layout pass.
            name = label.split("\n")[0].split(" (")[0]
            ax.set_title(f"{name}, h = {h:g} s", fontsize=9, y=1.0)
            ax.set_ylabel(f"{norm} of {label}", fontsize=8)
            ax.grid(True, which="major", alpha=0.3)
            _minor_log_grid(ax, alpha=0.3)
            if row == len(panels) - 1:
                ax.set_xticks(xs, [f"({e:g},{v:g})" for e, v in pairs], rotation=60, fontsize=8)
                ax.set_xlabel("noise (eta %, v %)", fontsize=8)
    labels: dict[str, Any] = {}
    for ax in axes.ravel():
        for handle, label in zip(*ax.get_legend_handles_labels(), strict=True):
            labels.setdefault(label, handle)
    ncol = min(6, max(1, len(labels)))
    fig.legend(
        list(labels.values()), list(labels), loc="lower center", ncol=ncol, fontsize=8,
        bbox_to_anchor=(0.5, _EDGE_IN / fig.get_figheight()),
    )  # fmt: skip
    if title:
        fig.suptitle(title, fontsize=10, y=1 - _EDGE_IN / fig.get_figheight(), va="top")
    label_lines = max(label.count("\n") + 1 for _q, label in panels)
    _margins(fig, -(-len(labels) // ncol), label_lines, bool(title))
    return fig


# Margins in inches, fixed (constrained layout took 40 % of the figure's drawing time,
# about 0.25 CPU s of every `reproduce fig7`): room for the y tick labels and label
# left of each column, the panel titles above each row, the x tick labels (rotated),
# the x label and the legend rows below the last row, the figure title on top.
_EDGE_IN = 0.06
_YLABEL_IN = 0.72
_RIGHT_IN = 0.12
_PANEL_TITLE_IN = 0.3
_FIG_TITLE_IN = 0.28
_XTICKS_IN = 0.62
_XLABEL_IN = 0.22
_LEGEND_ROW_IN = 0.24
_LABEL_LINE_IN = 0.14


def _margins(fig: Any, legend_rows: int, label_lines: int, title: bool) -> None:
    """Lay ``fig``'s grid of axes out with the fixed margins above (y labels of
    ``label_lines`` lines, a legend of ``legend_rows`` rows)."""
    width, height = fig.get_figwidth(), fig.get_figheight()
    left = _YLABEL_IN + (label_lines - 1) * _LABEL_LINE_IN
    (rows, cols) = fig.axes[0].get_subplotspec().get_gridspec().get_geometry()
    top = _EDGE_IN + _PANEL_TITLE_IN + (_FIG_TITLE_IN if title else 0.0)
    bottom = _EDGE_IN + _XTICKS_IN + _XLABEL_IN + legend_rows * _LEGEND_ROW_IN
    ax_w = (width - left - _RIGHT_IN - (cols - 1) * left) / cols
    ax_h = (height - top - bottom - (rows - 1) * _PANEL_TITLE_IN) / rows
    fig.subplots_adjust(
        left=left / width, right=1 - _RIGHT_IN / width,
        top=1 - top / height, bottom=bottom / height,
        wspace=left / ax_w, hspace=_PANEL_TITLE_IN / ax_h,
    )  # fmt: skip


def _minor_log_grid(ax: Any, alpha: float) -> None:
    """Grid lines at 2..9 x 10^k inside the y range of a log axes, as one collection.

    They are where ``ax.grid(which="minor")`` draws them, without the minor ticks
    matplotlib would create for them: a Tick of artists per minor line, which made
    most of the figure's drawing time (8 panels, up to 9 decades each)."""
    from matplotlib import rcParams
    from matplotlib.collections import LineCollection
    from matplotlib.ticker import NullLocator

    lo, hi = ax.get_ylim()
    k = np.arange(math.floor(math.log10(lo)), math.ceil(math.log10(hi)) + 1)
    ys = (np.arange(2, 10)[None, :] * 10.0 ** k[:, None]).ravel()
    ys = ys[(ys > lo) & (ys < hi)]
    segments = [((0.0, y), (1.0, y)) for y in ys]
    lines = LineCollection(
        segments, transform=ax.get_yaxis_transform(), colors=rcParams["grid.color"],
        linewidths=rcParams["grid.linewidth"], linestyles=rcParams["grid.linestyle"],
        alpha=alpha, zorder=0.5,
    )  # fmt: skip
    ax.add_collection(lines, autolim=False)
    ax.yaxis.set_minor_locator(NullLocator())


def plot_fig7(
    summary: Sequence[dict[str, Any]], path: str | Path, norm: str = "l2_over_n", title: str = ""
) -> Path:
    """The Fig. 7 errors per noise pair (sorted), one panel per quantity and h, with the
    seed spread as error bars.

    Each quantity has its unit: positions (m), Euler angles (rad), linear velocities
    (m/s) and angular rates (rad/s), from the norms split by unit (columns
    ``lin_pos_``, ``ang_pos_``, ``lin_vel_``, ``ang_vel_<norm>``). The paper's own
    norm adds m and rad in one number (its numbers are in :func:`fig7_table`); a
    summary without the split columns is drawn in that mixed norm, and says so.

    A ``.png`` path is drawn once by Agg (``savefig`` draws the figure twice: once to
    lay it out, once to render it; the pixels are the same); another suffix is
    saved in its format by ``savefig``.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig = _figure(summary, norm, title, dpi=_DPI)
    if path.suffix.lower() == ".png":
        FigureCanvasAgg(fig).print_png(path)
    else:
        fig.savefig(path, dpi=_DPI)
    return path


def prepare_fig7_report() -> None:
    """Import what :func:`fig7_report` draws with (matplotlib: a third of the report's
    time). ``reproduce fig7`` runs it in a thread while the workers compute the cells.
    (A small figure drawn here as well would spare the report only 20 ms of its 0.6 s
    and cost 0.1 s CPU.)"""
    import importlib

    for name in ("figure", "backends.backend_agg", "collections", "ticker"):
        importlib.import_module(f"matplotlib.{name}")


def _loop(config: Any) -> str:
    if config.feedback is None:
        return "open loop (the paper's input)"
    return f"closed by {config.feedback['law']} " + ", ".join(
        f"{k} {v:g}" for k, v in config.feedback.items() if k != "law"
    )


def fig7_report(output: Any, out: Path, *, store: Any = None) -> list[str]:
    """The report of ``reproduce fig7`` (a :class:`~sampledyn.experiments._studies.StudyOutput`
    of the Fig. 7 study): writes ``fig7_runs.csv`` (one row per run), ``fig7.csv``
    (means over seeds) and ``fig7.png`` into ``out``; returns the lines to print (the
    exact samples' certificates and motion, the table next to the paper's numbers,
    the evidence on which norm the paper's is)."""
    from ..experiments._rov import FIG7_NORMS
    from ._tables import write_csv

    (result,) = output.results
    config, norm, summary = result.study.config, output.settings.norm, output.summary
    write_csv(output.rows, out / "fig7_runs.csv")
    csv_path = write_csv(summary, out / "fig7.csv")
    model = next(iter(result.study.trajectories.values()))["vehicle"]
    title = (
        f"{model}, Fig. 6 input, +{config.buoyancy_pct:g} % buoyancy, "
        f"T={config.T:g} s, errors t>={config.after:g} s, {len(config.seeds)} seeds"
    )
    png = plot_fig7(summary, out / "fig7.png", norm=norm, title=title)
    # (the cells computed and found stored: said by the run, as it ends)
    lines = [f"{config.vehicle}: {_loop(config)}"]
    motion = result.summaries()
    for h, cert in result.certificates().items():
        mo = motion.get(h, {})
        lines.append(
            f"h = {h:g} s: exact samples certified to {cert:.1e} per interval; mean surge "
            f"{mo.get('mean_surge_m_s', math.nan):.3f} m/s, depth change "
            f"{mo.get('depth_change_m', math.nan):+.2f} m, max |pitch| "
            f"{mo.get('max_abs_pitch_deg', math.nan):.1f} deg, max |roll| "
            f"{mo.get('max_abs_roll_deg', math.nan):.1f} deg"
        )
    for message in sorted({r["error"] for r in output.rows if r.get("error")}):
        lines.append(f"failed cells (n/a in the table): {message}")
    lines.append(
        f"\nFig. 7, {norm} of the disturbed local errors, mean over seeds (ours) and paper:"
    )
    lines.append(fig7_table(summary, norm=norm))
    ev = norm_evidence(summary)
    lines.append("\nWhich norm is the paper's 'quadratic norm'?")
    for k in FIG7_NORMS:
        e = ev[k]
        lines.append(
            f"  {k:10s} ours/paper geometric mean {e['geo_mean_ratio']:.3g} (median "
            f"|log10| {e['median_abs_log10']:.2f} over {e['cells']} numbers); growth "
            f"h=0.1 -> 0.5 in noise-dominated cells {e['growth_h01_to_h05']:.2f}"
        )
    lines.append(
        f"  paper's own growth h=0.1 -> 0.5 in those cells: {ev['paper_growth_h01_to_h05']:.2f}"
    )
    lines.append(f"wrote {csv_path}, {out / 'fig7_runs.csv'} and {png}")
    return lines

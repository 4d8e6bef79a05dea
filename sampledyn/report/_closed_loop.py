"""Tables and figures of the closed-loop and multi-step studies."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["closed_loop_table", "multistep_table", "plot_closed_loop", "plot_multistep"]


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        if math.isnan(v):
            return "diverged"
        return f"{v:.3g}"
    return str(v)


def closed_loop_table(summary: list[dict[str, Any]]) -> str:
    """Markdown table: one row per (vehicle, h, method, noise pair) with the rule's
    one-step error on the loop's motion, the design's spectral radii, the residual sets
    (95th / 100th percentile after the transient) and the effort."""
    cols = (
        ("vehicle", "vehicle"), ("h", "h (s)"), ("method", "design"),
        ("noise", "noise eta/v %"), ("one_step_rms", "one-step err"),
        ("rho_design", "rho design"), ("rho_true", "rho exact"),
        ("depth_p95", "depth p95 (m)"), ("depth_max", "depth max (m)"),
        ("heading_p95", "heading p95 (rad)"), ("heading_max", "heading max (rad)"),
        ("surge_p95", "surge p95 (m/s)"), ("effort_rms", "effort rms (n_max)"),
        ("saturated", "saturated"),
    )  # fmt: skip
    lines = [
        "| " + " | ".join(title for _, title in cols) + " |",
        "|" + "---|" * len(cols),
    ]
    fixed = {"vehicle", "h", "method", "noise", "one_step_rms", "rho_design", "rho_true"}
    for r in sorted(summary, key=lambda r: (r["vehicle"], r["h"], r["eta_pct"], r["v_pct"])):
        cell = dict(r, noise=f"{r['eta_pct']:g}/{r['v_pct']:g}")
        # ZOH is the exact linearisation, the reference: it has no one-step model error.
        step = cell["one_step_rms"]
        cell["one_step_rms"] = "-" if isinstance(step, float) and math.isnan(step) else step
        shown = [_fmt(cell[k]) for k, _ in cols]
        if r.get("diverged"):  # the residual sets of a design with runs that left
            d = f"div {r['diverged']}/{r['runs']}"
            shown = [v if k in fixed else d for (k, _), v in zip(cols, shown, strict=True)]
        lines.append("| " + " | ".join(shown) + " |")
    return "\n".join(lines)


def multistep_table(summary: list[dict[str, Any]], ks: tuple[int, ...] = (1, 2, 5, 10, 20)) -> str:
    """Markdown table: position/angle rms error after k steps (and the free run, k = 0)
    per (h, noise pair, method)."""
    ks = tuple(k for k in ks if any(r["k"] == k for r in summary))
    head = ["h (s)", "noise eta/v %", "rule"] + [f"k={k}" for k in ks] + ["free run"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    index = {(r["method"], r["h"], r["eta_pct"], r["v_pct"], r["k"]): r for r in summary}
    keys = sorted({(r["h"], r["eta_pct"], r["v_pct"]) for r in summary})
    methods = list(dict.fromkeys(r["method"] for r in summary))
    for h, eta, v in keys:
        for m in methods:
            vals = [index.get((m, h, eta, v, k), {}).get("pos_rms", float("nan")) for k in ks]
            free = index.get((m, h, eta, v, 0), {})
            free_txt = "diverged" if free.get("diverged") else _fmt(free.get("pos_rms", math.nan))
            row = [f"{h:g}", f"{eta:g}/{v:g}", m] + [_err(x) for x in vals] + [free_txt]
            lines.append("| " + " | ".join(row) + " |")
    return "\n".join(lines)


def _err(x: float) -> str:
    return "diverged" if not math.isfinite(x) or x > 1e3 else f"{x:.3g}"


def plot_closed_loop(summary: list[dict[str, Any]], path: str | Path, *, title: str = "") -> Path:
    """Depth residual (95th percentile after the transient) of every design, one panel
    per (vehicle, h), one line per noise level; runs that diverged or saturated most of
    the time are drawn at the top edge with an x."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    vehicles = list(dict.fromkeys(r["vehicle"] for r in summary))
    hs = sorted({r["h"] for r in summary})
    methods = list(dict.fromkeys(r["method"] for r in summary))
    pairs = sorted({(r["eta_pct"], r["v_pct"]) for r in summary})
    fig, axes = plt.subplots(
        len(vehicles), len(hs), figsize=(5.2 * len(hs), 3.6 * len(vehicles)), squeeze=False
    )
    index = {(r["vehicle"], r["h"], r["method"], r["eta_pct"], r["v_pct"]): r for r in summary}
    top = 10.0
    for i, veh in enumerate(vehicles):
        for j, h in enumerate(hs):
            ax = axes[i][j]
            xs = np.arange(len(methods))
            for pair in pairs:
                ys = []
                bad = []
                for m in methods:
                    r = index.get((veh, h, m, *pair))
                    y = float("nan") if r is None else r["depth_p95"]
                    failed = r is not None and (not math.isfinite(y) or r["saturated"] > 0.2)
                    ys.append(top if failed else y)
                    bad.append(failed)
                ys_a = np.asarray(ys)
                line = ax.plot(
                    xs, np.where(bad, np.nan, ys_a), marker="o", label=f"{pair[0]:g}/{pair[1]:g} %"
                )
                ax.plot(
                    xs[np.asarray(bad)], ys_a[np.asarray(bad)], "x", ms=9,
                    color=line[0].get_color(),
                )  # fmt: skip
            ax.set_yscale("log")
            ax.set_ylim(1e-3, top * 1.5)
            ax.set_xticks(xs, methods)
            ax.set_title(f"{veh}, h = {h:g} s", fontsize=10)
            ax.set_ylabel("depth error, 95th pct (m)")
            ax.grid(True, which="both", alpha=0.3)
    axes[0][0].legend(title="noise eta/v", fontsize=8, title_fontsize=8)
    fig.suptitle(
        title
        or "LQR designed on each sampled-data model, run on the exact plant "
        "(x at the top: diverged or > 20 % of thruster-samples saturated)",
        fontsize=10,
    )
    fig.tight_layout(rect=(0, 0, 1, 0.95))
    path = Path(path)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def plot_multistep(summary: list[dict[str, Any]], path: str | Path, *, title: str = "") -> Path:
    """Position/angle error against the prediction horizon k, one panel per (h, noise
    pair), one curve per rule (log scale; errors above 1e3 clipped, i.e. diverged)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    hs = sorted({r["h"] for r in summary})
    pairs = sorted({(r["eta_pct"], r["v_pct"]) for r in summary})
    methods = list(dict.fromkeys(r["method"] for r in summary))
    fig, axes = plt.subplots(
        len(hs), len(pairs), figsize=(3.6 * len(pairs), 3.2 * len(hs)), squeeze=False
    )
    for i, h in enumerate(hs):
        for j, pair in enumerate(pairs):
            ax = axes[i][j]
            for m in methods:
                rs = sorted(
                    (r for r in summary
                     if r["method"] == m and r["h"] == h and (r["eta_pct"], r["v_pct"]) == pair
                     and r["k"] > 0),
                    key=lambda r: r["k"],
                )  # fmt: skip
                k = np.array([r["k"] for r in rs])
                e = np.array([r["pos_rms"] for r in rs])
                e = np.where(np.isfinite(e) & (e < 1e3), e, np.nan)
                ax.plot(k, e, marker=".", label=m)
            ax.set_yscale("log")
            ax.set_title(f"h = {h:g} s, noise {pair[0]:g}/{pair[1]:g} %", fontsize=9)
            ax.set_xlabel("steps ahead k")
            ax.set_ylabel("eta error rms (m, rad)")
            ax.grid(True, which="both", alpha=0.3)
    axes[0][0].legend(fontsize=7)
    fig.suptitle(
        title or "k-step-ahead prediction error (curves end where they diverge)", fontsize=10
    )
    fig.tight_layout(rect=(0, 0, 1, 0.95))
    path = Path(path)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def _controller_report(output: Any, out: Path, table: str, png: Path) -> list[str]:
    from ._tables import write_csv

    stem = output.study.replace("-", "_")
    write_csv(output.rows, out / f"{stem}_runs.csv")
    csv_path = write_csv(output.summary, out / f"{stem}.csv")
    (out / f"{stem}.md").write_text(table + "\n", encoding="utf-8")
    return [table, f"wrote {csv_path}, {out / f'{stem}_runs.csv'}, {out / f'{stem}.md'} and {png}"]


def closed_loop_report(output: Any, out: Path, *, store: Any = None) -> list[str]:
    """The report of ``reproduce closed-loop``: writes ``closed_loop_runs.csv``,
    ``closed_loop.csv``, ``closed_loop.md`` and ``closed_loop.png`` into ``out``;
    returns the lines to print (the table, the files)."""
    out.mkdir(parents=True, exist_ok=True)
    png = plot_closed_loop(output.summary, out / "closed_loop.png")
    return _controller_report(output, out, closed_loop_table(output.summary), png)


def multistep_report(output: Any, out: Path, *, store: Any = None) -> list[str]:
    """The report of ``reproduce multistep``: writes ``multistep_runs.csv``,
    ``multistep.csv``, ``multistep.md`` and ``multistep.png`` into ``out``; returns the
    lines to print (the table, the files)."""
    out.mkdir(parents=True, exist_ok=True)
    png = plot_multistep(output.summary, out / "multistep.png")
    return _controller_report(output, out, multistep_table(output.summary), png)

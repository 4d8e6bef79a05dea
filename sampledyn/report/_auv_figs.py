"""Figures 2 and 3: local-error norm against the order s, one curve per h_u/h."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..methods import Estimator, get_method

__all__ = ["plot_error_vs_order"]


def _figure(rows: Sequence[dict[str, Any]], norms: Sequence[tuple[str, str]], title: str) -> Any:
    from matplotlib import colormaps
    from matplotlib.figure import Figure

    ratios = sorted({r["hold_ratio"] for r in rows})
    families: dict[str, list[dict[str, Any]]] = {}
    for r in rows:
        families.setdefault(get_method(r["method"]).family, []).append(r)
    cmap = colormaps["viridis"]
    fig = Figure(figsize=(5.2 * len(norms), 5.6), layout="constrained")
    axes = fig.subplots(1, len(norms), sharey=True, squeeze=False)
    for ax, (norm, caption) in zip(axes[0], norms, strict=True):
        _panel(ax, rows, families, ratios, norm, caption, cmap)
    axes[0][0].set_ylabel("local error, rms over both states (x in m, y in m/s)")
    if title:
        fig.suptitle(title, fontsize=10)
    return fig


def plot_error_vs_order(
    rows: Sequence[dict[str, Any]],
    path: str | Path,
    *,
    norms: Sequence[tuple[str, str]] = (("rms", "all samples"),),
    title: str = "",
) -> Path:
    """Plot each norm (log scale) against the order, one panel per ``(key, caption)``.

    The rules of one family (AB, ABu, ABe, RK, ...) present at more than one order are
    joined as one curve per h_u/h (dashed for estimated rules); a family present at
    one order only (E, T, Ee in Fig. 3) is drawn as markers at that order. A curve
    without a finite value (a masked norm with no sample, e.g. no sample away from
    input jumps at h_u/h = 1) is not drawn and not in the legend; the panel says so.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    _figure(rows, norms, title).savefig(path, dpi=110)
    return path


def _panel(
    ax: Any,
    rows: Sequence[dict[str, Any]],
    families: dict[str, list[dict[str, Any]]],
    ratios: list[int],
    norm: str,
    caption: str,
    cmap: Any,
) -> None:
    single = [f for f, fr in families.items() if len({r["order"] for r in fr}) == 1]
    markers = dict(zip(single, "osD^v<>pPX*h", strict=False))
    estimated = {
        f for f, fr in families.items() if isinstance(get_method(fr[0]["method"]), Estimator)
    }
    curves = [f for f in families if f not in markers]
    # Solid curves carry the h_u/h labels; a second solid family gets another line style.
    solid = dict(zip([f for f in curves if f not in estimated], ("-", "-.", ":"), strict=False))
    labelled: set[str] = set()
    missing: list[int] = []
    for k, ratio in enumerate(ratios):
        color = cmap(k / max(1, len(ratios) - 1))
        drawn = False
        for fam, frows in families.items():
            pts = sorted(
                (r["order"], r[norm])
                for r in frows
                if r["hold_ratio"] == ratio and math.isfinite(float(r[norm]))
            )
            if not pts:
                continue
            drawn = True
            xs, ys = zip(*pts, strict=True)
            if fam in markers:
                label = get_method(frows[0]["method"]).label
            elif fam in estimated:
                label = f"{fam} (dashed; colour: $h_u/h$)"
            else:
                label = f"{fam}, $h_u/h$={ratio}"
            shown = label if label not in labelled else None
            labelled.add(label)
            if fam in markers:
                ax.plot(xs, ys, markers[fam], color=color, mfc="none", ms=8, label=shown)
            elif fam in estimated:
                ax.plot(xs, ys, "--", marker=".", color=color, label=shown)
            else:
                ax.plot(xs, ys, solid.get(fam, "-"), marker=".", color=color, label=shown)
        if not drawn:
            missing.append(ratio)
    ax.set_yscale("log")
    ax.set_xlabel("order s")
    title = caption
    if missing:
        title += f"\n(no such sample at $h_u/h$ = {', '.join(map(str, missing))})"
    ax.set_title(title, fontsize=9)
    ax.set_xticks(sorted({r["order"] for r in rows}))
    ax.grid(True, which="both", alpha=0.3)
    if labelled:
        ax.legend(fontsize=6, ncol=2)


_PANELS = (
    ("rms_away_from_jumps", "whose history holds no input jump"),
    ("rms_smooth", "away from input jumps and velocity zero crossings"),
)


def _missing_notes(rows: Sequence[dict[str, Any]]) -> list[str]:
    """The reasons of the n/a entries of the tables, once each."""
    reasons: dict[str, set[Any]] = {}
    for r in rows:
        for note in filter(None, str(r.get("notes", "")).split("; ")):
            column, _, why = note.partition(": ")
            reasons.setdefault(f"{column}: {why}", set()).add(r["hold_ratio"])
    return [
        f"n/a ({text.split(': ', 1)[0]}, h_u/h = {', '.join(map(str, sorted(ratios)))}): "
        f"{text.split(': ', 1)[1]}"
        for text, ratios in reasons.items()
    ]


def auv_report(output: Any, out: Path, *, store: Any = None) -> list[str]:
    """The report of ``reproduce fig2`` / ``fig3`` (a
    :class:`~sampledyn.experiments._studies.StudyOutput` of the AUV-like study): writes
    ``<study>.csv`` and ``<study>.png`` into ``out``; returns the lines to print (the
    norm's table, the masked rms tables, why an entry is n/a, the files)."""
    from ._tables import format_grid, write_csv

    which, study, rows = output.study, output.settings, output.rows
    csv_path = write_csv(rows, out / f"{which}.csv")
    title = (
        f"AUV-like (9)-(10): h={study.h:g} s, T={study.T:g} s, errors t>={study.after:g} s, "
        f"seed {study.seed}"
    )
    panels = ((study.norm, "all samples"), *_PANELS)
    png = plot_error_vs_order(rows, out / f"{which}.png", norms=panels, title=title)
    tau = min(r["tau_min"] for r in rows)
    cert = max(r["certificate"] for r in rows)
    lines = [
        f"{which}: {study.norm} norm of the one-step local errors (both states), "
        f"t >= {study.after:g} s",
        f"sampling period h = {study.h:g} s; fastest local time constant along the runs "
        f"{tau:.3g} s (h / tau = {study.h / tau:.2g}); exact samples certified to "
        f"{cert:.1e} per interval",
        format_grid(rows, "method", "hold_ratio", study.norm, col_title="hu/h"),
    ]
    for key, caption in _PANELS:
        lines.append(f"\nrms over the samples {caption}:")
        lines.append(format_grid(rows, "method", "hold_ratio", key, col_title="hu/h"))
    lines += _missing_notes(rows)
    lines.append(f"wrote {csv_path} and {png}")
    return lines

"""Figures 2 and 3: local-error norm against the order s, one curve per h_u/h."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..methods import get_method

__all__ = ["plot_error_vs_order"]


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
    one order only (E, T, Ee in Fig. 3) is drawn as markers at that order.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    ratios = sorted({r["hold_ratio"] for r in rows})
    families: dict[str, list[dict[str, Any]]] = {}
    for r in rows:
        families.setdefault(get_method(r["method"]).family, []).append(r)
    cmap = plt.get_cmap("viridis")
    fig, axes = plt.subplots(
        1, len(norms), figsize=(5.2 * len(norms), 4.8), sharey=True, squeeze=False
    )
    for ax, (norm, caption) in zip(axes[0], norms, strict=True):
        _panel(ax, rows, families, ratios, norm, caption, cmap)
    axes[0][0].set_ylabel("local error, rms over both states")
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
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
    estimated = {f for f, fr in families.items() if get_method(fr[0]["method"]).estimates_params}
    curves = [f for f in families if f not in markers]
    # Solid curves carry the h_u/h labels; a second solid family gets another line style.
    solid = dict(zip([f for f in curves if f not in estimated], ("-", "-.", ":"), strict=False))
    for k, ratio in enumerate(ratios):
        color = cmap(k / max(1, len(ratios) - 1))
        for fam, frows in families.items():
            pts = sorted((r["order"], r[norm]) for r in frows if r["hold_ratio"] == ratio)
            if not pts:
                continue
            xs, ys = zip(*pts, strict=True)
            if fam in markers:
                label = get_method(frows[0]["method"]).label if k == 0 else None
                ax.plot(xs, ys, markers[fam], color=color, mfc="none", ms=8, label=label)
            elif fam in estimated:
                ax.plot(xs, ys, "--", marker=".", color=color, label=fam if k == 0 else None)
            else:
                label = f"{fam}, $h_u/h$={ratio}"
                ax.plot(xs, ys, solid.get(fam, "-"), marker=".", color=color, label=label)
    ax.set_yscale("log")
    ax.set_xlabel("order s")
    ax.set_title(caption, fontsize=9)
    ax.set_xticks(sorted({r["order"] for r in rows}))
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=6, ncol=2)

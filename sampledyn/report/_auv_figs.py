"""Figures 2 and 3: local-error norm against the order s, one curve per h_u/h."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

__all__ = ["plot_error_vs_order"]


def plot_error_vs_order(
    rows: Sequence[dict[str, Any]], path: str | Path, *, norm: str = "rms", title: str = ""
) -> Path:
    """Plot ``norm`` (log scale) against the order for each method family.

    Methods whose names share a prefix (AB, ABe, RK) are joined as one curve per
    h_u/h; single rules (E, Ee, T) are drawn as markers at their order.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    ratios = sorted({r["hold_ratio"] for r in rows})
    families: dict[str, list[dict[str, Any]]] = {}
    for r in rows:
        fam = r["method"].rstrip("0123456789") if r["method"][-1].isdigit() else r["method"]
        families.setdefault(fam, []).append(r)
    styles = {"AB": "-", "RK": "-", "ABe": "--"}
    markers = {"E": "o", "T": "s", "Ee": "D"}
    cmap = plt.get_cmap("viridis")
    fig, ax = plt.subplots(figsize=(7.0, 4.8))
    for k, ratio in enumerate(ratios):
        color = cmap(k / max(1, len(ratios) - 1))
        for fam, frows in families.items():
            pts = sorted((r["order"], r[norm]) for r in frows if r["hold_ratio"] == ratio)
            if not pts:
                continue
            xs, ys = zip(*pts, strict=True)
            if fam in markers:
                ax.plot(
                    xs,
                    ys,
                    markers[fam],
                    color=color,
                    mfc="none",
                    ms=8,
                    label=f"{fam}" if k == 0 else None,
                )
            else:
                label = f"{fam}, $h_u/h$={ratio}" if fam != "ABe" else ("ABe" if k == 0 else None)
                ax.plot(xs, ys, styles.get(fam, "-"), marker=".", color=color, label=label)
    ax.set_yscale("log")
    ax.set_xlabel("order s")
    ax.set_ylabel(f"local error ({norm}, both states)")
    ax.set_xticks(sorted({r["order"] for r in rows}))
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    if title:
        ax.set_title(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path

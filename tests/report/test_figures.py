"""Figures a reader understands, checked by rendering them headless (Agg): units on
every y axis, legends that list only what is drawn, no title box over another,
noise pairs sorted, and tables that say "n/a" (with the reason) instead of "nan"."""

from __future__ import annotations

import math
from itertools import combinations
from unittest import mock

import numpy as np
import pandas as pd
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from sampledyn.experiments._paper_fig7 import PAPER_FIG7
from sampledyn.report import _auv_figs, _fig7, _sweep_figs, fig7_table
from sampledyn.report._tables import format_grid

UNITS = ("(m)", "(rad)", "(m/s)", "(rad/s)")


def _render(fig):
    FigureCanvasAgg(fig)
    renderer = fig.canvas.get_renderer()
    fig.draw(renderer)
    return renderer


def _boxes_overlap(a, b) -> bool:
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


def _title_boxes(fig, renderer):
    boxes = []
    if fig._suptitle is not None and fig._suptitle.get_text():
        boxes.append(("figure title", fig._suptitle.get_window_extent(renderer)))
    for i, ax in enumerate(fig.axes):
        if ax.get_title():
            boxes.append((f"axes {i} title", ax.title.get_window_extent(renderer)))
        if ax.get_xlabel():
            boxes.append((f"axes {i} x label", ax.xaxis.label.get_window_extent(renderer)))
    for legend in fig.legends:
        boxes.append(("figure legend", legend.get_window_extent(renderer)))
    return boxes


def _no_overlaps(fig):
    renderer = _render(fig)
    boxes = _title_boxes(fig, renderer)
    for (na, a), (nb, b) in combinations(boxes, 2):
        assert not _boxes_overlap(a, b), f"{na} overlaps {nb}"
    # and no title or legend runs into a panel
    for name, box in boxes:
        if "x label" in name:
            continue
        for i, ax in enumerate(fig.axes):
            if name == f"axes {i} title" or not ax.get_visible() or ax.get_label() == "<colorbar>":
                continue
            assert not _boxes_overlap(box, ax.get_window_extent(renderer)), (name, i)


def _drawn_labels(ax) -> set[str]:
    """Labels of artists with at least one finite point."""
    labels = set()
    for line in ax.get_lines():
        y = np.asarray(line.get_ydata(), dtype=float)
        if line.get_label() and not line.get_label().startswith("_") and np.isfinite(y).any():
            labels.add(line.get_label())
    for container in ax.containers:
        label = container.get_label()
        if label and not label.startswith("_"):
            y = np.asarray(container.lines[0].get_ydata(), dtype=float)
            if np.isfinite(y).any():
                labels.add(label)
    return labels


# ------------------------------------------------------------------------ Fig. 7
def _fig7_summary(split: bool = True):
    rows = []
    rng = np.random.default_rng(0)
    pairs = [(20, 2), (0, 0), (2, 0), (0, 10)]  # deliberately unsorted
    for h in (0.1, 0.5):
        for e, v in pairs:
            for m in ("AB1", "AB4", "RK4"):
                row = {"h": h, "eta_pct": e, "v_pct": v, "method": m, "seeds": 3}
                keys = ["pos", "vel"] + (
                    ["lin_pos", "ang_pos", "lin_vel", "ang_vel"] if split else []
                )
                for k in keys:
                    value = 10 ** rng.uniform(-5, -2)
                    if m == "RK4" and h == 0.5 and e == 20:
                        value = 1e7  # off scale
                    row[f"{k}_l2_over_n"] = value
                    row[f"{k}_l2_over_n_std"] = 0.1 * value
                rows.append(row)
    return rows


def test_fig7_axes_have_units_sorted_pairs_and_honest_legend():
    fig = _fig7._figure(_fig7_summary(), "l2_over_n", "a title")
    assert len(fig.axes) == 8  # 4 quantities x 2 h
    for ax in fig.axes:
        assert any(u in ax.get_ylabel() for u in UNITS), ax.get_ylabel()
        assert "mixed" not in ax.get_ylabel()
    bottom = fig.axes[-1]
    ticks = [t.get_text() for t in bottom.get_xticklabels()]
    assert ticks == ["(0,0)", "(0,10)", "(2,0)", "(20,2)"]  # sorted, not as given
    drawn = set().union(*(_drawn_labels(ax) for ax in fig.axes))
    [legend] = fig.legends
    listed = {t.get_text() for t in legend.get_texts()}
    assert listed == drawn and "RK4 off scale (drawn at the top edge; see fig7.csv)" in listed
    _no_overlaps(fig)


def test_fig7_without_split_norms_says_it_is_the_mixed_norm():
    fig = _fig7._figure(_fig7_summary(split=False), "l2_over_n", "")
    assert len(fig.axes) == 4
    assert all("mixed" in ax.get_ylabel() for ax in fig.axes)


def test_fig7_table_says_na_where_a_cell_failed():
    summary = []
    for (h, e, v), ((p1, p4), (v1, v4)) in PAPER_FIG7.items():
        for m, pos, vel in (("AB1", p1, v1), ("AB4", p4, v4)):
            summary.append({"h": h, "eta_pct": e, "v_pct": v, "method": m,
                            "pos_l2_over_n": pos, "vel_l2_over_n": vel})  # fmt: skip
    summary[0]["pos_l2_over_n"] = math.nan
    text = fig7_table(summary)
    assert "n/a (a cell failed)" in text and "nan" not in text


# -------------------------------------------------------------------- Figs. 2-3
def _fig2_rows():
    rows = []
    for ratio in (1, 10):
        for s in range(1, 4):
            for fam in ("AB", "ABu"):
                masked = math.nan if ratio == 1 else 10.0 ** (-s - 1)
                rows.append({
                    "hold_ratio": ratio, "method": f"{fam}{s}", "order": s,
                    "rms": 10.0**-s, "rms_away_from_jumps": masked,
                })  # fmt: skip
    return rows


def test_fig2_legend_lists_only_drawn_curves():
    norms = (("rms", "all samples"), ("rms_away_from_jumps", "away from input jumps"))
    fig = _auv_figs._figure(_fig2_rows(), norms, "a title")
    for ax in fig.axes:
        listed = {t.get_text() for t in ax.get_legend().get_texts()}
        assert listed == _drawn_labels(ax)
        assert ax.get_xlabel() == "order s"
    masked = fig.axes[1]
    assert not any(label.endswith("$=1") for label in _drawn_labels(masked))
    assert any(label.endswith("$=10") for label in _drawn_labels(masked))
    assert "no such sample at $h_u/h$ = 1" in masked.get_title()
    assert "(x in m, y in m/s)" in fig.axes[0].get_ylabel()
    _no_overlaps(fig)


def test_tables_print_na_not_nan():
    rows = [{"r": "AB1", "c": 1, "v": math.nan}, {"r": "AB1", "c": 2, "v": 1e-3}]
    text = format_grid(rows, "r", "c", "v")
    assert "n/a" in text and "nan" not in text


# ------------------------------------------------------------------ sweep report
PAIRS = tuple((e, v) for (h, e, v) in PAPER_FIG7 if h == 0.1)


def _means():
    rows = []
    for h in (0.1, 0.5):
        for e, v in PAIRS:  # the paper's order, not sorted
            for s in (1, 2, 4):
                rows.append({"h": h, "eta_pct": e, "v_pct": v, "method": f"AB{s}", "order": s,
                             "err_eta": 10.0**-s, "err_v": 2 * 10.0**-s, "seeds": 2})  # fmt: skip
            rows.append({"h": h, "eta_pct": e, "v_pct": v, "method": "RK4", "order": 4,
                         "err_eta": 1e-6, "err_v": 1e-6, "seeds": 2})  # fmt: skip
    return pd.DataFrame(rows)


@pytest.mark.parametrize("plot", ["order", "ratio"])
def test_report_figures_titles_labels_and_sorted_pairs(tmp_path, plot):
    captured = []

    def capture(fig, *args, **kwargs):
        captured.append(fig)

    title = "rexrov, input fig6, +1 % buoyancy, T = 20 s, errors on t >= 5 s, norm rms[m,m/s]"
    with mock.patch.object(Figure, "savefig", capture):
        if plot == "order":
            _sweep_figs.plot_order(_means(), tmp_path / "o.png", title, "rms[m,m/s]")
        else:
            _sweep_figs.plot_ratio_maps(_means(), tmp_path / "r.png", title, "rms[m,m/s]")
    [fig] = captured
    panels = [ax for ax in fig.axes if ax.get_label() != "<colorbar>" and ax.get_title()]
    assert panels
    for ax in panels:
        assert ax.get_ylabel() or plot == "ratio"  # maps: y axis = the noise pairs
        assert "(m)" in ax.get_title() or "(m/s)" in ax.get_title()  # units of rms[m,m/s]
    expected = [f"({e:g}%, {v:g}%)" for e, v in sorted(PAIRS)]
    assert expected != [f"({e:g}%, {v:g}%)" for e, v in PAIRS]
    if plot == "order":
        for ax in panels:
            assert "(m)" in ax.get_ylabel() or "(m/s)" in ax.get_ylabel()
        [legend] = fig.legends
        pairs = [t.get_text() for t in legend.get_texts() if t.get_text().startswith("(")]
        assert pairs == expected
    else:
        labels = [t.get_text() for t in panels[0].get_yticklabels()]
        assert labels == expected
    _no_overlaps(fig)

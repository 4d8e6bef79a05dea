"""fig7.png drawn once by Agg is the picture ``savefig`` draws (same pixels), at the
figure's size and resolution; another suffix is saved in its own format; and the
report's preparation (run ahead in a thread by ``reproduce``) leaves a failure to the
report."""

from __future__ import annotations

import matplotlib.image as mpimg
import numpy as np

from sampledyn.cli._reproduce import _Ahead
from sampledyn.report import _fig7


def _summary():
    rng = np.random.default_rng(1)
    rows = []
    for h in (0.1, 0.5):
        for e, v in ((0, 0), (2, 0), (20, 2)):
            for m in ("AB1", "AB4", "RK4"):
                row = {"h": h, "eta_pct": e, "v_pct": v, "method": m, "seeds": 3}
                for k in ("pos", "vel", "lin_pos", "ang_pos", "lin_vel", "ang_vel"):
                    value = 1e7 if (m == "RK4" and h == 0.5) else 10 ** rng.uniform(-5, -2)
                    row[f"{k}_l2_over_n"] = value
                    row[f"{k}_l2_over_n_std"] = 0.1 * value
                rows.append(row)
    return rows


def test_png_drawn_once_has_the_pixels_savefig_draws(tmp_path):
    summary = _summary()
    path = _fig7.plot_fig7(summary, tmp_path / "fig7.png", title="a title")
    _fig7._figure(summary, "l2_over_n", "a title").savefig(tmp_path / "ref.png", dpi=110)
    got, ref = mpimg.imread(path), mpimg.imread(tmp_path / "ref.png")
    # 4 panels x 2 h: (5.8 * 2 + 0.6) x (2.7 * 4 + 1.9) inches at 110 dpi
    assert got.shape == ref.shape == (1397, 1342, 4)
    assert np.array_equal(got, ref)


def test_another_suffix_is_saved_in_its_format(tmp_path):
    path = _fig7.plot_fig7(_summary(), tmp_path / "fig7.svg")
    assert path.read_text().lstrip().startswith("<?xml") and "<svg" in path.read_text()


def test_a_failing_preparation_is_left_to_the_report():
    def fails():
        raise ImportError("no matplotlib here")

    ahead = _Ahead(fails)
    ahead.start()
    ahead.wait()  # returns: the report meets the error again and reports it
    done = []
    ahead = _Ahead(lambda: done.append(1))
    ahead.start()
    ahead.start()  # once only
    ahead.wait()
    assert done == [1]
    _Ahead(None).start()  # a study without a preparation: nothing runs


def _boxes_apart(a, b):
    return a.x1 <= b.x0 or b.x1 <= a.x0 or a.y1 <= b.y0 or b.y1 <= a.y0


def test_fixed_margins_leave_room_for_every_label():
    """With the fixed margins (no layout engine) every panel, with its tick labels,
    labels and title, lies inside the figure and clear of the other panels, of the
    legend and of the figure title; on the study's summary (with off-scale entries:
    a longer legend) and on one in the paper's mixed norm (longer y labels)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    split = _summary()
    mixed = [{k: v for k, v in r.items() if not k.startswith(("lin_", "ang_"))} for r in split]
    for summary in (split, mixed, [r for r in split if r["h"] == 0.1]):
        fig = _fig7._figure(summary, "l2_over_n", "a title, as long as the study's own one")
        canvas = FigureCanvasAgg(fig)
        canvas.draw()
        renderer = canvas.get_renderer()
        page = fig.bbox
        panels = [ax.get_tightbbox(renderer) for ax in fig.axes]
        others = [fig.legends[0].get_window_extent(renderer), fig._suptitle.get_window_extent()]
        for k, box in enumerate(panels):
            assert page.x0 <= box.x0 and box.x1 <= page.x1 and page.y0 <= box.y0
            assert box.y1 <= page.y1
            for other in panels[k + 1 :] + others:
                assert _boxes_apart(box, other), (k, box, other)
        for other in others:
            assert page.x0 <= other.x0 and other.x1 <= page.x1
            assert page.y0 <= other.y0 and other.y1 <= page.y1

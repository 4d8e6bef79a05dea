"""A static report of a results store: one HTML page and one Markdown file with the
same tables, and PNG figures beside them (``figures/``), per study.

A study is a set of cells that can be compared: same vehicle, input (and their
fingerprints), T, error window, norm, noise distribution and library version. Cells
of different studies are never averaged together. The cells of the controller
studies (cell kinds other than prediction: ``reproduce closed-loop``, ``multistep``)
are reported as tables of their named results, means over seeds.

The HTML page checks its own figures: a script marks every ``img.figure`` with its
``naturalWidth`` once the page has loaded, and sets ``data-figures`` and
``data-figures-loaded`` on ``<body>``, so a headless browser can assert that every
figure rendered.
"""

from __future__ import annotations

import errno
import html
import json
import os
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from .._files import parse_json, read_text, write_text_atomic
from ._sweep_figs import ab_orders, noise_label, plot_order, plot_ratio_maps

__all__ = ["MANIFEST", "REPORT_FILES", "ReportFiles", "write_report"]

#: The report's list of the files it wrote (JSON), in its output folder: the next
#: report into that folder removes these (figures of studies no longer there), and
#: nothing else.
MANIFEST = ".sampledyn-report.json"
#: What a report writes into its folder ("/": a folder whose files it writes).
REPORT_FILES = ("index.html", "report.md", "figures/", MANIFEST)

STUDY_COLUMNS = (
    "vehicle",
    "input",
    "model_fingerprint",
    "input_fingerprint",
    "buoyancy_pct",
    "T",
    "after",
    "norm",
    "distribution",
    "base_seed",
    "version",
)

# The study of a cell of another kind: its norm column holds the kind's measure
# (several per study, e.g. the horizons k of a multistep study), its input is none.
KIND_STUDY_COLUMNS = tuple(c for c in STUDY_COLUMNS if c not in ("norm", "input"))
# (The prediction cells come from the store's prediction view, whose measure is "norm";
# the other kinds' from its generic table, whose measure is "measure".)

Block = tuple[Any, ...]


@dataclass(frozen=True)
class ReportFiles:
    """Paths written by :func:`write_report`."""

    html: Path
    markdown: Path
    figures: tuple[Path, ...]


def _fmt(x: Any) -> str:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return str(x)
    return "-" if v != v else f"{v:.2e}"


def phrase(a: float, b: float, la: str, lb: str) -> str:
    """The paper's wording of a ratio: "AB1 ~ 3xAB4", "1.5xAB1 ~ AB4", "AB1 ~ AB4"."""
    if not (a > 0 and b > 0):
        return "n/a"
    r = a / b
    big = max(r, 1.0 / r)
    if round(big, 1) <= 1.0:
        return f"{la} ~ {lb}"
    txt = f"{big:.0f}" if big >= 10 else f"{big:.2g}"
    return f"{la} ~ {txt}x{lb}" if r > 1 else f"{txt}x{la} ~ {lb}"


def _means(cells: Any) -> Any:
    keys = ["h", "eta_pct", "v_pct", "method"]
    g = cells.groupby(keys, sort=True, dropna=False)
    out = g.agg(
        order=("order", "first"),
        err_eta=("err_eta", "mean"),
        err_eta_std=("err_eta", "std"),
        err_v=("err_v", "mean"),
        err_v_std=("err_v", "std"),
        seeds=("seed", "count"),
    ).reset_index()
    pairs = sorted(set(zip(cells["eta_pct"], cells["v_pct"], strict=True)))
    rank = {p: i for i, p in enumerate(pairs)}
    out["_pair"] = [rank[(e, v)] for e, v in zip(out["eta_pct"], out["v_pct"], strict=True)]
    return out.sort_values(["h", "_pair", "method"]).drop(columns="_pair")


def _fig7_table(means: Any) -> Block | None:
    orders = ab_orders(means["method"].unique())
    if 1 not in orders or len(orders) < 2:
        return None
    top = 4 if 4 in orders else max(orders)
    lo, hi = orders[1], orders[top]
    hs = sorted(means["h"].unique())
    idx = {(r.h, r.eta_pct, r.v_pct, r.method): r for r in means.itertuples(index=False)}
    pairs = list(dict.fromkeys(zip(means["eta_pct"], means["v_pct"], strict=True)))
    heads = ["noise (eta %, v %)"] + [
        f"h = {h:g} s, {q} ({lo}, {hi})" for h in hs for q in ("position", "velocity")
    ]
    rows = []
    for e, v in pairs:
        row = [noise_label(e, v)]
        for h in hs:
            a, b = idx.get((h, e, v, lo)), idx.get((h, e, v, hi))
            for q in ("err_eta", "err_v"):
                if a is None or b is None:
                    row.append("-")
                else:
                    x, y = getattr(a, q), getattr(b, q)
                    row.append(f"{phrase(x, y, lo, hi)} ({_fmt(x)}, {_fmt(y)})")
        rows.append(row)
    caption = (
        f"Fig. 7-style comparison of {lo} and {hi}: mean over seeds of the error norm, "
        "and the ratio in the paper's wording."
    )
    return ("table", caption, heads, rows)


def _method_table(means: Any, q: str, label: str) -> Block:
    methods = list(dict.fromkeys(means["method"]))
    pairs = list(dict.fromkeys(zip(means["h"], means["eta_pct"], means["v_pct"], strict=True)))
    idx = {(r.h, r.eta_pct, r.v_pct, r.method): r for r in means.itertuples(index=False)}
    rows = []
    for h, e, v in pairs:
        row = [f"{h:g}", noise_label(e, v)]
        seeds = 0
        for m in methods:
            r = idx.get((h, e, v, m))
            row.append("-" if r is None else _fmt(getattr(r, q)))
            seeds = max(seeds, 0 if r is None else int(r.seeds))
        rows.append([*row, str(seeds)])
    return ("table", f"{label}: mean over seeds.", ["h (s)", "noise", *methods, "seeds"], rows)


def _study_title(key: dict[str, Any]) -> str:
    buoy = key.get("buoyancy_pct")
    extra = "" if buoy is None or buoy != buoy else f", +{buoy:g} % buoyancy"
    return (
        f"{key['vehicle']}, input {key['input']}{extra}, T = {key['T']:g} s, errors on "
        f"t >= {key['after']:g} s, norm {key['norm']}"
    )


def _study_blocks(
    i: int, key: dict[str, Any], cells: Any, trajs: Any, fig_dir: Path
) -> tuple[list[Block], list[Path]]:
    blocks: list[Block] = []
    figs: list[Path] = []
    title = _study_title(key)
    blocks.append(("h", 2, f"Study {i}: {title}"))
    ok = cells[cells["status"] == "ok"]
    bad = cells[cells["status"] != "ok"]
    blocks.append(
        (
            "p",
            f"{len(cells)} cells ({len(bad)} failed), {key['distribution']} noise, base seed "
            f"{key['base_seed']}, library version {key['version']}; model fingerprint "
            f"{key['model_fingerprint']}, input fingerprint {key['input_fingerprint']}.",
        )
    )
    if len(trajs):
        rows = [
            [
                f"{r.h:g}",
                str(r.status),
                str(r.n_samples),
                _fmt(r.certificate),
                f"{r.seconds:.2f}",
                (r.error or r.warnings or "")[:160],
            ]
            for r in trajs.sort_values("h").itertuples(index=False)
        ]
        heads = ["h (s)", "status", "samples", "certificate", "simulation (s)", "messages"]
        blocks.append(
            (
                "table",
                "Exact samples (certificate: largest scaled per-interval flow error).",
                heads,
                rows,
            )
        )
    if len(ok):
        means = _means(ok)
        fig7 = _fig7_table(means)
        if fig7 is not None:
            blocks.append(("h", 3, "Fig. 7-style table"))
            blocks.append(fig7)
        blocks.append(("h", 3, "Error against order, per noise level"))
        p = plot_order(means, fig_dir / f"study{i}_order.png", title, str(key["norm"]))
        figs.append(p)
        blocks.append(
            (
                "fig",
                p,
                f"Study {i}: {key['norm']} of the disturbed local errors "
                "against the order s (mean over seeds).",
            )
        )
        p2 = plot_ratio_maps(means, fig_dir / f"study{i}_ratio.png", title, str(key["norm"]))
        if p2 is not None:
            figs.append(p2)
            blocks.append(("h", 3, "AB_s / AB1 ratio maps over (h, noise)"))
            blocks.append(
                (
                    "fig",
                    p2,
                    f"Study {i}: ratio of the AB_s error to the AB1 error; "
                    "below 1 (blue) the higher order predicts better.",
                )
            )
        blocks.append(("h", 3, "All methods"))
        blocks.append(_method_table(means, "err_eta", "Position/angle error (eta)"))
        blocks.append(_method_table(means, "err_v", "Velocity error (v)"))
    if len(bad):
        msgs = bad.groupby("error", dropna=False).size().sort_values(ascending=False)
        rows = [[str(n), str(m)[:200]] for m, n in msgs.head(10).items()]
        blocks.append(("table", "Failed cells by message (first 10).", ["cells", "error"], rows))
    return blocks, figs


def _complete_mean(values: Any) -> float:
    """Mean over seeds, NaN unless every seed has a value (a diverged run has none)."""
    v = values.astype(float)
    return float(v.mean()) if len(v) and v.notna().all() else float("nan")


def _kind_blocks(i: int, key: dict[str, Any], cells: Any, trajs: Any) -> list[Block]:
    from ..experiments.sweep._cells import get_cell_kind

    """A study of another cell kind: its named results, means over seeds per (h,
    noise, method) (and per measure, pivoted, when it has several)."""
    buoy = key.get("buoyancy_pct")
    extra = "" if buoy is None or buoy != buoy else f", +{buoy:g} % buoyancy"
    blocks: list[Block] = [
        (
            "h",
            2,
            f"Study {i}: {key['kind']} on {key['vehicle']}{extra}, T = {key['T']:g} s, "
            f"measured on t >= {key['after']:g} s",
        ),
        (
            "p",
            f"{len(cells)} cells ({int((cells['status'] != 'ok').sum())} failed), "
            f"{key['distribution']} noise, base seed {key['base_seed']}, library version "
            f"{key['version']}; model fingerprint {key['model_fingerprint']}.",
        ),
    ]
    if len(trajs):
        rows = [
            [f"{r.h:g}", str(r.status), f"{r.seconds:.2f}", (r.error or r.warnings or "")[:160]]
            for r in trajs.sort_values("h").itertuples(index=False)
        ]
        heads = ["h (s)", "status", "shared part (s)", "messages"]
        blocks.append(("table", "What the cells of each h share, computed once.", heads, rows))
    ok = cells[cells["status"] == "ok"]
    declared = [n for n, _t in get_cell_kind(key["kind"]).columns]
    quantities = [q for q in declared if ok[q].notna().any() and _numeric(ok[q])]
    measures = list(dict.fromkeys(ok["measure"]))
    groups = ["h", "eta_pct", "v_pct", "method"]
    order = {m: n for n, m in enumerate(dict.fromkeys(ok["method"]))}
    if len(measures) > 1:
        for q in quantities:
            if ok.groupby("measure")[q].nunique(dropna=False).max() <= 1:
                continue  # the same for every cell of a measure (e.g. its k)
            means = ok.groupby([*groups, "measure"], sort=False)[q].agg(_complete_mean)
            rows = []
            for (h, e, v, m), _sub in sorted(
                ok.groupby(groups, sort=False), key=lambda g: (g[0][0], g[0][1], g[0][2],
                                                               order[g[0][3]])
            ):  # fmt: skip
                row = [f"{h:g}", noise_label(e, v), str(m)]
                row += [_fmt(means.get((h, e, v, m, k), float("nan"))) for k in measures]
                rows.append(row)
            blocks.append(
                (
                    "table",
                    f"{q}: mean over seeds per measure ('-': a seed without a value).",
                    ["h (s)", "noise", "method", *measures],
                    rows,
                )
            )
    elif quantities:
        rows = []
        for (h, e, v, m), sub in sorted(
            ok.groupby(groups, sort=False),
            key=lambda g: (g[0][0], g[0][1], g[0][2], order[g[0][3]]),
        ):
            row = [f"{h:g}", noise_label(e, v), str(m), str(len(sub))]
            row += [_fmt(_complete_mean(sub[q])) for q in quantities]
            rows.append(row)
        blocks.append(
            (
                "table",
                f"{measures[0] if measures else 'results'}: mean over seeds ('-': a seed "
                "without a value, e.g. a diverged run).",
                ["h (s)", "noise", "method", "seeds", *quantities],
                rows,
            )
        )
    bad = cells[cells["status"] != "ok"]
    if len(bad):
        msgs = bad.groupby("error", dropna=False).size().sort_values(ascending=False)
        rows = [[str(n), str(m)[:200]] for m, n in msgs.head(10).items()]
        blocks.append(("table", "Failed cells by message (first 10).", ["cells", "error"], rows))
    return blocks


def _numeric(column: Any) -> bool:
    """True for a column of numbers or booleans (a named result to average)."""
    import numpy as np

    return all(isinstance(x, int | float | np.number | np.bool_) for x in column.dropna())


# -- rendering ---------------------------------------------------------------------

_CSS = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1200px; padding: 0 1em; }
table { border-collapse: collapse; margin: 0.5em 0 1.5em; font-size: 0.85em; }
th, td { border: 1px solid #ccc; padding: 0.2em 0.5em; text-align: right; }
th { background: #f3f3f3; } caption { caption-side: top; text-align: left; color: #444; }
figure { margin: 1em 0; } img.figure { max-width: 100%; border: 1px solid #eee; }
"""

_CHECK_SCRIPT = """
window.addEventListener("load", function () {
  var imgs = document.querySelectorAll("img.figure"), loaded = 0;
  imgs.forEach(function (im) {
    im.setAttribute("data-natural-width", String(im.naturalWidth));
    if (im.complete && im.naturalWidth > 0) { loaded += 1; }
  });
  document.body.setAttribute("data-figures", String(imgs.length));
  document.body.setAttribute("data-figures-loaded", String(loaded));
});
"""


def _html(title: str, blocks: list[Block], out: Path) -> str:
    e = html.escape
    parts = [
        f'<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
        f"<title>{e(title)}</title>\n<style>{_CSS}</style>\n"
        f"<script>{_CHECK_SCRIPT}</script>\n</head>\n<body>\n<h1>{e(title)}</h1>"
    ]
    for b in blocks:
        if b[0] == "h":
            parts.append(f"<h{b[1]}>{e(b[2])}</h{b[1]}>")
        elif b[0] == "p":
            parts.append(f"<p>{e(b[1])}</p>")
        elif b[0] == "table":
            head = "".join(f"<th>{e(str(h))}</th>" for h in b[2])
            body = "".join(
                "<tr>" + "".join(f"<td>{e(str(c))}</td>" for c in row) + "</tr>" for row in b[3]
            )
            parts.append(
                f"<table><caption>{e(b[1])}</caption><thead><tr>{head}</tr></thead>"
                f"<tbody>{body}</tbody></table>"
            )
        elif b[0] == "fig":
            src = Path(os.path.relpath(b[1], out)).as_posix()
            parts.append(
                f'<figure><img class="figure" src="{e(src)}" alt="{e(b[2])}">'
                f"<figcaption>{e(b[2])}</figcaption></figure>"
            )
    parts.append("</body>\n</html>\n")
    return "\n".join(parts)


def _md_text(x: Any) -> str:
    """Text for Markdown: ``< > &`` as entities, as the HTML page escapes them (a
    Markdown viewer renders inline HTML), on one line."""
    return html.escape(str(x), quote=False).replace("\n", " ")


def _md_cell(x: Any) -> str:
    return _md_text(x).replace("|", "\\|")


def _markdown(title: str, blocks: list[Block], out: Path) -> str:
    lines = [f"# {_md_text(title)}", ""]
    for b in blocks:
        if b[0] == "h":
            lines += ["#" * b[1] + " " + _md_text(b[2]), ""]
        elif b[0] == "p":
            lines += [_md_text(b[1]), ""]
        elif b[0] == "table":
            lines += [f"*{_md_text(b[1])}*", ""]
            lines.append("| " + " | ".join(_md_cell(h) for h in b[2]) + " |")
            lines.append("|" + "---|" * len(b[2]))
            lines += ["| " + " | ".join(_md_cell(c) for c in row) + " |" for row in b[3]]
            lines.append("")
        elif b[0] == "fig":
            src = Path(os.path.relpath(b[1], out)).as_posix()
            lines += [f"![{_md_cell(b[2])}]({src})", ""]
    return "\n".join(lines)


def write_report(
    source: Any, out: str | os.PathLike[str], *, title: str = "sampledyn sweep report"
) -> ReportFiles:
    """Write ``index.html``, ``report.md`` and ``figures/*.png`` into ``out``.

    Parameters
    ----------
    source : str or path
        A results store (``sampledyn sweep --store``).
    out : str or path
        Output folder (created).
    title : str

    Returns
    -------
    ReportFiles

    Raises
    ------
    FileNotFoundError
        if ``source`` does not exist.
    ValueError
        if the store holds no cells.
    """
    from ..experiments.sweep._store import load_results as load

    cells = load(source)  # generic: every kind's cells
    if cells.empty:
        raise ValueError(f"`source` {str(source)!r} holds no cells; run `sampledyn sweep` first.")
    trajs = load(source, "trajectories")
    runs = load(source, "runs")
    out = Path(out)
    fig_dir = _own_folder(out / "figures")
    before = _manifest(out)
    stamp = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    blocks: list[Block] = [
        (
            "p",
            f"Store {source}: {len(cells)} cells ({int((cells['status'] != 'ok').sum())} "
            f"failed) from {len(runs)} runs; generated {stamp}.",
        ),
    ]
    figures: list[Path] = []
    predicted = load(source, kind="prediction")  # the prediction view (norm, err_eta...)
    others = cells[cells["kind"] != "prediction"]
    i = 0
    for values, sub in predicted.groupby(list(STUDY_COLUMNS), dropna=False, sort=False):
        i += 1
        key = dict(zip(STUDY_COLUMNS, values, strict=True))
        tr = trajs[trajs["traj_key"].isin(set(sub["traj_key"]))]
        b, f = _study_blocks(i, key, sub, tr, fig_dir)
        blocks += b
        figures += f
    columns = ["kind", *KIND_STUDY_COLUMNS]
    for values, sub in others.groupby(columns, dropna=False, sort=False):
        i += 1
        key = dict(zip(columns, values, strict=True))
        tr = trajs[trajs["traj_key"].isin(set(sub["traj_key"]))]
        blocks += _kind_blocks(i, key, sub, tr)
    html_path = out / "index.html"
    md_path = out / "report.md"
    write_text_atomic(html_path, _html(title, blocks, out))
    write_text_atomic(md_path, _markdown(title, blocks, out))
    written = {f.name for f in figures}
    for name in before - written:  # its own figures of an earlier report, only
        (fig_dir / name).unlink(missing_ok=True)
    write_text_atomic(out / MANIFEST, json.dumps({"figures": sorted(written)}, indent=1) + "\n")
    return ReportFiles(html_path, md_path, tuple(figures))


def _own_folder(path: Path) -> Path:
    """``path`` as a real folder of the report (created; a symbolic link refused)."""
    if path.is_symlink():
        raise NotADirectoryError(
            errno.ENOTDIR,
            f"is a symbolic link (to {os.path.realpath(path)}); the report writes its figures "
            "only into a folder of its own: remove the link or give another --out",
            str(path),
        )
    path.mkdir(parents=True, exist_ok=True)
    return path


def _manifest(out: Path) -> set[str]:
    """The figure names an earlier report listed in its manifest (plain file names
    only; a damaged manifest lists nothing, so nothing is removed)."""
    path = out / MANIFEST
    try:
        text = read_text(path, "report manifest", limit=1 << 20) if path.is_file() else "{}"
        listed = parse_json(text, str(path))
    except (OSError, ValueError):
        return set()
    names = listed.get("figures", []) if isinstance(listed, dict) else []
    return {
        n for n in names
        if isinstance(n, str) and n == Path(n).name and n not in ("", ".", "..")
        and n.endswith(".png")
    }  # fmt: skip

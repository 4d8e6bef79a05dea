"""``sampledyn sweep``, ``results`` and ``report`` (see docs/sweeps.md)."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from ._common import (
    option,
    progress,
    refuse,
    refuse_overwriting_inputs,
    writable_dir,
    writable_file,
)

__all__ = ["add_parsers"]


def _cmd_sweep(args: argparse.Namespace) -> int:
    from ..experiments.sweep import load_config, run_sweep

    with option("CONFIG"):
        config = load_config(args.config)
    args.on_interrupt = (
        f"the finished cells are in {args.store}; rerun the same command to compute the rest"
    )
    summary = run_sweep(
        config,
        args.store,
        workers=args.workers,
        scheduler=args.scheduler,
        groups_per_chunk=args.chunk,
        retry_failed=args.retry_failed,
        progress=progress(args),
        dry_run=args.dry_run,
        connect_timeout=args.connect_timeout,
        max_cells=args.max_cells,
    )
    todo = summary.planned - summary.skipped
    if args.dry_run:
        print(
            f"{summary.planned} cells in {args.config}; {summary.skipped} already in "
            f"{args.store}; {todo} to compute ({summary.backend})."
        )
        return 0
    print(
        f"{summary.planned} cells in {args.config}: {summary.skipped} already stored, "
        f"{summary.computed} computed ({summary.failed} failed), {summary.elsewhere} being "
        f"computed by other runs, in {summary.wall_seconds:.1f} s ({summary.backend}); "
        f"store {args.store}" + (f", run {summary.run_id}" if summary.run_id else "")
    )
    if summary.duplicates:
        print(
            f"  {summary.duplicates} cells computed here were stored first by another run "
            "(theirs kept)"
        )
    if summary.computed:
        print(
            f"  cell compute {summary.compute_seconds:.2f} s, exact samples "
            f"{summary.simulate_seconds:.2f} s, store {summary.store_seconds:.3f} s "
            f"({100 * summary.store_overhead:.2f} % of cell compute)"
        )
    if summary.failed:
        print(
            f"  {summary.failed} cells failed; see `sampledyn results {args.store}` "
            "(status, error) or rerun with --retry-failed."
        )
    return 0


_TABLE_COLUMNS = [
    "h",
    "eta_pct",
    "v_pct",
    "seed",
    "method",
    "measure",
    "err_eta",
    "err_v",
    "status",
]


def _table_columns(df: Any) -> list[str]:
    """The main columns of the cells table: the grid and the errors, the vehicle if
    the store holds several, and the named results of the controller studies
    (columns that are empty in every row are left out)."""
    from ..experiments.sweep._store import CELL_COLUMNS

    stored = {name for name, _type in CELL_COLUMNS}
    cols = ["vehicle"] if df["vehicle"].nunique() > 1 else []
    cols += [c for c in _TABLE_COLUMNS if c in df.columns]
    cols += [c for c in df.columns if c not in stored and c not in cols]
    return [c for c in cols if df[c].notna().any()] or cols


def _cmd_results(args: argparse.Namespace) -> int:
    if args.kind is not None and args.table != "cells":
        refuse("`--kind` selects from `--table cells` only.")
    if args.format == "parquet" and not args.out:
        refuse("`--format parquet` needs `--out FILE`.")
    out = writable_file(args.out, "--out") if args.out else None
    if out is not None:
        refuse_overwriting_inputs(out, "--out", _store_files(args.store))

    from ..experiments.sweep._store import load_results as load

    with option("STORE"):
        df = load(args.store, args.table, kind=args.kind)
    if args.format == "csv":
        from .._files import csv_safe_frame

        df = csv_safe_frame(df)  # text a spreadsheet would run as a formula: as text
    if args.format == "parquet":
        try:
            df.to_parquet(out, index=False)
        except ImportError as exc:
            raise ValueError("`--format parquet` needs pyarrow: pip install pyarrow.") from exc
        print(f"wrote {len(df)} rows to {out}")
    elif args.format == "csv":
        if out is not None:
            df.to_csv(out, index=False)
            print(f"wrote {len(df)} rows to {out}")
        else:
            df.to_csv(sys.stdout, index=False)
    else:
        cols = _table_columns(df) if args.table == "cells" else None
        text = df.to_string(columns=cols, index=False, float_format=lambda v: f"{v:.3e}")
        if out is not None:
            out.write_text(text + "\n")
            print(f"wrote {len(df)} rows to {out}")
        else:
            print(text)
    return 0


def _store_files(store: str) -> dict[str, str]:
    """The files of the store ``store`` (its side files hold committed rows too)."""
    return {
        "STORE": store,
        **{f"STORE's {what}": store + suffix
           for what, suffix in (("write-ahead log", "-wal"), ("shared memory", "-shm"),
                                ("journal", "-journal"))},
    }  # fmt: skip


def _cmd_report(args: argparse.Namespace) -> int:
    from ..report import write_report
    from ..report._sweep_report import REPORT_FILES

    out = writable_dir(args.out, "--out")
    refuse_overwriting_inputs(out, "--out", _store_files(args.store), writes=REPORT_FILES)

    with option("STORE"):
        files = write_report(args.store, out, title=args.title)
    print(f"wrote {files.html}, {files.markdown} and {len(files.figures)} figures")
    return 0


def add_parsers(sub: Any, parents: list[argparse.ArgumentParser]) -> None:
    """Add the sweep, results and report commands to ``sub`` (the subparsers of the
    ``sampledyn`` parser)."""
    sw = sub.add_parser(
        "sweep",
        parents=parents,
        help="run a grid of cells (h x noise x seed x method) into a results store",
        description=(
            "Run the cells of the sweep file CONFIG (TOML; see docs/sweeps.md) that the "
            "store lacks, and store them (SQLite). Rerunning the same command after an "
            "interruption (Ctrl-C, SIGTERM, even kill -9) computes only the missing cells; "
            "sweeps started at the same time on one store split the cells between them. "
            "A file that is not a sampledyn store is refused and left untouched."
        ),
    )
    sw.add_argument("config", metavar="CONFIG", help="sweep file (TOML)")
    sw.add_argument(
        "--store",
        required=True,
        help="results store (SQLite file; created when the run starts, never with --dry-run)",
    )
    where = sw.add_mutually_exclusive_group()
    where.add_argument(
        "--workers",
        type=int,
        help="run on N local worker processes (they stop when this command stops)",
    )
    where.add_argument("--scheduler", help="Dask scheduler address, e.g. tcp://host:8786")
    sw.add_argument(
        "--connect-timeout",
        type=float,
        default=30.0,
        help="seconds to wait for the Dask scheduler (default 30)",
    )
    sw.add_argument(
        "--chunk",
        type=int,
        default=None,
        help="measured trajectories (noise pair x seed) per task (default: auto)",
    )
    sw.add_argument(
        "--max-cells",
        type=int,
        default=None,
        help="refuse a grid of more cells (default: max_cells of the sweep file, else 1,000,000)",
    )
    sw.add_argument(
        "--retry-failed", action="store_true", help="recompute the cells stored with status 'error'"
    )
    sw.add_argument(
        "--dry-run",
        action="store_true",
        help="count the cells and those already stored; compute and write nothing",
    )
    sw.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    sw.set_defaults(func=_cmd_sweep)

    res = sub.add_parser(
        "results",
        parents=parents,
        help="export a results store (csv, parquet, table)",
        description="Print or write the rows of a results store; the store is opened read-only.",
    )
    res.add_argument("store", metavar="STORE", help="results store (SQLite file)")
    res.add_argument(
        "--format",
        choices=["csv", "parquet", "table"],
        default="table",
        help="table: aligned text of the main columns (default); csv: every column; parquet: "
        "every column, needs --out",
    )
    res.add_argument(
        "--table",
        choices=["cells", "trajectories", "runs"],
        default="cells",
        help="cells: one row per cell (default); trajectories: the exact samples and their "
        "certificates; runs: one row per sweep run with its counts",
    )
    res.add_argument(
        "--kind",
        default=None,
        help="cells only: the view of one cell kind (prediction, closed_loop, multistep): "
        "its cells, its measure under its own name (norm, horizon) and its own values",
    )
    res.add_argument("--out", help="output file (default: standard output; parquet needs it)")
    res.set_defaults(func=_cmd_results)

    rep = sub.add_parser(
        "report",
        parents=parents,
        help="HTML and Markdown report of a results store",
        description="Write index.html, report.md and figures/ of a results store (read-only).",
    )
    rep.add_argument("store", metavar="STORE", help="results store (SQLite file)")
    rep.add_argument("--out", required=True, help="output folder (index.html, report.md)")
    rep.add_argument(
        "--title",
        default="sampledyn sweep report",
        help="title of the report's page (default 'sampledyn sweep report')",
    )
    rep.set_defaults(func=_cmd_report)

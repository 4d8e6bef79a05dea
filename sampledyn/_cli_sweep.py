"""``sampledyn sweep``, ``results``, ``report`` and ``evaluate`` (see docs/sweeps.md)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

__all__ = ["add_parsers"]


def _cmd_sweep(args: argparse.Namespace) -> int:
    from .experiments.sweep import load_config, run_sweep

    try:
        config = load_config(args.config)
    except FileNotFoundError as exc:
        raise ValueError(f"`CONFIG`: {exc}") from exc
    try:
        summary = run_sweep(
            config,
            args.store,
            workers=args.workers,
            scheduler=args.scheduler,
            groups_per_chunk=args.chunk,
            retry_failed=args.retry_failed,
            progress=not args.no_progress,
            dry_run=args.dry_run,
            connect_timeout=args.connect_timeout,
        )
    except KeyboardInterrupt:
        print(
            f"\ninterrupted: the finished cells are in {args.store}; rerun the same command "
            "to compute the rest.",
            file=sys.stderr,
        )
        return 130
    todo = summary.planned - summary.skipped
    if args.dry_run:
        print(
            f"{summary.planned} cells in {args.config}; {summary.skipped} already in "
            f"{args.store}; {todo} to compute ({summary.backend})."
        )
        return 0
    print(
        f"{summary.planned} cells in {args.config}: {summary.skipped} already stored, "
        f"{summary.computed} computed ({summary.failed} failed) in {summary.wall_seconds:.1f} s "
        f"({summary.backend}); store {args.store}"
        + (f", run {summary.run_id}" if summary.run_id else "")
    )
    if summary.computed:
        print(
            f"  cell compute {summary.compute_seconds:.2f} s, exact samples "
            f"{summary.simulate_seconds:.2f} s, store writes {summary.store_seconds:.3f} s "
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
    "norm",
    "err_eta",
    "err_v",
    "status",
]


def _cmd_results(args: argparse.Namespace) -> int:
    from .experiments.sweep import load_results as load

    try:
        df = load(args.store, args.table)
    except FileNotFoundError as exc:
        raise ValueError(f"`STORE`: {exc}") from exc
    if args.format == "parquet":
        if not args.out:
            raise ValueError("`--format parquet` needs `--out FILE`.")
        try:
            df.to_parquet(args.out, index=False)
        except ImportError as exc:
            raise ValueError("`--format parquet` needs pyarrow: pip install pyarrow.") from exc
        print(f"wrote {len(df)} rows to {args.out}")
    elif args.format == "csv":
        if args.out:
            df.to_csv(args.out, index=False)
            print(f"wrote {len(df)} rows to {args.out}")
        else:
            df.to_csv(sys.stdout, index=False)
    else:
        cols = [c for c in _TABLE_COLUMNS if c in df.columns] if args.table == "cells" else None
        text = df.to_string(columns=cols, index=False, float_format=lambda v: f"{v:.3e}")
        if args.out:
            Path(args.out).write_text(text + "\n")
            print(f"wrote {len(df)} rows to {args.out}")
        else:
            print(text)
    return 0


def _cmd_report(args: argparse.Namespace) -> int:
    from .report import write_report

    if not Path(args.store).is_file():
        raise ValueError(f"`STORE`: no results store at {args.store!r}.")
    files = write_report(args.store, args.out, title=args.title)
    print(f"wrote {files.html}, {files.markdown} and {len(files.figures)} figures")
    return 0


def add_parsers(sub: Any) -> None:
    """Add the sweep, results, report and evaluate commands to ``sub`` (the
    subparsers of the ``sampledyn`` parser)."""
    from ._cli_evaluate import add_parser as add_evaluate

    sw = sub.add_parser(
        "sweep",
        help="run a grid of cells (h x noise x seed x method) into a results store",
        description=(
            "Run the cells of the sweep file CONFIG (TOML; see docs/sweeps.md) that the "
            "store lacks, and store them (SQLite). Rerunning the same command after an "
            "interruption computes only the missing cells."
        ),
    )
    sw.add_argument("config", metavar="CONFIG", help="sweep file (TOML)")
    sw.add_argument("--store", required=True, help="results store (SQLite file; created)")
    where = sw.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, help="run on N local worker processes")
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
        "--retry-failed", action="store_true", help="recompute the cells stored with status 'error'"
    )
    sw.add_argument("--dry-run", action="store_true", help="count the cells to compute only")
    sw.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    sw.set_defaults(func=_cmd_sweep)

    res = sub.add_parser("results", help="export a results store (csv, parquet, table)")
    res.add_argument("store", metavar="STORE", help="results store (SQLite file)")
    res.add_argument("--format", choices=["csv", "parquet", "table"], default="table")
    res.add_argument("--table", choices=["cells", "trajectories", "runs"], default="cells")
    res.add_argument("--out", help="output file (default: standard output; parquet needs it)")
    res.set_defaults(func=_cmd_results)

    rep = sub.add_parser("report", help="HTML and Markdown report of a results store")
    rep.add_argument("store", metavar="STORE", help="results store (SQLite file)")
    rep.add_argument("--out", required=True, help="output folder (index.html, report.md)")
    rep.add_argument("--title", default="sampledyn sweep report")
    rep.set_defaults(func=_cmd_report)

    add_evaluate(sub)

"""``sampledyn evaluate``: local errors of sampled-data models on a real log."""

from __future__ import annotations

import argparse
import csv
from pathlib import Path
from typing import Any

__all__ = ["add_parser"]


def _cmd_evaluate(args: argparse.Namespace) -> int:
    from .errors import ERROR_NORMS
    from .experiments.sweep import build_model
    from .logs import evaluate_log, read_log

    if args.norm not in ERROR_NORMS:
        raise ValueError(f"`--norm` must be one of {', '.join(ERROR_NORMS)}, got {args.norm!r}.")
    methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    if args.estimate:
        methods += [m.strip() for m in args.estimate.split(",") if m.strip()]
    try:
        model = build_model(args.vehicle)
    except FileNotFoundError as exc:
        raise ValueError(f"`--vehicle`: {exc}") from exc
    try:
        data = read_log(
            args.data,
            model,
            mapping=args.mapping,
            nan=args.nan,
            time_tolerance=args.time_tolerance,
            unwrap=not args.no_unwrap,
        )
    except FileNotFoundError as exc:
        raise ValueError(f"`--data`: {exc}") from exc
    result = evaluate_log(model, data, methods, norm=args.norm, after=args.after)
    tr = data.traj
    print(
        f"{data.source}: {tr.n_samples} samples, h = {tr.h:.6g} s (jitter "
        f"{100 * data.jitter:.2g} % of h), t = {tr.t[0]:g}..{tr.t[-1]:g} s; vehicle "
        f"{getattr(model, 'name', args.vehicle)}"
    )
    for note in data.notes:
        print(f"  {note}")
    window = "all samples" if args.after is None else f"t >= {args.after:g} s"
    print(f"\n{args.norm} of the one-step local errors (measurement - prediction), {window}:")
    head = (
        f"{'method':8s} {'order':>5s} {'position/angle':>15s} {'velocity':>12s} {'all':>12s} "
        f"{'samples':>8s}"
    )
    print(head)
    print("-" * len(head))
    for r in result.rows:
        print(
            f"{r['method']:8s} {r['order']:5d} {r['err_eta']:15.4e} {r['err_v']:12.4e} "
            f"{r['err_all']:12.4e} {r['samples']:8d}"
        )
    if result.estimation is not None:
        print(f"\n{result.estimation}")
    for w in result.warnings:
        print(f"warning: {w}")
    if args.out:
        out = Path(args.out)
        out.parent.mkdir(parents=True, exist_ok=True)
        with out.open("w", newline="") as fh:
            writer = csv.DictWriter(fh, fieldnames=list(result.rows[0]))
            writer.writeheader()
            writer.writerows(result.rows)
        print(f"wrote {out}")
    return 0


def add_parser(sub: Any) -> None:
    """Add the ``evaluate`` command to the subparsers ``sub``."""
    ev = sub.add_parser(
        "evaluate",
        help="local errors of sampled-data models on a real log (CSV or Parquet)",
        description=(
            "Read a vehicle log (columns t, the 12 states and the thruster rpm, units in "
            "the header like x[m], phi[deg], n1[rpm], or a --mapping file), validate it "
            "(uniform sampling, NaN policy, units, angle wrap-around), then print the "
            "one-step local errors of each method. Nothing is written unless --out is given."
        ),
    )
    ev.add_argument("--data", required=True, help="log file (.csv or .parquet)")
    ev.add_argument(
        "--vehicle", required=True, help="built-in vehicle name or vehicle TOML file (or auv_like)"
    )
    ev.add_argument(
        "--methods",
        default="E,AB2,AB4,RK4,T",
        help="comma-separated methods (default E,AB2,AB4,RK4,T)",
    )
    ev.add_argument(
        "--estimate",
        default=None,
        help="also estimate the parameters on the log: Ee or ABe<s>, e.g. ABe2",
    )
    ev.add_argument("--norm", default="rms", help="error norm (default rms)")
    ev.add_argument(
        "--after", type=float, default=None, help="count errors on t >= AFTER s only (log time)"
    )
    ev.add_argument(
        "--nan",
        choices=["error", "drop", "interpolate"],
        default="error",
        help="rows with NaN: error (default), drop from the norms, interpolate",
    )
    ev.add_argument(
        "--time-tolerance",
        type=float,
        default=0.01,
        help="largest relative deviation of a time step from h (default 0.01)",
    )
    ev.add_argument(
        "--mapping", default=None, help="TOML file mapping log columns to names and units"
    )
    ev.add_argument("--no-unwrap", action="store_true", help="do not unwrap angles")
    ev.add_argument("--out", default=None, help="also write the table as CSV")
    ev.set_defaults(func=_cmd_evaluate)

"""The ``sampledyn`` command: a thin layer over the library."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

__all__ = ["main"]

_REPRODUCERS: dict[str, Callable[[argparse.Namespace], int]] = {}


def _floats(text: str) -> tuple[float, ...]:
    try:
        return tuple(float(v) for v in text.split(",") if v.strip())
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}") from exc


def _ints(text: str) -> tuple[int, ...]:
    try:
        return tuple(int(v) for v in text.split(",") if v.strip())
    except ValueError as exc:
        raise argparse.ArgumentTypeError(
            f"expected comma-separated integers, got {text!r}"
        ) from exc


_PANELS = (
    ("rms_away_from_jumps", "whose history holds no input jump"),
    ("rms_smooth", "away from input jumps and velocity zero crossings"),
)


def _auv_figure(which: str, args: argparse.Namespace) -> int:
    from .experiments._auv import FIG2_METHODS, FIG3_METHODS, AUVStudy, run_auv_study
    from .report import format_grid, plot_error_vs_order, write_csv

    methods = FIG2_METHODS if which == "fig2" else FIG3_METHODS
    if args.methods:
        methods = tuple(m.strip() for m in args.methods.split(",") if m.strip())
    study = AUVStudy(
        methods=methods,
        hold_ratios=args.ratios,
        h=args.h,
        T=args.T,
        after=args.after,
        seed=args.seed,
    )
    rows = run_auv_study(study, progress=not args.no_progress)
    out = Path(args.out or f"out/{which}")
    csv_path = write_csv(rows, out / f"{which}.csv")
    title = (
        f"AUV-like (9)-(10): h={study.h:g} s, T={study.T:g} s, errors t>={study.after:g} s, "
        f"seed {study.seed}"
    )
    panels = ((args.norm, "all samples"), *_PANELS)
    png = plot_error_vs_order(rows, out / f"{which}.png", norms=panels, title=title)
    tau = min(r["tau_min"] for r in rows)
    cert = max(r["certificate"] for r in rows)
    print(
        f"{which}: {args.norm} norm of the one-step local errors (both states), "
        f"t >= {study.after:g} s"
    )
    print(
        f"sampling period h = {study.h:g} s; fastest local time constant along the runs "
        f"{tau:.3g} s (h / tau = {study.h / tau:.2g}); exact samples certified to "
        f"{cert:.1e} per interval"
    )
    print(format_grid(rows, "method", "hold_ratio", args.norm, col_title="hu/h"))
    for key, caption in _PANELS:
        print(f"\nrms over the samples {caption}:")
        print(format_grid(rows, "method", "hold_ratio", key, col_title="hu/h"))
    print(f"wrote {csv_path} and {png}")
    return 0


_REPRODUCERS["fig2"] = lambda a: _auv_figure("fig2", a)
_REPRODUCERS["fig3"] = lambda a: _auv_figure("fig3", a)


def _cmd_reproduce(args: argparse.Namespace) -> int:
    return _REPRODUCERS[args.figure](args)


def _cmd_methods(args: argparse.Namespace) -> int:
    from .methods import available_methods, describe_methods, get_method

    print("Method families:")
    for key, desc in describe_methods().items():
        print(f"  {key:8s} {desc}")
    print("\nBuilt-in fixed rules:")
    for name in available_methods():
        m = get_method(name)
        extra = f"  a_s = {m.a_s}" if hasattr(m, "a_s") else ""
        print(f"  {name:5s} order {m.order}{extra}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="sampledyn",
        description=(
            "Sampled-data models of vehicle dynamics: build Euler, Tustin, Runge-Kutta and "
            "Adams-Bashforth one-step predictors from continuous-time models, run them on "
            "exact (and noisy) samples, and measure their local errors."
        ),
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    rep = sub.add_parser(
        "reproduce",
        help="regenerate a figure or table of the paper (fig2, fig3)",
        description=(
            "fig2: local-error norms of AB_s (s = 1..6) against s, one curve per h_u/h, on the "
            "AUV-like system (9)-(10). fig3: the same for E, T and RK_s (s = 1..4). "
            "Writes CSV and PNG into --out and prints the table."
        ),
    )
    rep.add_argument("figure", choices=sorted(_REPRODUCERS), help="which result to regenerate")
    rep.add_argument("--out", help="output folder (default: out/FIGURE)")
    rep.add_argument("--h", type=float, default=0.01, help="sampling period h in s (default 0.01)")
    rep.add_argument("--T", type=float, default=200.0, help="duration in s (default 200)")
    rep.add_argument(
        "--after", type=float, default=20.0, help="errors from this time on, s (default 20)"
    )
    rep.add_argument("--seed", type=int, default=0, help="input seed (default 0)")
    rep.add_argument(
        "--ratios",
        type=_ints,
        default=(1, 2, 5, 10, 20, 50, 100),
        help="h_u/h values, comma-separated (default 1,2,5,10,20,50,100)",
    )
    rep.add_argument("--methods", help="comma-separated method names (default: the figure's)")
    rep.add_argument(
        "--norm",
        default="rms",
        choices=["rms", "max", "l2_over_n"],
        help="norm shown in the table and figure (all go to the CSV)",
    )
    rep.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    rep.set_defaults(func=_cmd_reproduce)

    meth = sub.add_parser("methods", help="list the registered sampled-data methods")
    meth.set_defaults(func=_cmd_methods)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        result: Any = args.func(args)
    except (ValueError, TypeError) as exc:
        parser.exit(2, f"sampledyn: error: {exc}\n")
    return int(result or 0)


if __name__ == "__main__":
    sys.exit(main())

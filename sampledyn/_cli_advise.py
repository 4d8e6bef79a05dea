"""``sampledyn advise``: which sampled-data model to use for a vehicle, h and noise."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

__all__ = ["add_parser"]


def _pair(text: str) -> tuple[float, float]:
    try:
        vals = tuple(float(v) for v in text.split(",") if v.strip())
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"expected numbers like 2,2, got {text!r}") from exc
    if len(vals) == 1:
        vals = vals * 2
    if len(vals) != 2:
        raise argparse.ArgumentTypeError(f"expected one or two numbers (eta,v), got {text!r}")
    return vals[0], vals[1]


def _run(args: argparse.Namespace) -> int:
    from .models import load_vehicle
    from .sensitivity import advise, plot_crossing, sensitivity_report

    if args.report:
        numbers = sensitivity_report(args.report, vehicle=args.vehicle, T=args.T, seeds=args.seeds)
        out = Path(args.report)
        print(f"sensitivity report for {numbers['vehicle']} written to {out}:")
        for p in sorted(out.glob("sensitivity_*")):
            print(f"  {p}")
        tight = numbers["tightness"]
        print(
            f"bound (24)-(25): {tight['violations']} violations in {tight['samples_checked']} "
            f"Monte Carlo samples; AB bound/measured {tight['AB_tightness_range'][0]:.3g}-"
            f"{tight['AB_tightness_range'][1]:.3g}"
        )
        return 0

    vehicle = load_vehicle(args.vehicle)
    methods = tuple(m.strip() for m in args.methods.split(",") if m.strip())
    eta_pct, v_pct = args.noise
    advice = advise(
        vehicle,
        args.h,
        eta_pct,
        v_pct,
        methods=methods,
        tolerance=args.tolerance,
        validate=not args.no_validate,
        T=args.T,
        seeds=args.seeds,
        rank_by=args.rank_by,
    )
    print(advice.table())
    print()
    print("Jacobian maxima over the domain (eqs. (19)-(23)):")
    print(advice.jacobians.table())
    out = Path(args.out or "out/advise")
    png = plot_crossing(advice.curves, out / "crossing.png", h_mark=args.h)
    crossings: list[str] = []
    for name in advice.curves.methods:
        c = advice.curves.crossing(name)
        txt = ", ".join("-" if x is None else f"{x:.3g} s" for x in c)
        crossings.append(f"{name} ({txt})")
    print("\ntruncation meets noise at h (eta, v): " + "; ".join(crossings))
    print(f"best: {advice.best}; wrote {png}")
    return 0


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``sampledyn advise`` on an argparse subparsers object."""
    from .sensitivity import DEFAULT_METHODS

    p = subparsers.add_parser(
        "advise",
        help="rank sampled-data models for a vehicle, h and noise level (section 5 and beyond)",
        description=(
            "Rank E, AB_s, RK_s and T by their predicted largest one-step error on noisy "
            "samples of a reference run (a gentle version of the Fig. 6 input), beside the "
            "guaranteed bound (24)-(25) and the measured Monte Carlo errors; with "
            "--tolerance, the largest h that keeps each rule's error under it. Writes a "
            "figure of truncation vs noise term against h to --out. --report DIR instead "
            "writes the figures and numbers of docs/sensitivity.md (takes minutes)."
        ),
    )
    p.add_argument("--vehicle", default="bluerov2_heavy", help="built-in name or TOML file")
    p.add_argument("--h", type=float, default=0.1, help="sampling period in s (default 0.1)")
    p.add_argument(
        "--noise",
        type=_pair,
        default=(2.0, 2.0),
        help="noise levels eta%%,v%% of 1 m/30 deg and 1 m/s/30 deg/s (default 2,2)",
    )
    p.add_argument(
        "--tolerance",
        type=_pair,
        default=None,
        help="error tolerance (eta[,v]) in state units; prints the largest h per rule",
    )
    p.add_argument(
        "--methods",
        default=",".join(DEFAULT_METHODS),
        help=f"comma-separated rules (default {','.join(DEFAULT_METHODS)})",
    )
    p.add_argument("--T", type=float, default=60.0, help="reference run length in s (default 60)")
    p.add_argument("--seeds", type=int, default=3, help="Monte Carlo noise seeds (default 3)")
    p.add_argument("--no-validate", action="store_true", help="skip the Monte Carlo check")
    p.add_argument("--rank-by", choices=("max", "eta", "v"), default="max", help="block ranked on")
    p.add_argument("--out", help="folder of the crossing figure (default out/advise)")
    p.add_argument("--report", metavar="DIR", help="write the sensitivity report into DIR")
    p.set_defaults(func=_run)
    return p

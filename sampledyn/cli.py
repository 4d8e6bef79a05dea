"""The ``sampledyn`` command: a thin layer over the library."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from ._cli_advise import add_parser as _add_advise
from ._cli_sweep import add_parsers as _add_sweep

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
    from .experiments import AUVStudy, fig2_methods, fig3_methods, run_auv_study
    from .report import format_grid, plot_error_vs_order, write_csv

    methods = fig2_methods() if which == "fig2" else fig3_methods()
    if args.methods:
        methods = tuple(m.strip() for m in args.methods.split(",") if m.strip())
    study = AUVStudy(
        methods=methods,
        hold_ratios=args.ratios,
        h=args.h[0] if args.h else 0.01,
        T=200.0 if args.T is None else args.T,
        after=20.0 if args.after is None else args.after,
        seed=args.seed,
    )
    rows = run_auv_study(study, progress=not args.no_progress)
    out = Path(args.out or f"out/{which}")
    csv_path = write_csv(rows, out / f"{which}.csv")
    title = (
        f"AUV-like (9)-(10): h={study.h:g} s, T={study.T:g} s, errors t>={study.after:g} s, "
        f"seed {study.seed}"
    )
    args.norm = args.norm or "rms"
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


def _fig7(args: argparse.Namespace) -> int:
    from .experiments import ROVStudy, run_rov_study, summarize
    from .report import fig7_table, norm_evidence, plot_fig7, write_csv

    kwargs: dict[str, Any] = {"seeds": args.seeds, "base_seed": args.seed}
    if args.h:
        kwargs["h_values"] = args.h
    if args.T is not None:
        kwargs["T"] = args.T
    if args.after is not None:
        kwargs["after"] = args.after
    if args.methods:
        kwargs["methods"] = tuple(m.strip() for m in args.methods.split(",") if m.strip())
    if args.vehicle:
        kwargs["vehicle"] = args.vehicle
    if args.open_loop:
        kwargs["attitude_hold"] = False
    study = ROVStudy(**kwargs)
    result = run_rov_study(study, progress=not args.no_progress)
    summary = summarize(result["rows"])
    out = Path(args.out or "out/fig7")
    write_csv(result["rows"], out / "fig7_runs.csv")
    csv_path = write_csv(summary, out / "fig7.csv")
    norm = args.norm or "l2_over_n"
    if norm not in ("l2_over_n", "rms"):
        raise ValueError(f"fig7 reports the norms l2_over_n and rms, not {norm!r}.")
    title = (
        f"{result['model'].name}, Fig. 6 input, +{study.buoyancy_pct:g} % buoyancy, "
        f"T={study.T:g} s, errors t>={study.after:g} s, {study.seeds} seeds"
    )
    png = plot_fig7(summary, out / "fig7.png", norm=norm, title=title)
    for h, cert in result["certificates"].items():
        mo = result["motion"][h]
        print(
            f"h = {h:g} s: exact samples certified to {cert:.1e} per interval; mean surge "
            f"{mo['mean_surge_m_s']:.3f} m/s, depth change {mo['depth_change_m']:+.2f} m, "
            f"max |pitch| {mo['max_abs_pitch_deg']:.1f} deg"
        )
    print(f"\nFig. 7, {norm} of the disturbed local errors, mean over seeds (ours) and paper:")
    print(fig7_table(summary, norm=norm))
    ev = norm_evidence(summary)
    print("\nWhich norm is the paper's 'quadratic norm'?")
    for k in ("l2_over_n", "rms"):
        e = ev[k]
        print(
            f"  {k:10s} ours/paper geometric mean {e['geo_mean_ratio']:.3g} (median "
            f"|log10| {e['median_abs_log10']:.2f} over {e['cells']} numbers); growth "
            f"h=0.1 -> 0.5 in noise-dominated cells {e['growth_h01_to_h05']:.2f}"
        )
    print(f"  paper's own growth h=0.1 -> 0.5 in those cells: {ev['paper_growth_h01_to_h05']:.2f}")
    print(f"wrote {csv_path}, {out / 'fig7_runs.csv'} and {png}")
    return 0


_REPRODUCERS["fig7"] = _fig7
_REPRODUCERS["fig2"] = lambda a: _auv_figure("fig2", a)
_REPRODUCERS["fig3"] = lambda a: _auv_figure("fig3", a)


def _cmd_reproduce(args: argparse.Namespace) -> int:
    return _REPRODUCERS[args.figure](args)


def _cmd_methods(args: argparse.Namespace) -> int:
    from .methods import available_methods, families, get_method

    print("Method families:")
    for fam in families():
        orders = ""
        if fam.ordered:
            top = "any s" if fam.max_order is None else f"s <= {fam.max_order}"
            orders = f" (listed: s = 1..{fam.default_max_order}; {top})"
        print(f"  {fam.key:8s} {fam.description}{orders}")
    print("\nRegistered rules (a_s: first-order noise gain c in G = c h L; C: error constant):")
    for name in available_methods():
        m = get_method(name)
        gain = "-" if m.first_order_gain is None else str(m.first_order_gain)
        const = "-" if m.error_constant is None else str(m.error_constant)
        where = "between samples" if m.intersample else "at samples"
        est = ", estimated" if m.estimates_params else ""
        print(
            f"  {name:6s} order {m.order}  history {m.history}  a_s = {gain:7s} "
            f"C = {const:12s} f {where}{est}"
        )
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
        help="regenerate a figure or table of the paper (fig2, fig3, fig7)",
        description=(
            "fig2: local-error norms of the multistep rules of the registry (AB_s, ABu_s, "
            "ABj_s and the estimated ABe_s, s = 1..6) against s, one curve per h_u/h, on "
            "the AUV-like system (9)-(10). fig3: the same for the one-step rules (E, T, "
            "RK_s for s = 1..4, Ee). "
            "fig7: the ROV study of section 6 on the BlueROV2 Heavy (T = 5000 s, errors "
            "from 1000 s, h in {0.1, 0.5}, the 12 noise pairs, AB1-AB4 and RK4, Monte Carlo "
            "over --seeds, with a roll-pitch hold unless --open-loop), printed in the "
            "paper's layout next to its numbers. "
            "Writes CSV and PNG into --out and prints the table."
        ),
    )
    rep.add_argument("figure", choices=sorted(_REPRODUCERS), help="which result to regenerate")
    rep.add_argument("--out", help="output folder (default: out/FIGURE)")
    rep.add_argument(
        "--h",
        type=_floats,
        default=None,
        help="sampling period(s) h in s, comma-separated (fig2/3: 0.01; fig7: 0.1,0.5)",
    )
    rep.add_argument(
        "--T", type=float, default=None, help="duration in s (fig2/3: 200; fig7: 5000)"
    )
    rep.add_argument(
        "--after",
        type=float,
        default=None,
        help="errors from this time on, s (fig2/3: 20; fig7: 1000)",
    )
    rep.add_argument("--seed", type=int, default=0, help="input / noise seed (default 0)")
    rep.add_argument("--seeds", type=int, default=10, help="fig7: Monte Carlo seeds (default 10)")
    rep.add_argument("--vehicle", help="fig7: vehicle name or TOML file (default bluerov2_heavy)")
    rep.add_argument(
        "--ratios",
        type=_ints,
        default=(1, 2, 5, 10, 20, 50, 100),
        help="h_u/h values, comma-separated (default 1,2,5,10,20,50,100)",
    )
    rep.add_argument("--methods", help="comma-separated method names (default: the figure's)")
    rep.add_argument(
        "--norm",
        default=None,
        choices=["rms", "max", "l2_over_n"],
        help="norm shown (fig2/3: rms; fig7: l2_over_n); all go to the CSV",
    )
    rep.add_argument(
        "--open-loop",
        action="store_true",
        help="fig7: drive the thrusters with the Fig. 6 rpm only, no roll-pitch hold "
        "(the BlueROV2 Heavy then pitches over)",
    )
    rep.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    rep.set_defaults(func=_cmd_reproduce)

    meth = sub.add_parser("methods", help="list the registered sampled-data methods")
    meth.set_defaults(func=_cmd_methods)
    _add_advise(sub)
    _add_sweep(sub)
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

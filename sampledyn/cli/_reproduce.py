"""``sampledyn reproduce fig2|fig3|fig7``: the paper's figures and tables.

Every option is checked before any work: an option that does not apply to the figure
is refused by name, as is a second ``--h`` for the one-h Figs. 2-3 and a norm the
figure does not report.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

from ._common import (
    floats,
    ints,
    names,
    option,
    progress,
    refuse,
    registry,
    writable_dir,
    writable_file,
)

__all__ = ["add_parser"]

_PANELS = (
    ("rms_away_from_jumps", "whose history holds no input jump"),
    ("rms_smooth", "away from input jumps and velocity zero crossings"),
)

# Options each figure uses (argparse dests); any other one given is refused.
_COMMON = {
    "figure", "out", "h", "T", "after", "seed", "methods", "norm", "no_progress", "store",
    "workers", "scheduler",
}  # fmt: skip
_USES = {
    "fig2": _COMMON | {"ratios"},
    "fig3": _COMMON | {"ratios"},
    "fig7": _COMMON | {"seeds", "vehicle", "attitude_hold", "hold_gains"},
    "closed-loop": _COMMON | {"seeds", "vehicle"},
    "multistep": _COMMON | {"seeds", "vehicle"},
}
_FLAGS = {
    "ratios": "--ratios",
    "seeds": "--seeds",
    "vehicle": "--vehicle",
    "attitude_hold": "--attitude-hold/--no-attitude-hold",
    "hold_gains": "--hold-gains",
    "store": "--store",
    "workers": "--workers",
    "scheduler": "--scheduler",
}


def _check_applies(args: argparse.Namespace) -> None:
    unused = [
        dest
        for dest in _FLAGS
        if dest not in _USES[args.figure] and getattr(args, dest) is not None
    ]
    if unused:
        users = sorted({fig for fig, uses in _USES.items() for d in unused if d in uses})
        refuse(
            f"reproduce {args.figure} does not use {', '.join(_FLAGS[d] for d in unused)} "
            f"(options of {', '.join(users)})."
        )


def _check_methods(methods: tuple[str, ...]) -> None:
    with option("--methods"):
        for name in methods:
            registry().get_method(name)


def _engine(args: argparse.Namespace, default_workers: int | None) -> dict[str, Any]:
    """The engine options of a reproduce run (store, workers, Dask), checked now."""
    if args.workers is not None and args.scheduler is not None:
        refuse("give --workers or --scheduler, not both.")
    if args.workers is not None and args.workers < 1:
        raise ValueError(f"`--workers` must be >= 1, got {args.workers}.")
    out: dict[str, Any] = {"store": args.store}
    if args.scheduler is not None:
        out["scheduler"] = args.scheduler
    else:
        out["workers"] = default_workers if args.workers is None else args.workers
    if args.store is not None:
        from ..experiments.sweep import inspect_store

        with option("--store"):
            writable_file(args.store, "--store")
            inspect_store(Path(args.store))  # refuses a foreign file, untouched
        args.on_interrupt = (
            f"the finished cells are in {args.store}; rerun the same command to compute the rest"
        )
    return out


def _missing_notes(rows: list[dict[str, Any]]) -> list[str]:
    """The reasons of the n/a entries of the tables, once each."""
    reasons: dict[str, set[Any]] = {}
    for r in rows:
        for note in filter(None, str(r.get("notes", "")).split("; ")):
            column, _, why = note.partition(": ")
            reasons.setdefault(f"{column}: {why}", set()).add(r["hold_ratio"])
    return [
        f"n/a ({text.split(': ', 1)[0]}, h_u/h = {', '.join(map(str, sorted(ratios)))}): "
        f"{text.split(': ', 1)[1]}"
        for text, ratios in reasons.items()
    ]


def _auv_figure(args: argparse.Namespace) -> int:
    from ..errors import ERROR_NORMS
    from ..experiments import AUVStudy, fig2_methods, fig3_methods

    which = args.figure
    if args.h is not None and len(args.h) != 1:
        refuse(
            f"reproduce {which} draws one sampling period; `--h` got {len(args.h)} values "
            f"({','.join(f'{h:g}' for h in args.h)}): run the command once per h."
        )
    norm = args.norm or "rms"
    if norm not in ERROR_NORMS:  # pragma: no cover - argparse's choices come from it
        refuse(f"`--norm` must be one of {', '.join(ERROR_NORMS)}, got {norm!r}.")
    methods = names(args.methods) or (fig2_methods() if which == "fig2" else fig3_methods())
    _check_methods(methods)
    with option("--h" if args.h else "--T"):
        study = AUVStudy(
            methods=methods,
            hold_ratios=args.ratios or (1, 2, 5, 10, 20, 50, 100),
            h=args.h[0] if args.h else 0.01,
            T=200.0 if args.T is None else args.T,
            after=20.0 if args.after is None else args.after,
            seed=0 if args.seed is None else args.seed,
        )
    out = writable_dir(args.out or f"out/{which}", "--out")
    engine = _engine(args, None)

    from ..experiments import run_auv_study
    from ..report import format_grid, plot_error_vs_order, write_csv

    rows = run_auv_study(study, progress=progress(args), **engine)
    csv_path = write_csv(rows, out / f"{which}.csv")
    title = (
        f"AUV-like (9)-(10): h={study.h:g} s, T={study.T:g} s, errors t>={study.after:g} s, "
        f"seed {study.seed}"
    )
    panels = ((norm, "all samples"), *_PANELS)
    png = plot_error_vs_order(rows, out / f"{which}.png", norms=panels, title=title)
    tau = min(r["tau_min"] for r in rows)
    cert = max(r["certificate"] for r in rows)
    print(
        f"{which}: {norm} norm of the one-step local errors (both states), t >= {study.after:g} s"
    )
    print(
        f"sampling period h = {study.h:g} s; fastest local time constant along the runs "
        f"{tau:.3g} s (h / tau = {study.h / tau:.2g}); exact samples certified to "
        f"{cert:.1e} per interval"
    )
    print(format_grid(rows, "method", "hold_ratio", norm, col_title="hu/h"))
    for key, caption in _PANELS:
        print(f"\nrms over the samples {caption}:")
        print(format_grid(rows, "method", "hold_ratio", key, col_title="hu/h"))
    for note in _missing_notes(rows):
        print(note)
    print(f"wrote {csv_path} and {png}")
    return 0


def _hold_gains(args: argparse.Namespace) -> tuple[float | None, float | None]:
    """(kp, kd) of ``--hold-gains KP,KD``, checked (None, None without it)."""
    if args.hold_gains is None:
        return None, None
    if len(args.hold_gains) != 2 or not all(math.isfinite(g) and g > 0 for g in args.hold_gains):
        raise ValueError(
            "`--hold-gains` must be two numbers > 0, KP (N m/rad) and KD (N m s/rad), e.g. "
            f"--hold-gains 16000,7200; got {','.join(f'{g:g}' for g in args.hold_gains)}."
        )
    if args.attitude_hold is False:
        refuse("--hold-gains sets the gains of the attitude hold, which --no-attitude-hold "
               "switches off; give one or the other.")  # fmt: skip
    return args.hold_gains


def _fig7(args: argparse.Namespace) -> int:
    from ..experiments import FIG7_NORMS, ROVStudy

    norm = args.norm or FIG7_NORMS[0]
    if norm not in FIG7_NORMS:
        refuse(f"reproduce fig7 reports the norms {', '.join(FIG7_NORMS)}, not `--norm {norm}`.")
    for h in args.h or ():
        if not h > 0:
            raise ValueError(f"`--h` must be > 0 s, got {h:g}.")
    if args.methods:
        _check_methods(names(args.methods))
    if args.vehicle:
        from ..models import load_vehicle

        with option("--vehicle"):
            load_vehicle(args.vehicle)
    kp, kd = _hold_gains(args)
    study = ROVStudy(
        vehicle=args.vehicle,
        T=args.T,
        after=args.after,
        h_values=args.h,
        methods=names(args.methods) or None,
        seeds=args.seeds,
        base_seed=args.seed,
        attitude_hold=args.attitude_hold,
        kp=kp,
        kd=kd,
    )
    with option("--hold-gains" if args.hold_gains else "--vehicle"):
        config = study.config()
    out = writable_dir(args.out or _fig7_out(config.vehicle), "--out")
    engine = _engine(args, 2)

    from ..experiments import run_rov_study, summarize_rov
    from ..report import fig7_table, norm_evidence, plot_fig7, write_csv

    result = run_rov_study(config, progress=progress(args), **engine)
    summary = summarize_rov(result["rows"])
    write_csv(result["rows"], out / "fig7_runs.csv")
    csv_path = write_csv(summary, out / "fig7.csv")
    loop = (
        "open loop (the paper's input)"
        if config.feedback is None
        else f"closed by {config.feedback['law']} "
        + ", ".join(f"{k} {v:g}" for k, v in config.feedback.items() if k != "law")
    )
    title = (
        f"{result['model']}, Fig. 6 input, +{config.buoyancy_pct:g} % buoyancy, "
        f"T={config.T:g} s, errors t>={config.after:g} s, {len(config.seeds)} seeds"
    )
    png = plot_fig7(summary, out / "fig7.png", norm=norm, title=title)
    print(f"fig7: {config.vehicle}, {loop}; {result['summary'].describe(args.store)}")
    for h, cert in result["certificates"].items():
        mo = result["motion"].get(h, {})
        print(
            f"h = {h:g} s: exact samples certified to {cert:.1e} per interval; mean surge "
            f"{mo.get('mean_surge_m_s', math.nan):.3f} m/s, depth change "
            f"{mo.get('depth_change_m', math.nan):+.2f} m, max |pitch| "
            f"{mo.get('max_abs_pitch_deg', math.nan):.1f} deg, max |roll| "
            f"{mo.get('max_abs_roll_deg', math.nan):.1f} deg"
        )
    failed = sorted({r["error"] for r in result["rows"] if r.get("error")})
    for message in failed:
        print(f"failed cells (n/a in the table): {message}")
    print(f"\nFig. 7, {norm} of the disturbed local errors, mean over seeds (ours) and paper:")
    print(fig7_table(summary, norm=norm))
    ev = norm_evidence(summary)
    print("\nWhich norm is the paper's 'quadratic norm'?")
    for k in FIG7_NORMS:
        e = ev[k]
        print(
            f"  {k:10s} ours/paper geometric mean {e['geo_mean_ratio']:.3g} (median "
            f"|log10| {e['median_abs_log10']:.2f} over {e['cells']} numbers); growth "
            f"h=0.1 -> 0.5 in noise-dominated cells {e['growth_h01_to_h05']:.2f}"
        )
    print(f"  paper's own growth h=0.1 -> 0.5 in those cells: {ev['paper_growth_h01_to_h05']:.2f}")
    print(f"wrote {csv_path}, {out / 'fig7_runs.csv'} and {png}")
    return 0


def _discrete_studies(args: argparse.Namespace) -> int:
    """``reproduce closed-loop`` (LQR designed on each rule, run on the exact plant) and
    ``reproduce multistep`` (k-step-ahead errors and free runs)."""
    closed = args.figure == "closed-loop"
    if args.norm is not None:
        refuse(f"reproduce {args.figure} reports its own measures; `--norm` does not apply.")
    kwargs: dict[str, Any] = {}
    if args.seeds is not None:
        kwargs["seeds"] = args.seeds
    if args.seed is not None:
        kwargs["base_seed"] = args.seed
    for h in args.h or ():
        if not h > 0:
            raise ValueError(f"`--h` must be > 0 s, got {h:g}.")
    if args.h:
        kwargs["h_values"] = args.h
    if args.T is not None:
        kwargs["T"] = args.T
    if args.after is not None:
        kwargs["transient" if closed else "after"] = args.after
    if args.methods:
        kwargs["methods"] = names(args.methods)
        _check_methods(kwargs["methods"])
    if args.vehicle:
        from ..models import load_vehicle

        chosen = names(args.vehicle) if closed else (args.vehicle,)
        if not closed and len(names(args.vehicle)) > 1:
            refuse(f"reproduce multistep runs one vehicle; got --vehicle {args.vehicle}.")
        with option("--vehicle"):
            for vehicle in chosen:
                load_vehicle(vehicle)
        kwargs["vehicles" if closed else "vehicle"] = tuple(chosen) if closed else args.vehicle
    from .. import experiments as ex
    from .. import report as rp

    study: Any = (ex.ClosedLoopStudy if closed else ex.MultistepStudy)(**kwargs)
    out = writable_dir(args.out or f"out/{args.figure}", "--out")
    engine = _engine(args, 2)
    out.mkdir(parents=True, exist_ok=True)

    def say(text: str) -> None:
        print(f"{args.figure}: {text}", flush=True)

    run = {"progress": say, "progress_bar": progress(args), **engine}
    if closed:
        rows = ex.run_closed_loop_study(study, **run)
        summary = ex.summarize_closed_loop(rows)
        table, png = (
            rp.closed_loop_table(summary),
            rp.plot_closed_loop(summary, out / "closed_loop.png"),
        )
    else:
        rows = ex.run_multistep_study(study, **run)
        summary = ex.summarize_multistep(rows)
        table, png = rp.multistep_table(summary), rp.plot_multistep(summary, out / "multistep.png")
    stem = args.figure.replace("-", "_")
    rp.write_csv(rows, out / f"{stem}_runs.csv")
    csv_path = rp.write_csv(summary, out / f"{stem}.csv")
    (out / f"{stem}.md").write_text(table + "\n", encoding="utf-8")
    print(table)
    print(f"wrote {csv_path}, {out / f'{stem}_runs.csv'}, {out / f'{stem}.md'} and {png}")
    return 0


def _fig7_out(vehicle: str) -> str:
    """Default output folder of fig7: ``out/fig7`` for the study's vehicle (RexROV),
    ``out/fig7_<name>`` for another, so one run does not overwrite the other."""
    from ..experiments import ROVStudy

    default = ROVStudy().config().vehicle
    return "out/fig7" if vehicle == default else f"out/fig7_{Path(vehicle).stem}"


def _run(args: argparse.Namespace) -> int:
    _check_applies(args)
    if args.figure in ("closed-loop", "multistep"):
        return _discrete_studies(args)
    return _fig7(args) if args.figure == "fig7" else _auv_figure(args)


def add_parser(sub: Any, parents: list[argparse.ArgumentParser]) -> None:
    """Add ``reproduce`` to the subparsers ``sub``."""
    from ..errors import ERROR_NORMS

    rep = sub.add_parser(
        "reproduce",
        parents=parents,
        help="regenerate a figure or table of the paper (fig2, fig3, fig7) or a "
        "controller study (closed-loop, multistep)",
        description=(
            "Regenerate the results of the paper 'On the Adequacy of Adams-Bashforth "
            "Sampled-Data Models for Characterizing Complex Underwater-Vehicle Dynamics "
            "with Noisy Measurements' (equation numbers refer to it). "
            "fig2: local-error norms of the multistep rules of the registry (AB_s, ABu_s, "
            "ABj_s and the estimated ABe_s, s = 1..6) against s, one curve per h_u/h, on "
            "the AUV-like system (9)-(10). fig3: the "
            "same for the one-step rules (E, T, RK_s for s = 1..4, Ee). "
            "fig7: the ROV study of section 6 (T = 5000 s, errors from 1000 s, h in "
            "{0.1, 0.5}, the 12 noise pairs, AB1-AB4 and RK4, Monte Carlo over --seeds) on "
            "the RexROV, open loop as in the paper (--vehicle to choose; the BlueROV2 Heavy "
            "runs with a roll-pitch hold, see --attitude-hold), printed in the paper's "
            "layout next to its numbers. "
            "Every study runs on the experiment engine: --store keeps the cells in a "
            "results store, so a killed run resumes and `sampledyn results`/`report` read it; "
            "--workers and --scheduler choose where the cells are computed. "
            "closed-loop: the same discrete LQR (depth/heading/surge hold) designed on each "
            "rule's discrete-time model (ZOH, E, AB2, AB4, ABu4, RK4, T), h in {0.1, 0.5}, "
            "run on the exact RexROV and BlueROV2 Heavy with thruster saturation and noise; "
            "residual sets and effort. multistep: k-step-ahead errors and free runs of each "
            "rule on the RexROV (Fig. 6 input). "
            "Writes CSV and PNG into --out and prints the table. Options that do not apply "
            "to the figure are refused."
        ),
    )
    rep.add_argument("figure", choices=sorted(_USES), help="which result to regenerate")
    rep.add_argument(
        "--out",
        help="output folder (default: out/FIGURE; fig7 with a vehicle other than the "
        "RexROV: out/fig7_VEHICLE)",
    )
    rep.add_argument(
        "--h",
        type=floats,
        default=None,
        help="sampling period h in s (fig2/3: one value, default 0.01; fig7: comma-separated, "
        "default 0.1,0.5)",
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
    rep.add_argument(
        "--seed",
        type=int,
        default=None,
        help="fig2/3: seed of the multilevel input; fig7: root of the noise seeds (default 0)",
    )
    rep.add_argument(
        "--seeds",
        type=int,
        default=None,
        help="fig7, closed-loop, multistep: noise seeds per noisy cell (default 10, 5, 3)",
    )
    rep.add_argument(
        "--vehicle",
        help="vehicle name or TOML file (fig7: default rexrov; closed-loop: "
        "comma-separated, default rexrov,bluerov2_heavy; multistep: default rexrov)",
    )
    rep.add_argument(
        "--ratios",
        type=ints,
        default=None,
        help="fig2/3 only: h_u/h values, comma-separated (default 1,2,5,10,20,50,100)",
    )
    rep.add_argument("--methods", help="comma-separated method names (default: the figure's)")
    rep.add_argument(
        "--norm",
        default=None,
        choices=ERROR_NORMS,
        help="norm shown (fig2/3: any, default rms; fig7: l2_over_n (default) or rms); the "
        "CSV has them all",
    )
    rep.add_argument(
        "--attitude-hold",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="fig7 only: close a roll-pitch PD loop on the vertical thrusters, or not "
        "(--no-attitude-hold: the paper's open-loop input). Default: the vehicle's entry "
        "in the study table (sampledyn/experiments/studies/fig7.toml): the BlueROV2 Heavy "
        "with the hold (open loop it tumbles), every other vehicle open loop. The hold's "
        "gains are the vehicle's in that table (feedback_tuning: RexROV kp 16000, kd 7200; "
        "BlueROV2 Heavy 40, 6; any other vehicle the law's 40, 6), or --hold-gains",
    )
    rep.add_argument(
        "--hold-gains",
        type=floats,
        default=None,
        metavar="KP,KD",
        help="fig7 only: gains of the roll-pitch hold, KP in N m/rad and KD in N m s/rad "
        "(> 0), instead of the study table's for the vehicle; the hold must be on (the "
        "vehicle's default, or --attitude-hold)",
    )
    rep.add_argument(
        "--store",
        default=None,
        help="results store (SQLite file): keep the cells there; rerunning after a kill "
        "computes only the missing ones; `sampledyn report STORE` renders them",
    )
    rep.add_argument(
        "--workers",
        type=int,
        default=None,
        help="local worker processes (fig7, closed-loop, multistep: default 2; fig2/3: in "
        "this process; 1: in this process)",
    )
    rep.add_argument(
        "--scheduler", default=None, help="address of a Dask scheduler, e.g. tcp://host:8786"
    )
    rep.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    rep.set_defaults(func=_run)

"""``sampledyn advise``: which sampled-data model to use for a vehicle, h and noise."""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ._common import (
    add_format,
    names,
    newton_options,
    option,
    pair,
    print_json,
    refuse,
    writable_dir,
)

if TYPE_CHECKING:  # the command line imports this module before the kernels
    from ..models import Model

__all__ = ["add_parser"]


def _report(args: argparse.Namespace) -> int:
    if args.input is not None:
        refuse("--report runs its own inputs (gentle and pitch, see docs/sensitivity.md); "
               "drop --input.")  # fmt: skip
    out = writable_dir(args.report, "--report")
    from ..report import sensitivity_report

    with option("--vehicle"):
        numbers = sensitivity_report(
            out, vehicle=args.vehicle, T=args.T, seeds=args.seeds, workers=args.workers
        )
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


def _crossings(advice: Any) -> dict[str, list[float | None]]:
    return {name: list(advice.curves.crossing(name)) for name in advice.curves.methods}


def _input(text: str, model: Model) -> Any:
    """The signal of ``--input``: a registered input name or an inline TOML table."""
    from .._files import parse_toml
    from ..models import ClosedLoop
    from ..signals._names import input_for

    text = text.strip()
    if text.startswith("{"):
        try:
            spec = parse_toml(f"input = {text}", "`--input`")["input"]
        except ValueError as exc:
            raise ValueError(
                f"`--input`: {text[:80]!r} is not a TOML inline table ({exc}); e.g. "
                "--input '{ name = \"multilevel\", hold = 0.5 }'."
            ) from None
    else:
        spec = {"name": text}
    plant = model.plant if isinstance(model, ClosedLoop) else model
    try:
        return input_for(spec, plant)
    except (ValueError, TypeError) as exc:
        raise ValueError(f"`--input` {text!r}: {exc}") from exc


def _json(advice: Any, args: argparse.Namespace, png: Path) -> dict[str, Any]:
    """The document of ``advise --format json`` (keys in docs/cli.md)."""
    return {
        "vehicle": advice.vehicle,
        "h": advice.h,
        "noise": {"eta_pct": advice.eta_pct, "v_pct": advice.v_pct},
        "tolerance": None if advice.tolerance is None else list(advice.tolerance),
        "rank_by": advice.rank_by,
        "seed": args.seed,
        "seeds": advice.seeds,
        "best": advice.best,
        "rank_agreement": advice.rank_agreement,
        "noise_levels": None
        if advice.noise_levels is None
        else dict(zip(advice.state_names, map(float, advice.noise_levels), strict=True)),
        "rows": [dataclasses.asdict(r) for r in advice.rows],
        "baselines": [dataclasses.asdict(r) for r in advice.baselines],
        "failed": {n: {"h": f[0], "reason": f[1]} for n, f in advice.curves.failed.items()},
        "notes": list(advice.notes),
        "crossings": _crossings(advice),
        "figure": str(png),
    }


def _check_options(args: argparse.Namespace) -> None:
    """The Newton options and --mapping, named, before any work."""
    newton_options(args)
    if args.mapping is not None and args.noise_from is None:
        refuse("`--mapping` reads the log of --noise-from; give --noise-from LOG too.")


def _run(args: argparse.Namespace) -> int:
    _check_options(args)
    if args.report:
        return _report(args)
    out = writable_dir(args.out or "out/advise", "--out")

    from ..experiments import advise
    from ..models import load_vehicle

    with option("--vehicle"):
        vehicle = load_vehicle(args.vehicle)
    signal = None if args.input is None else _input(args.input, vehicle)
    eta_pct, v_pct = args.noise
    levels = _noise_levels(args, vehicle)
    advice = advise(
        vehicle,
        args.h,
        eta_pct,
        v_pct,
        methods=_methods(args.methods),
        tolerance=args.tolerance,
        validate=not args.no_validate,
        signal=signal,
        T=args.T,
        seeds=args.seeds,
        base_seed=args.seed,
        rank_by=args.rank_by,
        workers=args.workers,
        noise_levels=levels,
        newton=newton_options(args),
    )
    from ..report._sensitivity_figs import plot_crossing

    png = plot_crossing(advice.curves, out / "crossing.png", h_mark=args.h)
    status = 7 if any(r.failed for r in advice.rows) else 0  # EXIT_NUMERICAL: a row failed
    if args.format == "json":
        print_json(_json(advice, args, png))
        return status
    print(advice.table())
    if advice.jacobians is not None:
        print()
        print("Jacobian maxima over the domain (eqs. (19)-(23)):")
        print(advice.jacobians.table())
    crossings = [
        f"{name} ({', '.join('-' if x is None else f'{x:.3g} s' for x in c)})"
        for name, c in _crossings(advice).items()
    ]
    print("\ntruncation meets noise at h (eta, v): " + "; ".join(crossings))
    print(f"best: {advice.best}; wrote {png}")
    return status


def _noise_levels(args: argparse.Namespace, vehicle: Any) -> Any:
    """Per-state noise levels: --noise-levels NAME=STD,..., or those estimated from the
    log --noise-from (read with --mapping); None for --noise."""
    if args.noise_levels is None and args.noise_from is None:
        return None
    if args.noise_levels is not None and args.noise_from is not None:
        refuse("give --noise-levels or --noise-from, not both.")
    if args.noise_levels is not None:
        return _parse_levels(args.noise_levels, vehicle)
    from ..logs import read_log
    from ..logs._evaluate import estimate_log_noise
    from ..logs._mapping import model_for_mapping

    with option("--mapping"):
        model = model_for_mapping(vehicle, args.mapping)
    with option("--noise-from"):
        data = read_log(args.noise_from, model, mapping=args.mapping)
    return estimate_log_noise(data)


def _parse_levels(text: str, vehicle: Any) -> Any:
    import numpy as np

    sigma = np.zeros(vehicle.nx)
    names = list(vehicle.state_names)
    for part in [p for p in text.split(",") if p.strip()]:
        name, _, value = part.partition("=")
        name = name.strip()
        if name not in names:
            raise ValueError(
                f"`--noise-levels`: {name!r} is no state of {vehicle.name!r}; states: "
                f"{', '.join(names)} (e.g. --noise-levels x=1e-5,u=2e-3)."
            )
        try:
            sigma[names.index(name)] = float(value)
        except ValueError:
            raise ValueError(
                f"`--noise-levels`: {part.strip()!r} is not NAME=STD; e.g. u=2e-3."
            ) from None
    if not (np.isfinite(sigma).all() and (sigma >= 0).all()):
        raise ValueError("`--noise-levels`: the standard deviations must be finite and >= 0.")
    return sigma


def _methods(text: str | None) -> tuple[str, ...]:
    """``--methods``: the default rules when not given; an empty list is refused."""
    if text is None:
        from ..experiments._advise import DEFAULT_METHODS

        return tuple(DEFAULT_METHODS)
    chosen = names(text)
    if not chosen:
        refuse("`--methods` is empty; give comma-separated rules, e.g. --methods E,AB4,RK4, "
               "or leave it out for the default ones.")  # fmt: skip
    return chosen


def add_parser(subparsers: Any, parents: list[argparse.ArgumentParser]) -> None:
    """Register ``sampledyn advise`` on an argparse subparsers object."""
    p = subparsers.add_parser(
        "advise",
        parents=parents,
        help="rank sampled-data models for a vehicle, h and noise level (section 5 and beyond)",
        description=(
            "Rank E, AB_s, RK_s and T by their predicted largest one-step error on noisy "
            "samples of a reference run (default input: a gentle version of the Fig. 6 "
            "input; --input to choose), beside the guaranteed bound (24)-(25) and the "
            "measured Monte Carlo errors (computed on the experiment engine); with "
            "--tolerance, the largest h that keeps each rule's error under it. Writes a "
            "figure of truncation vs noise term against h to --out. --report DIR instead "
            "writes the figures and numbers of docs/sensitivity.md (takes minutes)."
        ),
    )
    p.add_argument("--vehicle", default="bluerov2_heavy", help="built-in name or TOML file")
    p.add_argument(
        "--input",
        default=None,
        help="input of the reference run: a registered input name (gentle, fig6, pitch, "
        "multilevel, sinusoidal) or an inline TOML table such as "
        "'{ name = \"gentle\", scale = 0.3 }' (default: gentle, the Fig. 6 pattern at 20 %%, "
        "for vehicles with 4 vertical and 4 horizontal thrusters)",
    )
    p.add_argument(
        "--workers", type=int, default=None, help="local worker processes of the Monte Carlo"
    )
    p.add_argument("--h", type=float, default=0.1, help="sampling period in s (default 0.1)")
    p.add_argument(
        "--noise",
        type=pair,
        default=(2.0, 2.0),
        help="noise levels eta%%,v%% of 1 m/30 deg and 1 m/s/30 deg/s (default 2,2)",
    )
    p.add_argument(
        "--noise-levels",
        default=None,
        help="per-state noise standard deviations NAME=STD,... in state units (others 0), "
        "e.g. x=1e-5,u=2e-3: uniform noise of these std instead of --noise",
    )
    p.add_argument(
        "--noise-from",
        default=None,
        metavar="LOG",
        help="estimate the per-state noise levels from this log (read with --mapping, as "
        "sampledyn evaluate reads it) instead of --noise",
    )
    p.add_argument("--mapping", default=None, help="mapping file of --noise-from (docs/logs.md)")
    p.add_argument(
        "--newton-tol", type=float, default=None,
        help="Newton tolerance of the implicit rules (T) (default 1e-12)",
    )  # fmt: skip
    p.add_argument(
        "--newton-max-iter", type=int, default=None,
        help="Newton iterations of the implicit rules (T) (default 25)",
    )  # fmt: skip
    p.add_argument(
        "--tolerance",
        type=pair,
        default=None,
        help="error tolerance (eta[,v]) in state units; prints the largest h per rule",
    )
    p.add_argument(
        "--methods",
        default=None,
        help="comma-separated rules (default: E, AB2-AB6, RK2-RK4 and T: the rules the "
        "bounds cover)",
    )
    p.add_argument("--T", type=float, default=60.0, help="reference run length in s (default 60)")
    p.add_argument("--seeds", type=int, default=3, help="Monte Carlo noise seeds (default 3)")
    p.add_argument(
        "--seed",
        type=int,
        default=0,
        help="root of the Monte Carlo noise seeds: seed k draws from SeedSequence([SEED, k]) "
        "(default 0)",
    )
    p.add_argument("--no-validate", action="store_true", help="skip the Monte Carlo check")
    p.add_argument(
        "--rank-by",
        choices=("max", "eta", "v"),
        default="max",
        help="rank on the larger of the position/angle (eta) and velocity (v) errors "
        "(max, default), or on one of the two blocks",
    )
    add_format(p, "the ranking")
    p.add_argument("--out", help="folder of the crossing figure (default out/advise)")
    p.add_argument("--report", metavar="DIR", help="write the sensitivity report into DIR")
    p.set_defaults(func=_run)

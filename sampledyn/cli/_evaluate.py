"""``sampledyn evaluate``: local errors of sampled-data models on a real log."""

from __future__ import annotations

import argparse
import math
from typing import TYPE_CHECKING, Any

from ._common import (
    add_format,
    names,
    newton_options,
    option,
    print_json,
    refuse,
    refuse_overwriting_inputs,
    registry,
    writable_file,
)

if TYPE_CHECKING:  # the command line imports this module before the kernels
    from ..models import Model

__all__ = ["add_parser"]


def _estimating(name: str) -> bool:
    reg = registry()
    return isinstance(reg.get_method(name), reg.Estimator)


def _check_estimate(rules: tuple[str, ...]) -> None:
    """Every ``--estimate`` rule must estimate parameters (asked of the registry)."""
    for name in rules:
        if not _estimating(name):
            known = [m for m in registry().available_methods() if _estimating(m)]
            hint = f" ({', '.join(known)})" if known else ""
            refuse(
                f"`--estimate {name}`: {name} does not estimate parameters; give a rule that "
                f"does{hint}, e.g. its estimated counterpart listed by `sampledyn methods`, "
                f"or put {name} in --methods."
            )


def _estimation_json(est: Any) -> dict[str, Any]:
    return {
        "structure": est.structure,
        "p": est.p,
        "params": dict(est.params),
        "units": dict(est.units),
        "std_errors": None if est.std_errors is None else dict(est.std_errors),
        "flags": {k: list(v) for k, v in est.flags.items()},
        "straddling": est.straddling,
        "condition_number": est.condition_number,
        "residual_norm": est.residual_norm,
        "n_samples": est.n_samples,
        "left_out": est.left_out,
    }


def _noise_json(noise: Any) -> dict[str, Any] | None:
    if noise is None:
        return None
    return {
        "order": noise.order,
        "windows": noise.windows,
        "sigma": {n: _finite(s) for n, s in zip(noise.state_names, noise.sigma, strict=True)},
        "check": {n: _finite(s) for n, s in zip(noise.state_names, noise.check, strict=True)},
        "units": dict(zip(noise.state_names, noise.state_units, strict=True)),
    }


def _finite(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def _stability_json(limits: Any) -> list[dict[str, Any]]:
    return [
        {
            "method": lim.method,
            "h": lim.h,
            "h_stable": _finite(lim.h_stable),
            "stable": lim.stable,
            "eigenvalue": None if lim.sample < 0 else [lim.eigenvalue.real, lim.eigenvalue.imag],
            "sample": lim.sample,
            "amplification": lim.amplification,
        }
        for lim in limits
    ]


def _json(args: argparse.Namespace, model: Model, data: Any, result: Any) -> dict[str, Any]:
    """The document of ``evaluate --format json`` (keys in docs/cli.md)."""
    from ..sensitivity._floor import FLOOR_FACTOR

    tr = data.traj
    return {
        "source": str(data.source),
        "vehicle": getattr(model, "name", args.vehicle),
        "samples": int(tr.n_samples),
        "h": float(tr.h),
        "jitter": float(data.jitter),
        "t_start": float(tr.t[0]),
        "t_end": float(tr.t[-1]),
        "notes": list(data.notes),
        "time_base": list(result.notes),
        "left_out": list(result.left_out),
        "norm": args.norm,
        "after": args.after,
        "rows": [{k: _plain(v) for k, v in r.items()} for r in result.rows],
        "failed": list(result.failed),
        "noise": _noise_json(result.noise),
        "floor_factor": FLOOR_FACTOR,
        "stability": _stability_json(result.stability),
        "estimation": None if result.estimation is None else _estimation_json(result.estimation),
        "estimations": [_estimation_json(e) for e in result.estimations],
        "warnings": list(result.warnings),
        "out": args.out,
    }


def _inputs(args: argparse.Namespace) -> dict[str, Any]:
    """The files ``evaluate`` reads (a built-in vehicle name is none)."""
    from ..models._names import is_model_file

    vehicle = args.vehicle if is_model_file(args.vehicle) else None
    mapping = args.mapping if isinstance(args.mapping, str) else None
    return {"--data": args.data, "--vehicle": vehicle, "--mapping": mapping}


def _plain(v: Any) -> Any:
    """A row value for JSON: NaN and inf as null."""
    return _finite(v) if isinstance(v, float) else v


def _cmd_evaluate(args: argparse.Namespace) -> int:
    methods = names(args.methods)
    estimate = names(args.estimate)
    with option("--methods"):
        for name in methods:
            registry().get_method(name)
    _check_estimate(estimate)
    if args.max_missing is not None and args.gaps != "bridge":
        refuse(
            f"`--max-missing` applies to `--gaps bridge` only (here --gaps {args.gaps}); "
            "give both, or leave --max-missing out."
        )
    if args.after is not None and not math.isfinite(args.after):
        raise ValueError(
            f"`--after` must be a finite time in s (log time), got {args.after:g}; e.g. "
            "--after 2 counts the errors on t >= 2 s."
        )
    newton = newton_options(args)
    out = writable_file(args.out, "--out") if args.out else None
    if out is not None:
        refuse_overwriting_inputs(out, "--out", _inputs(args))

    from ..experiments.sweep._inputs import build_model
    from ..logs import evaluate_log, read_log
    from ..logs._mapping import model_for_mapping

    with option("--vehicle"):
        model = build_model(args.vehicle)
    with option("--mapping"):
        model = model_for_mapping(model, args.mapping)
    with option("--data"):
        data = read_log(
            args.data,
            model,
            mapping=args.mapping,
            nan=args.nan,
            time_tolerance=args.time_tolerance,
            unwrap=not args.no_unwrap,
            gaps=args.gaps,
            max_missing=1 if args.max_missing is None else args.max_missing,
            irregular=args.irregular,
        )
    result = evaluate_log(
        model, data, [*methods, *estimate], norm=args.norm, after=args.after,
        newton=newton,
    )  # fmt: skip
    if out is not None:
        from ..report._tables import write_csv

        write_csv(result.rows, out)
    if args.format == "json":
        print_json(_json(args, model, data, result))
        return _status(result)
    _print(args, model, data, result, out)
    return _status(result)


def _status(result: Any) -> int:
    """0, or EXIT_NUMERICAL when a rule's row failed (the table printed all the same)."""
    from ._status import EXIT_NUMERICAL

    return EXIT_NUMERICAL if result.failed else 0


def _print(args: argparse.Namespace, model: Any, data: Any, result: Any, out: Any) -> None:
    tr = data.traj
    print(
        f"{data.source}: {tr.n_samples} samples, h = {tr.h:.6g} s (jitter "
        f"{100 * data.jitter:.2g} % of h), t = {tr.t[0]:g}..{tr.t[-1]:g} s; vehicle "
        f"{getattr(model, 'name', args.vehicle)}"
    )
    for note in data.notes:
        print(f"  {note}")
    for note in result.notes:
        print(note)
    window = "all samples" if args.after is None else f"t >= {args.after:g} s"
    if result.left_out:
        window += f"; without {', '.join(result.left_out)} (not measured)"
    print(f"\n{args.norm} of the one-step local errors (measurement - prediction), {window}:")
    print(result.table())
    for est in result.estimations:
        print(f"\n{est}")
    for w in result.warnings:
        print(f"warning: {w}")
    if result.failed:
        print(
            f"failed: {', '.join(result.failed)} (the reason in its row; exit status 7); "
            "the other rows are complete"
        )
    if out is not None:
        print(f"wrote {out}")


def add_parser(sub: Any, parents: list[argparse.ArgumentParser]) -> None:
    """Add the ``evaluate`` command to the subparsers ``sub``."""
    from .._local_errors import ERROR_NORMS
    from ..logs._read import TIME_TOLERANCE
    from ..logs._time import GAP_POLICIES

    ev = sub.add_parser(
        "evaluate",
        parents=parents,
        help="local errors of sampled-data models on a real log (CSV, Parquet, ROS bag, "
        "ArduSub DataFlash, MAVLink tlog, BlueOS MCAP)",
        description=(
            "Read a vehicle log (columns t, the 12 states and the thruster rpm, units in "
            "the header like x[m], phi[deg], n1[rpm], or a --mapping file), validate it "
            "(time as logged, dropped records, NaN policy, units, angle wrap-around), then "
            "print the one-step local errors of each method. ROS bags are read through a "
            "--mapping file; ArduSub logs (DataFlash, tlog, BlueOS) with the defaults of "
            "examples/ardusub_*.toml when none is given (docs/logs.md). Every choice made is "
            "printed. Nothing is written unless --out is given."
        ),
    )
    ev.add_argument(
        "--data",
        required=True,
        help="log: .csv, .parquet, ROS 2 bag (directory, .db3, .mcap), ROS 1 .bag, ArduSub "
        ".bin, MAVLink .tlog, BlueOS .mcap (docs/logs.md)",
    )
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
        help="also estimate the parameters on the log with these comma-separated rules "
        "that estimate parameters (e.g. Ee or ABe2; see `sampledyn methods`)",
    )
    ev.add_argument(
        "--norm",
        default="rms",
        choices=ERROR_NORMS,
        help="error norm (default rms; see sampledyn.error_norm)",
    )
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
        default=TIME_TOLERANCE,
        help="largest deviation of a time step from a whole number of periods, as a "
        f"fraction of h (default {TIME_TOLERANCE})",
    )
    ev.add_argument(
        "--gaps",
        choices=list(GAP_POLICIES),
        default="refuse",
        help="dropped records: refuse (default), bridge up to --max-missing records in a "
        "row (samples keep their logged times), or split the log into segments",
    )
    ev.add_argument(
        "--max-missing",
        type=int,
        default=None,
        help="longest run of dropped records --gaps bridge accepts (default 1)",
    )
    ev.add_argument(
        "--mapping",
        default=None,
        help="TOML file: column names and units (CSV/Parquet), topics and frames (ROS bag, "
        "needed), messages and thruster curve (ArduSub; default: every key's default); "
        "see docs/logs.md",
    )
    ev.add_argument(
        "--irregular",
        action="store_true",
        help="accept a log whose steps are no whole numbers of one period (refused by "
        "default): every rule predicts on the logged stamps, the step ratios are printed",
    )
    ev.add_argument("--no-unwrap", action="store_true", help="do not unwrap angles")
    ev.add_argument(
        "--newton-tol",
        type=float,
        default=None,
        help="Newton tolerance of the implicit rules (T): stop when every update is <= TOL "
        "(1 + |x|) (default 1e-12)",
    )
    ev.add_argument(
        "--newton-max-iter",
        type=int,
        default=None,
        help="Newton iterations of the implicit rules (T) before their row fails (default 25)",
    )
    add_format(ev, "the error table")
    ev.add_argument("--out", default=None, help="also write the table as CSV")
    ev.set_defaults(func=_cmd_evaluate)

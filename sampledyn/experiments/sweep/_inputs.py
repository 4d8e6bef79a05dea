"""Named inputs, feedback laws and vehicles of a sweep file.

A sweep names its input by a string so that it follows the library: ``"fig6"`` is
whatever :func:`sampledyn.signals.fig6_thrusters` maps onto the vehicle today. Add an
input with :func:`register_input`, a feedback law (which closes a loop around the
model: a closed-loop study) with :func:`register_feedback`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

__all__ = [
    "available_feedback",
    "available_inputs",
    "build_model",
    "check_feedback",
    "check_input",
    "make_input",
    "register_feedback",
    "register_input",
]


@dataclass(frozen=True)
class _InputEntry:
    factory: Callable[..., Any]
    defaults: Mapping[str, Any]
    description: str


_INPUTS: dict[str, _InputEntry] = {}


def register_input(
    name: str,
    factory: Callable[..., Any],
    description: str,
    defaults: Mapping[str, Any] | None = None,
) -> None:
    """Register ``factory(model, **params) -> Signal`` under ``name``.

    ``defaults`` lists every parameter the input accepts, with its default value.
    """
    _INPUTS[name] = _InputEntry(factory, dict(defaults or {}), description)


def available_inputs() -> dict[str, str]:
    """Registered input name -> description."""
    return {k: e.description for k, e in _INPUTS.items()}


def _check(table: Mapping[str, _InputEntry], what: str, spec: Mapping[str, Any]) -> dict[str, Any]:
    name = spec.get("name")
    if name is None:
        raise ValueError(
            f"the {what} table {dict(spec)!r} has no `name`; give one of "
            f"{', '.join(sorted(table))}, e.g. {{ name = {sorted(table)[0]!r}, ... }}."
        )
    if not isinstance(name, str) or name not in table:
        raise ValueError(f"unknown {what} {name!r}; registered: {', '.join(sorted(table))}.")
    entry = table[name]
    params = {k: v for k, v in spec.items() if k != "name"}
    bad = sorted(set(params) - set(entry.defaults))
    if bad:
        valid = ", ".join(entry.defaults) or "none"
        raise ValueError(f"{what} {name!r} has no parameter {bad[0]!r}; its parameters: {valid}.")
    return {"name": name, **entry.defaults, **params}


def check_input(spec: Mapping[str, Any]) -> dict[str, Any]:
    """The input spec with defaults filled in, ``{"name": ..., **params}``.

    Raises
    ------
    ValueError
        for an unknown name or parameter (listing the valid ones).
    """
    return _check(_INPUTS, "input", spec)


def make_input(spec: Mapping[str, Any], model: Any) -> Any:
    """Build the signal of a (checked) input spec for ``model`` (the plant: a closed
    loop's reference has the plant's input channels)."""
    full = check_input(spec)
    params = {k: v for k, v in full.items() if k != "name"}
    return _INPUTS[full["name"]].factory(model, **params)


# -- feedback laws: closed loops as compositions ------------------------------------

_FEEDBACK: dict[str, _InputEntry] = {}


def register_feedback(
    name: str,
    factory: Callable[..., Any],
    description: str,
    defaults: Mapping[str, Any] | None = None,
) -> None:
    """Register ``factory(plant, **params) -> ClosedLoop`` under ``name``.

    ``defaults`` lists every parameter the law accepts, with its default value.
    """
    _FEEDBACK[name] = _InputEntry(factory, dict(defaults or {}), description)


def available_feedback() -> dict[str, str]:
    """Registered feedback law name -> description."""
    return {k: e.description for k, e in _FEEDBACK.items()}


def check_feedback(spec: Mapping[str, Any]) -> dict[str, Any]:
    """The feedback spec with defaults filled in, ``{"law": ..., **params}``.

    Raises
    ------
    ValueError
        for an unknown law or parameter (listing the valid ones).
    """
    params = {k: v for k, v in spec.items() if k != "law"}
    full = _check(_FEEDBACK, "feedback law", {"name": spec.get("law"), **params})
    return {"law": full.pop("name"), **full}


def build_model(
    vehicle: str,
    buoyancy_pct: float | None = None,
    feedback: Mapping[str, Any] | None = None,
) -> Any:
    """The model of a sweep: "auv_like" (eqs. (9)-(10)) or a vehicle name / file path,
    with its net buoyancy set to ``buoyancy_pct`` percent of its weight if given, and
    closed by the ``feedback`` law if given (a :class:`sampledyn.models.ClosedLoop`)."""
    from ...models import AUVLike, load_vehicle

    if vehicle.lower() in ("auv_like", "auvlike", "auv"):
        if buoyancy_pct is not None:
            raise ValueError("`buoyancy_pct` applies to vehicles only, not to 'auv_like'.")
        model: Any = AUVLike()
    else:
        try:
            model = load_vehicle(vehicle)
        except ValueError as exc:
            if str(exc).startswith("unknown built-in vehicle"):  # say what else is taken here
                raise ValueError(
                    f"{exc} Besides vehicles, 'auv_like' names the AUV-like system of eqs. "
                    "(9)-(10)."
                ) from exc
            raise
        if buoyancy_pct is not None:
            model = model.with_buoyancy(buoyancy_pct)
    if feedback is None:
        return model
    full = check_feedback(feedback)
    params = {k: v for k, v in full.items() if k != "law"}
    return _FEEDBACK[full["law"]].factory(model, **params)


def _fig6(model: Any) -> Any:
    from ...signals import fig6_thrusters

    return fig6_thrusters(model)


def _multilevel(model: Any, low: float, high: float, hold: float, seed: int) -> Any:
    from ...signals import Multilevel

    return Multilevel(low=low, high=high, hold=hold, seed=seed, nu=int(model.nu))


def _gentle(model: Any, scale: float) -> Any:
    from ...sensitivity import gentle_input

    return gentle_input(model, scale)


def _pitch(model: Any, pitch_frac: float, period_s: float, excitation_frac: float) -> Any:
    from ...sensitivity import pitch_input

    return pitch_input(model, pitch_frac, period_s, excitation_frac)


def _sinusoidal(model: Any, offset: Any, amplitude: Any, frequency_hz: Any, phase_rad: Any) -> Any:
    from ...signals import Sinusoidal

    nu = int(model.nu)
    offset = [0.0] * nu if offset is None else offset
    amplitude = [0.0] * nu if amplitude is None else amplitude
    frequency_hz = [0.0] * nu if frequency_hz is None else frequency_hz
    return Sinusoidal(
        offset,
        amplitude,
        frequency_hz,
        phase_rad,
        names=tuple(model.input_names),
        units=tuple(getattr(model, "input_units", ()) or ()),
    )


def _roll_pitch_hold(plant: Any, kp: float, kd: float, n_lin_frac: float) -> Any:
    from ...models import AttitudeHold

    return AttitudeHold(plant, kp, kd, n_lin_frac)


register_input("fig6", _fig6, "the paper's Fig. 6 thruster rpm, mapped onto the vehicle")
register_input(
    "gentle",
    _gentle,
    "the Fig. 6 thruster rpm with every mean and sinusoid times `scale` (keeps a light "
    "vehicle's attitude in range; sampledyn.sensitivity.gentle_input)",
    {"scale": 0.2},
)
register_input(
    "pitch",
    _pitch,
    "a slow nose-up / nose-down sweep by the vertical thrusters "
    "(sampledyn.sensitivity.pitch_input)",
    {"pitch_frac": 0.2, "period_s": 50.0, "excitation_frac": 0.1},
)
register_input(
    "sinusoidal",
    _sinusoidal,
    "offset + sum of sinusoids per input channel (lists of length nu, or nu lists of K "
    "sinusoids), input units and Hz",
    {"offset": None, "amplitude": None, "frequency_hz": None, "phase_rad": None},
)
register_feedback(
    "roll_pitch_hold",
    _roll_pitch_hold,
    "a roll-pitch PD loop on the vertical thrusters (sampledyn.models.AttitudeHold): kp in "
    "N m/rad, kd in N m s/rad",
    {"kp": 40.0, "kd": 6.0, "n_lin_frac": 0.3},
)
register_input(
    "multilevel",
    _multilevel,
    "random multilevel input (section 4.1): levels uniform in [low, high] held for `hold` s",
    {"low": -10.0, "high": 10.0, "hold": 0.1, "seed": 0},
)

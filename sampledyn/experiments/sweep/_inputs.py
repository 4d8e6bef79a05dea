"""Named inputs and vehicles of a sweep file.

A sweep names its input by a string so that it follows the library: ``"fig6"`` is
whatever :func:`sampledyn.signals.fig6_thrusters` maps onto the vehicle today. Add an
input with :func:`register_input`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

__all__ = ["available_inputs", "build_model", "check_input", "make_input", "register_input"]


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


def check_input(spec: Mapping[str, Any]) -> dict[str, Any]:
    """The input spec with defaults filled in, ``{"name": ..., **params}``.

    Raises
    ------
    ValueError
        for an unknown name or parameter (listing the valid ones).
    """
    name = spec.get("name")
    if name not in _INPUTS:
        raise ValueError(
            f"unknown input {name!r}; registered inputs: {', '.join(sorted(_INPUTS))}."
        )
    entry = _INPUTS[name]
    params = {k: v for k, v in spec.items() if k != "name"}
    bad = sorted(set(params) - set(entry.defaults))
    if bad:
        valid = ", ".join(entry.defaults) or "none"
        raise ValueError(f"input {name!r} has no parameter {bad[0]!r}; its parameters: {valid}.")
    return {"name": name, **entry.defaults, **params}


def make_input(spec: Mapping[str, Any], model: Any) -> Any:
    """Build the signal of a (checked) input spec for ``model``."""
    full = check_input(spec)
    params = {k: v for k, v in full.items() if k != "name"}
    return _INPUTS[full["name"]].factory(model, **params)


def build_model(vehicle: str, buoyancy_pct: float | None = None) -> Any:
    """The model of a sweep: "auv_like" (eqs. (9)-(10)) or a vehicle name / file path,
    with its net buoyancy set to ``buoyancy_pct`` percent of its weight if given."""
    from ...models import AUVLike, load_vehicle

    if vehicle.lower() in ("auv_like", "auvlike", "auv"):
        if buoyancy_pct is not None:
            raise ValueError("`buoyancy_pct` applies to vehicles only, not to 'auv_like'.")
        return AUVLike()
    model = load_vehicle(vehicle)
    if buoyancy_pct is not None:
        model = model.with_buoyancy(buoyancy_pct)
    return model


def _fig6(model: Any) -> Any:
    from ...signals import fig6_thrusters

    return fig6_thrusters(model)


def _multilevel(model: Any, low: float, high: float, hold: float, seed: int) -> Any:
    from ...signals import Multilevel

    return Multilevel(low=low, high=high, hold=hold, seed=seed, nu=int(model.nu))


register_input("fig6", _fig6, "the paper's Fig. 6 thruster rpm, mapped onto the vehicle")
register_input(
    "multilevel",
    _multilevel,
    "random multilevel input (section 4.1): levels uniform in [low, high] held for `hold` s",
    {"low": -10.0, "high": 10.0, "hold": 0.1, "seed": 0},
)

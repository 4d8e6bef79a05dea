"""The built-in model names and the feedback laws, in one table each.

A sweep file, a study or the command line names its model by a string: a built-in
vehicle (a file of ``sampledyn/models/vehicles/``, :func:`builtin_vehicles`), the
AUV-like system of the paper's eqs. (9)-(10) (``"auv_like"``, also ``"auvlike"`` and
``"auv"``), or the path of a vehicle file. A closed loop names its feedback law
(``{ law = "roll_pitch_hold", kp = 40.0 }``). These tables are the only place that
knows those names; every other layer asks :func:`model_from_name`,
:func:`model_names` and :data:`FEEDBACK_LAWS`.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any

from .._named import NamedTable
from ._attitude_hold import AttitudeHold
from ._auv import AUVLike
from ._vehicle_file import builtin_vehicles, load_vehicle

__all__ = [
    "FEEDBACK_LAWS",
    "MODELS",
    "close_loop",
    "is_model_file",
    "model_from_name",
    "model_names",
]

#: Built-in models other than the vehicle files: name (and aliases) -> factory().
MODELS = NamedTable("model")
MODELS.register(
    "auv_like", AUVLike, "the AUV-like system of eqs. (9)-(10)", aliases=("auvlike", "auv")
)

#: Feedback laws that close a loop around a plant: ``factory(plant, **parameters)``.
FEEDBACK_LAWS = NamedTable("feedback law", key="law")
FEEDBACK_LAWS.register(
    "roll_pitch_hold",
    AttitudeHold,
    "a roll-pitch PD loop on the vertical thrusters (sampledyn.models.AttitudeHold): kp in "
    "N m/rad, kd in N m s/rad",
    {"kp": 40.0, "kd": 6.0, "n_lin_frac": 0.3},
)


def is_model_file(name: str | os.PathLike[str]) -> bool:
    """True if ``name`` is the path of a vehicle file (not a built-in name)."""
    text = os.fspath(name)
    return text.endswith(".toml") or "/" in text or os.sep in text


def model_names() -> dict[str, str]:
    """Every built-in model name -> what it is (the vehicle files and :data:`MODELS`)."""
    vehicles = {v: f"the vehicle file {v}.toml" for v in builtin_vehicles()}
    return {**vehicles, **MODELS.describe()}


def model_from_name(name: str | os.PathLike[str], buoyancy_pct: float | None = None) -> Any:
    """The model a name stands for: a built-in vehicle, a vehicle file, or an entry of
    :data:`MODELS` (aliases accepted); with its net buoyancy set to ``buoyancy_pct``
    percent of its weight (B = (1 + pct/100) W) if given.

    Raises
    ------
    ValueError
        for an unknown name (listing every built-in one), a bad vehicle file, or a
        buoyancy for a model without one.
    FileNotFoundError
        for a vehicle file that does not exist.
    """
    if is_model_file(name):
        model: Any = load_vehicle(name)
    elif MODELS.canonical(name) is not None:
        model = MODELS.build({"name": name})
    elif isinstance(name, str) and name in builtin_vehicles():
        model = load_vehicle(name)
    else:
        raise ValueError(
            f"unknown model {name!r}; built-in: {', '.join(model_names())}, or give the path "
            "of a .toml vehicle file."
        )
    if buoyancy_pct is None:
        return model
    if not hasattr(model, "with_buoyancy"):
        raise ValueError(
            f"`buoyancy_pct` applies to vehicles only, not to {MODELS.canonical(name) or name!r}."
        )
    return model.with_buoyancy(buoyancy_pct)


def close_loop(plant: Any, feedback: Mapping[str, Any]) -> Any:
    """``plant`` closed by the feedback law of ``feedback`` (``{"law": ..., **params}``,
    checked against :data:`FEEDBACK_LAWS`): a :class:`sampledyn.models.ClosedLoop`."""
    return FEEDBACK_LAWS.build(feedback, plant)

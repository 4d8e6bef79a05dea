"""The model of a sweep, composed from the names of its file.

The names themselves live with what they name: built-in models and feedback laws in
:mod:`sampledyn.models` (:data:`~sampledyn.models.MODELS`,
:data:`~sampledyn.models.FEEDBACK_LAWS`), inputs in :mod:`sampledyn.signals`
(:data:`~sampledyn.signals.INPUTS`). The engine asks those tables.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ...models._names import close_loop, model_from_name

__all__ = ["build_model"]


def build_model(
    vehicle: str,
    buoyancy_pct: float | None = None,
    feedback: Mapping[str, Any] | None = None,
) -> Any:
    """The model of a sweep: a built-in model name or a vehicle file
    (:func:`sampledyn.models._names.model_from_name`), with its net buoyancy set to
    ``buoyancy_pct`` percent of its weight if given, and closed by the ``feedback``
    law if given (a :class:`sampledyn.models.ClosedLoop`)."""
    model = model_from_name(vehicle, buoyancy_pct)
    return model if feedback is None else close_loop(model, feedback)

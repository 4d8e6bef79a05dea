"""Continuous-time vehicle models: ``x' = f(t, x, u)`` with analytic Jacobians."""

from ._auv import AUVLike as AUVLike
from ._base import CompiledModel as CompiledModel
from ._base import LinearForm as LinearForm
from ._base import Model as Model

__all__ = ["AUVLike", "CompiledModel", "LinearForm", "Model"]

"""The experiment layer: one engine (:mod:`sampledyn.experiments.sweep`: plan, one
cell function, backends, store) and the studies built on it. The studies of
``sampledyn reproduce`` are plug-ins (:data:`STUDIES`, :class:`StudyDefinition`): the
paper's Figs. 2-3 (:class:`AUVStudy`) and 7 (:class:`ROVStudy`) and the controller
studies (:class:`ClosedLoopStudy`, :class:`MultistepStudy`, whose cells are of the
kinds ``closed_loop`` and ``multistep``). Also on the engine: the Monte Carlo of
:func:`advise` and the bound validation (:func:`monte_carlo_check`,
:func:`inertia_sensitivity`, :func:`sensitivity_study`).

The names load on first use: importing this package (or its light study registry,
:mod:`._studies`) does not load the numerical kernels.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

# Public name -> module that defines it: the studies a user runs from Python (the
# registry of ``sampledyn reproduce`` and its plug-in protocol, the studies' settings,
# the engine's run), the Monte Carlo of advise and the bound validation.
_EXPORTS: dict[str, str] = {
    "advise": "._advise",
    "AUVStudy": "._auv",
    "auv_config": "._auv",
    "inertia_sensitivity": "._bounds",
    "monte_carlo_check": "._bounds",
    "ClosedLoopStudy": "._closed_loop",
    "trim": "._closed_loop",
    "MultistepStudy": "._multistep",
    "ROVStudy": "._rov",
    "sensitivity_study": "._sensitivity",
    "STUDIES": "._studies",
    "Option": "._studies",
    "StudyDefinition": "._studies",
    "Take": "._studies",
    "register_study": "._studies",
    "run_study": ".sweep._run",
}

__all__ = sorted(_EXPORTS)

if TYPE_CHECKING:
    from ._advise import advise as advise
    from ._auv import AUVStudy as AUVStudy
    from ._auv import auv_config as auv_config
    from ._bounds import inertia_sensitivity as inertia_sensitivity
    from ._bounds import monte_carlo_check as monte_carlo_check
    from ._closed_loop import ClosedLoopStudy as ClosedLoopStudy
    from ._closed_loop import trim as trim
    from ._multistep import MultistepStudy as MultistepStudy
    from ._rov import ROVStudy as ROVStudy
    from ._sensitivity import sensitivity_study as sensitivity_study
    from ._studies import STUDIES as STUDIES
    from ._studies import Option as Option
    from ._studies import StudyDefinition as StudyDefinition
    from ._studies import Take as Take
    from ._studies import register_study as register_study
    from .sweep._run import run_study as run_study


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module 'sampledyn.experiments' has no attribute {name!r}")
    value = getattr(importlib.import_module(_EXPORTS[name], __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_EXPORTS})

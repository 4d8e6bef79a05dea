"""The public API, in python-control's spirit (its ``docstring_test`` and
``kwargs_test``): every public function and class, and every public method of a public
class, has a docstring (properties are described in their class's docstring); every
public callable that takes ``**kwargs`` refuses a keyword it does not know, naming it,
and is listed below with a call that shows it; exported names are few, and each is one
thing."""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import sampledyn as sd

PUBLIC_MODULES = (
    "sampledyn",
    "sampledyn.exceptions",
    "sampledyn.methods",
    "sampledyn.models",
    "sampledyn.signals",
    "sampledyn.sensitivity",
    "sampledyn.logs",
    "sampledyn.experiments",
    "sampledyn.experiments.sweep",
    "sampledyn.report",
    "sampledyn.results",
    "sampledyn.cli",
)
BOGUS = "no_such_keyword_xyz"
ROOT = Path(__file__).resolve().parents[2]


def _public() -> Iterator[tuple[str, Any]]:
    """(qualified name, object) of every exported function and class, once each."""
    seen: set[int] = set()
    for module in PUBLIC_MODULES:
        mod = importlib.import_module(module)
        for name in mod.__all__:
            obj = getattr(mod, name)
            if (inspect.isfunction(obj) or inspect.isclass(obj)) and id(obj) not in seen:
                seen.add(id(obj))
                yield f"{module}.{name}", obj


def _own_doc(obj: Any) -> str | None:
    doc = obj.__doc__
    if inspect.isclass(obj) and dataclasses.is_dataclass(obj) and doc:
        # a dataclass without a docstring gets its signature as __doc__
        return None if doc.startswith(f"{obj.__name__}(") else doc
    return doc


def _methods(cls: type) -> Iterator[tuple[str, Callable[..., Any]]]:
    for name, value in vars(cls).items():
        func = value.__func__ if isinstance(value, classmethod | staticmethod) else value
        if (not name.startswith("_") or name == "__init__") and inspect.isfunction(func):
            yield name, func


def _is_protocol(obj: Any) -> bool:
    return inspect.isclass(obj) and bool(getattr(obj, "_is_protocol", False))


PUBLIC = dict(_public())


def test_every_public_function_class_and_method_has_a_docstring():
    missing = [name for name, obj in PUBLIC.items() if not (_own_doc(obj) or "").strip()]
    for name, obj in PUBLIC.items():
        if inspect.isclass(obj):
            missing += [f"{name}.{m}" for m, f in _methods(obj)
                        if m != "__init__" and not (inspect.getdoc(f) or "").strip()]  # fmt: skip
    assert not missing, missing


def _takes_kwargs(func: Callable[..., Any]) -> bool:
    try:
        sig = inspect.signature(func)
    except (TypeError, ValueError):
        return False
    return any(p.kind is p.VAR_KEYWORD for p in sig.parameters.values())


def _kwargs_callables() -> set[str]:
    found = set()
    for name, obj in PUBLIC.items():
        if _is_protocol(obj):
            continue  # a protocol's __init__ is typing's; it cannot be called
        if inspect.isfunction(obj) and _takes_kwargs(obj):
            found.add(name)
        if inspect.isclass(obj):
            found |= {f"{name}.{m}" for m, f in _methods(obj) if _takes_kwargs(f)}
    return found


@pytest.fixture(scope="module")
def auv_run():
    model = sd.models.AUVLike()
    return model, sd.simulate(model, sd.signals.Multilevel(hold=0.1), T=2.0, h=0.1)


def _call(name: str, auv_run: Any, tmp_path: Any) -> None:
    """Call the public callable ``name`` with the unknown keyword BOGUS."""
    model, traj = auv_run
    bad = {BOGUS: 1}
    calls: dict[str, Callable[[], Any]] = {
        "sampledyn.Trajectory.replace": lambda: traj.replace(**bad),
        "sampledyn.estimate_and_predict": lambda: sd.estimate_and_predict(model, traj, **bad),
        "sampledyn.models.AUVLike.with_params": lambda: model.with_params(**bad),
        "sampledyn.models.Vehicle.with_params": lambda: _vehicle().with_params(**bad),
        "sampledyn.models.AttitudeHold.with_params": lambda: sd.models.AttitudeHold(
            _vehicle()
        ).with_params(**bad),
        "sampledyn.models.ClosedLoop.with_params": lambda: sd.models.ClosedLoop(
            model, sd.models.LinearFeedback(np.zeros((1, 2)))
        ).with_params(**bad),
        "sampledyn.models.load_vehicle": lambda: sd.models.load_vehicle("bluerov2_heavy", **bad),
        "sampledyn.logs.LogFormat.read": lambda: next(
            f for f in sd.logs.LOG_FORMATS if f.name == "csv"
        ).read(ROOT / "examples" / "rov_log.csv", _vehicle(), **bad),
        "sampledyn.logs.write_synthetic_log": lambda: sd.logs.write_synthetic_log(
            tmp_path / "log.csv", **bad
        ),
        "sampledyn.experiments.StudyDefinition.settings": lambda: _study().settings(**bad),
        "sampledyn.experiments.run_study": lambda: sd.experiments.run_study(_config(), **bad),
        "sampledyn.experiments.sweep.SweepConfig.with_feedback": lambda: _config().with_feedback(
            "roll_pitch_hold", **bad
        ),
    }
    calls[name]()


def _vehicle() -> Any:
    return sd.models.load_vehicle("bluerov2_heavy")


def _study() -> Any:
    return sd.experiments.STUDIES["fig2"].load()


def _config() -> Any:
    return sd.experiments.auv_config(sd.experiments.AUVStudy(T=2.0, after=0.0, ratios=(1,)))


# Public callables with **kwargs whose unknown keywords another library judges.
EXEMPT = {
    "sampledyn.experiments.sweep.local_cluster": "passes **kwargs to dask.distributed's "
    "LocalCluster, which hands unknown ones to its workers (Dask's own check, at start-up)",
}
CHECKED = sorted(_kwargs_callables() - set(EXEMPT))


def test_every_kwargs_callable_is_listed_here():
    # A new public callable with **kwargs must show here that it refuses a misspelling.
    listed = set(CHECKED) | set(EXEMPT)
    assert _kwargs_callables() == listed
    assert set(EXEMPT) <= _kwargs_callables()


@pytest.mark.parametrize("name", CHECKED)
def test_an_unknown_keyword_is_refused_by_name(name, auv_run, tmp_path):
    with pytest.raises((TypeError, ValueError), match=BOGUS):
        _call(name, auv_run, tmp_path)


def test_each_exported_name_is_one_thing():
    # No module shadows a function of the same name: sampledyn.discretize is the
    # function whatever was imported before, and there is no module sampledyn.discretize.
    import sampledyn._discretize  # noqa: F401  (the module behind the function)

    for name in ("simulate", "predict", "estimate", "discretize"):
        assert inspect.isfunction(getattr(sd, name)), name
        with pytest.raises(ModuleNotFoundError):
            importlib.import_module(f"sampledyn.{name}")


def test_every_exception_lives_in_one_module():
    classes = {
        obj
        for module in PUBLIC_MODULES
        for obj in vars(importlib.import_module(module)).values()
        if inspect.isclass(obj) and issubclass(obj, Exception)
    }
    sampledyn_ones = {c for c in classes if c.__module__.startswith("sampledyn")}
    # every exception class defined anywhere in the package is in sampledyn.exceptions
    for module in list(sys.modules):
        if module.startswith("sampledyn") and module != "sampledyn.exceptions":
            sampledyn_ones |= {c for c in vars(sys.modules[module]).values()
                               if inspect.isclass(c) and issubclass(c, Exception)
                               and c.__module__ == module}  # fmt: skip
    assert {c.__module__ for c in sampledyn_ones} == {"sampledyn.exceptions"}
    assert len(sd.exceptions.__all__) == 17
    assert issubclass(sd.exceptions.SweepConfigError, sd.exceptions.ArgumentError)


def test_the_public_surface_is_curated():
    # Counted as the names in __all__ of the public modules (docs/design.md, Public
    # API): 369 before the curation of issue 19, everything the packages needed from
    # one another. A new export is a decision; raise this bound with the reason.
    # 158 after issue 19; issue 21 adds six that users call to read a table of real
    # data: sd.estimate_noise, sd.get_baseline, methods.Stability (the protocol beside
    # the others) and methods.largest_stable_steps, sensitivity.stability_limits and
    # sensitivity.noise_floor_squares.
    # 168 (issue 24): four more, the exceptions of refused work (WorkLimitError), of
    # unreadable files (FileContentError) and of an unsafe kernel cache
    # (UnsafeCacheError), which the one exceptions module must hold, and
    # sampledyn.memory_limit, the one way to raise the memory limit from code.
    # 169: MissingArgumentError, an input that needs an argument not given (a ROS bag
    # without a mapping), which the command line ends with exit 2 like a missing option.
    total = sum(len(importlib.import_module(m).__all__) for m in PUBLIC_MODULES)
    assert total <= 169, total

"""python-control views of a DiscreteModel (``pip install 'sampledyn[control]'``)."""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["to_control"]


def _control() -> Any:
    try:
        import control
    except ImportError as exc:  # pragma: no cover - the test extra installs it
        raise ImportError(
            "to_control needs python-control: pip install 'sampledyn[control]'."
        ) from exc
    return control


def state_names(dm: Any) -> list[str]:
    """Names of the entries of z: the state names for the state block, ``f1_x`` for
    entry x of the f block of lag 1, ``x2_x`` for an older state, ``held_n`` for the
    held command (python-control allows no '.' in names)."""
    names = list(dm.model.state_names)
    out: list[str] = []
    for kind, lag in dm.layout:
        prefix = "" if (kind, lag) == ("x", 0) else f"{kind}{lag}_"
        out += [prefix + n for n in names]
    if dm.delay:
        out += [f"held_{n}" for n in dm.model.input_names]
    return out


def to_control(dm: Any, x0: Any, u0: Any, z0: Any) -> Any:
    """See :meth:`DiscreteModel.to_control`."""
    ct = _control()
    inputs = list(dm.model.input_names)
    outputs = list(dm.model.state_names)
    states = state_names(dm)
    name = f"{getattr(dm.model, 'name', 'model')} {dm.method.name} h={dm.h:g}".replace(".", "p")
    if x0 is None and u0 is None and z0 is None:

        def update(t: float, z: Any, u: Any, params: Any) -> np.ndarray:
            return dm.step(np.asarray(z, dtype=float), np.atleast_1d(u).astype(float), float(t))

        def output(t: float, z: Any, u: Any, params: Any) -> np.ndarray:
            return np.asarray(z, dtype=float)[: dm.nx]

        return ct.nlsys(
            update, output, dt=dm.h, states=states, inputs=inputs, outputs=outputs, name=name
        )
    if u0 is None or (x0 is None and z0 is None):
        raise ValueError(
            "the operating point needs `u0` and `x0` (or `z0`); give none of them for the "
            "nonlinear system."
        )
    u0 = np.asarray(u0, dtype=float)
    z0 = dm.steady_state(x0, u0) if z0 is None else np.asarray(z0, dtype=float)
    A, B = dm.linearize(z0, u0)
    C = dm.output_matrix()
    D = np.zeros((dm.nx, dm.nu))
    return ct.ss(A, B, C, D, dt=dm.h, states=states, inputs=inputs, outputs=outputs, name=name)

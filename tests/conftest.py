"""Shared test helpers: small models with closed-form solutions; the example log."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import expm

EXAMPLE_LOG = Path(__file__).resolve().parents[1] / "examples" / "rov_log.csv"


class LinearModel:
    """x' = A x (nu = 1, input unused): closed-form flow expm(A t)."""

    nx = 2
    nu = 1
    state_names = ("x1", "x2")
    state_units = ("m", "m/s")
    input_names = ("u1",)
    input_units = ("",)

    def __init__(self, a: np.ndarray) -> None:
        self.a = np.asarray(a, dtype=float)

    def f(self, t, x, u):
        return np.asarray(x) @ self.a.T

    def jacobian(self, t, x, u):
        x = np.asarray(x)
        return np.broadcast_to(self.a, (x.shape[0], 2, 2)).copy()

    def flow(self, t: np.ndarray, x0: np.ndarray) -> np.ndarray:
        return np.stack([expm(self.a * ti) @ x0 for ti in t])


@pytest.fixture
def damped_oscillator() -> LinearModel:
    return LinearModel(np.array([[0.0, 1.0], [-4.0, -0.4]]))


@pytest.fixture(scope="session")
def vehicle():
    """The BlueROV2 Heavy vehicle model."""
    import sampledyn as sd

    return sd.models.load_vehicle("bluerov2_heavy")


@pytest.fixture(scope="session")
def frame():
    """The example log (examples/rov_log.csv) as a DataFrame (do not modify)."""
    import pandas as pd

    return pd.read_csv(EXAMPLE_LOG)

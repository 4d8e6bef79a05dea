"""Local errors and their norms."""

import numpy as np
import pytest

import sampledyn as sd


def test_norms_on_known_errors():
    t = np.arange(5.0)
    e = np.array([[np.nan, np.nan], [3.0, 4.0], [0.0, 0.0], [0.0, 5.0], [6.0, 8.0]])
    # per-sample norms of the rows kept: 5, 0, 5, 10
    assert sd.error_norm(e, t, "max") == 10.0
    assert sd.error_norm(e, t, "rms") == pytest.approx(np.sqrt((25 + 0 + 25 + 100) / 4))
    assert sd.error_norm(e, t, "l2_over_n") == pytest.approx(np.sqrt(150) / 4)
    assert sd.error_norm(e, t, "rms", after=3.0) == pytest.approx(np.sqrt((25 + 100) / 2))
    assert sd.error_norm(e, t, "max", components=[0]) == 6.0
    where = np.array([True, True, True, False, False])
    assert sd.error_norm(e, t, "max", where=where) == 5.0


def test_local_errors_sign_is_measurement_minus_prediction():
    x = np.array([[1.0], [2.0]])
    x_hat = np.array([[np.nan], [1.5]])
    err = sd.local_errors(x_hat, x)
    assert np.isnan(err[0, 0]) and err[1, 0] == 0.5

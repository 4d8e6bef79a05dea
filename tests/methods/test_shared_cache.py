"""Rules sharing f at the samples (the ``cache`` of predict) give the bits of rules that
do not."""

from __future__ import annotations

import numpy as np

import sampledyn as sd


def test_rk_with_the_shared_cache_is_rk_without(rexrov_data):
    """RK's first stage taken from the Adams rules' f at the samples: the same bits."""
    veh, sig, data = rexrov_data
    jittered = data.replace(t=data.t + np.r_[0.0, np.linspace(-3e-3, 3e-3, data.n_samples - 1)])
    for d in (data, jittered):
        for name in ("RK4", "RK2", "RK1"):
            cache: dict = {}
            sd.predict("AB2", veh, d, cache=cache)
            with_cache = sd.predict(name, veh, d, sig, cache=cache)
            alone = sd.predict(name, veh, d, sig)
            assert np.array_equal(with_cache, alone, equal_nan=True), name
            # and RK fills the cache for the Adams rules that come after it
            later: dict = {}
            sd.predict(name, veh, d, sig, cache=later)
            assert any(k[0] == "f" for k in later)

"""AB_s rollouts take f at the samples from one table: the bits of step-by-step."""

from __future__ import annotations

import numpy as np

import sampledyn as sd


def test_ab_rollout_takes_f_from_one_table(rexrov_data):
    veh, _sig, data = rexrov_data
    for name, uses in (("AB4", True), ("AB1", False), ("ABu4", False), ("RK4", False),
                       ("T", False), ("E", False)):  # fmt: skip
        assert sd.get_method(name).discrete_step.takes_f0 is uses, name
    dm = sd.discretize(veh, "AB4", 0.1)
    assert np.array_equal(dm.rollout(data, 1), sd.predict("AB4", veh, data), equal_nan=True)
    for k in (2, 5):  # k steps from the z of the data, the first from f at the sample
        out = dm.rollout(data, k)
        for n in (k + 3, 200, data.n_samples - 1):
            z = dm.state_from_data(data, n - k)
            for j in range(k):
                z = dm.step(z, data.u[n - k + j], data.t[n - k + j])
            assert np.array_equal(out[n], z[: veh.nx])

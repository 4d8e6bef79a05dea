"""Measurement noise (sd.add_noise): the arithmetic of its definition, bit for bit."""

from __future__ import annotations

import numpy as np

import sampledyn as sd


def test_add_noise_is_the_former_formula(rexrov_data):
    import math

    from sampledyn._noise import NOISE_REFERENCE, noise_amplitudes

    veh, _sig, data = rexrov_data
    clean = data.clean
    for dist in ("uniform", "gaussian"):
        seq = np.random.SeedSequence([7, 3])
        got = sd.add_noise(clean, 10, 20, seq, distribution=dist)
        # main 04f6bc2's arithmetic
        amp = noise_amplitudes(clean.state_units, 10, 20)
        groups = np.array([NOISE_REFERENCE.get(u, ("", 0.0))[0] for u in clean.state_units])
        noise = np.zeros_like(clean.x)
        for group, ss in zip(("eta", "v"), np.random.SeedSequence([7, 3]).spawn(2), strict=True):
            cols = np.flatnonzero(groups == group)
            rng = np.random.default_rng(ss)
            shape = (clean.x.shape[0], cols.size)
            draw = (
                rng.uniform(-1.0, 1.0, shape)
                if dist == "uniform"
                else rng.standard_normal(shape) / math.sqrt(3.0)
            )
            noise[:, cols] = draw * amp[cols]
        want = clean.x + noise
        assert np.array_equal(got.x.view(np.int64), want.view(np.int64)), dist
        assert not got.x.flags.writeable and got.clean is clean

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


def test_a_zero_level_leaves_its_components_the_samples(rexrov_data):
    """A zero level draws nothing: those components are the samples, bit for bit (signed
    zeros too), and the other group's noise is that of the same seed with both levels."""
    from sampledyn._noise import NOISE_REFERENCE

    _veh, _sig, data = rexrov_data
    clean = data.clean
    groups = np.array([NOISE_REFERENCE.get(u, ("", 0.0))[0] for u in clean.state_units])
    eta, v = groups == "eta", groups == "v"
    both = sd.add_noise(clean, 10, 20, seed=3)
    for eta_pct, v_pct, quiet, noisy in ((0, 20, eta, v), (10, 0, v, eta)):
        got = sd.add_noise(clean, eta_pct, v_pct, seed=3)
        assert np.array_equal(got.x[:, quiet].view(np.int64), clean.x[:, quiet].view(np.int64))
        assert np.array_equal(got.x[:, noisy], both.x[:, noisy])

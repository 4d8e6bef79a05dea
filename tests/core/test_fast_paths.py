"""What the speed work of the performance issue must not change, and the fixed costs it
removed: every check here is about numbers staying the same bits or about what gets
imported; the speed itself is measured in ``benchmarks/`` (ratios in one run), not here.
"""

from __future__ import annotations

import importlib
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import sampledyn as sd

REPO = Path(__file__).resolve().parents[2]


def _run_python(code: str) -> dict:
    """Run ``code`` in a fresh interpreter (this checkout first on the path); it prints
    one JSON line last."""
    done = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)],
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(REPO)},
        check=True,
    )
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_embedded_dop853_table_is_scipys_to_the_last_bit():
    """The integrator's coefficient table (embedded, so that simulating does not import
    scipy.integrate) equals SciPy's transcription of Hairer's dop853.f bit for bit."""
    from scipy.integrate._ivp import dop853_coefficients as ref

    from sampledyn import _dop853 as ours

    n = ref.N_STAGES
    assert ours.N_STAGES == n == 12
    pairs = {
        "A": (ours.A, ref.A[:n, :n]),
        "B": (ours.B, ref.B),
        "C": (ours.C, ref.C[:n]),
        "E3": (ours.E3, ref.E3),
        "E5": (ours.E5, ref.E5),
    }
    for name, (a, b) in pairs.items():
        assert a.dtype == np.float64 and a.shape == b.shape, name
        # view as integers: equal bits, signed zeros included
        assert np.array_equal(a.view(np.int64), np.ascontiguousarray(b).view(np.int64)), name
    # the order conditions the table must meet (sum b = 1, c_i = sum_j a_ij)
    assert abs(ours.B.sum() - 1.0) < 1e-14
    np.testing.assert_allclose(ours.A.sum(axis=1), ours.C, atol=1e-14)


def test_simulating_imports_neither_scipy_integrate_nor_matplotlib():
    found = _run_python(
        """
        import json, sys
        import numpy as np
        import sampledyn as sd
        traj = sd.simulate(sd.models.AUVLike(), sd.signals.Multilevel(hold=0.1, seed=0),
                           T=1.0, h=0.1, x0=np.array([1.0, 0.0]))
        sd.predict("RK4", sd.models.AUVLike(), traj)
        print(json.dumps({m: m in sys.modules for m in
                          ("scipy.integrate", "scipy.optimize", "matplotlib", "sympy")}))
        """
    )
    assert found == {
        "scipy.integrate": False,
        "scipy.optimize": False,
        "matplotlib": False,
        "sympy": True,  # the AUV-like model is symbolic (sympy builds its kernel)
    }, found


def test_the_integrator_uses_the_whole_table():
    """The arrays the compiled integrator freezes into its code are SciPy's 12 stages."""
    from scipy.integrate._ivp import dop853_coefficients as ref

    sim_module = importlib.import_module("sampledyn._integrator")
    n = ref.N_STAGES
    for ours, theirs in (
        (sim_module._A, ref.A[:n, :n]),
        (sim_module._B, ref.B),
        (sim_module._C, ref.C[:n]),
        (sim_module._E3, ref.E3),
        (sim_module._E5, ref.E5),
    ):
        assert np.array_equal(ours.view(np.int64), np.ascontiguousarray(theirs).view(np.int64))


# ------------------------------------------------------------------ same numbers


def _old_error_norms(errors, t, kinds, after=None, components=None, where=None):
    """The error norms as they were computed before the window (main 04f6bc2), with the
    per-sample sum of squares in its documented order (first component to last, each
    square rounded): the reference the windowed computation must equal bit for bit."""
    from sampledyn.methods import uniform_grid

    e = np.asarray(errors, dtype=float)
    if components is not None:
        e = e[:, components]
    sq = e[:, 0] * e[:, 0]
    for c in range(1, e.shape[1]):
        sq = sq + e[:, c] * e[:, c]
    keep = ~np.isnan(sq)
    if where is not None:
        keep &= where
    if after is not None:
        keep &= t >= after - 1e-9 * max(1.0, abs(after))
    sq = sq[keep]
    w = None
    if not (t.size < 2 or uniform_grid(t, (t[-1] - t[0]) / (t.size - 1))):
        steps = np.diff(t)
        span = np.concatenate([steps[:1], steps])[keep]
        w = span / span.mean()
    total = float(sq.sum()) if w is None else float((w * sq).sum())
    return {
        "rms": float(np.sqrt(total / sq.size)),
        "max": float(np.sqrt(sq.max())),
        "l2_over_n": float(np.sqrt(total) / sq.size),
        "l2": float(np.sqrt(total)),
        "mean": float(np.sqrt(sq).mean())
        if w is None
        else float((w * np.sqrt(sq)).sum() / sq.size),
    }


@pytest.mark.parametrize("grid", ["uniform", "jittered", "unsorted"])
@pytest.mark.filterwarnings("ignore:invalid value encountered in sqrt")
def test_error_norms_on_a_window_equal_the_former_ones_bit_for_bit(grid):
    from sampledyn.errors import ERROR_NORMS, error_norms, error_window

    rng = np.random.default_rng(3)
    n = 5000
    t = np.arange(n) * 0.1
    if grid == "jittered":
        t = t + rng.uniform(-0.004, 0.004, n)
    elif grid == "unsorted":
        t = rng.permutation(t)
    err = rng.standard_normal((n, 12)) * np.exp(rng.uniform(-20, 5, (n, 12)))
    err[:4] = np.nan  # no prediction (history)
    err[rng.choice(n, 30)] = np.nan  # and some inside the window
    where = rng.uniform(size=n) > 0.3
    comps = [None, slice(0, 6), slice(6, 12), np.array([0, 1, 2, 6, 7, 8]), [3, 4, 5, 9]]
    for after in (None, 100.0):
        for mask in (None, where):
            window = error_window(t, after, mask)
            for c in comps:
                want = _old_error_norms(err, t, ERROR_NORMS, after, c, mask)
                got = error_norms(err, t, ERROR_NORMS, after, c, mask)
                again = window.norms(err, ERROR_NORMS, c)
                for k in ERROR_NORMS:  # the same bits (NaN where the weights are < 0)
                    assert np.array_equal(got[k], want[k], equal_nan=True), (k, c)
                    assert np.array_equal(again[k], want[k], equal_nan=True), (k, c)


def test_sum_of_squares_orders():
    """Index sets and slices alike: the sum from the first component on, each square
    rounded (the same on every machine: no fused multiply-add, no pairwise order);
    several sets in one pass give the same bits as each alone."""
    from sampledyn.errors import sum_of_squares, sums_of_squares

    rng = np.random.default_rng(5)
    e = rng.standard_normal((20000, 12)) * np.exp(rng.uniform(-30, 30, (20000, 12)))
    e[7, 2] = np.nan
    sets = ([0, 1, 2, 6, 7, 8], [11, 0, 5], [4], slice(0, 6), slice(3, 12), None)
    together = sums_of_squares(e, sets)
    for k, comps in enumerate(sets):
        idx = comps if isinstance(comps, list) else np.arange(12)[comps or slice(None)]
        by_hand = e[:, idx[0]] * e[:, idx[0]]
        for c in idx[1:]:
            by_hand = by_hand + e[:, c] * e[:, c]
        assert np.array_equal(sum_of_squares(e, comps), by_hand, equal_nan=True)
        assert np.array_equal(together[k], by_hand, equal_nan=True)
    with pytest.raises(ValueError, match="selects no component"):
        sum_of_squares(e, slice(12, 12))


def _rexrov():
    import warnings

    from sampledyn.experiments import fig7_vehicle

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the file's added-mass symmetry note
        return fig7_vehicle(sd.models.load_vehicle("rexrov"), 1.0)


@pytest.fixture(scope="module")
def rexrov_data():
    veh = _rexrov()
    sig = sd.signals.fig6_thrusters(veh)
    exact = sd.simulate(veh, sig, T=60.0, h=0.1, certify=False)
    return veh, sig, sd.add_noise(exact, 2, 10, seed=4)


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


def test_add_noise_is_the_former_formula(rexrov_data):
    import math

    from sampledyn.noise import NOISE_REFERENCE, noise_amplitudes

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


def test_trajectory_checks_are_remembered_and_unchanged():
    from sampledyn.methods import uniform_grid

    t = np.arange(100) * 0.01
    x = np.zeros((100, 2))
    traj = sd.Trajectory(t=t, x=x, u=np.zeros((100, 1)), h=0.01, state_names=("a", "b"),
                         state_units=("m", "m/s"))  # fmt: skip
    assert traj.on_uniform_grid is uniform_grid(traj.t, traj.h) is True
    bad_x = x.copy()
    bad_x[37, 1] = np.inf
    bad = traj.replace(x=bad_x)
    assert bad.on_uniform_grid
    for _ in range(2):  # the remembered answer raises the same message
        with pytest.raises(ValueError, match=r"`data.x` holds NaN or inf; first bad sample n=37"):
            bad.check_finite("data")
    jittered = traj.replace(t=t + np.r_[0.0, np.full(99, 1e-4)] * np.arange(100) % 3)
    assert jittered.on_uniform_grid is uniform_grid(jittered.t, jittered.h) is False


def test_pitch_check_of_a_batch_is_the_full_check():
    """The shortcut (every |theta| clearly below both thresholds) gives the answer of the
    full check; near and past the thresholds the full check runs."""
    from sampledyn.models._rigid_body import _pitch_verdict, check_pitch

    def full(theta, tol, limit):
        c = np.abs(np.cos(theta))
        worst = int(np.argmin(c))
        return _pitch_verdict(float(c[worst]), float(theta[worst]), worst, tol, limit)

    rng = np.random.default_rng(11)
    for scale in (0.1, 0.5, 1.2, 1.39, 1.4, 1.5):
        for _ in range(50):
            theta = rng.uniform(-scale, scale, 64)
            for tol, limit in ((0.5, 80.0), (0.5, None), (10.0, 85.0)):
                try:
                    want = full(theta, tol, limit)
                except ValueError as exc:
                    with pytest.raises(ValueError) as got:
                        check_pitch(theta, tol, limit)
                    assert str(got.value) == str(exc)
                    continue
                assert check_pitch(theta, tol, limit) == want


def test_local_errors_into_the_prediction(rexrov_data):
    from sampledyn.errors import local_errors

    veh, _sig, data = rexrov_data
    x_hat = sd.predict("AB4", veh, data)
    want = local_errors(x_hat, data)
    got = local_errors(x_hat, data, out=x_hat)
    assert got is x_hat and np.array_equal(got, want, equal_nan=True)


# --------------------------------------------------------------- closed loop, rollout


def test_closed_loop_jacobian_is_the_chain_rule_through_the_plant_bit_for_bit():
    veh = sd.models.load_vehicle("bluerov2_heavy")
    hold = sd.models.AttitudeHold(veh)
    assert hold._jacobian_parts() is not None  # the plant has compiled Jacobian kernels
    rng = np.random.default_rng(2)
    x = rng.normal(size=(300, 12)) * 0.2
    u = rng.uniform(-1.5, 1.5, (300, 8)) * veh.n_max  # saturated rpm included
    t = np.zeros(300)

    def by_hand(tt, xx, rr):
        ua = hold.applied_input(tt, xx, rr)
        f_u = veh.input_jacobian(tt, xx, ua)
        k_x = np.broadcast_to(hold.law.gain, (xx.shape[0], 8, 12)).copy()
        return veh.jacobian(tt, xx, ua) + f_u @ k_x, f_u

    want, f_u = by_hand(t, x, u)
    assert np.array_equal(hold.jacobian(t, x, u), want)
    assert np.array_equal(hold.input_jacobian(t, x, u), f_u @ np.eye(8))
    for i in (0, 7, 299):  # one state, and a batch of one
        assert np.array_equal(hold.jacobian(0.0, x[i], u[i]), want[i])
        assert np.array_equal(hold.jacobian(t[:1], x[i : i + 1], u[i : i + 1])[0], want[i])
    # the plant's pitch check still applies
    bad = x[0].copy()
    bad[4] = np.radians(89.8)
    with pytest.raises(ValueError, match="pitch angle"):
        hold.jacobian(0.0, bad, u[0])
    # the vehicle's input Jacobian kernel is its input_jacobian
    jac_u, p = veh.input_jacobian_kernel()
    out = np.empty((12, 8))
    from sampledyn.models import readonly

    jac_u(0.0, readonly(x[3]), readonly(u[3]), readonly(p), out)
    assert np.array_equal(out, veh.input_jacobian(0.0, x[3], u[3]))


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


# ------------------------------------------------------------------------- workers


def test_workers_keep_freed_memory():
    """A worker allocates and frees arrays of one size over and over (noise, predictions,
    errors of each cell). glibc maps each afresh (4 MB is above its mmap threshold,
    which it raises only to the size freed) and faults every page in again; after
    retain_freed_memory they come from the heap and are reused."""
    code = """
        import json, resource, sys
        import numpy as np
        from sampledyn.experiments.sweep import retain_freed_memory
        ok = retain_freed_memory() if sys.argv[-1] == "retain" else None

        def faults():
            f0 = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
            for _ in range(20):
                a = np.ones(500_000)  # 4 MB
                b = a + 1.0
                del a, b
            return resource.getrusage(resource.RUSAGE_SELF).ru_minflt - f0

        faults()
        print(json.dumps({"ok": ok, "faults": faults()}))
    """
    plain = _run_python(code)
    kept = _run_python(code.replace('sys.argv[-1] == "retain"', "True"))
    assert kept["ok"] is True
    assert plain["faults"] > 10_000 > 20 * kept["faults"], (plain, kept)

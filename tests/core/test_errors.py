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


def _old_error_norms(errors, t, kinds, after=None, components=None, where=None):
    """The error norms as they were computed before the window (main 04f6bc2), with the
    per-sample sum of squares in its documented order (first component to last, each
    square rounded): the reference the windowed computation must equal bit for bit."""
    from sampledyn._trajectory import uniform_grid

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
    from sampledyn._local_errors import ERROR_NORMS, error_norms, error_window

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
    from sampledyn._local_errors import sum_of_squares, sums_of_squares

    rng = np.random.default_rng(5)
    e = rng.standard_normal((20000, 12)) * np.exp(rng.uniform(-30, 30, (20000, 12)))
    e[7, 2] = np.nan
    sets = ([0, 1, 2, 6, 7, 8], [11, 0, 5], [4], slice(0, 6), slice(3, 12), None, [0, 1])
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


SETS = (slice(0, 6), slice(6, 12), slice(0, 12), slice(0, 3), slice(6, 9),
        np.array([0, 1, 2, 6, 7, 8]), [11, 0, 5], [4])  # fmt: skip
SUMMED = ("rms", "l2_over_n", "l2")  # the kinds that are sums of the squares


@pytest.mark.parametrize("n", [1, 7, 8, 128, 129, 1000, 8193, 50001])
def test_norms_in_one_pass_are_those_of_the_squares(n):
    """ErrorWindow.norms_of_sets (the errors a - b formed, squared and summed leaf by leaf
    of numpy's pairwise tree, no arrays) gives the kinds that are sums of the squares bit
    for bit as numpy's sums of the per-sample squares: lengths around the leaf size (128)
    and the split rule. "max" and "mean" are left to the squares (None)."""
    from sampledyn._local_errors import error_window, sums_of_squares

    rng = np.random.default_rng(n)
    a = rng.standard_normal((n, 12)) * np.exp(rng.uniform(-20, 20, (n, 12)))
    b = rng.standard_normal((n, 12))
    t = 0.1 * np.arange(n)
    for after in (None, 0.3 * t[-1]):
        window = error_window(t, after)
        got = window.norms_of_sets(a, b, SETS, SUMMED)
        squares = sums_of_squares(a - b, SETS)
        want = [window.norms_of_squares(squares[k], SUMMED) for k in range(len(SETS))]
        assert got == want
        for kinds in (("rms", "max"), ("mean",)):
            assert window.norms_of_sets(a, b, SETS, kinds) is None


def test_norms_in_one_pass_of_an_adams_prediction(rexrov_data):
    """With the weights of an Adams rule (sample_filter) the prediction is formed in the
    pass: the norms are those of predict()'s errors, bit for bit; rows without a
    prediction, a NaN, a mask or a non-uniform grid leave it to the squares (None)."""
    from sampledyn._local_errors import error_window, local_errors

    veh, _sig, data = rexrov_data
    window = error_window(data.t, data.t[len(data.t) // 3])
    for name in ("AB1", "AB3", "AB4"):
        method = sd.get_method(name)
        f, hw = method.sample_filter(veh, data)
        x_hat = sd.predict(name, veh, data)
        want = [window.norms(local_errors(x_hat, data), SUMMED, c) for c in SETS]
        assert window.norms_of_sets(data.x, f, SETS, SUMMED, hw) == want
        assert window.norms_of_sets(data.x, x_hat, SETS, SUMMED) == want
    assert error_window(data.t).norms_of_sets(data.x, f, SETS, SUMMED, hw) is None
    nan = np.array(data.x)
    nan[-1, 3] = np.nan
    assert window.norms_of_sets(nan, f, SETS, SUMMED) is None
    keep = np.arange(data.n_samples) % 2 == 0
    assert error_window(data.t, None, keep).norms_of_sets(data.x, f, SETS) is None
    jitter = data.t + 1e-3 * (np.arange(data.n_samples) % 3)
    assert error_window(jitter).norms_of_sets(data.x, f, SETS) is None


def test_local_errors_into_the_prediction(rexrov_data):
    from sampledyn._local_errors import local_errors

    veh, _sig, data = rexrov_data
    x_hat = sd.predict("AB4", veh, data)
    want = local_errors(x_hat, data)
    got = local_errors(x_hat, data, out=x_hat)
    assert got is x_hat and np.array_equal(got, want, equal_nan=True)


def test_error_norm_errors():
    t = np.arange(4.0)
    e = np.ones((4, 2))
    with pytest.raises(ValueError, match="unknown norm kind"):
        sd.error_norm(e, t, kind="l3")
    with pytest.raises(ValueError, match="no samples"):
        sd.error_norm(e, t, after=10.0)
    with pytest.raises(ValueError, match="`errors` must have shape"):
        sd.error_norm(np.ones((3, 2)), t)


def test_cached_f_is_a_read_only_copy(rexrov_data):
    """The f a cache keeps is read-only and its own: an array another object holds (a
    model that returns its own buffer, or a view of it) stays writable for its holder,
    and a later write there does not change the kept f."""
    from sampledyn.methods._base import _cached

    veh, _sig, data = rexrov_data
    held = np.ones(data.x.shape)
    for give in (lambda: held, lambda: held[:], lambda: veh.f(data.t, data.x, data.u)):
        kept = _cached("f", veh, data, {}, give)
        assert not kept.flags.writeable and not np.shares_memory(kept, held)
        assert held.flags.writeable
        before = kept.copy()
        held[0, 0] += 1.0
        assert np.array_equal(kept, before)

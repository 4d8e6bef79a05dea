"""User models: SymbolicModel (sympy -> cached kernels), FunctionModel, ClosedLoop."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from numba import njit

import sampledyn as sd
from sampledyn.models import ClosedLoop, FunctionModel, LinearFeedback, SymbolicModel
from sampledyn.models._base import JAC_SIG, RHS_SIG

REPO = Path(__file__).resolve().parents[2]


# ---------------------------------------------------------- the AUV-like system
# The hand-written kernels that the symbolic AUVLike replaced (eqs. (9)-(10)); kept
# here as the independent reference. Not cached: numba would write the cache next to
# this file, into the repository (tests write below tmp_path only).
@njit(RHS_SIG)
def _auv_rhs(t, x, u, p, out):  # pragma: no cover - compiled
    alpha, beta, gamma, delta = p[0], p[1], p[2], p[3]
    pos = x[0]
    vel = x[1]
    s2 = math.sin(pos) ** 2
    out[0] = -s2 * vel
    out[1] = alpha * vel * vel + beta * vel + gamma * vel * abs(vel) + delta * s2 + u[0]


@njit(JAC_SIG)
def _auv_jac(t, x, u, p, out):  # pragma: no cover - compiled
    alpha, beta, gamma, delta = p[0], p[1], p[2], p[3]
    pos = x[0]
    vel = x[1]
    s2x = math.sin(2.0 * pos)
    out[0, 0] = -s2x * vel
    out[0, 1] = -(math.sin(pos) ** 2)
    out[1, 0] = delta * s2x
    out[1, 1] = 2.0 * alpha * vel + beta + 2.0 * gamma * abs(vel)


def _auv_regressors(x, u):
    pos, vel = x[:, 0], x[:, 1]
    s2 = np.sin(pos) ** 2
    phi = np.zeros((x.shape[0], 2, 4))
    phi[:, 1, 0] = vel * vel
    phi[:, 1, 1] = vel
    phi[:, 1, 2] = vel * np.abs(vel)
    phi[:, 1, 3] = s2
    return phi, np.stack([-s2 * vel, u[:, 0]], axis=1)


@pytest.fixture(scope="module")
def states():
    rng = np.random.default_rng(20240601)
    n = 4000
    x = np.column_stack([rng.uniform(-7, 7, n), rng.uniform(-5, 5, n)])
    x[:50, 1] = 0.0  # on the kink
    u = rng.uniform(-10, 10, (n, 1))
    return rng.uniform(0, 100, n), x, u


@pytest.mark.parametrize("params", [{}, {"alpha": 0.3, "beta": -1.1, "gamma": 0.7, "delta": -2}])
def test_symbolic_auv_equals_the_hand_written_kernel(states, params):
    t, x, u = states
    model = sd.models.AUVLike(**params)
    p = np.array([model.alpha, model.beta, model.gamma, model.delta])
    f_ref = np.array([_ref(_auv_rhs, (2,), t[i], x[i], u[i], p) for i in range(len(t))])
    j_ref = np.array([_ref(_auv_jac, (2, 2), t[i], x[i], u[i], p) for i in range(len(t))])
    # f: the same operations in the same order, so bit for bit (the figures rely on it).
    np.testing.assert_array_equal(model.f(t, x, u), f_ref)
    np.testing.assert_array_equal(model.f(float(t[7]), x[7], u[7]), f_ref[7])
    jac = model.jacobian(t, x, u)
    scale = np.abs(j_ref).max(axis=(1, 2))[:, None, None] + 1e-300
    assert (np.abs(jac - j_ref) / scale).max() <= 1e-13
    lf = model.regressors(t, x, u)
    phi_ref, f0_ref = _auv_regressors(x, u)
    assert lf.names == ("alpha", "beta", "gamma", "delta")
    assert lf.units == ("1/m", "1/s", "1/m", "m/s^2")
    np.testing.assert_allclose(lf.phi, phi_ref, rtol=1e-13, atol=0)
    np.testing.assert_allclose(lf.f0, f0_ref, rtol=1e-13, atol=0)
    # and the form reproduces f
    np.testing.assert_allclose(lf.phi @ p + lf.f0, f_ref, rtol=1e-13, atol=1e-13)


def _ref(kernel, shape, t, x, u, p):
    out = np.empty(shape)
    kernel(t, x, u, p, out)
    return out


def test_symbolic_auv_kinks_found_without_declaration():
    model = sd.models.AUVLike()
    y = sp.Symbol("y", real=True)
    assert model.symbolic.expressions["kinks"] == (y,)
    assert model.kink_states == (1,)
    assert model.kink_inputs == ()
    sw, spar, input_only = model.switch_kernel()
    out = np.empty(1)
    sw(0.0, np.array([0.3, -1.25]), np.array([2.0]), spar, out)
    assert out[0] == -1.25 and not input_only.any()
    assert set(model.symbolic.expressions["linear_params"]) == set(
        sp.symbols("alpha beta gamma delta", real=True)
    )


def test_auv_default_state_leaves_the_equilibrium_and_excites_every_parameter():
    # Issue: (0, 0) is an equilibrium of eq. (10) (x stays 0, sin(x)^2 = 0, delta has
    # no regressor). The README's ten-line example runs from the default.
    model = sd.models.AUVLike()
    x0 = model.default_x0
    assert math.sin(x0[0]) ** 2 > 0.5
    signal = sd.signals.Multilevel(low=-10.0, high=10.0, hold=0.05, seed=0)
    traj = sd.simulate(model, signal, T=200.0, h=0.01)
    assert np.ptp(traj.x[:, 0]) > 0.5
    res = sd.estimate(model, traj, structure="AB4", after=20.0, skip_input_jumps=True)
    truth = model.params
    for name, value in res.params.items():
        assert abs(value - truth[name]) < 1e-3 * abs(truth[name]), (name, value)


# ------------------------------------------------------------- symbolic models
def _kinked_model():
    """v' = u - c|v|: for v < 0, v' = u + c v; for v > 0, v' = u - c v."""
    v, u, c = sp.symbols("v u c")
    return SymbolicModel([v], [u], [u - c * sp.Abs(v)], params={c: 1.0}, x0=[-1.0])


def _kinked_closed_form(t, v0=-1.0, u=2.0, c=1.0):
    # From v0 > -u/c below zero, v(t) = -u/c + (v0 + u/c) e^{ct} reaches 0 at
    # t* = ln((u/c) / (v0 + u/c)); after it, v = u/c (1 - e^{-c (t - t*)}).
    ts = math.log((u / c) / (v0 + u / c)) / c
    below = -u / c + (v0 + u / c) * np.exp(c * t)
    above = u / c * (1.0 - np.exp(-c * (t - ts)))
    return np.where(t < ts, below, above), ts


def test_abs_crossing_zero_simulated_to_1e12_against_the_closed_form():
    model = _kinked_model()
    assert model.kink_states == (0,)
    signal = sd.signals.ZeroOrderHold(np.array([0.0]), np.array([2.0]))  # u = 2
    h = 0.1
    traj = sd.simulate(model, signal, T=3.0, h=h, rtol=1e-13, atol=1e-13)
    exact, ts = _kinked_closed_form(traj.t)
    k = int(ts // h)
    assert traj.x[k, 0] < 0 < traj.x[k + 1, 0]  # the kink is inside one interval
    assert traj.certificate.max_error < 1e-12
    # Per interval: one interval from the exact state lands on the exact end. With the
    # kink located the error is at rounding level (measured 9e-16); integrated across
    # it without a switching function, the same rtol gives 2.7e-13.
    per_interval = [
        abs(sd.simulate(model, signal, T=h, h=h, x0=[exact[n]], rtol=1e-13, atol=1e-13).x[1, 0]
            - exact[n + 1])
        for n in range(len(exact) - 1)
    ]  # fmt: skip
    assert max(per_interval) < 1e-14
    assert np.abs(traj.x[:, 0] - exact).max() < 1e-14


def test_kinks_of_every_non_smooth_function_are_found():
    x, y, u, t = sp.symbols("x y u t")
    rhs = [
        sp.sign(x - 1) + sp.Max(x, 2 * y) + sp.Heaviside(u),
        sp.Min(y, 3) + sp.Piecewise((x, (y > 0.5) & (x < 4)), (0, True)) + sp.Abs(t - 5),
    ]
    model = SymbolicModel([x, y], [u], rhs, time=t)
    kinks = {str(g) for g in model.expressions["kinks"]}
    assert kinks == {"x - 1", "x - 2*y", "u", "y - 3", "y - 0.5", "x - 4", "t - 5"}
    sw, spar, input_only = model.switch_kernel()
    names = [str(g) for g in model.expressions["kinks"]]
    assert input_only[names.index("u")] and not input_only[names.index("t - 5")]
    out = np.empty(len(names))
    sw(1.5, np.array([2.5, 0.25]), np.array([-3.0]), spar, out)
    values = {"x - 1": 1.5, "x - 2*y": 2.0, "u": -3.0, "y - 3": -2.75, "y - 0.5": -0.25}
    values.update({"x - 4": -1.5, "t - 5": -3.5})
    assert {n: out[i] for i, n in enumerate(names)} == pytest.approx(values, abs=1e-15)
    # f and its Jacobian away from the kinks (Heaviside(-3) = 0, Piecewise -> 0 branch)
    f = model.f(1.5, np.array([2.5, 0.25]), np.array([-3.0]))
    np.testing.assert_allclose(f, [1.0 + 2.5 + 0.0, 0.25 + 0.0 + 3.5])
    np.testing.assert_allclose(model.jacobian(1.5, np.array([2.5, 0.25]), [-3.0]), [[1, 0], [0, 1]])


def test_symbolic_jacobians_against_finite_differences():
    x, v, u, k, c = sp.symbols("x v u k c")
    rhs = [v, -k * sp.sin(x) * sp.exp(-(x**2) / 4) - c * v * sp.Abs(v) + u**3 / (1 + u**2)]
    model = SymbolicModel([x, v], [u], rhs, params={k: 2.0, c: 0.4})
    rng = np.random.default_rng(3)
    xs, us = rng.normal(size=(40, 2)), rng.normal(size=(40, 1))
    jx = model.jacobian(0.0, xs, us)
    ju = model.input_jacobian(0.0, xs, us)
    assert jx.shape == (40, 2, 2) and ju.shape == (40, 2, 1)
    np.testing.assert_allclose(jx, _fd(lambda z: model.f(0.0, z, us), xs), rtol=1e-7, atol=1e-8)
    np.testing.assert_allclose(ju, _fd(lambda w: model.f(0.0, xs, w), us), rtol=1e-7, atol=1e-8)
    # c enters linearly, k too (k multiplies a function of x only).
    assert model.expressions["linear_params"] == (k, c)


def _fd(fun, z, eps=1e-6):
    cols = []
    for j in range(z.shape[1]):
        e = np.zeros(z.shape[1])
        e[j] = eps
        cols.append((fun(z + e) - fun(z - e)) / (2 * eps))
    return np.stack(cols, axis=2)


def test_nonlinear_parameters_are_left_to_nonlinear_estimation():
    x, u, a, b = sp.symbols("x u a b")
    model = SymbolicModel([x], [u], [-a * x + sp.sin(b * x) + u], params={a: 1.0, b: 2.0})
    assert model.expressions["linear_params"] == (a,)
    lf = model.regressors(0.0, np.array([[0.5]]), np.array([[0.0]]))
    assert lf.names == ("a",)
    np.testing.assert_allclose(lf.phi[:, :, 0], [[-0.5]])
    np.testing.assert_allclose(lf.f0, [[math.sin(1.0)]])
    only_b = SymbolicModel([x], [u], [sp.sin(b * x) + u], params={b: 2.0})
    with pytest.raises(NotImplementedError, match="linearly"):
        only_b.regressors(0.0, np.array([[0.5]]), np.array([[0.0]]))


def test_with_params_keeps_the_compiled_code():
    model = _kinked_model()
    other = model.with_params(c=3.0)
    assert other.kernel()[0] is model.kernel()[0]
    assert other.params == {"c": 3.0} and model.params == {"c": 1.0}
    np.testing.assert_allclose(other.f(0.0, np.array([-2.0]), np.array([1.0])), [1.0 - 6.0])
    with pytest.raises(TypeError, match="unknown parameter"):
        model.with_params(d=1.0)


def test_same_expressions_share_code_and_a_changed_expression_changes_the_key():
    v, u, c = sp.symbols("v u c")
    a = SymbolicModel([v], [u], [u - c * sp.Abs(v)], params={c: 1.0})
    b = SymbolicModel([v], [u], [u - c * sp.Abs(v)], params={c: 5.0})  # values are data
    d = SymbolicModel([v], [u], [u - c * v * sp.Abs(v)], params={c: 1.0})
    assert b._code is a._code and b.source_file == a.source_file
    assert d.source_file != a.source_file
    assert Path(a.source_file).parent == sd.models.cache_dir()
    # The evaluation order of an unevaluated expression is part of the key.
    e1 = sp.Add(u, -c * v, evaluate=False)
    e2 = sp.Add(-c * v, u, evaluate=False)
    m1 = SymbolicModel([v], [u], [e1], params={c: 1.0})
    m2 = SymbolicModel([v], [u], [e2], params={c: 1.0})
    assert m1.source_file != m2.source_file


_CACHE_SCRIPT = textwrap.dedent(
    """
    import json, sys, time
    import numpy as np
    import sympy as sp
    import sampledyn as sd
    x, v, u, c = sp.symbols("x v u c")
    t0 = time.perf_counter()
    m = sd.models.SymbolicModel([x, v], [u], [v, -c * v * sp.Abs(v) + sp.cos(x) + u],
                                params={c: 0.5})
    rhs, p = m.kernel()
    m.f(np.zeros(3), np.ones((3, 2)), np.ones((3, 1)))
    m.jacobian(np.zeros(3), np.ones((3, 2)), np.ones((3, 1)))
    elapsed = time.perf_counter() - t0
    from sampledyn.models import _codegen
    mod = m._code.load()
    stats = {}
    for name in ("rhs", "batch_rhs", "batch_jac"):
        s = getattr(mod, name).stats
        stats[name] = [sum(s.cache_hits.values()), sum(s.cache_misses.values())]
    print(json.dumps({"file": m.source_file, "stats": stats, "seconds": elapsed}))
    """
)


@pytest.mark.slow
def test_second_process_loads_the_kernels_from_the_disk_cache(tmp_path):
    env = dict(os.environ, SAMPLEDYN_CACHE_DIR=str(tmp_path), PYTHONPATH=str(REPO))
    env.pop("NUMBA_CACHE_DIR", None)
    runs = []
    for _ in range(2):
        done = subprocess.run(
            [sys.executable, "-c", _CACHE_SCRIPT], env=env, capture_output=True, text=True
        )
        assert done.returncode == 0, done.stderr
        runs.append(json.loads(done.stdout.strip().splitlines()[-1]))
    first, second = runs
    assert first["file"] == second["file"]
    assert Path(first["file"]).parent == tmp_path / "kernels"
    for name in ("rhs", "batch_rhs", "batch_jac"):
        assert first["stats"][name] == [0, 1]  # compiled ...
        assert second["stats"][name] == [1, 0]  # ... then loaded, not recompiled
    # For the record (not asserted: timings belong to benchmarks/).
    print(f"first {first['seconds']:.2f} s, second {second['seconds']:.2f} s")


@pytest.mark.slow
def test_unwritable_cache_dir_falls_back_with_a_warning(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("")
    code = (
        "import warnings, sampledyn.models as m\n"
        "with warnings.catch_warnings(record=True) as w:\n"
        "    warnings.simplefilter('always')\n"
        "    d = m.cache_dir()\n"
        "print(d); print(w[0].message if w else '')\n"
    )
    env = dict(os.environ, SAMPLEDYN_CACHE_DIR=str(blocker), PYTHONPATH=str(REPO))
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    path, message = done.stdout.strip().splitlines()
    assert Path(path).name == "kernels" and str(blocker) not in path
    assert "SAMPLEDYN_CACHE_DIR" in message and "not writable" in message


@pytest.mark.slow
def test_import_sampledyn_does_not_import_sympy():
    code = "import sys, sampledyn; print('sympy' in sys.modules)"
    env = dict(os.environ, PYTHONPATH=str(REPO))
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "False"


def test_bad_arguments_name_the_argument():
    x, v, u, c, d = sp.symbols("x v u c d")
    with pytest.raises(TypeError, match=r"`states\[1\]` must be a sympy Symbol"):
        SymbolicModel([x, "v"], [u], [v, u])
    with pytest.raises(TypeError, match=r"`inputs\[0\]` must be a sympy Symbol"):
        SymbolicModel([x], [u + 1], [u])
    with pytest.raises(ValueError, match=r"`rhs` has 1 expressions for 2 states"):
        SymbolicModel([x, v], [u], [v])
    with pytest.raises(ValueError, match=r"`rhs\[1\]` uses undeclared symbol\(s\) \['d'\]"):
        SymbolicModel([x, v], [u], [v, -d * v + u], params={c: 1.0})
    with pytest.raises(ValueError, match=r"`params\[c\]` has no value"):
        SymbolicModel([x], [u], [-c * x + u], params={c: None})
    with pytest.raises(ValueError, match=r"`params\[c\]` must be finite"):
        SymbolicModel([x], [u], [-c * x + u], params={c: float("nan")})
    with pytest.raises(TypeError, match=r"`params` must be a mapping"):
        SymbolicModel([x], [u], [-c * x + u], params=[c])
    with pytest.raises(ValueError, match=r"symbol name 'x' appears twice"):
        SymbolicModel([x], [sp.Symbol("x", real=True)], [x])
    with pytest.raises(TypeError, match=r"`rhs\[0\]` is a string"):
        SymbolicModel([x], [u], ["-x + u"])
    with pytest.raises(ValueError, match=r"`rhs\[0\]` contains \['Derivative'\]"):
        SymbolicModel([x], [u], [sp.Derivative(x**2, x)])
    with pytest.raises(ValueError, match=r"`rhs\[0\]` uses \['besselj'\]"):
        SymbolicModel([x], [u], [sp.besselj(0, x) + u])
    with pytest.raises(ValueError, match=r"`state_units` must be 1 strings"):
        SymbolicModel([x], [u], [u], state_units=["m", "s"])
    with pytest.raises(ValueError, match=r"`x0` must be 1 finite numbers"):
        SymbolicModel([x], [u], [u], x0=[0.0, 1.0])


def test_symbolic_model_runs_through_the_pipeline():
    # Mass-spring-damper with quadratic drag, declared with names and units.
    x, v, f, k, c, m = sp.symbols("x v F k c m")
    model = SymbolicModel(
        [x, v],
        [f],
        [v, (f - k * x - c * v * sp.Abs(v)) / m],
        params={k: 4.0, c: 0.8, m: 2.0},
        state_units=["m", "m/s"],
        input_units=["N"],
        param_units={"k": "N/m", "c": "N s^2/m^2", "m": "kg"},
        x0=[0.5, 0.0],
        name="spring",
    )
    signal = sd.signals.Multilevel(low=-2.0, high=2.0, hold=0.5, seed=1)
    traj = sd.simulate(model, signal, T=40.0, h=0.01)
    assert traj.state_units == ("m", "m/s") and traj.input_units == ("N",)
    assert traj.certificate.max_error < 1e-12
    # One-step errors of order s + 1 (h = 0.01; AB3 away from its history's input jumps).
    for name, bound in (("E", 1e-4), ("T", 1e-6), ("RK4", 1e-9), ("AB3", 1e-7)):
        err = np.abs(sd.local_errors(sd.predict(name, model, traj), traj))
        assert np.nanmedian(err) < bound, name
    # k and c enter linearly (m does not): least squares recovers them.
    res = sd.estimate(model, traj, structure="AB4", after=2.0, skip_input_jumps=True)
    assert set(res.params) == {"k", "c"}
    assert res.params["k"] == pytest.approx(4.0, rel=1e-3)
    assert res.params["c"] == pytest.approx(0.8, rel=1e-2)


# ------------------------------------------------------------- function models
def _spring_inplace(t, x, u, p, out):
    out[0] = x[1]
    out[1] = -p[0] * x[0] - p[1] * x[1] * abs(x[1]) + u[0]


def _spring_returning(t, x, u, p):
    return np.array([x[1], -p[0] * x[0] - p[1] * x[1] * abs(x[1]) + u[0]])


def _spring_jac(t, x, u, p, out):
    out[0, 0] = 0.0
    out[0, 1] = 1.0
    out[1, 0] = -p[0]
    out[1, 1] = -2.0 * p[1] * abs(x[1])


def test_function_model_both_forms_agree_and_run():
    params = {"k": 4.0, "c": 0.3}
    a = FunctionModel(_spring_inplace, 2, 1, jac=_spring_jac, params=params, kink_states=(1,))
    b = FunctionModel(_spring_returning, 2, 1, params=params, kink_states=(1,))
    rng = np.random.default_rng(0)
    x, u = rng.normal(size=(30, 2)), rng.normal(size=(30, 1))
    np.testing.assert_array_equal(a.f(0.0, x, u), b.f(0.0, x, u))
    np.testing.assert_allclose(a.jacobian(0.0, x, u), _fd(lambda z: a.f(0.0, z, u), x), atol=1e-7)
    signal = sd.signals.Multilevel(low=-1.0, high=1.0, hold=0.5, seed=0)
    traj = sd.simulate(b, signal, T=10.0, h=0.05, x0=np.array([1.0, 0.0]))
    assert traj.certificate.max_error < 1e-12
    assert b.with_params(k=1.0).params == {"k": 1.0, "c": 0.3}
    res = sd.estimate(b, traj, structure="E", params=("k",), after=1.0)  # nonlinear path
    assert res.params["k"] == pytest.approx(4.0, rel=0.05)


def test_function_model_without_jacobian_says_how_to_supply_one():
    model = FunctionModel(_spring_returning, 2, 1, params={"k": 4.0, "c": 0.3})
    x, u = np.ones((3, 2)), np.ones((3, 1))
    with pytest.raises(sd.exceptions.JacobianUnavailableError) as info:
        model.jacobian(0.0, x, u)
    message = str(info.value)
    assert "jac=" in message and "SymbolicModel" in message and "finite differences" in message
    signal = sd.signals.Multilevel(low=-1.0, high=1.0, hold=0.5, seed=0)
    traj = sd.simulate(model, signal, T=2.0, h=0.05, x0=np.array([1.0, 0.0]))
    with pytest.raises(sd.exceptions.JacobianUnavailableError, match="jac="):
        sd.predict("T", model, traj)
    with pytest.raises(sd.exceptions.JacobianUnavailableError, match="input_jac="):
        model.input_jacobian(0.0, x, u)


def test_function_model_bad_functions_are_refused():
    def short(t, x, u, p):
        return np.array([x[1]])

    def lazy(t, x, u, p, out):
        out[0] = x[1]

    def broken(t, x, u, p, out):
        out[0] = no_such_name(x)  # noqa: F821

    def three(t, x, u):
        return x

    with pytest.raises(ValueError, match=r"`f` did not write out\[0\], or returned"):
        FunctionModel(short, 2, 1)
    with pytest.raises(ValueError, match=r"`f` did not write out\[1\]"):
        FunctionModel(lazy, 2, 1)
    with pytest.raises(TypeError, match=r"`f` could not be compiled by numba.*no_such_name"):
        FunctionModel(broken, 2, 1)
    with pytest.raises(TypeError, match=r"`f` must take \(t, x, u, p, out\)"):
        FunctionModel(three, 2, 1)
    with pytest.raises(ValueError, match=r"`kink_states` must hold indices in \[0, 2\)"):
        FunctionModel(_spring_inplace, 2, 1, params={"k": 1.0, "c": 0.0}, kink_states=(2,))
    with pytest.raises(ValueError, match=r"`nx` must be an integer >= 1"):
        FunctionModel(_spring_inplace, 0, 1)


# ---------------------------------------------------------------- closed loops
def _plant():
    x, v, u, k, c = sp.symbols("x v u k c")
    rhs = [v, -k * sp.sin(x) - c * v * sp.Abs(v) + u * sp.Abs(u) / 10]
    return SymbolicModel([x, v], [u], rhs, params={k: 2.0, c: 0.5}, x0=[1.0, 0.0])


def test_closed_loop_jacobian_against_finite_differences():
    loop = ClosedLoop(_plant(), LinearFeedback([[-3.0, -1.5]]))
    rng = np.random.default_rng(1)
    x, r = rng.normal(size=(60, 2)), rng.normal(size=(60, 1)) * 3
    jac = loop.jacobian(0.0, x, r)
    np.testing.assert_allclose(jac, _fd(lambda z: loop.f(0.0, z, r), x), rtol=1e-6, atol=1e-8)
    jr = loop.input_jacobian(0.0, x, r)
    np.testing.assert_allclose(jr, _fd(lambda w: loop.f(0.0, x, w), r), rtol=1e-6, atol=1e-8)
    # The applied input is the law: u = r + K x.
    np.testing.assert_allclose(
        loop.applied_input(0.0, x, r)[:, 0], r[:, 0] - 3.0 * x[:, 0] - 1.5 * x[:, 1], rtol=1e-14
    )
    # ... and the loop is the plant driven by it.
    ua = loop.applied_input(0.0, x, r)
    np.testing.assert_array_equal(loop.f(0.0, x, r), loop.plant.f(0.0, x, ua))


def test_closed_loop_switches_are_the_plants_at_the_applied_input():
    loop = ClosedLoop(_plant(), LinearFeedback([[-3.0, -1.5]]))
    kinks = [str(g) for g in loop.plant.expressions["kinks"]]
    assert sorted(kinks) == ["u", "v"]
    sw, spar, input_only = loop.switch_kernel()
    x, r = np.array([0.4, -0.2]), np.array([1.0])
    out = np.empty(2)
    sw(0.0, x, r, spar, out)
    applied = loop.applied_input(0.0, x, r)[0]
    assert dict(zip(kinks, out, strict=True)) == pytest.approx({"v": -0.2, "u": applied})
    assert not input_only.any()  # the applied input depends on the state
    # Simulated across the kinks with the certificate of the open-loop models.
    signal = sd.signals.Multilevel(low=-2.0, high=2.0, hold=0.5, seed=0)
    traj = sd.simulate(loop, signal, T=20.0, h=0.1)
    assert traj.certificate.max_error < 1e-12


def test_closed_loop_around_a_function_model_needs_its_input_jacobian():
    def f(t, x, u, p, out):
        out[0] = x[1]
        out[1] = -p[0] * x[0] + u[0]

    def jx(t, x, u, p, out):
        out[0, 0] = 0.0
        out[0, 1] = 1.0
        out[1, 0] = -p[0]
        out[1, 1] = 0.0

    def ju(t, x, u, p, out):
        out[0, 0] = 0.0
        out[1, 0] = 1.0

    law = LinearFeedback([[-3.0, -1.5]])
    with_ju = ClosedLoop(FunctionModel(f, 2, 1, jac=jx, input_jac=ju, params={"k": 2.0}), law)
    np.testing.assert_allclose(with_ju.jacobian(0.0, np.ones(2), [0.0]), [[0, 1], [-5, -1.5]])
    without = ClosedLoop(FunctionModel(f, 2, 1, jac=jx, params={"k": 2.0}), law)
    np.testing.assert_allclose(without.f(0.0, np.ones(2), np.zeros(1)), [1.0, -6.5])
    with pytest.raises(sd.exceptions.JacobianUnavailableError, match="input Jacobian"):
        without.jacobian(0.0, np.ones(2), [0.0])


def test_closed_loop_bad_arguments():
    with pytest.raises(ValueError, match=r"`law` maps 3 states to 1 inputs"):
        ClosedLoop(_plant(), LinearFeedback(np.zeros((1, 3))))
    with pytest.raises(TypeError, match=r"`law` must be a sampledyn.models.FeedbackLaw"):
        ClosedLoop(_plant(), np.zeros((1, 2)))
    with pytest.raises(TypeError, match=r"`plant` must be a compiled sampledyn model"):
        ClosedLoop(object(), LinearFeedback(np.zeros((1, 2))))

import warnings
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import sampledyn as sd
from sampledyn.methods import ButcherTableau, ab_coefficients, available_methods
from sampledyn.methods._runge_kutta import TABLEAUX

F = Fraction

KNOWN = {
    1: (F(1),),
    2: (F(3, 2), F(-1, 2)),
    3: (F(23, 12), F(-16, 12), F(5, 12)),
    4: (F(55, 24), F(-59, 24), F(37, 24), F(-9, 24)),
}


@pytest.mark.parametrize("s", sorted(KNOWN))
def test_ab_known_values(s):
    assert ab_coefficients(s) == KNOWN[s]


@pytest.mark.parametrize("s", range(1, 11))
def test_ab_coefficients_sum_to_one(s):
    assert sum(ab_coefficients(s)) == 1


@pytest.mark.parametrize(
    "s, a_s", [(1, F(1)), (2, F(2)), (3, F(11, 3)), (4, F(20, 3)), (5, F(551, 45)), (6, F(114, 5))]
)
def test_a_s(s, a_s):
    assert sd.AdamsBashforth(s).a_s == a_s


@settings(max_examples=40, deadline=None)
@given(s=st.integers(1, 8), data=st.data())
def test_ab_exact_on_polynomials_below_degree_s(s, data):
    # integral_0^1 p(tau) dtau == sum a_i p(-i) for every polynomial of degree < s.
    degree = data.draw(st.integers(0, s - 1))
    coeffs = [F(data.draw(st.integers(-20, 20))) for _ in range(degree + 1)]

    def p(tau):
        return sum(c * F(tau) ** k for k, c in enumerate(coeffs))

    exact = sum(c / (k + 1) for k, c in enumerate(coeffs))
    assert sum(a * p(-i) for i, a in enumerate(ab_coefficients(s))) == exact


def test_ab_not_exact_on_degree_s():
    s = 3
    # tau**3 integrates to 1/4, AB3 gets it wrong: the order is exactly s.
    rule = sum(a * F(-i) ** s for i, a in enumerate(ab_coefficients(s)))
    assert rule != F(1, 4)


def test_ab_newest_first_public_api():
    ab4 = sd.AdamsBashforth(4)
    assert ab4.order == 4
    assert ab4.coefficients == (F(55, 24), F(-59, 24), F(37, 24), F(-3, 8))
    assert ab4.a_s == F(20, 3)


@pytest.mark.parametrize("s", sorted(TABLEAUX))
def test_tableaux_are_exact_and_of_declared_order(s):
    tab = TABLEAUX[s]
    assert tab.order == s
    assert sum(tab.b) == 1
    assert all(isinstance(v, Fraction) for v in tab.b)


def test_bad_tableau_rejected():
    with pytest.raises(ValueError, match="row 1"):
        ButcherTableau(
            a=((F(0), F(0)), (F(1, 3), F(0))), b=(F(1, 2), F(1, 2)), c=(F(0), F(1)), order=2
        )
    with pytest.raises(ValueError, match="order"):
        # Heun's coefficients declared as order 3.
        ButcherTableau(
            a=((F(0), F(0)), (F(1), F(0))), b=(F(1, 2), F(1, 2)), c=(F(0), F(1)), order=3
        )


def test_registry_names_and_euler_is_ab1():
    for name in available_methods():
        m = sd.get_method(name)
        assert m.name == name
    assert sd.get_method("E").coefficients == sd.AdamsBashforth(1).coefficients
    assert isinstance(sd.Euler(), sd.AdamsBashforth)
    with pytest.warns(UserWarning, match=r"AB9: .*\[-0\.0127, 0\]"):
        assert sd.get_method("AB9").order == 9


def test_registry_unknown_name_lists_valid():
    with pytest.raises(ValueError, match=r"unknown method 'XY3'.*AB<s>.*RK<s>"):
        sd.get_method("XY3")


@pytest.mark.parametrize("name", ["AB0", "RK0", "RK5"])
def test_registry_bad_order(name):
    with pytest.raises(ValueError, match="order `s`"):
        sd.get_method(name)


def test_ab_order_must_be_int():
    with pytest.raises(TypeError, match="order `s`"):
        sd.AdamsBashforth(2.5)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="order `s` must be an int >= 1"):
        sd.AdamsBashforth(0)


def test_weights_are_float_copy_of_coefficients():
    w = sd.AdamsBashforth(5).weights
    assert np.allclose(w, [float(a) for a in ab_coefficients(5)])


def _lagrange_ab(s):
    """AB coefficients the textbook way, independent of the library: integrals over
    [0, 1] of the Lagrange basis polynomials on the nodes 0, -1, ..., -(s-1)."""
    out = []
    for i in range(s):
        poly = [F(1)]  # coefficients, lowest degree first
        for j in range(s):
            if j != i:  # times (tau + j) / (j - i)
                nxt = [F(0)] * (len(poly) + 1)
                for k, c in enumerate(poly):
                    nxt[k] += c * j / (j - i)
                    nxt[k + 1] += c / (j - i)
                poly = nxt
        out.append(sum(c / (k + 1) for k, c in enumerate(poly)))
    return tuple(out)


@pytest.mark.parametrize("s", range(1, 13))
def test_ab_coefficients_equal_lagrange_integrals(s):
    assert ab_coefficients(s) == _lagrange_ab(s)


def _max_root(s, z):
    a = [float(c) for c in ab_coefficients(s)]
    # zeta^s - zeta^{s-1} - z sum_i a_i zeta^{s-1-i}
    p = np.zeros(s + 1)
    p[0], p[1] = 1.0, -1.0
    p[1:] -= z * np.array(a)
    return np.abs(np.roots(p)).max()


@pytest.mark.parametrize("s", range(1, 10))
def test_ab_real_stability_interval_is_two_over_a_s(s):
    # The boundary of the stability region on the negative real axis, found from the
    # roots of the characteristic polynomial by bisection, is -2 / a_s.
    beta = sd.methods.ab_stability_interval(s)
    assert beta == pytest.approx(2.0 / float(sum(abs(a) for a in ab_coefficients(s))))
    lo, hi = 0.0, 3.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        stable = all(_max_root(s, -x) <= 1 + 1e-12 for x in np.linspace(mid / 50, mid, 50))
        lo, hi = (mid, hi) if stable else (lo, mid)
    assert lo == pytest.approx(beta, rel=1e-6)


def test_ab_warns_past_the_collapse_of_its_stability_interval():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sd.AdamsBashforth(6)  # interval 0.0877 >= 0.05: quiet
        sd.get_method("AB6")
    with pytest.warns(UserWarning, match=r"AB7: .*\[-0\.0465, 0\].*\| = 43;.* 21 times") as rec:
        sd.AdamsBashforth(7)
    assert rec[0].filename == __file__  # points at the caller
    with pytest.warns(UserWarning, match=r"AB20: .*\| = 2\.589e\+05;"):
        sd.AdamsBashforth(20)


@pytest.mark.parametrize("h", [1.4, 2.0])
def test_tustin_converges_at_large_steps_where_newton_does(h):
    """advise runs T at steps up to 2 s; its simplified Newton must converge wherever
    full Newton does (a slowly contracting chord iteration renews its Jacobian, a
    fresh Jacobian's first step is always taken), to Newton's answer."""
    import sampledyn as sd
    from sampledyn.sensitivity import gentle_input

    veh = sd.models.load_vehicle("bluerov2_heavy")
    traj = sd.simulate(veh, gentle_input(veh), T=40.0, h=0.1, certify=False)
    # the input held over each interval (no signal), as the reference below
    data = traj.subsample(int(round(h / 0.1))).replace(signal=None)
    x_hat = sd.get_method("T").predict(veh, data)
    # Reference: full Newton, a fresh Jacobian at every iteration.
    x0, u, t = data.x[:-1], data.u[:-1], data.t[:-1]
    f0 = veh.f(t, x0, u)
    x = x0 + h * f0
    eye = np.eye(12)
    for _ in range(40):
        g = x - x0 - 0.5 * h * (f0 + veh.f(t + h, x, u))
        x = x - np.linalg.solve(eye - 0.5 * h * veh.jacobian(t + h, x, u), g[..., None])[..., 0]
    np.testing.assert_allclose(x_hat[1:], x, rtol=0, atol=1e-10 * (1 + np.abs(x).max()))

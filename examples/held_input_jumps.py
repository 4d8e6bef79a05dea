"""Can an Adams-Bashforth rule that knows the input is held keep its order across jumps?

Regenerates the tables of the study (issue 9, item 6):

    python examples/held_input_jumps.py            # about 2 minutes

1. The AUV-like Fig. 2 setup (eqs. (9)-(10), h = 0.01 s, T = 200 s, x0 = (1, 0),
   seed 0, errors on t >= 20 s): rms of the local errors over all samples and over
   the samples whose history holds no input jump (no jump in the last 7 samples, as
   in Fig. 2), for h_u/h in 1, 5, 10, 20, 100 and s = 1..6.
2. Empirical order over h at a fixed hold h_u = 0.4 s (h = 0.04 ... 0.005 s): slope of
   the largest local error over the predictions whose history holds a jump (away
   from velocity zero crossings, the |y| kink of (9)), on the AUV-like system and on
   a smooth pendulum with the same kind of input.

Rules: AB_s, ABu_s and ABj_s from the registry, and two candidates measured here only
(not registered, they do not keep the order):

* ``ABu+fx``: ABu_s's history corrected to first order with the known jump of the
  derivative, ``g_{n-i} = f(x_{n-i}, u_n) + h F_x(x_n, u_n) sum_{j=1..i} (f(x_n,
  u_{n-j}) - f(x_n, u_n))`` (for one jump at t_n: ``- i h f_x (f(x_n, u_n) -
  f(x_n, u_{n-1}))``);
* ``restart``: AB of order m = the number of samples since the input last changed
  (at most s), i.e. the order restarted at 1 after a jump.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

import sampledyn as sd
from sampledyn.experiments.sweep import away_from_jumps, away_from_kinks
from sampledyn.methods import ab_coefficients

H, T, AFTER, SEED = 0.01, 200.0, 20.0, 0
RATIOS = (1, 5, 10, 20, 100)
ORDERS = range(1, 7)


def _held(model, data, s):
    """f(t_{n-i}, x_{n-i}, u_n), shape (N - s, s, nx), for the predictions of rows s.."""
    n = np.arange(s - 1, data.n_samples - 1)
    return np.stack([model.f(data.t[n - i], data.x[n - i], data.u[n]) for i in range(s)], 1)


def _ab(data, g, s):
    a = np.array([float(c) for c in ab_coefficients(s)])
    out = np.full(data.x.shape, np.nan)
    out[s:] = data.x[s - 1 : -1] + data.h * np.einsum("k,rkx->rx", a, g)
    return out


def abu_fx(model, data, s):
    """ABu_s with the first-order correction of its history by the derivative jump."""
    g = _held(model, data, s)
    n = np.arange(s - 1, data.n_samples - 1)
    tn, xn, un = data.t[n], data.x[n], data.u[n]
    fx = model.jacobian(tn, xn, un)
    f_now = model.f(tn, xn, un)
    acc = np.zeros_like(xn)
    for i in range(1, s):
        acc = acc + model.f(tn, xn, data.u[n - i]) - f_now
        g[:, i] += data.h * np.einsum("rab,rb->ra", fx, acc)
    return _ab(data, g, s)


def restart(model, data, s):
    """AB of order m <= s on the samples since the last input change."""
    f = model.f(data.t, data.x, data.u)
    n = np.arange(s - 1, data.n_samples - 1)
    m = np.ones(n.size, dtype=int)
    for i in range(1, s):
        m[((data.u[n - i] == data.u[n]).all(axis=1)) & (m == i)] += 1
    out = np.full(data.x.shape, np.nan)
    for order in range(1, s + 1):
        a = [float(c) for c in ab_coefficients(order)]
        rows = n[m == order]
        out[rows + 1] = data.x[rows] + data.h * sum(a[i] * f[rows - i] for i in range(order))
    return out


RULES = {
    "AB": lambda model, data, s: sd.predict(f"AB{s}", model, data),
    "ABu": lambda model, data, s: sd.predict(f"ABu{s}", model, data),
    "ABu+fx": abu_fx,
    "restart": restart,
    "ABj": lambda model, data, s: sd.predict(f"ABj{s}", model, data),
}


def jump_rows(u, s):
    """True at k when the history u[k-s..k-1] of the prediction of x[k] is not constant."""
    out = np.zeros(u.shape[0], dtype=bool)
    for k in range(s + 1, u.shape[0]):
        out[k] = (u[k - s : k] != u[k - 1]).any()
    return out


def table_fig2() -> None:
    model = sd.models.AUVLike()
    print(f"rms local error, AUV-like, h = {H} s, T = {T:g} s, t >= {AFTER:g} s, seed {SEED}")
    print("(all samples | samples whose history holds no jump; '-' where none has)")
    for ratio in RATIOS:
        signal = sd.signals.Multilevel(-10.0, 10.0, hold=ratio * H, seed=SEED)
        data = sd.simulate(model, signal, T=T, h=H, x0=np.array([1.0, 0.0]))
        smooth = away_from_jumps(data.u, 7)
        print(f"\nh_u/h = {ratio}")
        head = "".join(f"{'s=' + str(s):>10s}" for s in ORDERS)
        print(f"rule     {head}  | {head}")
        for name, rule in RULES.items():
            all_, calm = [], []
            for s in ORDERS:
                e = sd.local_errors(rule(model, data, s), data)
                all_.append(sd.error_norm(e, data.t, "rms", after=AFTER))
                has = (smooth & (data.t >= AFTER)).any()
                calm.append(
                    sd.error_norm(e, data.t, "rms", after=AFTER, where=smooth) if has else None
                )
            cells = "".join(f"{v:10.2e}" for v in all_)
            rest = "".join(f"{v:10.2e}" if v is not None else f"{'-':>10s}" for v in calm)
            print(f"{name:8s} {cells}  | {rest}")


class Pendulum:
    """A smooth plant with an input: x' = y, y' = -sin x - 0.3 y + 0.5 u (1 + 0.3 cos x)."""

    nx, nu = 2, 1
    state_names, state_units = ("x", "y"), ("rad", "rad/s")

    def f(self, t, x, u):
        x, u = np.atleast_2d(x), np.atleast_2d(u)
        drive = 0.5 * u[:, 0] * (1.0 + 0.3 * np.cos(x[:, 0]))
        return np.stack([x[:, 1], -np.sin(x[:, 0]) - 0.3 * x[:, 1] + drive], axis=1)

    def jacobian(self, t, x, u):
        x, u = np.atleast_2d(x), np.atleast_2d(u)
        jac = np.zeros((x.shape[0], 2, 2))
        jac[:, 0, 1] = 1.0
        jac[:, 1, 0] = -np.cos(x[:, 0]) - 0.15 * u[:, 0] * np.sin(x[:, 0])
        jac[:, 1, 1] = -0.3
        return jac

    def samples(self, h, hold, duration):
        """Exact samples (DOP853 per interval, rtol 1e-13) under held random levels."""
        n = int(round(duration / h)) + 1
        t = h * np.arange(n)
        levels = np.random.default_rng(SEED).uniform(-3.0, 3.0, int(duration / hold) + 2)
        u = levels[np.floor(t / hold + 1e-9).astype(int)]
        x = np.empty((n, 2))
        x[0] = (0.5, 0.0)
        for k in range(n - 1):

            def rhs(_t, z, uk=u[k]):
                return self.f(0.0, z, np.array([[uk]]))[0]

            x[k + 1] = solve_ivp(rhs, (0.0, h), x[k], method="DOP853", rtol=1e-13, atol=1e-15).y[
                :, -1
            ]
        return sd.Trajectory(
            t=t, x=x, u=u[:, None], h=h, state_names=self.state_names, state_units=self.state_units
        )


def table_slopes() -> None:
    hs = np.array([0.04, 0.02, 0.01, 0.005])
    auv = sd.models.AUVLike()
    runs = {
        "AUV-like": (
            auv,
            [
                sd.simulate(
                    auv,
                    sd.signals.Multilevel(-10.0, 10.0, hold=0.4, seed=SEED),
                    T=60.0,
                    h=h,
                    x0=np.array([1.0, 0.0]),
                )
                for h in hs
            ],
        ),
        "pendulum": (Pendulum(), [Pendulum().samples(h, 0.4, 24.0) for h in hs]),
    }
    print("\nlargest local error over the predictions whose history holds a jump, h_u = 0.4 s")
    print("(AUV-like: away from velocity zero crossings); slope = fit of log err vs log h")
    for label, (model, trajs) in runs.items():
        print(f"\n{label}: h = " + ", ".join(f"{h:g}" for h in hs) + " s")
        print("rule     " + "".join(f"{'s=' + str(s):>8s}" for s in ORDERS))
        for name, rule in RULES.items():
            slopes = []
            for s in ORDERS:
                if s == 1:
                    slopes.append(None)  # no history to hold a jump
                    continue
                errs = []
                for data in trajs:
                    e = np.linalg.norm(sd.local_errors(rule(model, data, s), data), axis=1)
                    keep = jump_rows(data.u, s) & (data.t >= 2.0)
                    kinks = getattr(model, "kink_states", ())
                    if kinks:
                        keep &= away_from_kinks(data.x, kinks, s + 1)
                    errs.append(np.nanmax(e[keep]))
                slopes.append(np.polyfit(np.log(hs), np.log(errs), 1)[0])
            print(f"{name:8s} " + "".join(f"{v:8.2f}" if v else f"{'-':>8s}" for v in slopes))


class Counting:
    """Wraps a model and counts the points f and df/dx are evaluated at."""

    def __init__(self, model):
        self.model, self.points = model, 0
        self.nx, self.nu = model.nx, model.nu

    def f(self, t, x, u):
        self.points += np.shape(x)[0]
        return self.model.f(t, x, u)

    def jacobian(self, t, x, u):
        self.points += np.shape(x)[0]
        return self.model.jacobian(t, x, u)


def table_cost() -> None:
    model = sd.models.AUVLike()
    print("\nf (and df/dx) evaluations per predicted sample, AUV-like, h = 0.01 s, T = 40 s")
    for ratio in (1, 10, 100):
        signal = sd.signals.Multilevel(-10.0, 10.0, hold=ratio * H, seed=SEED)
        data = sd.simulate(model, signal, T=40.0, h=H, x0=np.array([1.0, 0.0]))
        print(f"h_u/h = {ratio:3d}: ", end="")
        for name in ("AB", "ABu", "ABu+fx", "ABj"):
            per = []
            for s in (2, 4, 6):
                counting = Counting(model)
                RULES[name](counting, data, s)
                per.append(counting.points / data.n_samples)
            print(f"{name} " + "/".join(f"{v:.2g}" for v in per) + "   ", end="")
        print("(s = 2/4/6; RK_s: s)")


if __name__ == "__main__":
    table_fig2()
    table_slopes()
    table_cost()

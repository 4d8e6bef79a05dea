"""The compiled integrator's Dormand-Prince 8(5,3) table is SciPy's, bit for bit;
simulating imports neither scipy.integrate nor matplotlib; the certifying run beside
the main one gives the lockstep numbers; the first run compiles it aside."""

from __future__ import annotations

import importlib

import numpy as np
import pytest
from _processes import run_python


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


@pytest.mark.slow
def test_simulating_imports_neither_scipy_integrate_nor_matplotlib():
    found = run_python(
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


def test_a_kernel_that_allocates_does_not_change_the_samples():
    """The integrator's own work arrays live for the whole call: a model kernel whose
    temporaries take memory of their sizes (filled with garbage) gets the same samples
    to the bit as the same f without them (once, numba freed those arrays before the
    integration started, and such a kernel moved the samples by 1e-7)."""
    import sampledyn as sd
    from sampledyn.models import FunctionModel

    def plain(t, x, u, p, out):
        out[0] = x[1]
        out[1] = -x[0] - 0.1 * x[1] * abs(x[1]) + u[0]

    def allocating(t, x, u, p, out):
        for n in (2, 3, 4, 5, 8, 12, 16):
            w = np.empty(n)
            w[:] = 1e300
        out[0] = x[1]
        out[1] = -x[0] - 0.1 * x[1] * abs(x[1]) + u[0]

    signal = sd.signals.Multilevel(low=-1.0, high=1.0, hold=0.5, seed=0)
    a = sd.simulate(FunctionModel(plain, 2, 1, x0=[1.0, 0.0]), signal, T=5.0, h=0.1)
    b = sd.simulate(FunctionModel(allocating, 2, 1, x0=[1.0, 0.0]), signal, T=5.0, h=0.1)
    assert np.array_equal(a.x, b.x)
    assert np.array_equal(a.certificate.per_interval, b.certificate.per_interval)


def _kinked_model():
    from sampledyn.models import FunctionModel

    def rhs(t, x, u, p, out):
        out[0] = x[1]
        out[1] = -x[0] - 0.1 * x[1] * abs(x[1]) + u[0]

    return FunctionModel(rhs, 2, 1, x0=[1.0, 0.0])


def test_the_certificate_from_another_thread_is_the_lockstep_one(monkeypatch):
    """A certified run certified by a second thread from the main run's step ends
    (issue 23: the half steps on the core the main run leaves idle) has the samples,
    steps and certificate of the lockstep run to the bit, through chunks, pauses
    inside an interval and a step-end array that fills and grows."""
    import sampledyn as sd
    from sampledyn import _simulate

    made = []

    class Counted(_simulate._Certifier):
        def __init__(self, *a, **k):
            super().__init__(*a, **k)
            self.calls = {"hand_over": 0, "grow": 0}
            made.append(self)

        def hand_over(self, *a, **k):
            self.calls["hand_over"] += 1
            return super().hand_over(*a, **k)

        def grow(self):
            self.calls["grow"] += 1
            super().grow()

    monkeypatch.setattr(_simulate, "_Certifier", Counted)
    monkeypatch.setattr(_simulate, "_cores", lambda: 2)
    monkeypatch.setattr(_simulate, "_CHUNK", 64)  # several chunks
    monkeypatch.setattr(_simulate, "_FIRST_BUDGET", 16)  # pauses
    monkeypatch.setattr(_simulate, "_CALL_SECONDS", 1e-5)  # ... inside intervals too
    monkeypatch.setattr(_simulate, "_ENDS", 1)  # an interval of 2 steps fills it
    signal = sd.signals.Multilevel(low=-1.0, high=1.0, hold=0.5, seed=0)
    runs = {}
    for name, least in (("lockstep", 1 << 60), ("beside", 0)):
        monkeypatch.setattr(_simulate, "_THREAD_MIN", least)
        runs[name] = sd.simulate(_kinked_model(), signal, T=30.0, h=0.1)
    (used,) = made
    assert used.calls["grow"] >= 1 and used.calls["hand_over"] > 300 // 64
    a, b = runs["lockstep"], runs["beside"]
    assert a.certificate.steps.max() >= 2
    assert np.array_equal(a.x, b.x)
    assert np.array_equal(a.certificate.steps, b.certificate.steps)
    assert np.array_equal(a.certificate.per_interval, b.certificate.per_interval)
    assert a.certificate.max_error == b.certificate.max_error


def test_an_interrupted_run_leaves_no_certifying_thread(monkeypatch):
    """Ctrl-C between two chunks of a run certified by a second thread stops that
    thread too (it is joined before the interrupt goes on)."""
    import threading

    import sampledyn as sd
    from sampledyn import _simulate

    monkeypatch.setattr(_simulate, "_cores", lambda: 2)
    monkeypatch.setattr(_simulate, "_THREAD_MIN", 0)
    monkeypatch.setattr(_simulate, "_CHUNK", 64)
    calls = []
    real = _simulate._check_held

    def interrupted(*a, **k):
        calls.append(1)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return real(*a, **k)

    monkeypatch.setattr(_simulate, "_check_held", interrupted)
    signal = sd.signals.Multilevel(low=-1.0, high=1.0, hold=0.5, seed=0)
    with pytest.raises(KeyboardInterrupt):
        sd.simulate(_kinked_model(), signal, T=30.0, h=0.1)
    assert len(calls) == 3
    assert not [t for t in threading.enumerate() if t.name == "sampledyn-certify"]


@pytest.mark.slow
def test_a_first_run_compiles_the_integrator_aside_and_loads_it_from_the_cache(
    tmp_path, monkeypatch
):
    """Empty numba cache (issue 23, a first run): compile_aside forks a process that
    compiles the integrator into the cache; integrator() waits for it (a numba compile
    event, so the compile notice is said), compiling the certifying thread's kernel
    meanwhile, and loads what the child saved instead of compiling it a second time.
    Once compiled, compile_aside starts nothing."""
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "numba"))
    found = run_python(
        """
        import json
        from numba.core import event
        from sampledyn import _integrator as I

        seen = []

        class Seen(event.Listener):
            def on_start(self, ev):
                seen.append(getattr(ev.data["dispatcher"], "__name__", ""))

            def on_end(self, ev):
                pass

        event.register("numba:compile", Seen())
        I.compile_aside(True)
        aside = I.compiling_aside()
        child = I._ASIDE[True]
        disp = I.integrator(True)
        after = I.compiling_aside()
        I.compile_aside(True)
        beside = I.certify_steps
        print(json.dumps({
            "aside": aside, "exit": child.exitcode, "after": after,
            "again": I.compiling_aside(), "hits": sum(disp.stats.cache_hits.values()),
            "misses": sum(disp.stats.cache_misses.values()), "events": seen,
            "beside": [sum(beside.stats.cache_hits.values()),
                       sum(beside.stats.cache_misses.values())],
        }))
        """
    )
    assert found["aside"] and found["exit"] == 0
    assert found["hits"] == 1 and found["misses"] == 0  # loaded, not compiled here

    assert not found["after"] and not found["again"]
    assert found["events"].count("_integrate") == 1  # the wait, as one compile of it
    assert found["events"][-1] == "_integrate"
    assert found["beside"] == [0, 1]  # compiled here meanwhile (an empty cache)


def test_the_disk_cache_check_sees_what_numba_saved(tmp_path, monkeypatch):
    """compile_aside's test (_in_disk_cache): False before numba saved a function for
    a signature, True after, as numba's own load would find it."""
    import sys

    from numba import float64

    from sampledyn import _integrator as I

    (tmp_path / "aside_probe.py").write_text(
        "from numba import njit\n\n@njit(cache=True)\ndef twice(x):\n    return 2.0 * x\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, "aside_probe", raising=False)
    probe = importlib.import_module("aside_probe")
    sig = float64(float64)
    assert not I._in_disk_cache(probe.twice, sig)
    probe.twice.compile(sig)
    assert I._in_disk_cache(probe.twice, sig)


def test_the_specialisation_compiled_aside_is_the_models(monkeypatch):
    """compile_integrator_aside follows simulate's rule (smooth unless the model has
    jumps); a model whose jump kernel fails is left to its simulations to report."""
    from sampledyn import _integrator as I
    from sampledyn import _simulate

    asked = []
    monkeypatch.setattr(I, "compile_aside", lambda smooth: asked.append(smooth))

    class Model:
        def __init__(self, jumps):
            self.jumps = jumps

        def jump_kernel(self):
            if isinstance(self.jumps, Exception):
                raise self.jumps
            return self.jumps

    _simulate.compile_integrator_aside(Model(None))
    _simulate.compile_integrator_aside(Model(("branch", "grad", None, None)))
    _simulate.compile_integrator_aside(object())  # no jump kernel at all: smooth
    _simulate.compile_integrator_aside(Model(ValueError("no branch kernel")))
    assert asked == [True, False, True]

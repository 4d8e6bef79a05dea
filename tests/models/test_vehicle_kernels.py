"""The generated vehicle kernels (issue 23): today's f, Jacobians and switching values
for every vehicle variant, structural zeros written as no code, compiled once per
sparsity pattern and cached on disk.

The oracle is the generic kernel the generated ones replaced (``_vehicle_generic_kernel``,
run as plain Python on the same parameter array).
"""

from __future__ import annotations

import json
import os
import pickle
import re
import subprocess
import sys
import textwrap
import warnings
from pathlib import Path

import numpy as np
import pytest
from _vehicle_generic_kernel import vehicle_input_jac, vehicle_jac, vehicle_rhs, vehicle_switch
from _vehicle_reference import FULL_MATRICES

from sampledyn.models import Vehicle, load_vehicle
from sampledyn.models._vehicle_kernels import _M, _MINV

ULPS = 4  # the bound: 4 ulp of the largest term summed in a component


def _vehicle(name: str) -> Vehicle:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the RexROV file's added-mass symmetry note
        return load_vehicle(name).with_buoyancy(1.0)


CURRENT = (0.1, -0.2, 0.05, 0.01, 0.0, 0.02)
VARIANTS = {
    "rexrov": lambda: _vehicle("rexrov"),
    "bluerov2 (6 thrusters)": lambda: _vehicle("bluerov2"),
    "bluerov2_heavy": lambda: _vehicle("bluerov2_heavy"),
    "full matrices": lambda: _vehicle("bluerov2_heavy").with_params(**FULL_MATRICES),
    "thruster lag": lambda: _vehicle("rexrov").with_params(thruster_lag=True, T_n=0.2),
    "lag, 6 thrusters": lambda: _vehicle("bluerov2").with_params(thruster_lag=True),
    "wrench input": lambda: _vehicle("rexrov").with_params(wrench_input=True),
    "wrench input, bluerov2": lambda: _vehicle("bluerov2").with_params(wrench_input=True),
    "body current": lambda: _vehicle("bluerov2_heavy").with_params(current=CURRENT),
    "NED current": lambda: _vehicle("rexrov").with_params(current=CURRENT, current_frame="ned"),
    "cable": lambda: _vehicle("rexrov").with_params(cable_force=(5, 0, -3, 0, 1.5, 0)),
    "inflow K2": lambda: _vehicle("bluerov2_heavy").with_params(K2=2e-6),
    "inflow K2 and lag": lambda: _vehicle("rexrov").with_params(K2=1e-3, thruster_lag=True),
}


def _states(v: Vehicle, n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """|theta| < 1 rad, velocities within +-0.6, rpm (inputs and lag states) within
    +-1.3 n_max: a third of the inputs beyond the saturation's corners."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(-0.6, 0.6, size=(n, v.nx))
    x[:, 3:6] = rng.uniform(-1.0, 1.0, size=(n, 3))
    x[:, 12:] = rng.uniform(-1.3, 1.3, size=(n, v.nx - 12)) * v.n_max
    scale = 200.0 if v.wrench_input else 1.3 * v.n_max
    return x, rng.uniform(-1.0, 1.0, size=(n, v.nu)) * scale


def _oracle(v: Vehicle, x: np.ndarray, u: np.ndarray):
    p = v.kernel()[1]
    n = x.shape[0]
    f, jx, ju = np.empty((n, v.nx)), np.empty((n, v.nx, v.nx)), np.empty((n, v.nx, v.nu))
    for i in range(n):
        vehicle_rhs(0.0, x[i], u[i], p, f[i])
        vehicle_jac(0.0, x[i], u[i], p, jx[i])
        vehicle_input_jac(0.0, x[i], u[i], p, ju[i])
    return f, jx, ju


def _largest_terms(v: Vehicle, x: np.ndarray, out: np.ndarray) -> np.ndarray:
    """The largest |term| summed into each row of ``out`` (f, shape (N, nx), or a
    Jacobian, shape (N, nx, m)), an upper bound where the exact term is not in reach:

    * v rows: out_v = M^-1 q, so the terms are M^-1[k, j] q_j with q = M out_v;
    * eta rows: products of sines and cosines (at most 1, over cos(theta) at most
      twice) with v + v_c or 1: at most max(1, |v + v_c|) / cos(theta)^2 (plus |v_c|);
    * lag rows: one product, the entry itself.
    """
    vec = out.ndim == 2
    o = out[..., None] if vec else out
    terms = np.abs(o).copy()
    q = np.einsum("kj,njc->nkc", v.mass_matrix, o[:, 6:12])
    terms[:, 6:12] = np.max(np.abs(v.minv)[None, :, :, None] * np.abs(q)[:, None], axis=2)
    w = np.abs(x[:, 6:12] + np.asarray(v.current)).max(axis=1)
    kin = np.maximum(1.0, w) / np.cos(x[:, 4]) ** 2 + np.abs(v.current).max()
    terms[:, :6] = np.maximum(terms[:, :6], kin[:, None, None])
    return terms[..., 0] if vec else terms


def _assert_within_ulps(got: np.ndarray, want: np.ndarray, terms: np.ndarray) -> None:
    bound = ULPS * np.spacing(terms)
    excess = np.abs(got - want) - bound
    worst = np.unravel_index(np.argmax(excess), excess.shape)
    assert excess[worst] <= 0.0, (
        f"entry {worst}: {got[worst]!r} vs today's {want[worst]!r}, more than {ULPS} ulp of "
        f"its largest term {terms[worst]:.3g}"
    )


@pytest.mark.parametrize("variant", list(VARIANTS))
def test_f_and_jacobians_equal_todays_kernel(variant: str) -> None:
    v = VARIANTS[variant]()
    x, u = _states(v, 300, seed=len(variant))
    t = np.zeros(len(x))
    f_old, jx_old, ju_old = _oracle(v, x, u)
    f, jx, ju = v.f(t, x, u), v.jacobian(t, x, u), v.input_jacobian(t, x, u)
    _assert_within_ulps(f, f_old, _largest_terms(v, x, f_old))
    _assert_within_ulps(jx, jx_old, _largest_terms(v, x, jx_old))
    _assert_within_ulps(ju, ju_old, _largest_terms(v, x, ju_old))
    # the switching values are copies and one subtraction each: exactly today's
    sw, sp, input_only = v.switch_kernel()
    got, want = np.empty(input_only.size), np.empty(input_only.size)
    for i in range(0, len(x), 37):
        sw(0.0, x[i], u[i], sp, got)
        vehicle_switch(0.0, x[i], u[i], sp, want)
        np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("variant", ["rexrov", "thruster lag", "wrench input", "full matrices"])
def test_one_state_and_batch_paths_give_the_same_bits(variant: str) -> None:
    """The scalar kernel (what the integrator calls) and the batch evaluators (model.f,
    jacobian) run the same arithmetic: same run, same machine, bit for bit."""
    v = VARIANTS[variant]()
    x, u = _states(v, 50, seed=3)
    t = np.zeros(len(x))
    rhs, p = v.kernel()
    jac, _ = v.jacobian_kernel()
    jac_u, _ = v.input_jacobian_kernel()
    f, jx, ju = v.f(t, x, u), v.jacobian(t, x, u), v.input_jacobian(t, x, u)
    out, jout, uout = np.empty(v.nx), np.empty((v.nx, v.nx)), np.empty((v.nx, v.nu))
    for i in range(len(x)):
        rhs(0.0, x[i], u[i], p, out)
        jac(0.0, x[i], u[i], p, jout)
        jac_u(0.0, x[i], u[i], p, uout)
        np.testing.assert_array_equal(out, f[i])
        np.testing.assert_array_equal(jout, jx[i])
        np.testing.assert_array_equal(uout, ju[i])
        np.testing.assert_array_equal(v.f(0.0, x[i], u[i]), f[i])


@pytest.mark.parametrize("variant", list(VARIANTS))
def test_structural_zeros_are_never_read(variant: str) -> None:
    """Every zero of p (a zero of M, M^-1, D_l, d_q, B, no current, no cable, the option
    flags) replaced by NaN changes nothing: the generated code does not read it."""
    v = VARIANTS[variant]()
    p = v.kernel()[1]
    poisoned = np.where(p == 0.0, np.nan, p)
    assert np.isnan(poisoned).sum() >= 6
    x, u = _states(v, 20, seed=7)
    sw, _, flags = v.switch_kernel()
    for kernel, shape in (
        (v.kernel()[0], (v.nx,)),
        (v.jacobian_kernel()[0], (v.nx, v.nx)),
        (v.input_jacobian_kernel()[0], (v.nx, v.nu)),
        (sw, (flags.size,)),
    ):
        clean, dirty = np.empty(shape), np.empty(shape)
        for i in range(len(x)):
            kernel(0.0, x[i], u[i], p, clean)
            kernel(0.0, x[i], u[i], poisoned, dirty)
            np.testing.assert_array_equal(dirty, clean)


@pytest.mark.parametrize("name", ["bluerov2 (6 thrusters)", "bluerov2_heavy"])
def test_the_sparse_blocks_of_a_light_vehicle_are_written_term_by_term(name: str) -> None:
    """A BlueROV2's M has zeros (the Heavy's is diagonal; the 6-thruster frame's couples
    surge with pitch and sway with roll through r_G): its f reads exactly the nonzero
    entries of M and M^-1, not 36 of each (a vehicle without a zero in M, the RexROV,
    has the loop of six LLVM unrolls)."""
    blue = VARIANTS[name]()
    p = np.asarray(blue.kernel()[1])
    rhs = blue._kernels.source.split("\ndef rhs(", 1)[1].split("\n@njit", 1)[0]
    reads = {int(k) for k in re.findall(r"p\[(\d+)\]", rhs)}
    for start in (_M, _MINV):
        nonzero = {start + k for k in np.flatnonzero(p[start : start + 36])}
        assert 6 <= len(nonzero) < 36
        assert reads & set(range(start, start + 36)) == nonzero
    assert "for j in range(6)" not in rhs
    rex_rhs = VARIANTS["rexrov"]()._kernels.source.split("\ndef rhs(", 1)[1]
    assert "for j in range(6)" in rex_rhs.split("\n@njit", 1)[0]


def test_new_values_share_the_compiled_kernels_a_new_pattern_does_not() -> None:
    rex = VARIANTS["rexrov"]()
    tuned = rex.with_params(X_u=80.0, Z_ww=1500.0, mass=1900.0)  # same zeros
    assert tuned._kernels is rex._kernels
    assert tuned.kernel()[0] is rex.kernel()[0]
    coupled = rex.with_params(linear_damping=np.full((6, 6), 3.0))  # D_l now full
    assert coupled._kernels is not rex._kernels
    for v in (tuned, coupled):
        x, u = _states(v, 40, seed=5)
        f_old = _oracle(v, x, u)[0]
        _assert_within_ulps(v.f(np.zeros(40), x, u), f_old, _largest_terms(v, x, f_old))


def test_a_pickled_vehicle_keeps_its_kernels() -> None:
    v = VARIANTS["thruster lag"]()
    back = pickle.loads(pickle.dumps(v))
    assert back._kernels is v._kernels  # the same pattern, in this process
    x, u = _states(v, 5, seed=1)
    np.testing.assert_array_equal(back.f(np.zeros(5), x, u), v.f(np.zeros(5), x, u))


_PROCESS = textwrap.dedent(
    """
    import json, warnings
    import numpy as np
    import sampledyn as sd
    warnings.simplefilter("ignore")
    v = sd.models.load_vehicle("bluerov2").with_params(cable_force=(1, 0, 0, 0, 0, 0.5))
    v.f(np.zeros(3), np.zeros((3, 12)), np.zeros((3, 6)))
    kernels = (v.kernel()[0], v._kernels.get("batch_rhs"))
    hits = sum(sum(k.stats.cache_hits.values()) for k in kernels)
    misses = sum(sum(k.stats.cache_misses.values()) for k in kernels)
    print(json.dumps({"file": v._kernels.module.__file__, "hits": hits, "misses": misses}))
    """
)


@pytest.mark.slow
def test_a_second_process_loads_the_kernels_from_the_disk_cache(tmp_path: Path) -> None:
    env = dict(os.environ, SAMPLEDYN_CACHE_DIR=str(tmp_path / "kernels"))
    env.pop("NUMBA_CACHE_DIR", None)
    runs = []
    for _ in range(2):
        done = subprocess.run([sys.executable, "-c", _PROCESS], env=env, capture_output=True,
                              text=True, check=True)  # fmt: skip
        runs.append(json.loads(done.stdout.strip().splitlines()[-1]))
    first, second = runs
    assert Path(first["file"]).parent.parent == tmp_path / "kernels"
    assert Path(first["file"]).name.startswith("vehicle_")
    assert first["file"] == second["file"]  # the hash of the same source
    assert first["misses"] == 2 and first["hits"] == 0  # compiled
    assert second["hits"] == 2 and second["misses"] == 0  # loaded, not compiled

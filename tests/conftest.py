"""Shared test helpers: small models with closed-form solutions; the example log; the
check that the suite writes nothing into the repository."""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import settings
from hypothesis.configuration import set_hypothesis_home_dir
from scipy.linalg import expm

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE_LOG = ROOT / "examples" / "rov_log.csv"

# Hypothesis keeps its files (by default in .hypothesis/ of the working directory) in a
# temporary folder removed at the end, and no example database: a test run writes only
# below temporary folders.
_HYPOTHESIS_HOME = tempfile.mkdtemp(prefix="sampledyn-hypothesis-")
set_hypothesis_home_dir(_HYPOTHESIS_HOME)
settings.register_profile("sampledyn", database=None)
settings.load_profile("sampledyn")


def pytest_unconfigure(config):
    shutil.rmtree(_HYPOTHESIS_HOME, ignore_errors=True)


def _exempt(rel: Path) -> bool:
    """Files a test run may leave in the repository: Python's bytecode of the modules it
    imports, and the kernels the library caches next to its own modules (where an
    installed package keeps them; README, "the first run compiles the numba kernels")."""
    if rel.parent.name != "__pycache__":
        return False
    return rel.suffix == ".pyc" or (rel.parts[0] == "sampledyn" and rel.suffix in (".nbi", ".nbc"))


def _repository_files() -> dict[str, tuple[int, int]]:
    """Size and mtime (ns) of every file of the checkout but .git, virtualenvs inside it,
    pytest's own cache and the exempt files."""
    found: dict[str, tuple[int, int]] = {}
    for folder, dirs, files in os.walk(ROOT):
        here = Path(folder)
        dirs[:] = [
            d
            for d in dirs
            if d not in (".git", ".pytest_cache") and not (here / d / "pyvenv.cfg").exists()
        ]
        for name in files:
            rel = (here / name).relative_to(ROOT)
            if not _exempt(rel):
                st = (here / name).lstat()
                found[rel.as_posix()] = (st.st_size, st.st_mtime_ns)
    return found


@pytest.fixture(scope="session", autouse=True)
def _repository_untouched():
    """Fails the run (an error at the teardown of its last test) if any test wrote,
    changed or removed a file of the checkout: tests write below their tmp_path."""
    before = _repository_files()
    yield
    after = _repository_files()
    changed = sorted(p for p in before.keys() | after.keys() if before.get(p) != after.get(p))
    assert not changed, (
        "the test run wrote into the repository (tests must write below tmp_path): "
        + ", ".join(changed[:20])
        + (f" and {len(changed) - 20} more" if len(changed) > 20 else "")
    )


class LinearModel:
    """x' = A x (nu = 1, input unused): closed-form flow expm(A t)."""

    nx = 2
    nu = 1
    state_names = ("x1", "x2")
    state_units = ("m", "m/s")
    input_names = ("u1",)
    input_units = ("",)

    def __init__(self, a: np.ndarray) -> None:
        self.a = np.asarray(a, dtype=float)

    def f(self, t, x, u):
        return np.asarray(x) @ self.a.T

    def jacobian(self, t, x, u):
        x = np.asarray(x)
        return np.broadcast_to(self.a, (x.shape[0], 2, 2)).copy()

    def flow(self, t: np.ndarray, x0: np.ndarray) -> np.ndarray:
        return np.stack([expm(self.a * ti) @ x0 for ti in t])


@pytest.fixture
def damped_oscillator() -> LinearModel:
    return LinearModel(np.array([[0.0, 1.0], [-4.0, -0.4]]))


@pytest.fixture(scope="session")
def vehicle():
    """The BlueROV2 Heavy vehicle model."""
    import sampledyn as sd

    return sd.models.load_vehicle("bluerov2_heavy")


@pytest.fixture(scope="session")
def frame():
    """The example log (examples/rov_log.csv) as a DataFrame (do not modify)."""
    import pandas as pd

    return pd.read_csv(EXAMPLE_LOG)


@pytest.fixture(scope="session")
def rexrov_data():
    """(vehicle, signal, noisy run): the Fig. 7 RexROV (+1 % buoyancy) under the Fig. 6
    input, 60 s at h = 0.1 s, noise (2 %, 10 %) seed 4 (do not modify)."""
    import warnings

    import sampledyn as sd
    from sampledyn.experiments._rov import fig7_vehicle

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the file's added-mass symmetry note
        veh = fig7_vehicle(sd.models.load_vehicle("rexrov"), 1.0)
    sig = sd.signals.fig6_thrusters(veh)
    exact = sd.simulate(veh, sig, T=60.0, h=0.1, certify=False)
    return veh, sig, sd.add_noise(exact, 2, 10, seed=4)

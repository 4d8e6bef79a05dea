"""The kernel cache is private: nobody else's code runs from it (issue 24, item 1).

Generated kernels are Python files named by the hash of their source, with numba's
pickled index (``.nbi``) and data (``.nbc``) beside them. These tests plant what
another local user could plant (open folders, foreign owners, symbolic links, an
edited source, a damaged or foreign index) and check that it is refused, or rebuilt
with a warning, and never run.
"""

from __future__ import annotations

import os
import stat
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from _faults import error_lines

from sampledyn.exceptions import UnsafeCacheError
from sampledyn.models import _kernel_cache as kc

REPO = Path(__file__).resolve().parents[2]
CLI = [sys.executable, "-m", "sampledyn.cli"]
ROOT = hasattr(os, "geteuid") and os.geteuid() == 0
OTHER_UID = 65534  # "nobody"
posix = pytest.mark.skipif(not hasattr(os, "getuid"), reason="ownership checks need user ids")
needs_root = pytest.mark.skipif(not ROOT, reason="giving a folder to another user needs root")


def _mode(path: Path) -> int:
    return stat.S_IMODE(os.lstat(path).st_mode)


@posix
def test_folders_are_created_0700_and_files_0600_whatever_the_umask(tmp_path):
    old = os.umask(0)
    try:
        kernels = kc.kernel_dir([tmp_path / "a" / "b"], None)
        kc.ensure_source(kernels / "symbolic_x.py", "X = 1\n")
    finally:
        os.umask(old)
    assert kernels == tmp_path / "a" / "b" / "kernels"
    for folder in (tmp_path / "a", tmp_path / "a" / "b", kernels, kernels / "__pycache__"):
        assert _mode(folder) == 0o700, folder
    assert _mode(kernels / "symbolic_x.py") == 0o600


@posix
@pytest.mark.parametrize("mode, who", [(0o777, "others"), (0o770, "its group")])
def test_a_folder_others_may_write_is_refused_naming_the_reason_and_the_variable(
    tmp_path, mode, who
):
    root = tmp_path / "sampledyn-victim"
    (root / "kernels").mkdir(parents=True)
    os.chmod(root / "kernels", mode)
    with pytest.raises(UnsafeCacheError) as info:
        kc.kernel_dir([root], None)
    text = str(info.value)
    assert f"may be written by {who} (mode {mode:04o})" in text
    assert "SAMPLEDYN_CACHE_DIR" in text and str(root / "kernels") in text
    assert not (root / "kernels" / "__pycache__").exists() or _mode(root / "kernels") == mode


@posix
def test_an_open_fallback_is_refused_not_skipped(tmp_path):
    """HOME unwritable (a service account): the predictable temp folder that another
    user pre-created mode 777 is refused, and nothing is written into it."""
    blocked = tmp_path / "file"
    blocked.write_text("")
    planted = tmp_path / "sampledyn-victim"
    planted.mkdir()
    os.chmod(planted, 0o777)
    with pytest.raises(UnsafeCacheError, match="may be written by others"):
        kc.kernel_dir([blocked / "home-cache", planted], None)
    assert list(planted.iterdir()) == [] or not any(planted.rglob("*.py"))


@needs_root
def test_a_folder_of_another_user_is_refused(tmp_path):
    root = tmp_path / "sampledyn-victim"
    (root / "kernels").mkdir(parents=True, mode=0o700)
    os.chown(root, OTHER_UID, -1)
    with pytest.raises(UnsafeCacheError, match=f"owned by uid {OTHER_UID}"):
        kc.kernel_dir([root], None)


@needs_root
def test_a_symlink_to_another_users_folder_is_refused_one_to_ones_own_accepted(tmp_path):
    theirs = tmp_path / "theirs"
    theirs.mkdir(mode=0o700)
    os.chown(theirs, OTHER_UID, -1)
    link = tmp_path / "cache"
    link.symlink_to(theirs)
    with pytest.raises(UnsafeCacheError, match="its target .* owned by uid 65534"):
        kc.kernel_dir([link], None)
    mine = tmp_path / "mine"
    mine.mkdir(mode=0o700)
    own_link = tmp_path / "own"
    own_link.symlink_to(mine)
    assert kc.kernel_dir([own_link], None) == own_link / "kernels"


@posix
def test_an_edited_or_empty_source_is_rewritten_with_a_warning(tmp_path):
    kernels = kc.kernel_dir([tmp_path], None)
    path = kernels / "symbolic_abc.py"
    kc.ensure_source(path, "X = 1\n")
    index = kernels / "__pycache__" / "symbolic_abc.rhs-3.py311.nbi"
    index.write_bytes(b"planted pickle")
    os.chmod(index, 0o600)
    for planted in ("X = 1\nimport os; os.system('touch pwned')\n", ""):
        path.write_text(planted)
        with pytest.warns(UserWarning) as caught:
            kc.ensure_source(path, "X = 1\n")
        said = " ".join(str(w.message) for w in caught)
        assert "differs from the source its name hashes" in said
        assert path.read_text() == "X = 1\n" and _mode(path) == 0o600
        assert not index.exists()  # an index compiled from who knows what: gone


@posix
def test_numba_files_others_could_write_are_removed_before_numba_reads_them(tmp_path):
    kernels = kc.kernel_dir([tmp_path], None)
    path = kernels / "symbolic_abc.py"
    kc.ensure_source(path, "X = 1\n")
    index = kernels / "__pycache__" / "symbolic_abc.rhs-3.py311.nbi"
    index.write_bytes(b"x")
    os.chmod(index, 0o666)
    other = kernels / "__pycache__" / "symbolic_other.rhs-3.py311.nbi"
    other.write_bytes(b"y")
    os.chmod(other, 0o600)
    with pytest.warns(UserWarning, match="may be written by others"):
        kc.ensure_source(path, "X = 1\n")
    assert not index.exists() and other.exists()  # only that module's files


@posix
def test_a_source_read_by_name_must_hash_to_its_name(tmp_path):
    kernels = kc.kernel_dir([tmp_path], None)
    path = kernels / "symbolic_abc.py"
    kc.ensure_source(path, "X = 1\n")
    assert kc.verified_source(path, lambda text: "symbolic_abc") == "X = 1\n"
    with pytest.raises(ValueError, match="does not hash to its name.*it was not run"):
        kc.verified_source(path, lambda text: "symbolic_def")


_SCRIPT = textwrap.dedent(
    """
    import warnings
    warnings.simplefilter("always")
    import numpy as np, sympy as sp
    import sampledyn as sd
    x, v, u = sp.symbols("x v u")
    m = sd.models.SymbolicModel([x, v], [u], [v, -0.25 * v * sp.Abs(v) + sp.sin(x) + u])
    print(m.f(np.zeros(1), np.ones((1, 2)), np.ones((1, 1)))[0].tolist())
    print(m.source_file)
    """
)


def _run(env: dict[str, str], cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-c", _SCRIPT], env=env, cwd=cwd, capture_output=True, text=True
    )


@pytest.mark.slow
@posix
def test_a_planted_source_and_a_damaged_index_do_not_break_or_run(tmp_path):
    env = dict(os.environ, SAMPLEDYN_CACHE_DIR=str(tmp_path / "cache"), PYTHONPATH=str(REPO))
    env.pop("NUMBA_CACHE_DIR", None)
    first = _run(env, tmp_path)
    assert first.returncode == 0, first.stderr
    value, source_file = first.stdout.strip().splitlines()
    source = Path(source_file)
    indexes = sorted((source.parent / "__pycache__").glob(source.stem + ".*.nbi"))
    assert indexes and all(_mode(f) == 0o600 for f in indexes)
    # A damaged index (truncated pickle): rebuilt with a warning, not "internal error".
    indexes[0].write_bytes(indexes[0].read_bytes()[:7])
    second = _run(env, tmp_path)
    assert second.returncode == 0, second.stderr
    assert second.stdout.strip().splitlines()[0] == value
    assert "could not be loaded" in second.stderr
    # A source edited in place: not run (the marker is not created), rewritten.
    marker = tmp_path / "pwned"
    source.write_text(source.read_text() + f"\nopen({str(marker)!r}, 'w').close()\n")
    third = _run(env, tmp_path)
    assert third.returncode == 0, third.stderr
    assert not marker.exists()
    assert "differs from the source its name hashes" in third.stderr
    assert third.stdout.strip().splitlines()[0] == value


@pytest.mark.slow
@posix
def test_the_cli_refuses_an_open_cache_in_one_line_exit_4(tmp_path):
    planted = tmp_path / "cache"
    (planted / "kernels").mkdir(parents=True)
    os.chmod(planted / "kernels", 0o777)
    env = dict(os.environ, SAMPLEDYN_CACHE_DIR=str(planted), PYTHONPATH=str(REPO))
    grid = tmp_path / "grid.toml"
    grid.write_text(
        'vehicle = "auv_like"\ninput = { name = "multilevel", hold = 0.1, seed = 3 }\n'
        'x0 = [1.0, 0.0]\nT = 1.0\nafter = 0.0\nh = [0.1]\nmethods = ["E"]\nnorm = "rms"\n'
    )
    done = subprocess.run(
        [*CLI, "sweep", str(grid), "--store", str(tmp_path / "s.db"), "--no-progress"],
        env=env,
        capture_output=True,
        text=True,
    )
    assert done.returncode == 4, done.stderr
    lines = error_lines(done.stderr)
    assert len(lines) == 1 and "Traceback" not in done.stderr
    assert "may be written by others" in lines[0] and "SAMPLEDYN_CACHE_DIR" in lines[0]

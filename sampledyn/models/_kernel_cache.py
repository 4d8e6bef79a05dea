"""A private folder for generated kernels: nobody else's code runs from it.

Generated kernels (:mod:`._codegen`) are Python files under names that are hashes of
their source, imported from a cache folder, with numba's compiled code and its index
(``__pycache__/*.nbi``, pickles loaded on the next run) beside them. Whoever can
write in that folder can run code as the user of the next ``sampledyn`` command, so:

* the folders are created mode 0700 and the files 0600, explicitly (not by umask);
* a folder (or a symbolic link to one) that is not owned by the user, or that group
  or others may write, is refused with the reason and the variable to set
  (:data:`CACHE_ENV`), never used;
* a source file is compared with the source its name hashes before it is imported,
  and rewritten (with a warning) if it differs: edited, damaged or empty; it is
  executed from the checked text, never from a ``.pyc``;
* numba's files of a module (index and data) that are not regular files of the
  user, private to the user, are removed with a warning before numba reads them,
  and so are those of a rewritten source; numba files that cannot be loaded
  (damaged, truncated) are removed and the kernel compiled again, with a warning.

On systems without user ids (Windows) the ownership checks are skipped; the folder
is then the user's profile folder or ``$SAMPLEDYN_CACHE_DIR``.
"""

from __future__ import annotations

import errno
import os
import stat
import threading
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from ..exceptions import UnsafeCacheError

__all__ = [
    "CACHE_ENV",
    "compile_or_rebuild",
    "ensure_source",
    "kernel_dir",
    "verified_source",
]

CACHE_ENV = "SAMPLEDYN_CACHE_DIR"
_NUMBA_ENV = "NUMBA_CACHE_DIR"
_POSIX = hasattr(os, "getuid")


def _fix(path: Path) -> str:
    return (
        f"delete {path} if it is yours (a cache: it is rebuilt), or set ${CACHE_ENV} "
        "to a folder of your own (created private, mode 0700)"
    )


def _owner(uid: int) -> str:
    try:
        import pwd

        return f"uid {uid} ({pwd.getpwuid(uid).pw_name})"
    except (ImportError, KeyError):
        return f"uid {uid}"


def _unsafe_reason(st: os.stat_result, what: str) -> str | None:
    """Why a file or folder with status ``st`` is not private to this user, or None."""
    if not _POSIX:
        return None
    me = os.getuid()
    if st.st_uid != me:
        return f"{what} is owned by {_owner(st.st_uid)}, not by you ({_owner(me)})"
    if st.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
        return (
            f"{what} may be written by {'others' if st.st_mode & stat.S_IWOTH else 'its group'} "
            f"(mode {stat.S_IMODE(st.st_mode):04o})"
        )
    return None


def check_private_dir(path: Path) -> None:
    """Refuse ``path`` unless it is a folder of this user that only the user writes
    (a symbolic link: the link and its target both).

    Raises
    ------
    UnsafeCacheError
        naming the reason and the variable to set.
    NotADirectoryError
        if ``path`` is not a folder.
    """
    st = os.lstat(path)
    reasons = []
    if stat.S_ISLNK(st.st_mode):
        link = _unsafe_reason(st, "the symbolic link")
        if link and os.getuid() != st.st_uid:  # a link's own mode is always 0777
            reasons.append(link)
        st = os.stat(path)
        what = f"its target {os.path.realpath(path)}"
    else:
        what = "the folder"
    if not stat.S_ISDIR(st.st_mode):
        raise NotADirectoryError(errno.ENOTDIR, "the kernel cache must be a folder", str(path))
    target = _unsafe_reason(st, what)
    if target:
        reasons.append(target)
    if reasons:
        raise UnsafeCacheError(
            errno.EPERM,
            f"refused as the cache of generated kernels: {'; '.join(reasons)}, so another "
            f"user could put code there that would run as you; {_fix(path)}",
            str(path),
        )


def _private_mkdir(path: Path) -> None:
    """Create ``path`` and its missing parents, mode 0700 whatever the umask."""
    missing = []
    p = path
    while not os.path.lexists(p) and p != p.parent:
        missing.append(p)
        p = p.parent
    for d in reversed(missing):
        try:
            os.mkdir(d, 0o700)
        except FileExistsError:
            continue  # another process created it meanwhile: checked below
        os.chmod(d, 0o700)


def _writable(path: Path) -> bool:
    probe = path / f".probe-{os.getpid()}-{threading.get_ident()}"
    try:
        fd = os.open(probe, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o600)
        os.close(fd)
        os.unlink(probe)
    except OSError:
        return False
    return True


def _prepare(root: Path) -> Path | None:
    """``root/kernels`` (and its ``__pycache__``) created private and checked; None
    if ``root`` cannot be written. Unsafe folders raise :class:`UnsafeCacheError`."""
    kernels = root / "kernels"
    try:
        _private_mkdir(kernels / "__pycache__")
    except OSError:
        if not os.path.isdir(kernels):
            return None
    for folder in (root, kernels, kernels / "__pycache__"):
        if os.path.lexists(folder):
            check_private_dir(folder)
    numba_dir = os.environ.get(_NUMBA_ENV)
    if numba_dir and os.path.lexists(numba_dir):
        try:
            check_private_dir(Path(numba_dir))
        except UnsafeCacheError as exc:
            exc.strerror = (exc.strerror or "").replace(CACHE_ENV, _NUMBA_ENV)
            raise
    return kernels if _writable(kernels) else None


def kernel_dir(roots: Sequence[Path], env: str | None) -> Path:
    """The first of ``roots`` (in order) whose ``kernels`` folder can be made private
    and written: ``<root>/kernels``.

    Parameters
    ----------
    roots : sequence of Path
        Candidate roots; ``roots[0]`` is ``$SAMPLEDYN_CACHE_DIR`` when ``env`` is set.
    env : str or None
        The value of ``$SAMPLEDYN_CACHE_DIR`` (a root that cannot be written is then
        reported with a warning, and the next one used).

    Raises
    ------
    UnsafeCacheError
        for a root, ``kernels`` or ``__pycache__`` folder (or ``$NUMBA_CACHE_DIR``)
        not owned by the user or writable by group or others: never skipped, since
        the next root would hide the attempt.
    OSError
        if no root can be written.
    """
    for root in roots:
        kernels = _prepare(root)
        if kernels is None:
            continue
        if env and root != Path(env):
            warnings.warn(
                f"${CACHE_ENV}={env!r} is not writable; generated kernels go to {root} "
                f"instead. Point ${CACHE_ENV} at a writable directory.",
                stacklevel=4,
            )
        return kernels
    raise OSError(
        errno.EACCES,
        f"no writable directory for generated kernels among {[str(r) for r in roots]}; "
        f"set ${CACHE_ENV} to a writable directory",
    )


def _numba_files(path: Path) -> list[Path]:
    """numba's cache files (index ``.nbi``, data ``.nbc``) of the module ``path``."""
    folders = [path.parent / "__pycache__"]
    numba_dir = os.environ.get(_NUMBA_ENV)
    if numba_dir:
        folders.append(Path(numba_dir))
    out: list[Path] = []
    for folder in folders:
        try:
            names = os.listdir(folder)
        except OSError:
            continue
        out += [folder / n for n in names if n.startswith(path.stem + ".")]
    return out


def _remove(files: Sequence[Path]) -> None:
    for f in files:
        try:
            os.unlink(f)
        except FileNotFoundError:
            pass


def _not_private_file(path: Path) -> str | None:
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        return None
    if not stat.S_ISREG(st.st_mode):
        return "is not a regular file"
    return _unsafe_reason(st, "it")


def _drop_numba_files(path: Path, why: str) -> None:
    files = [f for f in _numba_files(path) if not f.name.endswith(".tmp")]
    if files:
        _remove(files)
        warnings.warn(
            f"removed numba's cache of {path.name} ({len(files)} files: {why}); the kernel "
            "is compiled again",
            stacklevel=5,
        )


def _write_private(path: Path, source: str, *, replace: bool) -> None:
    """Write ``source`` to ``path`` (mode 0600), atomically; without ``replace``,
    keep a file another process wrote meanwhile (numba keys its cache by the
    source's time stamp, so an identical file is never rewritten)."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.{threading.get_ident()}.tmp")
    fd = os.open(tmp, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o600)
    try:
        if hasattr(os, "fchmod"):
            os.fchmod(fd, 0o600)
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(source)
        if replace:
            os.replace(tmp, path)
            return
        try:
            os.link(tmp, path)  # fails if another process created it meanwhile
        except FileExistsError:
            pass
        except OSError:  # no hard links on this file system
            if not path.exists():
                os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def ensure_source(path: Path, source: str) -> None:
    """Make ``path`` hold exactly ``source``, private to the user, before it runs.

    A missing file is written (0600). An existing one that is not a regular file of
    the user, private to the user, or whose text differs from ``source`` (edited,
    damaged, empty: its name is the hash of ``source``), is rewritten with a warning,
    and numba's cache files of the module are removed (their index is a pickle,
    loaded before numba compares time stamps). numba's files that others could have
    written are removed too (with a warning).
    """
    problem = _not_private_file(path)
    if problem is None and path.exists():
        try:
            same = path.read_bytes() == source.encode("utf-8")
        except OSError:
            same = False
        problem = None if same else "its text differs from the source its name hashes"
    if problem is not None:
        warnings.warn(
            f"the cached kernel {path} {problem} (edited, damaged or planted); rewritten "
            "from the generated source",
            stacklevel=4,
        )
        if os.path.isdir(path) and not os.path.islink(path):
            raise UnsafeCacheError(
                errno.EISDIR, f"a folder stands where a cached kernel goes; {_fix(path)}", str(path)
            )
        _write_private(path, source, replace=True)
        _drop_numba_files(path, "its source was rewritten")
    elif not path.exists():
        _write_private(path, source, replace=False)
    bad = [f for f in _numba_files(path) if _not_private_file(f)]
    if bad:
        _drop_numba_files(path, f"{bad[0].name} {_not_private_file(bad[0])}")


def verified_source(path: Path, stem_of: Callable[[str], str]) -> str:
    """The text of the cached module ``path``, checked against the hash in its name
    (``stem_of(text)`` must give ``path.stem``).

    Raises
    ------
    ValueError
        if the file's text does not hash to its name (it was edited or damaged; the
        module that generates it rewrites it on its next use).
    """
    problem = _not_private_file(path)
    text = path.read_text(encoding="utf-8", errors="replace") if problem is None else ""
    if problem is None and stem_of(text) != path.stem:
        problem = "its text does not hash to its name"
    if problem is not None:
        raise ValueError(
            f"the cached kernel {path} {problem} (edited, damaged or planted); it was not "
            f"run. Delete it (the cache is rebuilt) or set ${CACHE_ENV} to a new folder."
        )
    return text


def _seal(path: Path) -> None:
    """numba's new files of module ``path``: mode 0600 (numba writes them by umask)."""
    for f in _numba_files(path):
        try:
            st = os.lstat(f)
            if stat.S_ISREG(st.st_mode) and stat.S_IMODE(st.st_mode) & 0o077:
                os.chmod(f, 0o600)
        except OSError:
            pass


def compile_or_rebuild(dispatcher: Any, signatures: Any, module: Any) -> None:
    """``dispatcher.compile(signatures)``; if numba's cache files of ``module`` (a
    generated module, cached on disk if it has a ``__file__``) cannot be loaded
    (damaged, truncated), remove them, warn, and compile again. numba's new files
    are then made private (0600)."""
    path = getattr(module, "__file__", None)
    try:
        dispatcher.compile(signatures)
    except Exception as exc:
        files = _numba_files(Path(path)) if path else []
        if not files:
            raise
        _drop_numba_files(Path(path), f"they could not be loaded: {type(exc).__name__}")  # type: ignore[arg-type]
        dispatcher.compile(signatures)
    if path:
        _seal(Path(path))

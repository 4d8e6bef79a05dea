"""Generated, disk-cached kernel modules.

numba caches a compiled function on disk only when it can find the function's source
file again in the next process; functions made at run time (``lambdify``, closures)
are recompiled in every process. So every kernel sampledyn derives at run time
(symbolic models, closed loops, per-kernel batch evaluators) is written as real Python
source into a cache directory, under a name that is the hash of that source, and
imported from there; its functions are compiled with ``cache=True`` and the project's
explicit signatures, so a second process loads them in milliseconds.

Cache directory (first that is writable; one owned by someone else or writable by
group or others is refused, not skipped):

1. ``$SAMPLEDYN_CACHE_DIR`` if set;
2. the user cache directory: ``$XDG_CACHE_HOME/sampledyn`` (default
   ``~/.cache/sampledyn``) on Linux, ``~/Library/Caches/sampledyn`` on macOS,
   ``%LOCALAPPDATA%\\sampledyn\\Cache`` on Windows;
3. ``<tempdir>/sampledyn-<user>``.

Each generated module lives in ``<dir>/kernels/<stem>.py`` with numba's cache next to
it (``__pycache__``, or ``$NUMBA_CACHE_DIR``). Files are never rewritten (the name is
the content hash), so deleting the directory is always safe. The folders are private
to the user and checked before use, and a file is checked against its name before it
runs (:mod:`._kernel_cache`).

Functions in a generated module are compiled lazily: :func:`compiled` compiles (or
loads from numba's cache) one of them for its declared signature on first use.
"""

from __future__ import annotations

import getpass
import hashlib
import importlib.util
import itertools
import os
import sys
import tempfile
import threading
from collections.abc import Mapping
from pathlib import Path
from types import ModuleType
from typing import Any

from . import _kernel_cache

__all__ = [
    "CACHE_ENV",
    "GENERATED_PACKAGE",
    "batch_functions",
    "cache_dir",
    "compiled",
    "import_generated",
    "import_line",
    "load_module",
    "object_import_line",
    "register_batch",
]

CACHE_ENV = _kernel_cache.CACHE_ENV
# Prefix of the module names of generated modules (not an importable package: they
# are loaded from their files by :func:`load_module`).
GENERATED_PACKAGE = "_sampledyn_generated"
# Bump when the generated code changes meaning: every module then gets a new name.
GENERATOR_VERSION = 1

_LOCK = threading.RLock()
_CACHE_DIR: Path | None = None


def _user_cache_root() -> Path:
    if sys.platform == "win32":
        base = os.environ.get("LOCALAPPDATA") or str(Path.home() / "AppData" / "Local")
        return Path(base) / "sampledyn" / "Cache"
    if sys.platform == "darwin":
        return Path.home() / "Library" / "Caches" / "sampledyn"
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "sampledyn"


def cache_dir() -> Path:
    """The directory of generated kernel modules (created if needed).

    Returns
    -------
    Path
        ``<root>/kernels`` for the first writable root of ``$SAMPLEDYN_CACHE_DIR``, the
        user cache directory and ``<tempdir>/sampledyn-<user>`` (see the module
        docstring). A ``$SAMPLEDYN_CACHE_DIR`` that cannot be written is reported with
        a warning and skipped.

    Raises
    ------
    PermissionError
        (:class:`._kernel_cache.UnsafeCacheError`) for a folder on the way that is not
        the user's own or that group or others may write, naming ``$SAMPLEDYN_CACHE_DIR``.
    OSError
        if no root can be written.
    """
    global _CACHE_DIR
    env = os.environ.get(CACHE_ENV)
    if _CACHE_DIR is not None and (env is None or _CACHE_DIR.parent == Path(env)):
        return _CACHE_DIR
    with _LOCK:
        try:
            user = getpass.getuser()
        except (KeyError, OSError):  # no user name (some containers)
            user = str(os.getuid()) if hasattr(os, "getuid") else "user"
        roots = [_user_cache_root(), Path(tempfile.gettempdir()) / f"sampledyn-{user}"]
        if env:
            roots.insert(0, Path(env))
        _CACHE_DIR = _kernel_cache.kernel_dir(roots, env)  # private, checked (0700)
        return _CACHE_DIR


_MODULES: dict[str, ModuleType] = {}
_IN_PROCESS = itertools.count()
_IN_PROCESS_MODULES: dict[Any, tuple[ModuleType, dict[str, Any]]] = {}


def load_module(source: str, *, kind: str, globals_: Mapping[str, Any] | None = None) -> ModuleType:
    """Import generated ``source`` as a module.

    Parameters
    ----------
    source : str
        Python source. It must define ``CACHE`` from the name ``_SAMPLEDYN_CACHE``
        (``CACHE = _SAMPLEDYN_CACHE``), used as numba's ``cache=`` flag.
    kind : str
        Short label in the file name (``symbolic``, ``closed_loop``, ``batch``).
    globals_ : mapping, optional
        Names to inject before the source runs. Given, the module is executed in this
        process only (nothing is written, ``CACHE`` is False): for kernels that
        cannot be imported by name in another process.

    Returns
    -------
    module
        With ``__file__`` the cached file (or ``None`` with ``globals_``); the same
        module object for the same source within a process.
    """
    stem = _stem_of(source, kind)
    name = f"{GENERATED_PACKAGE}.{stem}"
    with _LOCK:
        if globals_ is None and stem in _MODULES:
            return _MODULES[stem]
        if globals_ is not None:
            # Same source and the same injected objects: the same module (compiled once).
            key = (stem, tuple((k, id(v)) for k, v in sorted(globals_.items())))
            entry = _IN_PROCESS_MODULES.get(key)
            if entry is not None:
                return entry[0]
            module = ModuleType(f"{name}_inprocess_{next(_IN_PROCESS)}")
            module.__dict__.update(globals_)
            module.__dict__["_SAMPLEDYN_CACHE"] = False
            exec(compile(source, f"<sampledyn generated {stem}>", "exec"), module.__dict__)
            _IN_PROCESS_MODULES[key] = (module, dict(globals_))  # keeps the ids valid
            return module
        path = cache_dir() / f"{stem}.py"
        _kernel_cache.ensure_source(path, source)  # the file holds exactly `source`
        spec = importlib.util.spec_from_file_location(name, path)
        if spec is None or spec.loader is None:  # pragma: no cover - defensive
            raise ImportError(f"cannot load the generated module {path}.")
        module = importlib.util.module_from_spec(spec)
        module.__dict__["_SAMPLEDYN_CACHE"] = True
        sys.modules[name] = module
        try:  # the checked text, not a .pyc that could differ from it
            exec(compile(source, str(path), "exec"), module.__dict__)
        except BaseException:
            del sys.modules[name]
            raise
        _MODULES[stem] = module
        return module


def import_generated(stem: str) -> ModuleType:
    """A generated module by its file stem (used by generated modules that call the
    kernels of another one)."""
    with _LOCK:
        if stem in _MODULES:
            return _MODULES[stem]
        path = cache_dir() / f"{stem}.py"
        kind = stem.rsplit("_", 1)[0]
        source = _kernel_cache.verified_source(path, lambda text: _stem_of(text, kind))
    return load_module(source, kind=kind)


def _stem_of(source: str, kind: str) -> str:
    """The file stem of a generated module: its kind and the hash of its source."""
    digest = hashlib.sha256(f"{GENERATOR_VERSION}\n{source}".encode()).hexdigest()[:24]
    return f"{kind}_{digest}"


def _stem(module: ModuleType) -> str:
    return module.__name__.rsplit(".", 1)[1]


def import_line(kernel: Any, alias: str) -> str | None:
    """A source line binding the numba function ``kernel`` to ``alias`` in a generated
    module, or None if the kernel cannot be imported by name in another process
    (defined in ``__main__``, in a closure, or in an in-process generated module).

    The line carries a hash of the kernel's source file, so a generated module that
    inlines the kernel gets a new name (and is recompiled) when that file changes:
    numba's cache does not track the source of called functions.
    """
    py_func = getattr(kernel, "py_func", None)
    if py_func is None:
        return None
    modname = py_func.__module__
    qualname = py_func.__qualname__
    if "<" in qualname or modname == "__main__":
        return None
    module = sys.modules.get(modname)
    if module is None or getattr(module, qualname, None) is not kernel:
        return None
    if modname.startswith(GENERATED_PACKAGE + "."):
        if getattr(module, "__file__", None) is None:
            return None
        return f"{alias} = _codegen.import_generated({_stem(module)!r}).{qualname}"
    return object_import_line(modname, qualname, alias)


def object_import_line(modname: str, name: str, alias: str) -> str | None:
    """``from modname import name as alias`` stamped with the hash of the module's
    source file (None if the module has no file)."""
    module = sys.modules.get(modname)
    filename = getattr(module, "__file__", None)
    if filename is None:
        return None
    stamp = hashlib.sha256(Path(filename).read_bytes()).hexdigest()[:16]
    return f"from {modname} import {name} as {alias}  # source sha256 {stamp}"


_COMPILED: dict[tuple[str, str], Any] = {}


def compiled(module: ModuleType, name: str) -> Any:
    """Function ``name`` of a generated module, compiled (or loaded from numba's disk
    cache) for its signature in the module's ``SIGNATURES`` table."""
    key = (module.__name__, name)
    disp = _COMPILED.get(key)
    if disp is None or disp is not getattr(module, name):
        with _LOCK:
            disp = getattr(module, name)
            if not disp.signatures:
                _kernel_cache.compile_or_rebuild(disp, module.SIGNATURES[name], module)
                disp.disable_compile()
            _COMPILED[key] = disp
    return disp


# Per-kernel batch evaluators, bound to the kernel as a global (a kernel passed as a
# function-pointer argument costs about 35 us of numba dispatch per call; bound as a
# global about 1 us). Registered by the modules that define them; generated on demand
# for hand-written kernels. id(kernel) -> [kernel, module, name, compiled or None].
_BATCH: dict[int, list[Any]] = {}

BATCH_TEMPLATE = """
_{name}_inline = njit(inline="always", error_model="numpy")({kernel}.py_func)


@njit(cache=CACHE, error_model="numpy")
def batch_{name}(t, x, u, p):
    n = x.shape[0]
    out = np.empty((n, {shape}))
    for i in range(n):
        _{name}_inline(t[i], x[i], u[i], p, out[i])
    return out
"""

BATCH_HEADER = """# Generated by sampledyn (sampledyn.models._codegen); do not edit.
import numpy as np
from numba import njit

from sampledyn.models import _codegen
from sampledyn.models._base import BATCH_RHS_SIG, BATCH_JAC_SIG

CACHE = _SAMPLEDYN_CACHE
"""


def register_batch(kernel: Any, module: ModuleType, name: str) -> None:
    """Record that ``module.<name>`` evaluates ``kernel`` over a batch."""
    with _LOCK:
        _BATCH[id(kernel)] = [kernel, module, name, None]


def batch_functions(kernel: Any, kind: str | None) -> Any:
    """The batch evaluator ``batch(t, x, u, p)`` of a compiled kernel, or None.

    Parameters
    ----------
    kernel : numba dispatcher
        A kernel ``kernel(t, x, u, p, out)``.
    kind : {"rhs", "jac", None}
        ``out`` of shape (nx,) or (nx, nx) (nx = ``x.shape[1]``), for generating an
        evaluator of a hand-written kernel; None: only a registered one (generated
        modules register the evaluators of their kernels).

    Returns
    -------
    dispatcher or None
        ``batch(t, x, u, p)`` returning shape (N, nx) or (N, nx, nx); None when the
        kernel cannot be imported by name (the caller then passes the kernel as a
        function pointer).
    """
    entry = _BATCH.get(id(kernel))
    if entry is not None and entry[0] is kernel:
        if entry[3] is None:
            entry[3] = compiled(entry[1], entry[2])
        return entry[3]
    line = None if kind is None else import_line(kernel, "_kernel")
    if line is None:
        return None
    shape = "x.shape[1]" if kind == "rhs" else "x.shape[1], x.shape[1]"
    sig = "BATCH_RHS_SIG" if kind == "rhs" else "BATCH_JAC_SIG"
    source = (
        BATCH_HEADER
        + line
        + "\n"
        + BATCH_TEMPLATE.format(name=kind, kernel="_kernel", shape=shape)
        + f"\nSIGNATURES = {{'batch_{kind}': {sig}}}\n"
    )
    module = load_module(source, kind="batch")
    register_batch(kernel, module, f"batch_{kind}")
    return batch_functions(kernel, kind)

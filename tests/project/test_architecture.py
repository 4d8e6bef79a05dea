"""The package's import graph: layers, no circles, no private module across packages.

Every module of ``sampledyn`` is parsed (not imported) and every ``import`` and
``from ... import`` is collected, at module level and inside functions alike: an
import inside a function is still a dependency, only a later one. Three rules
(docs: the layer table of the design notes):

1. a module imports only from its own layer or lower ones;
2. no circle of imports between modules;
3. private modules (``_name``) are shared inside sampledyn, so that a package's
   ``__init__`` exports what users call and nothing for its neighbours; a private
   *name* (``_helper``) is not imported across packages, and the examples import
   public modules and names only.

Imports of the parent package that Python performs implicitly (importing
``sampledyn.methods._adams`` first runs ``sampledyn/__init__.py``) are not edges;
only what the source names is.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import sampledyn

ROOT = Path(sampledyn.__file__).parent
PACKAGE = "sampledyn"

# Lowest first. A module belongs to the longest prefix that names it. Entries for
# modules that do not exist yet are allowed (they place future code).
LAYERS: dict[str, int] = {
    "sampledyn._trajectory": 0,
    "sampledyn._dop853": 0,
    "sampledyn._sums": 0,
    "sampledyn._version": 0,
    "sampledyn._named": 0,
    "sampledyn._checks": 0,
    "sampledyn.exceptions": 0,
    "sampledyn._files": 0,
    "sampledyn.models": 1,
    "sampledyn.signals": 1,
    "sampledyn.methods": 2,
    "sampledyn._simulate": 3,
    "sampledyn._integrator": 3,
    "sampledyn._noise": 3,
    "sampledyn._local_errors": 3,
    "sampledyn._predict": 3,
    "sampledyn._baselines": 3,
    "sampledyn.sensitivity": 4,
    "sampledyn._estimate": 4,
    "sampledyn._discretize": 5,
    "sampledyn.logs": 5,
    "sampledyn.experiments": 6,
    "sampledyn.report": 7,
    "sampledyn.cli": 8,
    "sampledyn._cli_advise": 8,
    "sampledyn._cli_evaluate": 8,
    "sampledyn._cli_sweep": 8,
    "sampledyn.results": 9,
    "sampledyn": 9,  # sampledyn/__init__.py, the facade
}


def _modules() -> dict[str, Path]:
    out = {}
    for path in sorted(ROOT.rglob("*.py")):
        rel = path.relative_to(ROOT.parent).with_suffix("")
        parts = list(rel.parts)
        if parts[-1] == "__init__":
            parts.pop()
        out[".".join(parts)] = path
    return out


MODULES = _modules()


def _is_package(name: str) -> bool:
    return MODULES[name].name == "__init__.py"


def _resolve(module: str, node: ast.ImportFrom) -> str:
    """Absolute name of the module a ``from`` import names."""
    if node.level == 0:
        return node.module or ""
    base = module.split(".")
    if not _is_package(module):
        base = base[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def _imports(module: str) -> set[str]:
    """Modules of ``sampledyn`` that ``module`` imports, anywhere in its source."""
    tree = ast.parse(MODULES[module].read_text(), filename=str(MODULES[module]))
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            target = _resolve(module, node)
            # ``from pkg import sub`` depends on pkg.sub when that is a module.
            subs = [f"{target}.{a.name}" for a in node.names if f"{target}.{a.name}" in MODULES]
            names = subs if len(subs) == len(node.names) else [target, *subs]
        else:
            continue
        for name in names:
            # ``import sampledyn.a.b`` names the deepest existing module.
            while name and name not in MODULES:
                name = name.rpartition(".")[0]
            if name.startswith(PACKAGE) and name != module:
                found.add(name)
    return found


GRAPH = {m: _imports(m) for m in MODULES}


def layer(module: str) -> int:
    best = max((p for p in LAYERS if module == p or module.startswith(p + ".")), key=len)
    return LAYERS[best]


def test_every_module_has_a_layer():
    missing = [
        m
        for m in MODULES
        if m != PACKAGE and not any(m == p or m.startswith(p + ".") for p in LAYERS if p != PACKAGE)
    ]
    assert not missing, f"place these modules in LAYERS: {missing}"


def test_no_import_from_a_higher_layer():
    bad = [
        f"{m} (layer {layer(m)}) imports {t} (layer {layer(t)})"
        for m, targets in GRAPH.items()
        for t in sorted(targets)
        if layer(t) > layer(m)
    ]
    assert not bad, "\n".join(bad)


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_no_import_circle():
    assert not _cycles(GRAPH), _cycles(GRAPH)


def test_cycle_finder_finds_a_circle():
    # The check above can fail: a three-module circle is reported.
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def _package(module: str) -> str:
    """The first-level package of a module (``sampledyn.experiments.sweep._run`` ->
    ``sampledyn.experiments``; ``sampledyn._simulate`` -> itself)."""
    return ".".join(module.split(".")[:2])


def _private_names(module: str) -> list[tuple[str, str]]:
    """(target module, name) of every ``from X import _name`` in ``module``."""
    tree = ast.parse(MODULES[module].read_text(), filename=str(MODULES[module]))
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            target = _resolve(module, node)
            if target.startswith(PACKAGE):
                names = [a.name for a in node.names if a.name.startswith("_")]
                out += [(target, n) for n in names if f"{target}.{n}" not in MODULES]
    return out


def test_no_private_name_crosses_packages():
    # Private modules are shared inside sampledyn (the public surface is what the
    # packages' __init__ export); a private *name* (``_helper``) stays in its package.
    bad = [
        f"{m} imports {name} of {target}"
        for m in MODULES
        for target, name in _private_names(m)
        if _package(target) != _package(m) and name != "__version__"
    ]
    assert not bad, "\n".join(bad)


# The repository's examples (beside tests/, not beside the installed package: CI
# installs it into site-packages, where this found none and the test was skipped).
EXAMPLES = sorted((Path(__file__).resolve().parents[2] / "examples").glob("*.py"))
assert EXAMPLES, "no examples/*.py found beside tests/"


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.name)
def test_examples_use_the_public_api_only(path):
    # What users are shown imports public modules and names only.
    tree = ast.parse(path.read_text(), filename=str(path))
    bad = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith(PACKAGE):
            names = [node.module, *(f"{node.module}.{a.name}" for a in node.names)]
        elif isinstance(node, ast.Import):
            names = [a.name for a in node.names if a.name.startswith(PACKAGE)]
        else:
            continue
        bad += [n for n in names if any(p.startswith("_") for p in n.split(".")[1:])]
    assert not bad, bad


@pytest.mark.parametrize("module", ["sampledyn.methods", "sampledyn.methods._adams"])
def test_methods_know_nothing_above_them(module):
    # The layer rule made concrete for the registry: methods import no prediction,
    # estimation, experiment or report code, not even inside a function.
    assert all(layer(t) <= 2 for t in GRAPH[module])


def test_graph_sees_imports_inside_functions(tmp_path):
    # The walk reads imports anywhere in the source, not only at module level.
    src = "def f():\n    from .experiments import run\n"
    tree = ast.parse(src)
    assert any(isinstance(n, ast.ImportFrom) for n in ast.walk(tree))
    assert "sampledyn.experiments" in {
        _resolve("sampledyn._noise", n) for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)
    }

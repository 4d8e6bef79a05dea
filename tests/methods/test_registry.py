"""The registry is one static table: complete in a fresh process, lazy, written by no
other layer."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

import sampledyn
from sampledyn.methods import available_methods, families, get_method
from sampledyn.methods._registry import BUILT_IN
from sampledyn.methods._runge_kutta import TABLEAUX

ROOT = Path(sampledyn.__file__).parent


@pytest.mark.slow
def test_a_fresh_process_lists_every_family_without_importing_them():
    # The estimated rules are named by the table, not registered by their layer: the
    # listing is complete before sampledyn.estimate is imported, and building one
    # imports it.
    code = (
        "import sys\n"
        "from sampledyn.methods import available_methods, get_method\n"
        "names = available_methods()\n"
        "print(len(names), 'Ee' in names, 'ABe6' in names, 'ZOH' in names,"
        " 'sampledyn._estimate' in sys.modules)\n"
        "get_method('ABe2')\n"
        "print('sampledyn._estimate' in sys.modules)\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=120
    ).stdout.split()
    assert out == [str(len(available_methods())), "True", "True", "True", "False", "True"]


def test_every_lazy_entry_names_a_rule_module_of_methods_or_estimate():
    for fam in families():
        if isinstance(fam.factory, str):
            module = fam.factory.partition(":")[0]
            assert module.startswith(("sampledyn.methods.", "sampledyn._estimate.")), fam.key
        assert get_method(fam.names()[0]).name == fam.names()[0]


def test_the_table_agrees_with_the_rules_it_names():
    rk = next(row for row in BUILT_IN if row[0] == "RK<s>")
    assert rk[4] == rk[5] == max(TABLEAUX) and str(sorted(TABLEAUX)) in rk[3]
    with pytest.raises(ValueError, match="RK<s> must be in 1..4"):
        get_method(f"RK{max(TABLEAUX) + 1}")


def test_no_module_writes_into_the_registry():
    # register_family is for the user's own families; the package's are table rows.
    callers = []
    for path in ROOT.rglob("*.py"):
        if path.name == "_registry.py":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "register_family":
                callers.append(str(path.relative_to(ROOT)))
            if isinstance(node, ast.Call) and getattr(node.func, "attr", None) == "register_family":
                callers.append(str(path.relative_to(ROOT)))
    assert not callers

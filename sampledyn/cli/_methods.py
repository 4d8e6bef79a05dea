"""``sampledyn methods``: the registered sampled-data rules."""

from __future__ import annotations

import argparse
from typing import Any

from ._common import registry

__all__ = ["add_parser"]


def _cmd_methods(args: argparse.Namespace) -> int:
    reg = registry()
    available_methods, families, get_method = reg.available_methods, reg.families, reg.get_method

    print("Method families:")
    for fam in families():
        orders = ""
        if fam.ordered:
            top = "any s" if fam.max_order is None else f"s <= {fam.max_order}"
            orders = f" (listed: s = 1..{fam.default_max_order}; {top})"
        print(f"  {fam.key:8s} {fam.description}{orders}")
    print("\nRegistered rules (a_s: first-order noise gain c in G = c h L; C: error constant):")
    for name in available_methods():
        m = get_method(name)
        bounded = isinstance(m, reg.NoiseAnalysis)
        gain = str(m.first_order_gain) if bounded else "-"
        const = str(m.error_constant) if bounded and m.error_constant is not None else "-"
        order = "-" if m.order is None else str(m.order)
        if isinstance(m, reg.Predictor):
            where = "f between samples" if m.intersample else "f at samples"
        else:
            where = "discrete-time system only"
        est = ", estimated" if isinstance(m, reg.Estimator) else ""
        print(
            f"  {name:6s} order {order}  history {m.history}  a_s = {gain:7s} "
            f"C = {const:12s} {where}{est}"
        )
    return 0


def add_parser(sub: Any, parents: list[argparse.ArgumentParser]) -> None:
    """Add ``methods`` to the subparsers ``sub``."""
    meth = sub.add_parser(
        "methods",
        parents=parents,
        help="list the registered sampled-data methods",
        description="List the method families of the registry and the built-in rules.",
    )
    meth.set_defaults(func=_cmd_methods)

"""``sampledyn methods``: the registered sampled-data rules."""

from __future__ import annotations

import argparse
from typing import Any

__all__ = ["add_parser"]


def _cmd_methods(args: argparse.Namespace) -> int:
    from ..methods import available_methods, describe_methods, get_method

    print("Method families:")
    for key, desc in describe_methods().items():
        print(f"  {key:8s} {desc}")
    print("\nBuilt-in fixed rules:")
    for name in available_methods():
        m = get_method(name)
        extra = f"  a_s = {m.a_s}" if hasattr(m, "a_s") else ""
        print(f"  {name:5s} order {m.order}{extra}")
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

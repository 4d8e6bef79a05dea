"""The lowest versions CI tests (.ci/constraints-lowest.txt, the second leg of .ci/run)
are the lower bounds of pyproject.toml: every dependency and every requirement of the
``test`` extra pinned at its bound; the ``test`` extra holds every other extra (but
``bench``) at the same bounds."""

from __future__ import annotations

import tomllib
from pathlib import Path

from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

ROOT = Path(__file__).resolve().parents[2]
CONSTRAINTS = ROOT / ".ci" / "constraints-lowest.txt"


def _project() -> dict:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]


def _lowest(req: Requirement) -> str:
    """``name==v`` of a requirement bounded below (>= v) or pinned (== v)."""
    specs = list(req.specifier)
    assert len(specs) == 1 and specs[0].operator in (">=", "=="), (
        f"{req}: give one lower bound (>=) or a pin (==), so that the lowest version is defined"
    )
    return f"{canonicalize_name(req.name)}=={specs[0].version}"


def test_the_lowest_constraints_are_the_lower_bounds_of_pyproject():
    project = _project()
    reqs = [
        Requirement(r)
        for r in (*project["dependencies"], *project["optional-dependencies"]["test"])
    ]
    want = sorted({_lowest(r) for r in reqs})
    lines = [ln.split("#")[0].strip() for ln in CONSTRAINTS.read_text().splitlines()]
    got = sorted(ln for ln in lines if ln)
    assert got == want, (
        f"{CONSTRAINTS.relative_to(ROOT)} is not pyproject's lower bounds; its pins "
        "should be:\n" + "\n".join(want)
    )


def test_the_test_extra_holds_every_other_extra_at_its_bound():
    extras = _project()["optional-dependencies"]
    test = {canonicalize_name(Requirement(r).name): Requirement(r) for r in extras["test"]}
    for extra, reqs in extras.items():
        if extra in ("test", "bench"):
            continue
        for text in reqs:
            req = Requirement(text)
            name = canonicalize_name(req.name)
            assert name in test, f"[{extra}] {req} is not in [test]: CI would not test it"
            assert test[name].specifier == req.specifier and test[name].extras == req.extras, (
                f"[{extra}] {req} against [test] {test[name]}"
            )

"""Unknown method names: the closest name suggested (case ignored, a single rule also
by its description: "Euler" -> E), the families in one short line, as an
ArgumentError naming the argument ``method``."""

from __future__ import annotations

import pytest

import sampledyn as sd
from sampledyn.exceptions import ArgumentError


@pytest.mark.parametrize(
    "name, close",
    [("Eular", "E"), ("ab4", "AB4"), ("Tustn", "T"), ("ABE3", "ABe3"), ("rk4", "RK4")],
)
def test_an_unknown_method_suggests_the_closest(name, close):
    with pytest.raises(ArgumentError) as exc:
        sd.methods.get_method(name)
    assert exc.value.argument == "method"
    text = str(exc.value)
    assert f"did you mean {close!r}" in text, text
    assert "E, AB<s>, T, RK1-RK4" in text and len(text) < 300, text


def test_no_suggestion_when_nothing_is_close():
    with pytest.raises(ArgumentError, match=r"unknown method 'XY3'; the methods are") as exc:
        sd.methods.get_method("XY3")
    assert "did you mean" not in str(exc.value)


def test_an_order_beyond_the_family_is_an_argument_error():
    with pytest.raises(ArgumentError, match=r"RK<s> must be in 1..4, got 5") as exc:
        sd.methods.get_method("RK5")
    assert exc.value.argument == "method"

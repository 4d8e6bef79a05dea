"""Unknown vehicle names: one message (models._vehicle_file.unknown_vehicle), the
closest built-in suggested with case ignored, as an ArgumentError naming the argument
(no command-line option in the library's words)."""

from __future__ import annotations

import pytest

from sampledyn.exceptions import ArgumentError
from sampledyn.models import load_vehicle
from sampledyn.models._names import model_from_name


@pytest.mark.parametrize("name", ["bluerov_heavy", "BlueROV2_Heavy", "bluerov2-heavy"])
def test_load_vehicle_suggests_the_closest_built_in(name):
    with pytest.raises(ArgumentError) as exc:
        load_vehicle(name)
    assert exc.value.argument == "name_or_path"
    text = str(exc.value)
    assert f"unknown vehicle {name!r} (did you mean 'bluerov2_heavy'" in text, text
    assert "built-in: bluerov2, bluerov2_heavy, rexrov" in text and "--" not in text


def test_model_names_share_the_message_and_name_their_argument():
    with pytest.raises(ArgumentError) as exc:
        model_from_name("rexrof")
    assert exc.value.argument == "vehicle"
    assert "did you mean 'rexrov'" in str(exc.value) and "auv_like" in str(exc.value)

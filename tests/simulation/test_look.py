"""A world file's "look" checked before anything starts (cart2d/simulation/look.py): what the
file gives goes to the simulator as given (its defaults for the rest), a bad member is a
sentence that names it, and the named rooms all pass."""

from __future__ import annotations

import json

import pytest

from cart2d.simulation.look import LookSpec
from cart2d.simulation.world_file import WorldSpec, parse
from cart2d.spec import repo_file


def test_only_what_the_file_gives_is_sent() -> None:
    look = LookSpec.model_validate(
        {"floor": {"material": "tiles", "size": 0.2}, "lights": [{"x": 1.0, "y": 2.0}], "ambient": 0.3}
    )
    assert look.message() == {
        "floor": {"material": "tiles", "size": 0.2},
        "lights": [{"x": 1.0, "y": 2.0}],
        "ambient": 0.3,
    }


@pytest.mark.parametrize(
    ("look", "says"),
    [
        ({"floor": {"material": "marble"}}, "look.floor.material: input should be"),
        ({"floor": {"grout": "#ffffff"}}, "unknown key 'grout' in look.floor"),
        ({"lights": [{"x": 1.0}]}, "look.lights[0].y is missing"),
        ({"camera": {"vignetting": 2}}, "look.camera.vignetting: input should be less than or equal to 0.9"),
        ({"walls": {"colour": "white"}}, "look.walls.colour: string should match pattern"),
    ],
)
def test_a_bad_look_is_a_sentence_naming_it(look: dict[str, object], says: str) -> None:
    spec, problems = parse(json.dumps({"look": look}).encode(), WorldSpec, "world.json")
    assert spec is None and len(problems) == 1 and says in problems[0], problems


@pytest.mark.parametrize("room", ["kitchen", "office", "carpet", "corridor"])
def test_each_named_room_passes(room: str) -> None:
    spec, problems = parse(repo_file("docs", "examples", f"{room}.json").read_bytes(), WorldSpec, room)
    assert problems == [] and spec is not None and spec.look is not None
    assert spec.look.lights and spec.look.floor is not None and spec.look.floor.material != "plain"

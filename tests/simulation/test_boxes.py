"""Boxes in the world of `cart2d sim` (issue 14): the command line's --world, and GET
/api/sim/world, POST /api/sim/boxes, DELETE /api/sim/boxes/{id}, DELETE /api/sim/boxes (all),
checked against what the simulator itself holds (world_get), across a restart of the simulator
and a new map, and told to /ws viewers."""

from __future__ import annotations

import json
import urllib.request
from pathlib import Path
from typing import Any

import pytest

from cart2d.gateway import Gateway
from cart2d.link import Link
from cart2d.simulation.simulator import Simulator
from cart2d.store import Store
from tests.support.cli import cart2d, one_sentence, running_cart2d
from tests.support.server import Rig
from tests.support.sim import start_sim
from tests.support.sockets import free_port
from tests.support.waiting import wait_serving

SMALL = {"x": 0.4, "y": 1.2, "sx": 0.2, "sy": 0.2}
CRATE = {"x": 1.0, "y": 0.6, "sx": 0.3, "sy": 0.2, "height": 0.25, "colour": "#a0522d", "id": "crate"}


def held(sim: Simulator) -> dict[str, tuple[float, float, float, float]]:
    """The boxes the simulator holds: id -> (x, y, sx, sy)."""
    boxes = sim.world_state()["boxes"]
    return {b["id"]: (b["x"], b["y"], b["sx"], b["sy"]) for b in boxes if not b["obstacle"]}


def test_boxes_are_added_listed_and_removed_in_the_simulator(rig: Rig) -> None:
    told: list[dict[str, Any]] = []  # the /ws messages "sim_world"
    rig.gateway.subscribe(lambda m: told.append(m) if m["type"] == "sim_world" else None)
    assert rig.client.get("/api/sim/world").json()["boxes"] == []
    answer = rig.client.post("/api/sim/boxes", json={"boxes": [CRATE, SMALL]})
    assert answer.status_code == 200, answer.text
    assert answer.json()["added"] == ["crate", "box-1"]  # an id given to the box without one
    assert held(rig.sim) == {"crate": (1.0, 0.6, 0.3, 0.2), "box-1": (0.4, 1.2, 0.2, 0.2)}
    listed = {b["id"]: b for b in rig.client.get("/api/sim/world").json()["boxes"]}
    assert listed["crate"] == {**CRATE, "solid": True}
    assert listed["box-1"]["height"] == 0.3 and listed["box-1"]["colour"] == "#b8742f"  # BoxSpec's defaults
    assert [b["id"] for b in told[-1]["boxes"]] == ["crate", "box-1"]

    # one more without an id: the next free one
    answer = rig.client.post("/api/sim/boxes", json={"boxes": [{"x": 1.4, "y": 1.4, "sx": 0.1, "sy": 0.1}]})
    assert answer.json()["added"] == ["box-2"]
    assert rig.client.delete("/api/sim/boxes/crate").status_code == 200
    assert set(held(rig.sim)) == {"box-1", "box-2"}
    assert [b["id"] for b in told[-1]["boxes"]] == ["box-1", "box-2"]
    gone = rig.client.delete("/api/sim/boxes/crate")
    assert gone.status_code == 404 and "no box 'crate'" in gone.json()["detail"]
    cleared = rig.client.delete("/api/sim/boxes")
    assert cleared.status_code == 200 and sorted(cleared.json()["removed"]) == ["box-1", "box-2"]
    assert held(rig.sim) == {}
    assert told[-1]["boxes"] == [] and len(told) == 4


@pytest.mark.parametrize(
    ("box", "words"),
    [
        ({**CRATE, "sx": -0.1}, "boxes.1.sx: Input should be greater than or equal to 0.01"),
        ({**CRATE, "y": False}, "boxes.1.y: Input should be a valid number"),
        ({**CRATE, "colour": "red"}, "boxes.1.colour: String should match pattern"),
        ({**CRATE, "weight": 3}, "boxes.1.weight: Extra inputs are not permitted"),
        ({"x": 1.0, "sx": 0.2, "sy": 0.2}, "boxes.1.y: Field required"),
        ({**CRATE, "height": 0}, "boxes.1.height: Input should be greater than 0"),
    ],
)
def test_bad_boxes_are_refused_with_a_sentence_and_change_nothing(
    rig: Rig, box: dict[str, Any], words: str
) -> None:
    rig.client.post("/api/sim/boxes", json={"boxes": [{**SMALL, "id": "kept"}]})
    answer = rig.client.post("/api/sim/boxes", json={"boxes": [{**SMALL, "x": 0.8}, box]})
    assert answer.status_code == 422 and words in answer.json()["detail"], answer.text
    assert set(held(rig.sim)) == {"kept"}
    assert rig.client.post("/api/sim/boxes", json={"boxes": []}).status_code == 422


def test_a_box_under_the_cart_is_refused(rig: Rig) -> None:
    """The cart stands at (0, 0), 0.17 m round: a box whose edge comes within that is refused,
    the whole request with it; one just clear of it is taken."""
    near = {"x": 0.25, "y": 0.0, "sx": 0.2, "sy": 0.2}  # its edge 0.15 m from the cart's centre
    answer = rig.client.post("/api/sim/boxes", json={"boxes": [CRATE, near]})
    assert answer.status_code == 422
    assert "boxes[1] at (0.25, 0) would stand under the cart" in answer.json()["detail"]
    assert held(rig.sim) == {}
    clear = {"x": 0.3, "y": 0.0, "sx": 0.2, "sy": 0.2}  # edge at 0.2 m
    assert rig.client.post("/api/sim/boxes", json={"boxes": [clear]}).status_code == 200


def test_boxes_stay_across_a_restart_and_a_new_map(rig: Rig) -> None:
    rig.client.post("/api/sim/boxes", json={"boxes": [CRATE, {**CRATE, "id": "gone", "x": 1.4}]})
    rig.client.delete("/api/sim/boxes/gone")
    rig.sim.restart()
    assert held(rig.sim) == {"crate": (1.0, 0.6, 0.3, 0.2)}
    # a larger arena: new walls (core.py's _sync_world), the boxes standing where they were
    larger = rig.gateway.settings.map.model_copy(update={"cols": 14, "rows": 12})
    rig.gateway.update_settings(rig.gateway.settings.model_copy(update={"map": larger}))
    assert held(rig.sim) == {"crate": (1.0, 0.6, 0.3, 0.2)}
    walls = rig.sim.world_state()["walls"]
    assert max(w["x"] + w["sx"] / 2 for w in walls) > 0.2 * 13  # the new arena's walls


def test_a_real_cart_has_no_simulated_world(tmp_path: Path) -> None:
    from fastapi.testclient import TestClient

    from cart2d.server import create_app
    from tests.support.server import BASE_URL, JSON

    sim = start_sim(tmp_path)
    try:
        with Link(sim.pty) as link:
            gateway = Gateway(link, Store(tmp_path / "g"), Store(tmp_path / "g").load())  # no sim
            client = TestClient(create_app(gateway), base_url=BASE_URL, headers=JSON)
            for answer in (
                client.get("/api/sim/world"),
                client.post("/api/sim/boxes", json={"boxes": [CRATE]}),
                client.delete("/api/sim/boxes/crate"),
                client.delete("/api/sim/boxes"),
            ):
                assert answer.status_code == 404 and "real cart" in answer.json()["detail"], answer.text
    finally:
        sim.stop()


# -- cart2d sim --world ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("content", "words"),
    [
        (None, "there is no world file"),
        ("{", "is not JSON: Expecting property name"),
        ('{"boxes": [{"x": 1, "y": 1, "sx": 0, "sy": 0.2}]}', "boxes[0].sx: input should be greater than 0"),
        ('{"crates": []}', "unknown key 'crates' (a world has: boxes, look)"),
        ('{"boxes": [{"x": 0.1, "y": 0, "sx": 0.1, "sy": 0.1}]}', "boxes[0] at (0.1, 0) would stand under"),
    ],
)
def test_a_bad_world_file_is_one_sentence(tmp_path: Path, content: str | None, words: str) -> None:
    world = tmp_path / "world.json"
    if content is not None:
        world.write_text(content)
    done = cart2d(tmp_path, "sim", "--world", str(world), "--port", str(free_port()))
    assert done.returncode == 2
    line = one_sentence(done.stderr)
    assert line.startswith("cart2d sim: ") and words in line, line


def test_the_world_file_boxes_stand_in_the_simulator(tmp_path: Path) -> None:
    world = tmp_path / "world.json"
    world.write_text(json.dumps({"boxes": [CRATE, {"x": 0.6, "y": 1.4, "sx": 0.2, "sy": 0.4}]}))
    port = free_port()
    run = ["sim", "--port", str(port), "--world", str(world), "--no-camera"]
    with running_cart2d(tmp_path, *run) as gateway:
        wait_serving(port)
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/api/sim/world", timeout=5) as answer:
            boxes = {b["id"]: b for b in json.load(answer)["boxes"]}
        out = gateway.stop()
    assert set(boxes) == {"crate", "box-1"}
    assert (boxes["crate"]["x"], boxes["crate"]["y"], boxes["crate"]["colour"]) == (1.0, 0.6, "#a0522d")
    assert (boxes["box-1"]["sx"], boxes["box-1"]["sy"]) == (0.2, 0.4)
    assert f"2 boxes from {world}" in out

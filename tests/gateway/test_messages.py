"""The /ws messages (cart2d/gateway/messages.py): every kind the gateway sends is one of the
union's models and its JSON reads back as the same model; a message the union does not describe
is refused. Most kinds come from a gateway on a fake firmware; telemetry, truth and the
simulated world's boxes from a short run on the simulator."""

from __future__ import annotations

import json
import typing
from dataclasses import asdict
from typing import Any

import pytest
from pydantic import ValidationError

from cart2d.gateway import Gateway
from cart2d.gateway.bus import ViewerMessage
from cart2d.gateway.messages import LIVE_MESSAGE, SimulatorMessage, wire
from cart2d.gateway.state import SimulatorRun, SimulatorState
from cart2d.maps.world import Box
from tests.support.fake_firmware import FakeFirmware
from tests.support.waiting import wait_for

ACROSS = [(1.0, 0.6), (1.0, 0.8), (1.0, 1.0)]  # three nodes across the straight route at y = 0.8


def sent(events: list[ViewerMessage]) -> set[str]:
    """The kinds sent, each checked: its JSON (as /ws carries it) reads back as the same model."""
    for event in events:
        text = json.dumps(event.wire)
        assert LIVE_MESSAGE.validate_json(text) == event.message, text
        assert json.loads(text) == event.wire
    return {event.message.type for event in events}


def test_what_a_gateway_sends_on_a_fake_firmware_is_of_the_union(
    gateway: Gateway, cart: FakeFirmware
) -> None:
    events: list[ViewerMessage] = []
    gateway.bus.subscribe(ViewerMessage, events.append)
    gateway.go_to(1.6, 0.8)
    gateway.change_obstacles(ACROSS, [], "a box was put down")  # map, replan, mission
    gateway.set_perceived([(0.4, 1.6, 0.9)], "the camera saw a box")
    gateway.camera_service.tell_camera(12.5, [(0.0, 0.0), (1.0, 0.5), (1.0, -0.5)], [(0.8, 0.1)])
    cart.restart()
    gateway.read_status()  # reset, the mission failed
    gateway.set_pose(0.2, 0.8, 0.0)  # pose_trust
    gateway.start_reset_routine()
    gateway.stop("stopped by the user")  # routine
    kinds = sent(events)
    assert kinds == {"mission", "map", "replan", "perceived", "camera", "reset", "pose_trust", "routine"}
    (replan,) = gateway.mission.replans  # the JSON, keys in order, is the dict's it replaced
    told = [e.wire for e in events if e.message.type == "replan"]
    assert [json.dumps(m) for m in told] == [json.dumps({"type": "replan", **asdict(replan)})]
    mission = [e.wire for e in events if e.message.type == "mission"][-1]
    assert json.dumps(mission) == json.dumps({"type": "mission", **gateway.mission_view()})


def test_the_simulators_state_is_a_simulator_message() -> None:
    """What the gateway publishes when the simulator it started exits (core.py), for each state."""
    for state in typing.get_args(SimulatorRun):
        message = SimulatorMessage(**asdict(SimulatorState(state, 2, "it exited with status 1")))
        assert LIVE_MESSAGE.validate_python(message.model_dump(mode="json")) == message


def test_a_short_run_on_the_simulator_sends_only_messages_of_the_union(rig: Any) -> None:
    events: list[ViewerMessage] = []
    rig.gateway.bus.subscribe(ViewerMessage, events.append)
    rig.simulation.world.add_boxes([Box(1.4, 1.4, 0.2, 0.2, id="crate")])
    assert rig.client.put("/api/map/obstacle", json={"x": 0.8, "y": 1.2}).status_code == 200
    answer = rig.client.post("/api/goto", json={"x": 0.6, "y": 0.2})
    assert answer.status_code == 200, answer.text
    wait_for(lambda: {"telemetry", "truth"} <= {e.message.type for e in events}, 30)
    wait_for(lambda: rig.mission_state() != "driving", 60)
    with rig.client.websocket_connect("ws://127.0.0.1:8080/ws") as ws:
        hello = json.loads(ws.receive_text())[0]
    assert LIVE_MESSAGE.validate_python(hello).type == "hello"
    assert {"telemetry", "truth", "sim_world", "map", "mission"} <= sent(list(events))
    last = {e.message.type: e.wire for e in events}  # the JSON is the views' the dicts were made of
    assert last["sim_world"] == {"type": "sim_world", **rig.simulation.world.view()}
    assert last["mission"] == {"type": "mission", **rig.gateway.mission_view()}
    assert hello == {"type": "hello", **rig.gateway.mission_view()}


def test_a_field_with_nothing_to_say_is_left_out_as_the_dicts_left_it_out() -> None:
    box = {"id": "crate", "x": 1, "y": 1.5, "sx": 0.2, "sy": 0.2, "height": 0.3, "colour": "#b8742f"}
    message = LIVE_MESSAGE.validate_python({"type": "sim_world", "version": 3, "boxes": [box]})
    assert wire(message) == {"type": "sim_world", "version": 3, "boxes": [box]}  # no "solid": null
    started = {"type": "goal", "index": 1, "of": 2, "goal": [1.0, 0.5], "state": "started"}
    assert wire(LIVE_MESSAGE.validate_python(started)) == started  # no "reason": null
    assert json.dumps(wire(message)) == json.dumps({"type": "sim_world", "version": 3, "boxes": [box]})


@pytest.mark.parametrize(
    ("message", "fragment"),
    [
        ({"type": "teleport", "x": 1.0}, "does not match any of the expected tags"),
        ({"version": 3, "why": "no type"}, "Unable to extract tag"),
        ({"type": "map", "version": 3}, "why"),  # a field missing
        ({"type": "map", "version": 3, "why": "w", "colour": "red"}, "Extra inputs"),
        ({"type": "routine", "state": "asleep", "words": ""}, "state"),
        ({"type": "camera", "t": "12.5", "fov": [], "hits": []}, "t"),  # a number as a string
        ({"type": "camera", "t": 1.0, "fov": [[0.0, 1.0, 2.0]], "hits": []}, "fov"),  # not a point
    ],
)
def test_a_message_the_union_does_not_describe_is_refused(message: dict[str, Any], fragment: str) -> None:
    with pytest.raises(ValidationError, match=fragment):
        LIVE_MESSAGE.validate_python(message)

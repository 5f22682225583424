"""`cart2d replay` of a real recorded mission on a ROS map with a world (boxes, the simulated camera,
perception, a timed event, a goal refused at once): the replay serves what the recording holds
(the floor plan, the boxes, the camera), rebuilds the state at any time (a panel that opens late,
a seek) and is played, paused, sought and restarted through its API. And the mission itself: its
times count from its first goal, and every goal is in the report and the recording."""

from __future__ import annotations

import io
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient
from PIL import Image

from cart2d.maps import OCCUPIED, OccupancyMap, save_ros_map
from cart2d.recording import channels as c
from cart2d.recording.recorded import Frame, Recorded
from cart2d.recording.replay import Player, read_recording
from cart2d.recording.replay_app import create_replay_app
from cart2d.tools.missions.run import run_mission
from cart2d.tools.missions.spec import MissionSpec
from tests.support.recording import Read
from tests.support.server import BASE_URL, JSON, WS_BASE
from tests.support.waiting import wait_for

BOX = {"x": 1.2, "y": 0.9, "sx": 0.2, "sy": 0.2, "height": 0.3, "colour": "#3050c0", "id": "blue"}
EVENT_AT_S = 1.0
EVENT_NODE = [0.0, 1.0]  # off every route: it changes the map, not the drive
IN_THE_WALL = [-0.45, 0.0]  # the room's outline: refused at once
START = (0.0, 0.0)


def at_the_start(trail: list[list[float]]) -> bool:
    """Nothing of the drive in a trail: no point, or the start's (telemetry recorded at 0.0 s,
    which a seek to 0.0 keeps, on a busy machine's recording)."""
    return all(math.hypot(x - START[0], y - START[1]) < 0.005 for x, y in trail)


GOALS = [[1.2, 0.0], IN_THE_WALL, [0.4, 0.4]]
MISSION = {
    "map": "maps/room.yaml",
    "start": [*START, 0.0],
    "goals": GOALS,
    "world": {"boxes": [BOX]},
    "events": [{"at_s": EVENT_AT_S, "add": [EVENT_NODE]}],
    "timeout_s": 60,
}


def room() -> OccupancyMap:
    """A 3 x 2 m room at 5 cm, its outline walled."""
    cells = np.zeros((40, 60), dtype=np.int8)
    cells[0, :] = cells[-1, :] = cells[:, 0] = cells[:, -1] = OCCUPIED
    return OccupancyMap((-0.5, -0.5), 0.05, cells)


@pytest.fixture(scope="module")
def mission(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, Any]]:
    folder = tmp_path_factory.mktemp("replay")
    save_ros_map(room(), folder / "maps" / "room.yaml")
    path = folder / "mission.mcap"
    report = run_mission(MissionSpec.model_validate(MISSION), base_dir=folder, mcap_path=path)
    return path, report


@pytest.fixture(scope="module")
def recorded(mission: tuple[Path, dict[str, Any]]) -> Recorded:
    return read_recording(mission[0])


def replay(recorded: Recorded, speed: float = 1.0) -> tuple[Player, TestClient]:
    player = Player(recorded, speed)
    return player, TestClient(create_replay_app(player), base_url=BASE_URL, headers=JSON)


def ws_at(recorded: Recorded, kind: str, **match: Any) -> float:
    """The time (s into the recording) of the first /ws message of `kind` with these values."""
    return next(
        e.at_s
        for e in recorded.entries
        if e.topic == c.TOPIC_WS
        and isinstance(e.message, dict)
        and e.message.get("type") == kind
        and all(e.message.get(k) == v for k, v in match.items())
    )


def event_obstacle(view: dict[str, Any]) -> bool:
    """Whether the map has the event's obstacle (on the planning node nearest it)."""
    return any(math.dist(node, EVENT_NODE) < 0.1 for node in view["obstacles"])


# -- the mission -----------------------------------------------------------------------------------
def test_event_times_count_from_the_first_goal_once_the_camera_sees(
    mission: tuple[Path, dict[str, Any]], recorded: Recorded
) -> None:
    """The camera takes seconds to start (at full speed, many simulated ones): an event at 1 s
    comes 1 s into the first goal, not while the cart still stands waiting for the camera."""
    _, report = mission
    assert report["perception"]["frames"] > 0  # the mission saw
    first = report["goals"][0]
    assert first["reached"], first.get("reason")
    assert 0.0 <= first["started_s"] < 0.2  # the events are scheduled in between
    (event,) = report["events"]
    assert EVENT_AT_S <= event["seen_s"] < EVENT_AT_S + 0.3
    # and in the recording: the event's map change against the first goal's start
    started = ws_at(recorded, "goal", index=1, state="started")
    changed = next(
        e.at_s
        for e in recorded.entries
        if isinstance(e.message, dict)
        and e.message.get("type") == "map"
        and "mission event" in e.message["why"]
    )
    # (a message takes the time of the latest ground truth: 20 ms apart)
    assert EVENT_AT_S - first["started_s"] - 0.05 <= changed - started < EVENT_AT_S + 0.3


def test_every_goal_even_one_refused_at_once_is_in_the_report_and_the_recording(
    mission: tuple[Path, dict[str, Any]],
) -> None:
    path, report = mission
    goals = report["goals"]
    assert [g["goal"] for g in goals] == GOALS
    refused = goals[1]
    assert (
        not refused["reached"]
        and "inside a wall of the floor plan" in refused["reason"]
        and refused["time_s"] == 0.0
    )
    assert goals[2]["reached"], goals[2].get("reason")
    told = [(m["index"], m["state"], m.get("reason", "")) for m in Read(path).ws("goal")]
    assert told == [
        (1, "started", ""),
        (1, "reached", ""),
        (2, "started", ""),
        (2, "failed", refused["reason"]),
        (3, "started", ""),
        (3, "reached", ""),
    ]


# -- what the replay serves --------------------------------------------------------------------------
def test_the_replay_serves_the_recorded_floor_plan_boxes_and_camera(recorded: Recorded) -> None:
    player, client = replay(recorded)
    try:
        answer = client.get("/api/map/image")
        assert answer.status_code == 200 and answer.headers["content-type"] == "image/png"
        grey = np.asarray(Image.open(io.BytesIO(answer.content)))
        expected = np.where(room().cells[::-1] == OCCUPIED, 0, 254)  # map_saver's levels, top row first
        assert np.array_equal(grey, expected)
        assert client.get("/api/map").json()["floor_plan"]["image"].startswith("/api/map/image")
        camera = client.get("/api/camera").json()
        assert camera["camera"] and camera["recorded_frames"] == recorded.frames > 0
        assert 0.0 < camera["fps"] <= 2.5  # recorded at 2 frames a second
        assert client.get("/api/camera/frame.jpg").status_code == 404  # none yet at the start
        player.seek(recorded.duration_s)
        frame = client.get("/api/camera/frame.jpg")
        last = [e.message for e in recorded.entries if isinstance(e.message, Frame)][-1]
        assert frame.status_code == 200 and frame.content == last.jpeg and frame.content[:2] == b"\xff\xd8"
        assert client.get("/api/camera").json()["connected"]
        (box,) = client.get("/api/sim/world").json()["boxes"]  # put there as the mission began
        assert {k: box[k] for k in BOX} == BOX
        assert client.get("/api/perception").json()["cells"]  # what the camera made of the box
    finally:
        player.close()


def test_a_panel_that_opens_after_the_end_gets_the_world_as_it_was(recorded: Recorded) -> None:
    player, client = replay(recorded, speed=1000.0)
    try:
        player.play()
        wait_for(lambda: player.state == "ended", 60.0)
        with client.websocket_connect(f"{WS_BASE}/ws") as ws:
            got: list[dict[str, Any]] = []
            while not got or got[-1]["type"] != "hello":
                got.extend(ws.receive_json())  # a frame: an array of messages
        kinds = {m["type"]: m for m in got}
        said = kinds["replay"]
        assert said["state"] == "ended" and said["position_s"] == pytest.approx(recorded.duration_s, abs=1e-3)
        trail, truth_trail = said["trail"], said["truth_trail"]
        assert len(trail) > 50 and len(truth_trail) > 50  # the whole drive, not only what comes next
        last = kinds["telemetry"]
        assert trail[-1] == pytest.approx([last["x"], last["y"]], abs=0.011)
        assert [last["x"], last["y"]] == pytest.approx(GOALS[2], abs=0.05)
        assert [b["id"] for b in kinds["sim_world"]["boxes"]] == ["blue"]
        assert kinds["map"]["version"] == client.get("/api/map").json()["version"] > 1  # after the event
        assert kinds["mission"]["state"] == kinds["hello"]["state"] == "arrived"
        assert kinds["perceived"]["cells"] and kinds["camera"]["fov"]
    finally:
        player.close()


def test_a_seek_rebuilds_the_state_at_that_time_and_tells_the_viewers(recorded: Recorded) -> None:
    player, client = replay(recorded)
    told: list[dict[str, Any]] = []
    try:
        event_s = ws_at(recorded, "map")  # the event's map change, as the cart looks round before it drives
        player.seek((ws_at(recorded, "goal", index=1, state="started") + event_s) / 2)
        player.subscribe(told.append)  # paused at a seek: a viewer does not start it
        assert player.state == "paused"
        assert not event_obstacle(client.get("/api/map").json())
        driving = (
            ws_at(recorded, "mission", state="driving") + ws_at(recorded, "mission", state="arrived")
        ) / 2
        player.seek(driving)
        assert event_obstacle(client.get("/api/map").json())
        assert client.get("/api/status").json()["mission"]["state"] == "driving"
        said, *state = told
        assert (
            said["type"] == "replay"
            and said["seeks"] == 2
            and said["position_s"] == pytest.approx(driving, abs=1e-3)
        )
        assert [m["type"] for m in state][:2] == ["map", "sim_world"]  # the map first, the pose last
        mission_then = next(m for m in state if m["type"] == "mission")
        assert mission_then["state"] == "driving" and mission_then["goal"] == GOALS[0]
        x_then = next(m for m in state if m["type"] == "telemetry")["x"]
        assert 0.0 < x_then < GOALS[0][0]
        told.clear()
        player.seek(0.0)  # back to before anything: what came later is taken away
        kinds = {m["type"]: m for m in told}
        assert at_the_start(kinds["replay"]["trail"]) and kinds["mission"]["state"] == "idle"
        assert kinds["perceived"]["cells"] == []
        assert client.get("/api/map").json()["version"] == recorded.first_map_view()["version"]  # type: ignore[index]
    finally:
        player.close()


def test_play_pause_seek_and_restart_through_the_api(recorded: Recorded) -> None:
    player, client = replay(recorded, speed=4.0)

    def act(**body: Any) -> Any:
        return client.post("/api/replay", json=body)

    try:
        assert client.get("/api/replay").json()["state"] == "waiting"
        assert act(action="play").json()["state"] == "playing"
        wait_for(lambda: player.position_s > 0.5, 30.0)
        paused = act(action="pause").json()
        assert paused["state"] == "paused"
        sent = player.sent
        assert client.get("/api/replay").json()["position_s"] == paused["position_s"]  # it stays there
        assert player.sent == sent
        middle = round(recorded.duration_s / 2, 3)
        answer = act(action="seek", position_s=middle).json()
        assert answer["state"] == "paused" and answer["position_s"] == middle and answer["seeks"] == 1
        for body, words in (
            ({"action": "seek", "position_s": recorded.duration_s + 1}, "past the recording's end"),
            ({"action": "seek"}, "seek needs position_s"),
            ({"action": "seek", "position_s": -1}, "position_s"),
            ({"action": "play", "position_s": 1.0}, "goes with seek only"),
            ({"action": "rewind"}, "action"),
        ):
            refused = act(**body)
            assert refused.status_code == 422 and words in refused.json()["detail"], body
        assert client.get("/api/replay").json()["position_s"] == middle  # a refusal changes nothing
        end = act(action="seek", position_s=answer["duration_s"]).json()  # the slider's end, rounded
        assert end["position_s"] == answer["duration_s"] and player.mission_view()["state"] == "arrived"
        restarted = act(action="restart").json()
        assert restarted["state"] == "playing" and restarted["position_s"] < 1.0 and restarted["seeks"] == 3
        spec = client.get("/openapi.json").json()["paths"]["/api/replay"]
        schema = json.dumps(spec["post"]["requestBody"])
        assert "ReplayIn" in schema and set(spec) == {"get", "post"}
    finally:
        player.close()


def test_a_looped_replay_starts_again_from_the_start_with_the_state_there(recorded: Recorded) -> None:
    player = Player(recorded, speed=1000.0, loop=True)
    told: list[dict[str, Any]] = []
    try:
        player.subscribe(told.append)  # the first viewer starts it
        wait_for(lambda: player.seeks >= 2, 60.0)
        assert player.state == "playing"
        again = [m for m in told if m["type"] == "replay" and "trail" in m]
        # 1 ms is 1 s here
        assert again and all(m["position_s"] < 1.0 and at_the_start(m["trail"]) for m in again)
    finally:
        player.close()

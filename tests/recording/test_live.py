"""The Foxglove live view and the recorder's hooks, on a stand-in for the gateway (no simulator):
a viewer that subscribes gets the map at once and the live messages after it; camera frames are
recorded as they were given."""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from mcap.reader import make_reader
from websockets.sync.client import ClientConnection, connect

from cart2d.maps import OccupancyMap
from cart2d.recording import channels as c
from cart2d.recording import open_recording
from cart2d.recording.session import DEFAULT_CAMERA_FPS
from tests.support.recording import StandIn

MESSAGE_DATA = 0x01  # the Foxglove WebSocket protocol's binary opcode for a message


def telemetry(tick: int) -> dict[str, Any]:
    return {"type": "telemetry", "x": 0.01 * tick, "y": 0.0, "theta": 0.0, "tick": tick}


def _channels(ws: ClientConnection) -> dict[str, int]:
    """topic → channel id, from the server's advertisements."""
    ids: dict[str, int] = {}
    deadline = time.monotonic() + 10.0
    while time.monotonic() < deadline and c.TOPIC_TELEMETRY not in ids:
        message = ws.recv(timeout=5.0)
        if isinstance(message, str) and json.loads(message).get("op") == "advertise":
            ids |= {ch["topic"]: ch["id"] for ch in json.loads(message)["channels"]}
    return ids


def _received(
    ws: ClientConnection, subscriptions: dict[int, int], until: Callable[[list[int]], bool]
) -> list[int]:
    """The channel ids of the messages received (a subscription id → its channel), until `until`."""
    got: list[int] = []
    deadline = time.monotonic() + 10.0
    while time.monotonic() < deadline and not until(got):
        message = ws.recv(timeout=5.0)
        if isinstance(message, bytes) and message[0] == MESSAGE_DATA:
            got.append(subscriptions[int.from_bytes(message[1:5], "little")])
    return got


def test_a_foxglove_viewer_gets_the_map_when_it_subscribes_and_the_live_data_after() -> None:
    gateway = StandIn()
    with open_recording(gateway, foxglove_port=0) as recording:
        assert recording is not None and recording.server is not None
        with connect(f"ws://127.0.0.1:{recording.server.port}", subprotocols=["foxglove.sdk.v1"]) as ws:  # type: ignore[list-item]
            ids = _channels(ws)
            topics = (c.TOPIC_MAP_NODES, c.TOPIC_TELEMETRY, c.TOPIC_TF)
            subscriptions = {k: ids[topic] for k, topic in enumerate(topics)}
            ws.send(
                json.dumps(
                    {
                        "op": "subscribe",
                        "subscriptions": [{"id": k, "channelId": ch} for k, ch in subscriptions.items()],
                    }
                )
            )
            # the map was published before this viewer came: it comes again for it
            assert _received(ws, subscriptions, lambda got: ids[c.TOPIC_MAP_NODES] in got)
            for tick in range(3):
                gateway.publish(telemetry(tick))
            got = _received(ws, subscriptions, lambda got: got.count(ids[c.TOPIC_TELEMETRY]) >= 3)
            assert got.count(ids[c.TOPIC_TELEMETRY]) == got.count(ids[c.TOPIC_TF]) == 3


def test_camera_frames_are_recorded_as_given(tmp_path: Path) -> None:
    image = np.zeros((48, 64, 3), np.uint8)
    image[10:30, 20:40] = (0, 200, 255)
    ok, encoded = cv2.imencode(".jpg", image)
    assert ok
    jpeg = encoded.tobytes()
    path = tmp_path / "camera.mcap"
    stamps = [1_700_000_000_000_000_000 + k * 40_000_000 for k in range(5)]
    with open_recording(StandIn(), path, camera_fps=25.0) as recording:  # 25 fps: every one kept
        assert recording is not None
        for stamp in stamps:
            recording.publish_camera_jpeg(jpeg, stamp)
    with path.open("rb") as stream:
        reader = make_reader(stream)
        frames = [(schema, message) for schema, _, message in reader.iter_messages(topics=[c.TOPIC_CAMERA])]
    assert len(frames) == len(stamps)
    for schema, message in frames:
        assert schema is not None and schema.name == "foxglove.CompressedImage"
        assert jpeg in message.data  # the JPEG's bytes whole, in the message's `data` field


def _recorded_frames(path: Path, camera_fps: float = DEFAULT_CAMERA_FPS) -> list[int]:
    """The log times of the camera frames kept of 3 s of a 15 fps camera, 0.2 s into the session."""
    start = time.time_ns() + 200_000_000
    with open_recording(StandIn(), path, camera_fps=camera_fps) as recording:
        assert recording is not None
        for k in range(45):
            recording.publish_camera_jpeg(b"\xff\xd8 a frame \xff\xd9", start + k * 66_666_667)
    with path.open("rb") as stream:
        reader = make_reader(stream)
        return [m.log_time for _, _, m in reader.iter_messages(topics=[c.TOPIC_CAMERA])]


def test_the_camera_is_recorded_at_a_bounded_rate(tmp_path: Path) -> None:
    """2 frames a second by default (the camera's 15 would be most of the file), as asked, or none."""
    assert len(_recorded_frames(tmp_path / "default.mcap")) == 6  # one every 0.5 s of the 3 s
    assert len(_recorded_frames(tmp_path / "five.mcap", camera_fps=5.0)) == 15
    assert _recorded_frames(tmp_path / "none.mcap", camera_fps=0.0) == []
    with open_recording(StandIn(), foxglove_port=0) as live:  # no file: the live view gets every frame
        assert live is not None and live.camera_fps is None


def test_the_map_is_recorded_as_grids_of_the_nodes_and_the_floor_plan(tmp_path: Path) -> None:
    cells = np.zeros((3, 4), np.int8)
    cells[0, 1], cells[2, 3] = 100, -1  # row 0 is the lowest y (nav_msgs/OccupancyGrid)
    path = tmp_path / "map.mcap"
    with open_recording(StandIn(OccupancyMap((-0.5, -0.5), 0.25, cells)), path):
        pass
    with path.open("rb") as stream:
        grids = {
            channel.topic: message.data
            for _, channel, message in make_reader(stream).iter_messages(
                topics=[c.TOPIC_MAP_NODES, c.TOPIC_MAP_FLOOR_PLAN]
            )
        }
    nodes = bytearray(5 * 4)
    nodes[1 * 5 + 2] = 100  # the obstacle at (0.4, 0.2): column 2 of row 1, 0.2 m apart
    assert bytes(nodes) in grids[c.TOPIC_MAP_NODES]
    assert cells.tobytes() in grids[c.TOPIC_MAP_FLOOR_PLAN]

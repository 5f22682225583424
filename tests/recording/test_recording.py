"""MCAP recordings (cart2d/recording/) read back with the `mcap` package, the Foxglove live view
and `cart2d replay`."""

from __future__ import annotations

import contextlib
import json
import os
import socket
import subprocess
import sys
import threading
import time
from collections import Counter
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient
from websockets.sync.client import connect

from cart2d.recording import channels as c
from cart2d.recording.replay import Player, read_recording
from cart2d.recording.replay_app import create_replay_app
from cart2d.server import serving
from cart2d.server.live import SAMPLE_KINDS
from cart2d.tools.missions.run import run_mission
from cart2d.tools.missions.spec import MissionSpec
from tests.support.cli import running_cart2d
from tests.support.recording import Read
from tests.support.server import BASE_URL, JSON
from tests.support.sockets import free_port
from tests.support.waiting import wait_for, wait_serving

SCHEMAS = {
    c.TOPIC_TF: ("foxglove.FrameTransforms", "protobuf"),
    c.TOPIC_ODOM_POSE: ("foxglove.PoseInFrame", "protobuf"),
    c.TOPIC_TRUTH_POSE: ("foxglove.PoseInFrame", "protobuf"),
    c.TOPIC_PLAN_SCENE: ("foxglove.SceneUpdate", "protobuf"),
    c.TOPIC_PLAN_POSES: ("foxglove.PosesInFrame", "protobuf"),
    c.TOPIC_MAP_NODES: ("foxglove.Grid", "protobuf"),
    c.TOPIC_LOG: ("foxglove.Log", "protobuf"),
    c.TOPIC_TELEMETRY: ("cart2d.Telemetry", "json"),
    c.TOPIC_WS: ("cart2d.WsMessage", "json"),
    c.TOPIC_MAP_VIEW: ("cart2d.MapView", "json"),
}
MISSION = {"obstacles": [[0.4, 0.2]], "start": [0.0, 0.0, 0.0], "goals": [[0.8, 0.4]], "timeout_s": 30}


@pytest.fixture(scope="module")
def mission_recording(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, Any]]:
    path = tmp_path_factory.mktemp("recording") / "mission.mcap"
    report = run_mission(MissionSpec.model_validate(MISSION), mcap_path=path)
    assert report["goals"][0]["reached"]
    return path, report


def test_a_mission_is_recorded_on_every_channel_with_the_foxglove_schemas(
    mission_recording: tuple[Path, dict[str, Any]],
) -> None:
    read = Read(mission_recording[0])
    for topic, (schema, encoding) in SCHEMAS.items():
        assert read.schemas[topic].name == schema, topic
        assert read.channels[topic].message_encoding == encoding, topic
        assert read.on(topic), f"no message on {topic}"
        assert read.schemas[topic].data  # a descriptor set or JSON schema a viewer can decode with


def test_each_telemetry_and_truth_message_has_its_foxglove_messages(
    mission_recording: tuple[Path, dict[str, Any]],
) -> None:
    read = Read(mission_recording[0])
    telemetry, truth = read.ws("telemetry"), read.ws("truth")
    assert len(telemetry) > 20 and len(truth) > 40  # 25 Hz and 50 Hz over a few simulated seconds
    for topic in (c.TOPIC_TF, c.TOPIC_ODOM_POSE, c.TOPIC_TELEMETRY):
        assert len(read.on(topic)) == len(telemetry), topic
    assert len(read.on(c.TOPIC_TRUTH_POSE)) == len(truth)
    assert [json.loads(m.data)["tick"] for m in read.on(c.TOPIC_TELEMETRY)] == [t["tick"] for t in telemetry]
    plans = [m["plan"] for m in read.ws("mission")]
    changes = sum(1 for before, after in zip([None, *plans], plans, strict=False) if after != before)
    assert len(read.on(c.TOPIC_PLAN_POSES)) == len(read.on(c.TOPIC_PLAN_SCENE)) == changes >= 1
    assert len(read.on(c.TOPIC_MAP_NODES)) == len(read.on(c.TOPIC_MAP_VIEW)) >= 1
    (view,) = [json.loads(m.data) for m in read.on(c.TOPIC_MAP_VIEW)]
    assert view["obstacles"] == [[0.4, 0.2]]
    counts = read.statistics.channel_message_counts
    assert sum(counts.values()) == read.statistics.message_count == len(read.messages)


def test_log_times_never_go_back_and_follow_the_simulated_time(
    mission_recording: tuple[Path, dict[str, Any]],
) -> None:
    path, report = mission_recording
    read = Read(path)
    times = [message.log_time for _, message in read.messages]
    assert times == sorted(times)
    truth_times = [m.log_time for m in read.on(c.TOPIC_TRUTH_POSE)]
    sim_t = [t["t"] for t in read.ws("truth")]
    for log_ns, t in zip(truth_times, sim_t, strict=True):
        assert abs((log_ns - truth_times[0]) - round((t - sim_t[0]) * 1e9)) <= 1
    # The file starts at simulated time 0 (the map, before the first truth message) and ends at the
    # last truth's; at --speed max a file on the wall clock would be several times shorter.
    span_s = (read.statistics.message_end_time - read.statistics.message_start_time) / 1e9
    assert span_s == pytest.approx(sim_t[-1], abs=1e-6)
    assert span_s > report["sim_time_s"] > 3.0


def is_subsequence(part: list[dict[str, Any]], whole: list[dict[str, Any]]) -> bool:
    """Whether `part` is `whole` with some items left out, in the same order."""
    rest = iter(whole)
    return all(any(item == candidate for candidate in rest) for item in part)


def test_replay_serves_the_recorded_ws_messages_in_order(
    mission_recording: tuple[Path, dict[str, Any]],
) -> None:
    """Over a real socket at the recorded pace (75 messages a second, as a live gateway sends):
    every /ws event of the recording, in its order, none dropped; of the samples (telemetry,
    truth) all but those the fan-out counted as thinned (a busy machine stalls the player, which
    then catches up in bursts over the sample budget: server/live.py), in their order."""
    recorded = read_recording(mission_recording[0])
    expected = recorded.ws_messages()
    player = Player(recorded, speed=1.0)
    app = create_replay_app(player)
    sock = serving.listening_socket("127.0.0.1", 0)
    port = sock.getsockname()[1]
    server = serving.server(app)
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    got: list[dict[str, Any]] = []
    try:
        wait_for(lambda: server.started, 20)
        assert player.state == "waiting"  # until the first viewer
        with connect(f"ws://127.0.0.1:{port}/ws") as ws:
            # first the state at the position (the start: nothing played yet) in one frame, then
            # the hello's frame, then the stream: each WebSocket message an array of messages
            first = json.loads(ws.recv(timeout=10.0))
            assert first[0]["type"] == "replay" and first[0]["trail"] == []
            hello, *rest = json.loads(ws.recv(timeout=10.0))
            assert hello["type"] == "hello"
            frame = rest
            with contextlib.suppress(TimeoutError):  # a dropped message would never come
                while True:
                    got.extend(m for m in frame if m["type"] != "replay")  # the replay's own: playing, ended
                    if any(m["type"] == "replay" and m["state"] == "ended" for m in frame):
                        break
                    frame = json.loads(ws.recv(timeout=10.0))
            viewers = app.state.viewers
            dropped = sum(viewer.dropped for viewer in viewers.viewers)
            thinned = sum(viewer.thinned for viewer in viewers.viewers) + sum(
                fanout.thinned for fanout in viewers.fanouts.values()
            )
        assert dropped == 0
        events = [m for m in expected if m["type"] not in SAMPLE_KINDS]
        assert [m for m in got if m["type"] not in SAMPLE_KINDS] == events
        assert is_subsequence(got, expected) and len(expected) - len(got) == thinned
        assert Counter(m["type"] for m in expected)["truth"] == len(
            Read(mission_recording[0]).on(c.TOPIC_TRUTH_POSE)
        )
        wait_for(lambda: player.state == "ended", 10.0)
        client = TestClient(app, base_url=BASE_URL, headers=JSON)
        status = client.get("/api/status").json()
        assert status["replay"]["state"] == "ended" and status["replay"]["sent"] == len(expected)
        assert status["replay"]["position_s"] == pytest.approx(recorded.duration_s, abs=1e-3)
        assert status["mission"]["state"] == "arrived" and status["link"]["simulated"]
        assert client.get("/api/map").json() == recorded.first_map_view()
    finally:
        server.should_exit = True
        thread.join(10)
        player.close()


def test_replay_changes_nothing(mission_recording: tuple[Path, dict[str, Any]]) -> None:
    player = Player(read_recording(mission_recording[0]))
    client = TestClient(create_replay_app(player), base_url=BASE_URL, headers=JSON)
    for method, path, body in (
        ("POST", "/api/goto", {"x": 0.2, "y": 0.2}),
        ("POST", "/api/drive", {"v": 0.1, "omega": 0.0}),
        ("POST", "/api/stop", {}),
        ("PUT", "/api/map/obstacle", {"x": 0.2, "y": 0.2, "present": True}),
    ):
        answer = client.request(method, path, json=body)
        assert answer.status_code == 409 and "replay" in answer.json()["detail"], path
    assert client.get("/api/sim/faults").status_code == 404  # the panel hides what a replay lacks
    assert player.state == "waiting" and player.sent == 0


def test_replay_refuses_a_file_that_is_no_recording(tmp_path: Path) -> None:
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(b"not an mcap file")
    done = subprocess.run(
        [sys.executable, "-m", "cart2d.tools.cli", "replay", str(bad)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 2 and "is not a readable MCAP recording" in done.stderr


def _advertised(ws: Any) -> set[str]:
    """The topics the Foxglove server advertises, from its first messages."""
    topics: set[str] = set()
    deadline = time.monotonic() + 10.0
    while time.monotonic() < deadline and not set(SCHEMAS) <= topics:
        message = ws.recv(timeout=5.0)
        if isinstance(message, str):
            data = json.loads(message)
            if data.get("op") == "advertise":
                topics |= {channel["topic"] for channel in data["channels"]}
    return topics


def test_sim_with_foxglove_serves_the_sdk_websocket_and_records(tmp_path: Path) -> None:
    """`cart2d sim --foxglove PORT --record DIR`: a Foxglove client connects with the SDK's
    subprotocol and is told the channels; the session's file is complete after a SIGTERM."""
    port, fox = free_port(), free_port()
    run = [
        "sim",
        "--port",
        str(port),
        "--foxglove",
        str(fox),
        "--record",
        str(tmp_path / "rec"),
        "--no-camera",
    ]
    with running_cart2d(tmp_path / "home", *run) as gateway:
        wait_serving(port)
        with connect(f"ws://127.0.0.1:{fox}", subprotocols=["foxglove.sdk.v1"]) as ws:  # type: ignore[list-item]
            assert ws.subprotocol == "foxglove.sdk.v1"
            first = json.loads(ws.recv(timeout=5.0))
            assert first["op"] == "serverInfo" and first["name"] == "cart2d"
            assert set(SCHEMAS) <= _advertised(ws)
        out = gateway.stop()
    assert f"ws://127.0.0.1:{fox}" in out
    (recording,) = (tmp_path / "rec").glob("cart2d-*.mcap")
    read = Read(recording)  # a file finished on SIGTERM has its summary
    assert len(read.on(c.TOPIC_TRUTH_POSE)) == len(read.ws("truth")) > 0


@pytest.mark.parametrize(
    ("options", "where"),
    [([], "reports/m.mcap"), (["--mcap", "elsewhere/run.mcap"], "elsewhere/run.mcap"), (["--no-mcap"], None)],
)
def test_a_mission_records_beside_its_report_unless_told(
    tmp_path: Path, options: list[str], where: str | None
) -> None:
    mission = tmp_path / "m.json"
    mission.write_text(json.dumps({"goals": [[0.2, 0.0]]}))
    (tmp_path / "reports").mkdir()
    report = tmp_path / "reports" / "m.report.json"
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "cart2d.tools.cli",
            "mission",
            str(mission),
            "--report",
            str(report),
            *options,
        ],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=tmp_path,
    )
    assert done.returncode == 0, done.stderr
    recordings = sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*.mcap"))
    assert recordings == ([where] if where else [])
    if where:
        shown = done.stderr.split("recording in ", 1)[1].split(" (cart2d replay")[0]
        assert (tmp_path / shown).resolve() == (tmp_path / where).resolve()
        assert Read(tmp_path / where).ws("telemetry")


def test_a_foxglove_port_in_use_is_one_sentence_before_anything_starts(tmp_path: Path) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        done = subprocess.run(
            [
                sys.executable,
                "-m",
                "cart2d.tools.cli",
                "sim",
                "--port",
                str(free_port()),
                "--foxglove",
                str(port),
            ],
            env={**os.environ, "CART2D_HOME": str(tmp_path)},
            capture_output=True,
            text=True,
            timeout=60,
        )
    assert done.returncode == 2
    assert (
        done.stderr.strip()
        == f"cart2d sim: --foxglove {port}: cannot listen on 127.0.0.1 (Address already in use)"
    )

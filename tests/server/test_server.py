"""The gateway's HTTP/WebSocket API, against the real firmware in the simulator."""

from __future__ import annotations

import json
import math
import socket
import time
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient
from starlette.testclient import WebSocketDenialResponse
from starlette.websockets import WebSocketDisconnect

from cart2d.link import Link
from cart2d.server import MAX_BODY_BYTES, create_app
from cart2d.simulation.side_channel import SimulatorError
from cart2d.simulation.simulator import Simulator
from cart2d.simulation.wiring import simulated_gateway
from cart2d.store import Store
from tests.support.cli import running_cart2d
from tests.support.server import BASE_URL, JSON, WS_BASE, Rig
from tests.support.sim import run_for, start_sim
from tests.support.waiting import wait_for, wait_serving


def raw(client: TestClient, method: str, url: str, body: str) -> Any:
    return client.request(method, url, content=body.encode(), headers=JSON)


def test_status_reports_link_firmware_and_pose(rig: Rig) -> None:
    status = rig.client.get("/api/status").json()
    assert status["link"] == {"state": "connected", "port": rig.sim.pty, "simulated": True}
    assert status["firmware"]["firmware"] == "0.1.0"
    assert status["status"]["mode"] == "IDLE" and status["pose"] == {"x": 0.0, "y": 0.0, "theta": 0.0}


def test_clearing_the_obstacles_removes_every_one_saves_and_says_which(rig: Rig) -> None:
    """DELETE /api/map/obstacles (the panel's "Clear obstacles"): all at once, saved, viewers told,
    and the answer names them (to put them back), as its documented response model says."""
    nodes = [[0.4, 0.4], [0.8, 1.2], [1.6, 0.2]]
    for x, y in nodes:
        assert rig.client.put("/api/map/obstacle", json={"x": x, "y": y}).status_code == 200
    version = rig.client.get("/api/map").json()["version"]
    told: list[dict[str, Any]] = []
    rig.gateway.subscribe(lambda m: told.append(m) if m["type"] == "map" else None)
    answer = rig.client.delete("/api/map/obstacles")
    assert answer.status_code == 200, answer.text
    body = answer.json()
    removed = sorted(body["removed"])
    assert [c for p in removed for c in p] == pytest.approx([c for p in sorted(nodes) for c in p])
    assert body["version"] == version + 1
    assert rig.client.get("/api/map").json()["obstacles"] == []
    assert rig.store.load().map.obstacles == []
    assert [m["version"] for m in told] == [version + 1]
    schema = rig.client.get("/openapi.json").json()
    ok = schema["paths"]["/api/map/obstacles"]["delete"]["responses"]["200"]["content"]["application/json"]
    assert ok["schema"]["$ref"].endswith("/ObstaclesClearedOut")
    # nothing left: nothing removed, and the map is not changed again
    again = rig.client.delete("/api/map/obstacles").json()
    assert again == {"removed": [], "version": version + 1}


def test_openapi_schema_documents_the_api(rig: Rig) -> None:
    paths = rig.client.get("/openapi.json").json()["paths"]
    for path in ("/api/goto", "/api/map/obstacle", "/api/command", "/api/stop", "/api/drive"):
        assert path in paths


def test_mission_through_obstacles_arrives_without_collision(rig: Rig) -> None:
    for x, y in [(0.8, 0.0), (0.8, 0.2), (0.8, 0.4)]:  # a wall across the direct route
        assert rig.client.put("/api/map/obstacle", json={"x": x, "y": y}).status_code == 200
    rig.sim.control("obstacles", points=[[0.8, 0.0], [0.8, 0.2], [0.8, 0.4]])
    plan = rig.client.post("/api/goto", json={"x": 1.6, "y": 0.2}).json()
    assert plan["length_m"] <= plan["grid_length_m"] + 1e-9 and plan["waypoints"][-1] == [1.6, 0.2]
    wait_for(lambda: rig.mission_state() != "driving", 60)
    truth = rig.sim.truth()
    assert rig.mission_state() == "arrived"
    assert math.hypot(truth["x"] - 1.6, truth["y"] - 0.2) < 0.01
    assert truth["collisions"] == 0


@pytest.mark.parametrize(
    ("goal", "fragment"),
    [
        ({"x": 5.0, "y": 0.0}, "off the map"),
        ({"x": 0.8, "y": 0.8}, "obstacle"),
        ({"x": 1.8, "y": 1.8}, "reach"),
    ],
)
def test_bad_goals_are_refused_and_nothing_is_sent(rig: Rig, goal: dict[str, float], fragment: str) -> None:
    rig.client.put("/api/map/obstacle", json={"x": 0.8, "y": 0.8})
    # A wall two nodes from the corner (1.8, 1.8): the corner stays free for the 0.17 m
    # footprint but cannot be reached.
    for x, y in [(1.4, 1.4), (1.4, 1.6), (1.4, 1.8), (1.6, 1.4), (1.8, 1.4)]:
        rig.client.put("/api/map/obstacle", json={"x": x, "y": y})
    response = rig.client.post("/api/goto", json=goal)
    assert response.status_code == 422
    assert fragment in response.json()["detail"]
    assert rig.mission_state() == "idle"
    assert rig.client.get("/api/status").json()["status"]["waypoint_count"] == 0


BAD_BODIES = [
    '{"x": NaN, "y": 0}',
    '{"x": Infinity, "y": 0}',
    '{"x": -Infinity, "y": 0}',
    '{"x": "one", "y": 0}',
    '{"x": 1e7, "y": 0}',
    '{"x": 0.5}',
    '{"x": 0.5, "y": 0.5, "z": 1}',
    "[0.5, 0.5]",
    "not json",
]


@pytest.mark.parametrize("body", BAD_BODIES)
def test_bad_inputs_get_4xx_with_a_message_and_change_nothing(rig: Rig, body: str) -> None:
    before = rig.client.get("/api/map").json()
    for method, url in [("POST", "/api/goto"), ("PUT", "/api/map/obstacle"), ("POST", "/api/drive")]:
        response = raw(
            rig.client,
            method,
            url,
            body.replace('"x"', '"v"').replace('"y"', '"omega"') if "drive" in url else body,
        )
        assert 400 <= response.status_code < 500, (url, response.text)
        assert response.json()["detail"]
    assert rig.client.get("/api/map").json() == before
    assert rig.mission_state() == "idle"
    assert rig.client.get("/api/status").json()["status"]["mode"] == "IDLE"


def test_oversized_bodies_are_refused(rig: Rig) -> None:
    big = '{"x": 0.5, "y": 0.5, "pad": "' + "a" * (MAX_BODY_BYTES + 1) + '"}'
    response = raw(rig.client, "POST", "/api/goto", big)
    assert response.status_code == 413 and "bytes" in response.json()["detail"]


def test_generic_command_form(rig: Rig) -> None:
    pose = rig.client.post("/api/command", json={"name": "POSE", "args": []}).json()
    assert pose == {
        "command": "COMMAND_POSE",
        "status": "CONTROL_OK",
        "results": [0.0, 0.0, 0.0],
        "message": "",
    }
    refused = rig.client.post("/api/command", json={"name": "TOL_SET", "args": [5.0]}).json()
    assert refused["status"] == "CONTROL_ERROR" and "out of range" in refused["message"]
    assert rig.client.post("/api/command", json={"name": "FLY", "args": []}).status_code == 422
    assert rig.client.post("/api/command", json={"name": "CONTROL_OK", "args": []}).status_code == 422
    too_many = {"name": "GOTO", "args": [0.0] * 32}
    assert rig.client.post("/api/command", json=too_many).status_code == 422
    names = {c["name"] for c in rig.client.get("/api/protocol").json()}
    assert {"GOTO", "POSE", "VELOCITY"} <= names
    for name in names - {"REBOOT"}:  # every listed name is accepted by the command form
        assert rig.client.post("/api/command", json={"name": name, "args": []}).status_code == 200


def test_firmware_settings_are_read_and_range_checked(rig: Rig) -> None:
    settings = {s["name"]: s for s in rig.client.get("/api/firmware/settings").json()}
    assert settings["v_max_mps"]["value"] == pytest.approx(0.5) and settings["v_max_mps"]["unit"] == "m/s"
    assert rig.client.put("/api/firmware/settings", json={"id": 6, "value": 0.3}).json()[
        "value"
    ] == pytest.approx(0.3)
    refused = rig.client.put("/api/firmware/settings", json={"id": 6, "value": 9.0})
    assert refused.status_code == 409 and "out of range" in refused.json()["detail"]
    assert rig.client.put("/api/firmware/settings", json={"id": 99, "value": 1.0}).status_code == 409


def test_emergency_stop_halts_a_moving_robot(rig: Rig) -> None:
    rig.client.post("/api/goto", json={"x": 1.6, "y": 1.6})
    wait_for(lambda: rig.sim.truth()["v"] > 0.2, 30)
    assert rig.client.post("/api/stop").status_code == 200
    mission = rig.client.get("/api/mission").json()
    assert mission["state"] == "failed" and "stopped" in mission["reason"]
    # The firmware replies to STOP at once and sets the motors at its next control tick (8 ms):
    # read them after that tick, not in the race before it (seen on a loaded machine).
    run_for(rig.sim, 0.008)
    truth = rig.sim.truth()
    assert truth["duty_l"] == 0.0 and truth["duty_r"] == 0.0


def test_settings_file_export_and_import(rig: Rig) -> None:
    rig.client.put("/api/map/obstacle", json={"x": 1.0, "y": 1.0})
    exported = rig.client.get("/api/settings/file")
    assert "attachment" in exported.headers["content-disposition"] and "token" not in exported.json()
    rig.client.put("/api/map/obstacle", json={"x": 1.0, "y": 1.0, "present": False})
    assert rig.client.post("/api/settings/file", content=exported.content).status_code == 200
    assert rig.client.get("/api/map").json()["obstacles"] == [[1.0, 1.0]]
    bad = rig.client.post("/api/settings/file", content=b'{"map": {"cols": 1}}')
    assert bad.status_code == 422 and "map.cols" in bad.json()["detail"]
    assert rig.client.get("/api/map").json()["obstacles"] == [[1.0, 1.0]]
    assert rig.store.load().map.obstacles == [(5, 5)]  # persisted


def test_websocket_streams_telemetry_and_truth(rig: Rig) -> None:
    with rig.client.websocket_connect(f"{WS_BASE}/ws") as ws:
        assert json.loads(ws.receive_text())[0]["type"] == "hello"  # a frame: an array of messages
        kinds: set[str] = set()
        # truth comes at 50 Hz of simulated time from the start, telemetry at 25 Hz once the link
        # has opened the port and the MCU has come out of the reset that opening causes: at full
        # simulator speed hundreds of truth messages may come first. Wait in wall time.
        deadline = time.monotonic() + 30
        while not {"telemetry", "truth"} <= kinds and time.monotonic() < deadline:
            kinds |= {message["type"] for message in json.loads(ws.receive_text())}
    assert {"telemetry", "truth"} <= kinds


def test_token_is_required_off_loopback(tmp_path: Path) -> None:
    rig = Rig(tmp_path, bind_host="0.0.0.0", token="s3cret-token-for-tests")
    try:
        assert rig.client.get("/api/status").status_code == 200  # reading is allowed
        refused = rig.client.post("/api/goto", json={"x": 0.4, "y": 0.0})
        assert refused.status_code == 401 and "token" in refused.json()["detail"]
        assert rig.mission_state() == "idle"
        wrong = {"X-Cart2d-Token": "wrong"}
        assert rig.client.post("/api/goto", json={"x": 0.4, "y": 0.0}, headers=wrong).status_code == 401
        assert (
            rig.client.post(
                "/api/pose/accept", headers={"X-Cart2d-Token": "s3cret-token-for-tests"}
            ).status_code
            == 200
        )
        bearer = {"Authorization": "Bearer s3cret-token-for-tests"}
        assert rig.client.post("/api/pose/accept", headers=bearer).status_code == 200
        with (
            pytest.raises(WebSocketDisconnect) as refused_ws,
            rig.client.websocket_connect(f"{WS_BASE}/ws") as ws,
        ):
            ws.receive_text()
        assert refused_ws.value.code == 1008
        with rig.client.websocket_connect(f"{WS_BASE}/ws?token=s3cret-token-for-tests") as ws:
            assert json.loads(ws.receive_text())[0]["type"] == "hello"
    finally:
        rig.close()


def test_the_stop_needs_no_token_and_stops_the_cart_but_not_for_another_site(tmp_path: Path) -> None:
    """Off loopback a change needs the token, but the stop does not: anyone who can reach the panel
    may stop the cart (SECURITY.md). Host, origin and content type are checked as for any change:
    another site's page cannot stop it (issue 22: a panel without the token got 401)."""
    secret = {"X-Cart2d-Token": "s3cret-token-for-tests"}
    # in real time: at full speed the cart arrived while a busy machine answered the refusals
    rig = Rig(tmp_path, bind_host="0.0.0.0", token=secret["X-Cart2d-Token"], speed="1")
    try:
        assert rig.client.post("/api/goto", json={"x": 1.6, "y": 0.0}, headers=secret).status_code == 200
        assert rig.mission_state() == "driving"
        evil = {"Origin": "http://evil.example", "Sec-Fetch-Site": "cross-site"}
        assert rig.client.post("/api/stop", headers=evil).status_code == 403
        assert rig.client.post("/api/stop", headers={"Content-Type": "text/plain"}).status_code == 415
        assert rig.client.post("/api/stop", headers={"Host": "evil.example"}).status_code == 421
        assert rig.mission_state() == "driving"
        stopped = rig.client.post("/api/stop")  # no token
        assert stopped.status_code == 200 and stopped.json() == {"result": "stopped"}
        mission = rig.client.get("/api/mission").json()
        assert mission["state"] == "failed" and mission["reason"] == "stopped by the user"
        reply = rig.client.post("/api/command", json={"name": "STATUS", "args": []}, headers=secret).json()
        assert reply["results"][0] == 0  # the firmware's mode: IDLE
        # and nothing else is allowed without it: not a START that would resume the mission
        start = rig.client.post("/api/command", json={"name": "START", "args": []})
        assert start.status_code == 401
    finally:
        rig.close()


def test_cross_origin_websocket_is_refused(rig: Rig) -> None:
    for evil in ({"origin": "http://evil.example"}, {"origin": "http://127.0.0.1:9999"}, {"origin": "null"}):
        # refused at the handshake, with a status and a sentence (the guard's, cart2d/server/guards.py)
        with (
            pytest.raises(WebSocketDenialResponse) as refused,
            rig.client.websocket_connect(f"{WS_BASE}/ws", headers=evil),
        ):
            pass
        assert refused.value.status_code == 403 and "origin" in refused.value.json()["detail"]
    with rig.client.websocket_connect(f"{WS_BASE}/ws", headers={"origin": BASE_URL}) as ws:
        assert json.loads(ws.receive_text())[0]["type"] == "hello"


def test_a_gateway_off_loopback_without_token_does_not_start(tmp_path: Path) -> None:
    sim: Simulator = start_sim(tmp_path)
    try:
        with Link(sim.pty) as link:
            gateway = simulated_gateway(
                link, Store(tmp_path / "g"), Store(tmp_path / "g").load(), sim
            ).gateway
            with pytest.raises(ValueError, match="token"):
                create_app(gateway, "0.0.0.0", None)
    finally:
        sim.stop()


def test_gateway_survives_the_simulator_being_killed_and_restarted(tmp_path: Path) -> None:
    rig = Rig(tmp_path)
    try:
        rig.client.put("/api/map/obstacle", json={"x": 1.0, "y": 1.0})
        run_for(rig.sim, 5.0)  # an uptime the new MCU's will not have caught up with when it answers
        # the gateway saw it (its monitor reads STATUS a few times a second)
        wait_for(lambda: rig.client.get("/api/status").json()["status"]["uptime_s"] >= 5.0, 10)
        rig.sim.kill()
        wait_for(lambda: rig.client.get("/api/status").json()["link"]["state"] == "reconnecting", 10)
        down = rig.client.post("/api/goto", json={"x": 0.4, "y": 0.0})
        assert down.status_code == 503 and "not reachable" in down.json()["detail"]
        # back on the same port name, in real time
        rig.sim = start_sim(tmp_path, pty_link=tmp_path / "robot-tty", speed="1")
        wait_for(lambda: rig.client.get("/api/status").json()["link"]["state"] == "connected", 10)
        assert rig.client.get("/api/map").json()["obstacles"] == [[1.0, 1.0]]  # the gateway kept its state
        # A new MCU: its restart is noticed (once it answers), and its pose (0, 0, 0) is not
        # planned from unasked.
        wait_for(lambda: rig.client.get("/api/status").json()["reset"]["noticed"] > 0, 10)
        status = rig.client.get("/api/status").json()
        assert status["reset"]["noticed"] == 1 and not status["pose_trust"]["trusted"]
        assert rig.client.post("/api/goto", json={"x": 0.4, "y": 0.0}).status_code == 409
        assert rig.client.post("/api/pose/accept").status_code == 200
        assert rig.client.post("/api/goto", json={"x": 0.4, "y": 0.0}).status_code == 200
    finally:
        rig.close()


@pytest.mark.parametrize("step", [5e-324, 1e-300, 0.0])
def test_a_settings_file_with_a_tiny_grid_step_is_refused_quickly(rig: Rig, step: float) -> None:
    """Found by fuzzing: a tiny step used to crash the planner (500) or exhaust memory."""
    body = json.dumps({"map": {"step_m": step}}).encode()
    response = rig.client.post("/api/settings/file", content=body)
    assert response.status_code == 422 and "map.step_m" in response.json()["detail"]
    assert rig.client.get("/api/map").json()["step_m"] == 0.2


@pytest.mark.parametrize("body", ['{"port": true}', '{"port": "80"}', '{"host": 1}'])
def test_network_settings_take_no_coercion(rig: Rig, body: str) -> None:
    response = raw(rig.client, "PUT", "/api/settings/network", body)
    assert response.status_code == 422
    assert rig.client.get("/api/settings").json()["network"]["port"] == 8080


def test_map_gives_the_arena_walls_the_simulator_uses(rig: Rig) -> None:
    arena = rig.client.get("/api/map").json()["arena"]
    # The grid spans 0..1.8 m; the walls stand 0.25 m outside it (config/robot.toml, [sim]).
    assert arena == pytest.approx({"x_min": -0.25, "y_min": -0.25, "x_max": 2.05, "y_max": 2.05})
    # The simulator agrees (the gateway gave it the walls of its map): placing the cart's 0.17 m
    # disc against the east wall works (a nanometre off: an exact touch is decided by rounding),
    # beyond fails.
    rig.sim.control("place", x=2.05 - 0.17 - 1e-9, y=0.9)
    with pytest.raises(SimulatorError):
        rig.sim.control("place", x=2.05 - 0.16, y=0.9)


def test_sigterm_stops_cart2d_sim_and_its_simulator_before_it_exits(tmp_path: Path) -> None:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    run = ["sim", "--port", str(port), "--host", "127.0.0.1", "--no-camera"]
    with running_cart2d(tmp_path, *run) as gateway:
        wait_serving(port)
        gateway.stop()
        assert gateway.process.returncode == 0  # a clean stop, as with Ctrl-C
        # The simulator writes its EEPROM image when it exits: it was stopped, not orphaned.
        assert (tmp_path / "sim-eeprom.bin").exists()

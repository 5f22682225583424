"""STOP then START from the command form: the firmware keeps its path and START resumes it, so
the mission drives again and ends as the path does (arrived), a long path's stream included."""

from __future__ import annotations

import math
from pathlib import Path

from bench.streaming import ARENA_NODES, ARENA_STEP_M, serpentine_mission
from cart2d.link import Link
from cart2d.planning import Grid
from cart2d.simulation.wiring import simulated_gateway
from cart2d.spec import load_spec
from cart2d.store import GatewaySettings, MapSettings, Store
from tests.support.server import Rig
from tests.support.sim import start_sim
from tests.support.waiting import wait_for


def command(rig: Rig, name: str) -> None:
    answer = rig.client.post("/api/command", json={"name": name, "args": []})
    assert answer.status_code == 200 and answer.json()["status"] == "CONTROL_OK", answer.text


def test_start_after_stop_resumes_the_mission_to_its_arrival(rig: Rig) -> None:
    assert rig.client.post("/api/goto", json={"x": 1.6, "y": 1.6}).status_code == 200
    wait_for(lambda: rig.sim.truth()["v"] > 0.2, 30)
    command(rig, "STOP")
    stopped = rig.client.get("/api/mission").json()
    assert stopped["state"] == "failed" and stopped["reason"] == "stopped by the user"
    command(rig, "START")
    resumed = rig.client.get("/api/mission").json()
    assert resumed["state"] == "driving" and resumed["reason"] == "" and resumed["goal"] == [1.6, 1.6]
    wait_for(lambda: rig.mission_state() != "driving", 60)
    assert rig.client.get("/api/mission").json()["state"] == "arrived"
    truth = rig.sim.truth()
    assert math.hypot(truth["x"] - 1.6, truth["y"] - 1.6) < 0.01


def test_start_after_another_path_does_not_resume_the_old_mission(rig: Rig) -> None:
    assert rig.client.post("/api/goto", json={"x": 1.6, "y": 1.6}).status_code == 200
    wait_for(lambda: rig.sim.truth()["v"] > 0.2, 30)
    command(rig, "STOP")
    goto = rig.client.post("/api/command", json={"name": "GOTO", "args": [0.0, 0.0]})
    assert goto.json()["status"] == "CONTROL_OK"
    command(rig, "STOP")
    command(rig, "START")  # drives the user's GOTO, not the mission's path
    mission = rig.client.get("/api/mission").json()
    assert mission["state"] == "failed" and mission["reason"] == "stopped by the user"


def test_start_after_stop_resumes_a_long_path_and_its_stream(tmp_path: Path) -> None:
    """A path of 111 waypoints, more than three windows: the stop ends its stream with points
    unsent; START resumes the path and the stream, and the cart arrives."""
    mission = serpentine_mission()
    grid = Grid(cols=ARENA_NODES, rows=ARENA_NODES, step_m=ARENA_STEP_M)
    nodes = sorted({grid.nearest_node(x, y) for x, y in mission["obstacles"]})
    sim = start_sim(tmp_path, grid=(ARENA_NODES, ARENA_STEP_M), start=tuple(mission["start"]))
    try:
        with Link(sim.pty) as link:
            settings = GatewaySettings(
                map=MapSettings(cols=ARENA_NODES, rows=ARENA_NODES, step_m=ARENA_STEP_M, obstacles=nodes)
            )
            gateway = simulated_gateway(link, Store(tmp_path / "gateway"), settings, sim).gateway
            gateway.check_firmware()
            link.call("SET_POSE", *mission["start"])
            gateway.start()
            try:
                goal = mission["goals"][0]
                plan = gateway.go_to(*goal)
                assert len(plan.waypoints) > 3 * gateway.waypoint_capacity
                wait_for(lambda: link.call("STATUS")[2] >= 10, 60)  # the 10th waypoint is current
                gateway.stop()
                stream = gateway.path_stream
                assert stream is not None and stream.sent < stream.count  # points left unsent
                assert gateway.mission_view()["state"] == "failed"
                assert gateway.command(load_spec().code("START"), ()).ok
                assert gateway.mission_view()["state"] == "driving"
                wait_for(lambda: gateway.mission_view()["state"] != "driving", 120)
                assert gateway.mission_view()["state"] == "arrived", gateway.mission_view()["reason"]
                truth = sim.truth()
                assert math.hypot(truth["x"] - goal[0], truth["y"] - goal[1]) < 0.01
                resumed = gateway.path_stream
                assert resumed is not stream and resumed is not None and resumed.sent == resumed.count
            finally:
                gateway.close()
    finally:
        sim.stop()

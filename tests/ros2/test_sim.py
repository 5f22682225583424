"""cmd_vel from a DDS writer drives the simulated cart (its ground truth), which stops once the
commands have been silent for the manual timeout (0.5 s, simulated time), and a stop on the API
wins over a stream of cmd_vel that goes on."""

from __future__ import annotations

import math
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from cart2d.ros2 import qos
from cart2d.ros2 import types as t
from cart2d.ros2.action import SUCCEEDED
from cart2d.ros2.bridge import Bridge
from cart2d.store import GatewaySettings
from tests.support.gateway import GatewayRig
from tests.support.ros2 import ACTION, GUID, Peer, call, matched, options, samples, send_goal
from tests.support.sim import high_rate_truth, run_for
from tests.support.waiting import wait_for

STILL_MPS = 0.01
DECELERATION_S = 0.3  # from 0.2 m/s at the firmware's a_max of 1 m/s^2: 0.2 s, and a margin


@pytest.fixture
def rig(tmp_path: Path) -> Iterator[GatewayRig]:
    r = GatewayRig(tmp_path, GatewaySettings())
    yield r
    r.close()


class Teleop:
    """teleop_twist_keyboard held down: a Twist again and again on its own thread until stopped."""

    def __init__(self, peer: Peer, v_mps: float) -> None:
        self.writer = peer.writer("rt/cmd_vel", t.Twist, qos.stream())
        matched(self.writer)
        self.v_mps = v_mps
        self.written = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def __enter__(self) -> Teleop:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()

    def _run(self) -> None:
        while not self._stop.wait(0.005):  # pacing only: the assertions are in simulated time
            self.writer.write(t.Twist(t.Vector3(self.v_mps)))
            self.written += 1


def moving(truth: dict[str, Any]) -> bool:
    return abs(float(truth["v"])) > STILL_MPS


def test_cmd_vel_drives_the_cart_and_a_silence_stops_it(rig: GatewayRig) -> None:
    bridge = Bridge(rig.gateway, options()).start()
    peer = Peer()
    try:
        truth = high_rate_truth(rig.sim, 200.0)
        with Teleop(peer, 0.2):
            wait_for(lambda: bool(truth) and float(truth[-1]["v"]) > 0.15, 60.0)
            x_start = float(truth[-1]["x"])
        for _ in range(2):  # the last samples read after the writer stopped are sent too
            wait_for(lambda: not bridge.inbound.driver.busy, 20.0)
            run_for(rig.sim, 0.05)
        silent_from = rig.sim.truth()["t"]  # the last command reached the firmware before this
        run_for(rig.sim, 0.5 + DECELERATION_S + 0.2)
        after = [s for s in truth if s["t"] >= silent_from + 0.5 + DECELERATION_S]
        assert after and not any(moving(s) for s in after)
        assert float(truth[-1]["x"]) > x_start  # it drove forwards (world x: its heading at start)
    finally:
        bridge.close()
        peer.close()


def test_a_stop_on_the_api_wins_over_a_stream_of_cmd_vel(rig: GatewayRig) -> None:
    bridge = Bridge(rig.gateway, options()).start()
    peer = Peer()
    try:
        # 50 samples a simulated second: at full speed, 200 were 4000 a second for this process
        # to read beside the bridge, and a busy machine once left the simulator's acks 10 s behind
        truth = high_rate_truth(rig.sim, 50.0)
        with Teleop(peer, 0.2) as teleop:
            wait_for(lambda: bool(truth) and float(truth[-1]["v"]) > 0.15, 60.0)
            rig.gateway.stop()
            stopped_at = rig.sim.truth()["t"]
            written = teleop.written
            run_for(rig.sim, 1.5)
            # a command of the stream after the stop is refused or skipped: at this process's pace,
            # which a busy machine slows (1.5 simulated seconds at full speed had passed before the
            # driver's thread got to one: fresh run 4)
            driver = bridge.inbound.driver
            wait_for(lambda: driver.cancelled + driver.skipped >= 1, 20.0)
            assert teleop.written > written  # the stream went on all along
        held = [s for s in truth if s["t"] >= stopped_at + DECELERATION_S]
        assert held and not any(moving(s) for s in held)
    finally:
        bridge.close()
        peer.close()


def test_navigate_to_pose_goes_round_an_obstacle_with_feedback(rig: GatewayRig) -> None:
    bridge = Bridge(rig.gateway, options()).start()
    peer = Peer()
    try:
        start = rig.gateway.mission_view()  # idle, at the simulator's start pose
        x0, y0 = float(rig.sim.truth()["x"]), float(rig.sim.truth()["y"])
        goal = (x0 + 0.8, y0)
        rig.gateway.set_obstacle(x0 + 0.4, y0, True)  # on the straight line
        # every feedback kept (5 a second): read after the result, a short history holds only the
        # last seconds, all at the goal on a busy machine
        feedback = peer.reader(f"rt/{ACTION}/feedback", t.NavigateToPoseFeedbackMessage, qos.stream(1000))
        matched(feedback)
        goal_id = bytes(range(60, 76))
        assert start["state"] == "idle" and send_goal(peer, goal_id, *goal, seq=1).accepted
        request = t.NavigateToPoseGetResultRequest(GUID, 2, t.UUID(goal_id))
        result = call(peer, f"{ACTION}/get_result", request, t.NavigateToPoseGetResultResponse)
        assert result.status == SUCCEEDED, result.result.error_msg
        plan = rig.gateway.mission_view()["plan"]
        assert len(plan["waypoints"]) >= 2  # not straight through the obstacle
        distances = [f.feedback.distance_remaining for f in samples(feedback, lambda got: len(got) >= 2)]
        assert distances[0] > distances[-1]
        truth = rig.sim.truth()
        assert math.dist((truth["x"], truth["y"]), goal) < 0.05
    finally:
        bridge.close()
        peer.close()

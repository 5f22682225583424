"""The stop and reset_odometry services and the navigate_to_pose action, as an rmw_cyclonedds_cpp
client frames them (its request header echoed in the reply), over a Gateway on the fake firmware."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from cart2d.gateway import Gateway
from cart2d.ros2 import qos
from cart2d.ros2 import types as t
from cart2d.ros2.action import ABORTED, CANCEL_NONE, CANCELED, EXECUTING, SUCCEEDED
from cart2d.ros2.bridge import Bridge
from tests.support.fake_firmware import FakeFirmware
from tests.support.ros2 import ACTION, GUID, Peer, call, matched, options, samples, send_goal
from tests.support.waiting import wait_for


@pytest.fixture
def bridge(gateway: Gateway) -> Iterator[Bridge]:
    b = Bridge(gateway, options()).start()
    yield b
    b.close()


@pytest.fixture
def peer() -> Iterator[Peer]:
    p = Peer()
    yield p
    p.close()


def test_the_stop_service_stops_and_answers_its_caller(
    bridge: Bridge, peer: Peer, cart: FakeFirmware
) -> None:
    reply = call(peer, "stop", t.TriggerRequest(GUID, 7), t.TriggerResponse)
    assert (reply.success, reply.message) == (True, "stopped")
    assert "STOP" in cart.requests


def test_reset_odometry_sets_the_pose_to_the_origin(bridge: Bridge, peer: Peer, cart: FakeFirmware) -> None:
    reply = call(peer, "reset_odometry", t.TriggerRequest(GUID, 3), t.TriggerResponse)
    assert reply.success and cart.pose == [0.0, 0.0, 0.0]


def status_of(peer: Peer, goal_id: bytes, wanted: int) -> None:
    reader = peer.reader(f"rt/{ACTION}/status", t.GoalStatusArray, qos.latched())

    def reached(got: list[t.GoalStatusArray]) -> bool:
        return any(
            s.goal_info.goal_id.uuid == goal_id and s.status == wanted for a in got for s in a.status_list
        )

    samples(reader, reached)


def test_a_goal_reached_with_feedback_and_its_result(
    bridge: Bridge, peer: Peer, gateway: Gateway, cart: FakeFirmware
) -> None:
    goal_id = bytes(range(1, 17))
    feedback = peer.reader(f"rt/{ACTION}/feedback", t.NavigateToPoseFeedbackMessage, qos.stream())
    matched(feedback)
    assert send_goal(peer, goal_id, 1.6, 0.8, seq=1).accepted
    wait_for(lambda: gateway.mission_view()["state"] == "driving", 20.0)
    status_of(peer, goal_id, EXECUTING)
    for tick in range(0, 50, 5):  # the firmware's telemetry on the way (0.6 m from the goal)
        bridge.on_message(
            {"type": "telemetry", "x": 1.0, "y": 0.8, "theta": 0.0, "v_left": 0.2, "v_right": 0.2, "v": 0.2,
             "omega": 0.0, "tick": tick, "waypoint_index": 0, "distance_to_waypoint": 0.6}
        )  # fmt: skip
    got = samples(feedback, lambda got: len(got) >= 1)[-1]
    assert bytes(got.goal_id.uuid) == goal_id
    assert got.feedback.distance_remaining == pytest.approx(0.6)
    assert got.feedback.current_pose.pose.position.x == 1.0
    cart.arrive()
    gateway.monitor.look()
    request = t.NavigateToPoseGetResultRequest(GUID, 2, t.UUID(goal_id))
    result = call(peer, f"{ACTION}/get_result", request, t.NavigateToPoseGetResultResponse)
    assert (result.status, result.result.error_code) == (SUCCEEDED, 0)


def test_a_goal_cancelled_stops_the_cart_and_ends_cancelled(
    bridge: Bridge, peer: Peer, gateway: Gateway, cart: FakeFirmware
) -> None:
    goal_id = bytes(range(20, 36))
    assert send_goal(peer, goal_id, 1.6, 0.8, seq=1).accepted
    status_of(peer, goal_id, EXECUTING)
    cancel = t.CancelGoalRequest(GUID, 2, t.GoalInfo(t.UUID(goal_id)))
    reply = call(peer, f"{ACTION}/cancel_goal", cancel, t.CancelGoalResponse)
    assert reply.return_code == CANCEL_NONE and [bytes(g.goal_id.uuid) for g in reply.goals_canceling] == [
        goal_id
    ]
    assert "STOP" in cart.requests
    request = t.NavigateToPoseGetResultRequest(GUID, 3, t.UUID(goal_id))
    result = call(peer, f"{ACTION}/get_result", request, t.NavigateToPoseGetResultResponse)
    assert result.status == CANCELED and result.result.error_code != 0
    assert gateway.mission_view()["state"] == "failed"


def test_a_goal_without_a_route_is_aborted(bridge: Bridge, peer: Peer, gateway: Gateway) -> None:
    goal_id = bytes(range(40, 56))
    assert send_goal(peer, goal_id, 50.0, 50.0, seq=1).accepted  # far beyond the map
    request = t.NavigateToPoseGetResultRequest(GUID, 2, t.UUID(goal_id))
    result = call(peer, f"{ACTION}/get_result", request, t.NavigateToPoseGetResultResponse)
    assert result.status == ABORTED and result.result.error_msg

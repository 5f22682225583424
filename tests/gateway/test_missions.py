"""The gateway's mission logic against a fake firmware (fake_firmware.py): no simulator, no port,
no thread of its own (the monitor is not started; a test reads STATUS where the monitor would)."""

from __future__ import annotations

import pytest

from cart2d.gateway import Gateway, PoseUntrusted
from cart2d.gateway.bus import Event, MapChanged, MissionEnded, MissionStarted, PoseCorrected, Restarted
from cart2d.link import MotionCancelled
from cart2d.planning import StartBlocked
from tests.support.fake_firmware import FakeFirmware

ACROSS = [(1.0, 0.6), (1.0, 0.8), (1.0, 1.0)]  # three nodes across the straight route at y = 0.8


@pytest.fixture
def events(gateway: Gateway) -> list[Event]:
    seen: list[Event] = []
    gateway.bus.subscribe(Event, seen.append)
    return seen


def test_a_goal_is_planned_from_the_measured_pose_and_sent(
    gateway: Gateway, cart: FakeFirmware, events: list[Event]
) -> None:
    plan = gateway.go_to(1.6, 0.8)
    assert plan.start == (0.2, 0.8) and cart.path[-1] == pytest.approx((1.6, 0.8))
    assert gateway.mission_view()["state"] == "driving"
    assert MissionStarted((1.6, 0.8)) in events
    cart.arrive()
    gateway.monitor.look()  # the monitor's round
    assert gateway.mission_view()["state"] == "arrived"
    assert events[-1] == MissionEnded((1.6, 0.8), "arrived", "")


def test_a_goal_asked_for_before_a_stop_is_refused_unsent(gateway: Gateway, cart: FakeFirmware) -> None:
    token = cart.motion_token()
    gateway.stop()
    with pytest.raises(MotionCancelled):
        gateway.go_to(1.6, 0.8, token)
    assert "WAIT_XY_ARRAY" not in cart.requests and gateway.mission_view()["state"] == "idle"


def test_a_stop_ends_the_mission_it_cut_short(
    gateway: Gateway, cart: FakeFirmware, events: list[Event]
) -> None:
    gateway.go_to(1.6, 0.8)
    gateway.stop("stopped by the user")
    view = gateway.mission_view()
    assert (view["state"], view["reason"]) == ("failed", "stopped by the user")
    assert cart.mode == "IDLE" and cart.requests[-1] == "STOP"
    assert events[-1] == MissionEnded((1.6, 0.8), "failed", "stopped by the user")
    assert gateway.mission.resumable  # the firmware keeps the path: START resumes it


def test_a_restart_ends_the_mission_and_leaves_the_pose_untrusted(
    gateway: Gateway, cart: FakeFirmware, events: list[Event]
) -> None:
    gateway.go_to(1.6, 0.8)
    cart.restart()
    gateway.read_status()  # the monitor's next look
    assert gateway.mission_view()["state"] == "failed"
    assert "the controller restarted" in gateway.mission_view()["reason"]
    assert not gateway.pose_trust.trusted and gateway.resets_noticed == 1
    restarted = [e for e in events if isinstance(e, Restarted)]
    assert restarted == [Restarted(expected=False, caused_by="", pose_trusted=False, mission_ended=True)]
    sent = cart.requests.count("WAIT_XY_ARRAY")
    with pytest.raises(PoseUntrusted, match="not trusted"):
        gateway.go_to(1.6, 0.8)
    assert cart.requests.count("WAIT_XY_ARRAY") == sent  # nothing planned from an untrusted pose


def test_setting_the_pose_trusts_it_again(gateway: Gateway, cart: FakeFirmware, events: list[Event]) -> None:
    cart.restart()
    gateway.read_status()
    gateway.set_pose(0.2, 0.8, 0.0)
    assert gateway.pose_trust.trusted and isinstance(events[-1], PoseCorrected)
    gateway.go_to(1.6, 0.8)
    assert gateway.mission_view()["state"] == "driving"


def test_an_obstacle_on_the_driven_route_replans_it(
    gateway: Gateway, cart: FakeFirmware, events: list[Event]
) -> None:
    gateway.go_to(1.6, 0.8)
    straight = list(cart.path)
    assert all(y == pytest.approx(0.8) for _, y in straight)
    gateway.change_obstacles(ACROSS, [], "a box was put down")
    assert MapChanged(2, "a box was put down") in events
    (replan,) = gateway.mission.replans
    assert replan.outcome == "replanned" and replan.reason == "the map changed: a box was put down"
    assert cart.path != straight and cart.path[-1] == pytest.approx((1.6, 0.8))
    assert gateway.mission_view()["state"] == "driving"


def test_an_obstacle_off_the_route_replans_nothing(gateway: Gateway, cart: FakeFirmware) -> None:
    gateway.go_to(1.6, 0.8)
    sent = cart.requests.count("WAIT_XY_ARRAY")
    gateway.change_obstacles([(1.0, 1.6)], [], "a box far from the route")
    assert not gateway.mission.replans and cart.requests.count("WAIT_XY_ARRAY") == sent


def test_an_obstacle_on_the_goal_fails_the_mission_and_stops_the_cart(
    gateway: Gateway, cart: FakeFirmware
) -> None:
    gateway.go_to(1.6, 0.8)
    gateway.change_obstacles([(1.6, 0.8)], [], "a box on the goal")
    view = gateway.mission_view()
    assert view["state"] == "failed" and "no path remains" in view["reason"]
    assert cart.mode == "IDLE" and "STOP" in cart.requests


def test_manual_driving_takes_the_mission_over(gateway: Gateway, cart: FakeFirmware) -> None:
    gateway.go_to(1.6, 0.8)
    gateway.drive(0.1, 0.0)
    view = gateway.mission_view()
    assert (view["state"], view["reason"]) == ("failed", "taken over by manual driving")
    assert not gateway.mission.resumable  # VELOCITY replaced the firmware's path


def test_abort_ends_only_the_mission_and_routine_it_was_meant_for(
    gateway: Gateway, cart: FakeFirmware
) -> None:
    gateway.go_to(1.6, 0.8)
    first = gateway.mission
    gateway.go_to(1.6, 1.2)  # a new goal: a new mission
    assert gateway.abort("a fault of the first mission", mission=first) is None
    assert gateway.mission_view()["state"] == "driving"
    assert gateway.abort("a fault now") == (1.6, 1.2)
    assert gateway.mission_view()["reason"] == "a fault now"
    assert gateway.abort("nothing drives") is None and gateway.mission_view()["reason"] == "a fault now"


def test_a_stop_fails_the_reset_routine_before_it_squared_up(gateway: Gateway, cart: FakeFirmware) -> None:
    gateway.start_reset_routine()
    assert gateway.routine_view()["state"] == "running"
    gateway.stop("stopped by the user")
    assert gateway.routine_view() == {"state": "failed", "words": "stopped by the user before it squared up"}


def test_the_plan_stays_an_object_in_the_mission_and_is_rendered_in_its_view(gateway: Gateway) -> None:
    plan = gateway.go_to(1.6, 0.8)
    assert gateway.mission.plan is plan
    view = gateway.mission_view()["plan"]
    assert view["waypoints"] == [list(p) for p in plan.waypoints] and view["length_m"] == pytest.approx(1.4)


def test_a_cart_within_its_clearance_of_an_obstacle_still_takes_a_goal(
    gateway: Gateway, cart: FakeFirmware
) -> None:
    """Perception may mark a face a cell nearer than it is after the cart stopped beside it: the
    cart's body clears it, so the plan starts at the nearest place the cart may stand
    (way_out.py), a short straight move, and not refused for good; one deeper is refused."""
    gateway.change_obstacles([(0.6, 0.8)], [], "a box")  # its square spans x 0.5-0.7
    cart.pose = [0.31, 0.8, 0.0]  # 0.19 m from it: within footprint and clearance (0.2 m)
    plan = gateway.go_to(0.2, 0.2)
    assert 0.0 < abs(complex(*plan.start) - complex(0.31, 0.8)) <= 0.03 + 1e-9
    assert cart.path[-1] == pytest.approx((0.2, 0.2))
    gateway.stop()
    cart.pose = [0.36, 0.8, 0.0]  # 0.14 m from it: inside the footprint
    with pytest.raises(StartBlocked):
        gateway.go_to(0.2, 0.2)


def test_a_replan_from_within_the_clearance_goes_on_from_the_nearest_place_to_stand(
    gateway: Gateway, cart: FakeFirmware
) -> None:
    """The CI's 'no path remains: the cart's position is ... too close' (issue 26): a face marked
    0.19 m beside the driving cart blocked both its position and its route's entry."""
    gateway.go_to(1.6, 0.8)
    cart.pose = [0.31, 0.89, 0.0]  # 0.09 m off its route, 0.19 m from the box's square (y 0.5-0.7)
    gateway.change_obstacles([(0.4, 0.6), *ACROSS], [], "a box beside, a wall across")
    (replan,) = gateway.mission.replans
    assert replan.outcome == "replanned", replan
    assert gateway.mission_view()["state"] == "driving" and cart.path[-1] == pytest.approx((1.6, 0.8))

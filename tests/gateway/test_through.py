"""A mission through stops (through.py, issue 27: a fleet cart's released nodes as one path)
against a fake firmware: one path through each stop in turn, and a replan that keeps to the
stops not passed yet (a fleet cart must not cut across nodes not released to it)."""

from __future__ import annotations

import itertools
import math

import pytest

from cart2d.gateway import Gateway
from cart2d.gateway.bus import Event, MissionEnded
from tests.support.fake_firmware import FakeFirmware

STOP = (1.0, 1.4)  # off the straight route from the cart (0.2, 0.8) to the goal (1.6, 0.8)


def distance_to_path(point: tuple[float, float], path: list[tuple[float, float]]) -> float:
    best = math.inf
    for (ax, ay), (bx, by) in itertools.pairwise(path):
        dx, dy = bx - ax, by - ay
        t = max(0.0, min(1.0, ((point[0] - ax) * dx + (point[1] - ay) * dy) / (dx * dx + dy * dy or 1.0)))
        best = min(best, math.dist(point, (ax + t * dx, ay + t * dy)))
    return best


def test_one_path_through_the_stops_and_a_replan_through_those_not_passed(
    gateway: Gateway, cart: FakeFirmware
) -> None:
    ended: list[Event] = []
    gateway.bus.subscribe(MissionEnded, ended.append)
    plan = gateway.missions.go_to(1.6, 0.8, via=(STOP,))
    assert cart.requests.count("WAIT_XY_ARRAY") == 1 and cart.path[-1] == pytest.approx((1.6, 0.8))
    assert distance_to_path(STOP, [(0.2, 0.8), *cart.path]) < 0.1  # its corner rounded
    assert plan.length_m > 1.4 + 0.3  # the way round by the stop, not the straight 1.4 m
    gateway.change_obstacles([(0.6, 1.0)], [], "a box on the way up")  # on the first leg
    assert gateway.mission.replans[-1].outcome == "replanned"
    assert distance_to_path(STOP, [(0.2, 0.8), *cart.path]) < 0.1  # still through the stop
    gateway.missions.passed(STOP)
    gateway.change_obstacles([(0.9, 1.2)], [], "another box")  # on the route by the stop
    assert gateway.mission.replans[-1].outcome == "replanned"
    assert distance_to_path(STOP, [(0.2, 0.8), *cart.path]) > 0.3  # passed: straight to the goal
    cart.arrive()
    gateway.monitor.look()
    assert ended == [MissionEnded((1.6, 0.8), "arrived", "")]  # one mission, ended at its goal

"""The look before driving off (cart2d/gateway/look.py) with what it takes, a link, the routes'
planner and the perception, and no Gateway: a fake firmware that turns on the spot as VELOCITY
asks, and a perception that has observed everything or nothing."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pytest

from cart2d.gateway.live_map import planner_for
from cart2d.gateway.look import LOOK_SIDE_RAD, MAX_LOOKS, TURN_TOLERANCE_RAD, look_before_driving
from cart2d.link import MotionCancelled
from cart2d.store import MapSettings
from tests.support.fake_firmware import FakeFirmware

REFRESH_TURN_S = 0.04  # a VELOCITY turns the fake cart for this long (look.REFRESH_S)


class TurningCart(FakeFirmware):
    """Turns by omega for a refresh's time at each VELOCITY; tells its top speeds."""

    def _results(self, name: str, args: list[float]) -> tuple[float, ...]:
        if name == "VELOCITY":
            self.pose[2] += args[1] * REFRESH_TURN_S
        if name == "MAX_SPEED_GET":
            return (0.5, 4.0)
        return super()._results(name, args)


class FakeSeeing:
    def __init__(self, observed: bool) -> None:
        self.all_observed = observed
        self.looks: list[tuple[float, float, float] | None] = []

    def look(self, at: tuple[float, float, float] | None = None) -> bool:
        self.looks.append(at)
        return True

    def observed(self, points: Sequence[Sequence[float]]) -> np.ndarray:
        return np.full(len(points), self.all_observed)


def cart_at(x: float, y: float, theta: float) -> TurningCart:
    cart = TurningCart()
    cart.pose = [x, y, theta]
    return cart


def test_with_the_floor_beside_the_way_observed_the_cart_drives_off_without_turning() -> None:
    cart, seeing, planner = cart_at(0.2, 0.8, 0.0), FakeSeeing(True), planner_for(MapSettings())
    turns = look_before_driving(cart, lambda: planner, seeing, (1.6, 0.8), None)  # type: ignore[arg-type]
    assert turns == 0 and "VELOCITY" not in cart.requests and seeing.looks == [(0.2, 0.8, 0.0)]


def test_with_the_floor_beside_the_way_unseen_the_cart_turns_to_look_and_plans_again() -> None:
    cart, seeing, planner = cart_at(0.2, 0.8, 0.0), FakeSeeing(False), planner_for(MapSettings())
    asked: list[int] = []

    def routes() -> object:
        asked.append(1)
        return planner

    turns = look_before_driving(cart, routes, seeing, (1.6, 0.8), None)  # type: ignore[arg-type]
    assert turns == MAX_LOOKS and len(asked) == MAX_LOOKS  # planned again after each look
    assert len(seeing.looks) == MAX_LOOKS + 1  # a look after each turn
    # facing past the route's bearing (east) on a side, within the turn's tolerance; then stopped
    assert abs(abs(cart.pose[2]) - LOOK_SIDE_RAD) <= TURN_TOLERANCE_RAD
    assert cart.requests[-2:] == ["VELOCITY", "POSE"] and cart.mode == "IDLE"  # stopped, then looked


def test_a_stop_before_the_look_leaves_the_turn_unsent() -> None:
    cart, seeing, planner = cart_at(0.2, 0.8, 0.0), FakeSeeing(False), planner_for(MapSettings())
    token = cart.motion_token()
    cart.stop()
    with pytest.raises(MotionCancelled):
        look_before_driving(cart, lambda: planner, seeing, (1.6, 0.8), token)  # type: ignore[arg-type]
    assert "VELOCITY" not in cart.requests and math.isclose(cart.pose[2], 0.0)

"""Which pose corrections re-send a driven route: any while the goal is farther than [planning]
correction_near_goal_m, nearer only one that moves a point of the route by correction_resend_m
or more (cart2d/gateway/correction_resend.py)."""

from __future__ import annotations

import math

import pytest

from cart2d.gateway.correction_resend import ResendLimits, largest_shift_m, worth_resending

ROUTE = [(0.2, 0.8), (0.9, 0.8), (1.6, 0.8)]  # the goal last
IDENTITY = (0.0, 0.0, 0.0)
LIMITS = ResendLimits(min_shift_m=0.03, near_goal_m=0.15)


def test_a_translation_moves_every_point_by_itself() -> None:
    assert largest_shift_m(ROUTE, IDENTITY, (0.01, -0.02, 0.0)) == pytest.approx(math.hypot(0.01, 0.02))


def test_a_turn_about_the_cart_moves_the_far_end_most() -> None:
    # map -> odom turned by 2 degrees about the route's start: its end, 1.4 m away, moves 4.9 cm
    turn = math.radians(2.0)
    c, s = math.cos(turn), math.sin(turn)
    about_start = (0.2 - (c * 0.2 - s * 0.8), 0.8 - (s * 0.2 + c * 0.8), turn)
    assert largest_shift_m(ROUTE, IDENTITY, about_start) == pytest.approx(1.4 * turn, rel=1e-3)


def test_the_shift_is_measured_from_the_frame_the_route_was_sent_in() -> None:
    sent_with = (0.1, 0.0, 0.0)
    assert largest_shift_m(ROUTE, sent_with, sent_with) == 0.0
    assert largest_shift_m(ROUTE, sent_with, (0.12, 0.0, 0.0)) == pytest.approx(0.02)


def test_near_the_goal_a_centimetre_keeps_the_route_and_the_limit_re_sends_it() -> None:
    at_goal = (1.58, 0.81)
    assert not worth_resending(ROUTE, IDENTITY, (0.01, 0.0, 0.0), at_goal, LIMITS)
    assert not worth_resending(ROUTE, IDENTITY, (0.0, 0.029, 0.0), at_goal, LIMITS)
    assert worth_resending(ROUTE, IDENTITY, (0.0, 0.031, 0.0), at_goal, LIMITS)


def test_away_from_the_goal_or_not_knowing_where_the_cart_is_any_correction_re_sends_it() -> None:
    assert worth_resending(ROUTE, IDENTITY, (0.01, 0.0, 0.0), (1.4, 0.8), LIMITS)
    assert worth_resending(ROUTE, IDENTITY, (0.01, 0.0, 0.0), None, LIMITS)
    assert not worth_resending([], IDENTITY, (1.0, 0.0, 0.0), (0.0, 0.0), LIMITS)


def test_the_robots_limits_are_read_from_its_file() -> None:
    limits = ResendLimits.of_the_robot()
    assert 0.01 < limits.min_shift_m < limits.near_goal_m <= 0.3

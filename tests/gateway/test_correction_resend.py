"""Which pose corrections re-send a driven route: those that move a point of it by
[planning] correction_resend_m or more (cart2d/gateway/correction_resend.py)."""

from __future__ import annotations

import math

import pytest

from cart2d.gateway.correction_resend import largest_shift_m, resend_min_m, worth_resending

ROUTE = [(0.2, 0.8), (0.9, 0.8), (1.6, 0.8)]
IDENTITY = (0.0, 0.0, 0.0)


def test_a_translation_moves_every_point_by_itself() -> None:
    assert largest_shift_m(ROUTE, IDENTITY, (0.01, -0.02, 0.0)) == pytest.approx(math.hypot(0.01, 0.02))


def test_a_turn_about_the_cart_moves_the_far_end_most() -> None:
    # map -> odom turned by 2 degrees about the route's start: its end, 1.4 m away, moves 4.9 cm
    turn = math.radians(2.0)
    c, s = math.cos(turn), math.sin(turn)
    about_start = (0.2 - (c * 0.2 - s * 0.8), 0.8 - (s * 0.2 + c * 0.8), turn)
    assert largest_shift_m(ROUTE, IDENTITY, about_start) == pytest.approx(1.4 * turn, rel=1e-3)
    assert worth_resending(ROUTE, IDENTITY, about_start, min_m=0.03)


def test_the_shift_is_measured_from_the_frame_the_route_was_sent_in() -> None:
    sent_with = (0.1, 0.0, 0.0)
    assert largest_shift_m(ROUTE, sent_with, sent_with) == 0.0
    assert largest_shift_m(ROUTE, sent_with, (0.12, 0.0, 0.0)) == pytest.approx(0.02)


def test_a_centimetre_is_not_worth_a_new_route_and_the_setting_decides() -> None:
    assert 0.01 < resend_min_m() <= 0.05
    assert not worth_resending(ROUTE, IDENTITY, (0.01, 0.0, 0.0))
    assert worth_resending(ROUTE, IDENTITY, (resend_min_m(), 0.0, 0.0))
    assert not worth_resending([], IDENTITY, (1.0, 0.0, 0.0))

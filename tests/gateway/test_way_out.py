"""way_out.py: a cart within its planning clearance of an obstacle plans from the nearest place
it may stand, no further than the clearance; one nearer to the obstacle than that is refused."""

from __future__ import annotations

import math

import pytest

from cart2d.gateway.way_out import nearest_clear, plan_from
from cart2d.planning import Grid, Planner, StartBlocked

STEP = 0.025
KEEP = 0.2  # footprint and clearance
FACE_Y = 0.5 - STEP / 2  # the obstacle's cell, centred on (0.5, 0.5), faces the cart at y = 0.4875


def planner() -> Planner:
    return Planner(Grid(cols=41, rows=41, step_m=STEP), footprint_radius_m=KEEP, obstacles=[(20, 20)])


def test_a_cart_just_inside_its_clearance_plans_from_the_nearest_clear_place() -> None:
    p = planner()
    here = (0.5, FACE_Y - KEEP + 0.01)  # 1 cm too close
    with pytest.raises(StartBlocked):
        p.plan(here, (0.2, 0.2))
    plan = plan_from(p, here, (0.2, 0.2), within_m=0.03)
    assert plan.waypoints[-1] == pytest.approx((0.2, 0.2))
    assert 0.0 < math.dist(plan.start, here) <= 0.03 + 1e-9
    assert p.graph.point_free(*plan.start)


def test_a_cart_deeper_than_that_is_refused_as_before() -> None:
    p = planner()
    here = (0.5, FACE_Y - KEEP + 0.05)  # 5 cm too close: its body would be within 2 cm
    assert nearest_clear(p, here, 0.03) is None
    with pytest.raises(StartBlocked):
        plan_from(p, here, (0.2, 0.2), within_m=0.03)

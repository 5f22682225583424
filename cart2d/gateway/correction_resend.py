"""Whether a pose correction is worth re-sending the driven route for (missions.py).

A correction moves map -> odom, so the route's waypoints, sent in odom, now lie elsewhere in
`map`. Re-sent near its end, a route whose goal moved by a centimetre or two makes the firmware
turn on the spot (up to half a turn: it drives forwards only while the camera sees) to close
them, and a turn after the last marker fix, with the marker out of view when it ends, is
counted by the odometry with its errors: a measuring wheel slipping 5 % turns the heading by
2.5 % of the turn, 4.5° for a half turn (issue 26, a goal 5.1° off). So within [planning]
correction_near_goal_m of the goal, a route whose points all moved by less than
correction_resend_m is kept: the cart stops that close to its goal. Farther away every
correction re-sends it: the goal is ahead, and a few centimetres steer the cart by a few degrees.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from cart2d.localisation.ekf import Pose2, to_map, to_odom
from cart2d.params import robot


@dataclass(frozen=True)
class ResendLimits:
    min_shift_m: float  # correction_resend_m
    near_goal_m: float  # correction_near_goal_m

    @classmethod
    def of_the_robot(cls) -> ResendLimits:
        planning = robot()["planning"]
        return cls(float(planning["correction_resend_m"]), float(planning["correction_near_goal_m"]))


def largest_shift_m(route: Sequence[tuple[float, float]], sent_with: Pose2, now: Pose2) -> float:
    """How far the correction from map -> odom `sent_with` (the route's, when it was sent) to
    `now` moved the route's points in `map`; 0 for an empty route."""
    shifts = (
        math.dist(point, to_map(now, to_odom(sent_with, (point[0], point[1], 0.0)))[:2]) for point in route
    )
    return max(shifts, default=0.0)


def worth_resending(
    route: Sequence[tuple[float, float]],
    sent_with: Pose2,
    now: Pose2,
    cart: tuple[float, float] | None,
    limits: ResendLimits | None = None,
) -> bool:
    """Whether the route sent with map -> odom `sent_with` is re-sent after a correction to `now`
    that puts the cart at `cart` in `map` (None: not known, re-sent); its goal is its last point."""
    if not route:
        return False
    limits = limits or ResendLimits.of_the_robot()
    if cart is None or math.dist(cart, route[-1]) > limits.near_goal_m:
        return True
    return largest_shift_m(route, sent_with, now) >= limits.min_shift_m

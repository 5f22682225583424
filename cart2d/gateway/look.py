"""Look before driving off: while the gateway sees, a route that starts from rest begins with the
cart turning on the spot to look beside the way it is about to go.

The camera's picture is 55 degrees wide and starts 0.19 m ahead (config/robot.toml [camera]): the
floor beside the bumper's corners, up to about 0.33 m ahead and 0.1 to 0.2 m to the side, is
never in it. Driving straight on, that floor was in the picture earlier, further ahead; but after
a turn it can be floor no frame has shown, and a box standing there is found by the front switch,
not by the camera. So before a route leaves, the floor beside its first stretch (BAND: points
ahead along the first waypoint's bearing, at the bumper's corners and the clearance beyond) is
checked against what perception has observed (off the map's node rectangle there is nothing to
look for: a perceived cell there blocks nothing); while a side has a point never observed, the
cart turns on the spot to face LOOK_SIDE_RAD past the bearing on that side, where the picture
covers the band (with both sides unseen, the side away from its heading: turning there sweeps
the picture over the other side), and the route is planned again with what was seen, which may
send it another way (at most MAX_LOOKS turns).

Turning uses manual driving (VELOCITY v = 0), refreshed while the odometry heading (POSE) closes
on the target, and a stop; a user's stop during the look cancels the route (the link's token).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from cart2d.planning import Grid, PlanError, Planner

if TYPE_CHECKING:
    from cart2d.gateway.seeing import Seeing
    from cart2d.link import Link

Point = tuple[float, float]

# Past the bearing by this, the BAND on that side lies within 20 degrees of the picture's centre
# line, within its half width of 27.5 (its nearest point, 0.23 m away, above the bottom edge).
LOOK_SIDE_RAD = math.radians(25.0)
# (forward, lateral) in the first waypoint's frame: the floor beside the bumper's corners (0.17 m
# ahead, 0.1 m to each side) and the cart's clearance (0.2 m) beyond, on each side (lateral > 0: left)
BAND = tuple((f, s * w) for f in (0.2, 0.3, 0.4) for w in (0.12, 0.2) for s in (1.0, -1.0))
MIN_FIRST_M = 0.05  # a first waypoint nearer than this gives no bearing to look along
TURN_RATE_RADPS = 3.0  # at most; and at most 90 % of the firmware's w_max
# Slowing down towards the heading as braking at this rate would (3/4 of the default alpha_max:
# the heading read is a round trip and a refresh old), omega = sqrt(2 * BRAKING * error).
BRAKING_RADPS2 = 9.0
MIN_TURN_RADPS = 0.3
TURN_TOLERANCE_RAD = math.radians(8.0)
TURN_TIMEOUT_S = 4.0  # a turn that does not get there in this long (blocked, a slipping wheel) ends
REFRESH_S = 0.04  # VELOCITY refreshes (the firmware's manual timeout is 0.5 s by default)
MAX_LOOKS = 2  # turns to look, along the routes planned in turn (each may send the cart another way)


def first_bearing(start: Point, waypoints: Sequence[Point]) -> float | None:
    """The bearing of the route's first waypoint at least MIN_FIRST_M from `start`."""
    for x, y in waypoints:
        if math.dist(start, (x, y)) >= MIN_FIRST_M:
            return math.atan2(y - start[1], x - start[0])
    return None


def unseen_sides(start: Point, bearing: float, observed: Callable[[np.ndarray], np.ndarray]) -> list[float]:
    """+1 (left) and/or -1 (right): the sides of the first stretch with a BAND point never observed."""
    c, s = math.cos(bearing), math.sin(bearing)
    band = np.array(BAND)
    points = np.column_stack(
        [start[0] + c * band[:, 0] - s * band[:, 1], start[1] + s * band[:, 0] + c * band[:, 1]]
    )
    seen = observed(points)
    return [side for side in (1.0, -1.0) if not seen[np.sign(band[:, 1]) == side].all()]


def look_heading(heading: float, bearing: float, sides: Sequence[float]) -> float | None:
    """The heading to face: LOOK_SIDE_RAD past `bearing` on an unseen side; with both unseen, on
    the side away from the cart's heading, so that the turn there sweeps the picture over the
    other side on its way."""
    if not sides:
        return None
    away = 1.0 if math.remainder(bearing - heading, math.tau) >= 0.0 else -1.0
    side = away if away in sides else sides[0]
    return bearing + side * LOOK_SIDE_RAD


def turn_to(link: Link, heading: float, w_max: float, token: int | None) -> None:
    """Turns on the spot until the odometry heading is within TURN_TOLERANCE_RAD of `heading`
    (or TURN_TIMEOUT_S passed), then stops turning."""
    rate = min(TURN_RATE_RADPS, 0.9 * w_max)
    deadline = time.monotonic() + TURN_TIMEOUT_S
    try:
        while time.monotonic() < deadline:
            theta = link.call("POSE")[2]  # not telemetry: the user may have turned it off
            error = math.remainder(heading - theta, math.tau)
            if abs(error) <= TURN_TOLERANCE_RAD:
                return
            braking = math.sqrt(2.0 * BRAKING_RADPS2 * abs(error))
            omega = math.copysign(min(rate, max(MIN_TURN_RADPS, braking)), error)
            link.call("VELOCITY", 0.0, omega, token=token)
            time.sleep(REFRESH_S)
    finally:
        link.call("VELOCITY", 0.0, 0.0, token=token)


def _known(seeing: Seeing, grid: Grid) -> Callable[[np.ndarray], np.ndarray]:
    """Whether points need no look: observed, or off the planner's node rectangle (the arena's
    margin, past a floor plan's edge), where a perceived cell blocks nothing (perceived.py)."""

    def known(points: np.ndarray) -> np.ndarray:
        off_map = np.array([not grid.inside(float(x), float(y)) for x, y in points])
        return np.asarray(seeing.observed(points) | off_map)

    return known


def look_before_driving(
    link: Link, planner: Callable[[], Planner], seeing: Seeing, goal: Point, token: int | None
) -> int:
    """The look (see the module's docstring) for a route to `goal` from where the cart stands,
    again for the route planned with what it showed (what the cart saw may send it another way),
    at most MAX_LOOKS times; how many turns it took. `planner()`: the routes' planner now (the
    live map's snapshot, which no later change alters). Called with no lock held: the frames
    taken in meanwhile change the map."""
    turns = 0
    w_max: float | None = None
    for _ in range(MAX_LOOKS + 1):
        x, y, theta = link.call("POSE")
        seeing.look(at=(x, y, theta))
        if turns == MAX_LOOKS:
            return turns
        routes = planner()
        try:
            plan = routes.plan((x, y), goal)
        except PlanError:
            return turns  # go_to plans again and says why
        bearing = first_bearing((x, y), plan.waypoints)
        if bearing is None:
            return turns
        heading = look_heading(theta, bearing, unseen_sides((x, y), bearing, _known(seeing, routes.grid)))
        if heading is None:
            return turns
        if w_max is None:
            w_max = float(link.call("MAX_SPEED_GET")[1])
        turn_to(link, heading, w_max, token)
        turns += 1
    return turns

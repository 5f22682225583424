"""A way out for a cart that stands within its planning clearance of an obstacle (issue 26's
flaky exploration): perception marks a face's cells a cell or so nearer than the face, and a
cart that drove past it legally is then "too close" where it stands; every plan from there is
refused (StartBlocked), and exploration took that for no reachable frontier left. The body still
clears the obstacle (the clearance is the path-following error's margin), so the plan may start
at the nearest point the cart's centre may stand, a short straight move away, as a replan starts
at the route's entry (missions.py)."""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator

from cart2d.params import robot
from cart2d.planning import Plan, Planner, Point, StartBlocked

STEPS = 8  # rings searched, out to `within_m`
RING_POINTS = 16


def clearance_m() -> float:
    """How far a cart may be moved out of its clearance: no further, its body clears then."""
    return float(robot()["body"]["clearance_m"])


def rings(centre: Point, radii: Iterable[float]) -> Iterator[list[Point]]:
    """RING_POINTS points evenly round `centre` at each radius in turn: a search outwards."""
    for r in radii:
        yield [
            (centre[0] + r * math.cos(a), centre[1] + r * math.sin(a))
            for a in (math.tau * n / RING_POINTS for n in range(RING_POINTS))
        ]


def nearest_clear(planner: Planner, here: Point, within_m: float) -> Point | None:
    """The nearest point to `here` (on rings, STEPS of them out to `within_m`) where the
    planner lets the cart's centre stand; None if there is none that near."""
    graph = planner.graph
    for ring in rings(here, (within_m * k / STEPS for k in range(1, STEPS + 1))):
        free = [p for p in ring if graph.point_free(*p)]
        if free:
            return free[0]
    return None


def plan_from(planner: Planner, here: Point, goal: Point, within_m: float) -> Plan:
    """planner.plan(here, goal); from the nearest clear point within `within_m` if the cart
    stands too close to an obstacle there (StartBlocked, as before, if none is that near)."""
    try:
        return planner.plan(here, goal)
    except StartBlocked:
        out = nearest_clear(planner, here, within_m)
        if out is None:
            raise
        return planner.plan(out, goal)

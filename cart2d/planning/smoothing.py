"""Rounded corners: a planned polyline made drivable at speed.

The firmware drives straight segments and must stop at a corner of 45 degrees or more to turn
on the spot (1 - |tan e| of its speed is left at a heading error e). A fillet, an arc tangent to
both segments, sent as short chords that each turn by a few degrees, lets it keep most of its
speed through the corner instead. A fillet cuts the corner, so every chord is checked free for
the footprint (the same test as the planner's own segments), and the radius shrinks until it
is; a corner with no room for any arc stays sharp, as planned.

Nothing here talks to the cart: `round_corners` maps waypoints to waypoints.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence

from cart2d.planning import Point

SegmentFree = Callable[[Point, Point], bool]

# The arc radius tried first: at v = 0.5 m/s it needs omega = 2.5 rad/s (w_max is pi).
RADIUS_M = 0.2
# Radii below this are not worth the waypoints: the corner stays sharp.
MIN_RADIUS_M = 0.03
# Each chord turns by at most this much (the cart keeps 1 - tan(12 deg) = 79 % of its speed).
CHORD_TURN_RAD = math.radians(12.0)
# Corners gentler than this are driven as they are.
MIN_TURN_RAD = math.radians(8.0)


def _unit(a: Point, b: Point) -> tuple[Point, float]:
    dx, dy = b[0] - a[0], b[1] - a[1]
    length = math.hypot(dx, dy)
    return ((dx / length, dy / length) if length > 0 else (0.0, 0.0)), length


def _fillet(
    corner: Point, u_in: Point, u_out: Point, turn: float, radius: float, chord_turn: float
) -> list[Point]:
    """The points of the arc of `radius` tangent to both segments at `corner`, from the tangent
    point on the incoming segment to the one on the outgoing segment."""
    tangent = radius * math.tan(turn / 2)
    left = u_in[0] * u_out[1] - u_in[1] * u_out[0] > 0
    normal = (-u_in[1], u_in[0]) if left else (u_in[1], -u_in[0])
    a = (corner[0] - u_in[0] * tangent, corner[1] - u_in[1] * tangent)
    centre = (a[0] + normal[0] * radius, a[1] + normal[1] * radius)
    start_angle = math.atan2(a[1] - centre[1], a[0] - centre[0])
    sign = 1.0 if left else -1.0
    steps = max(1, math.ceil(turn / chord_turn - 1e-9))
    return [
        (
            centre[0] + radius * math.cos(start_angle + sign * turn * k / steps),
            centre[1] + radius * math.sin(start_angle + sign * turn * k / steps),
        )
        for k in range(steps + 1)
    ]


def _round_one(
    before: Point,
    corner: Point,
    after: Point,
    room_in: float,
    room_out: float,
    free: SegmentFree,
    chord_turn: float,
) -> list[Point]:
    u_in, _ = _unit(before, corner)
    u_out, _ = _unit(corner, after)
    turn = _angle_between(u_in, u_out)
    if turn < MIN_TURN_RAD or turn > math.radians(170.0):
        return [corner]  # nearly straight, or a U-turn better made on the spot
    tan_half = math.tan(turn / 2)
    radius = min(RADIUS_M, min(room_in, room_out) / tan_half)
    while radius >= MIN_RADIUS_M:
        arc = _fillet(corner, u_in, u_out, turn, radius, chord_turn)
        if all(free(p, q) for p, q in itertools.pairwise(arc)):
            return arc
        radius *= 0.7
    return [corner]


def _arcs(points: list[Point], free: SegmentFree, chord_turn: float) -> list[list[Point]]:
    """For every inner point, what replaces it: an arc, or the point itself."""
    arcs = []
    for k in range(1, len(points) - 1):
        # A segment is shared by the corners at its two ends, except the first and the last.
        _, len_in = _unit(points[k - 1], points[k])
        _, len_out = _unit(points[k], points[k + 1])
        room_in = len_in * (1.0 if k == 1 else 0.5)
        room_out = len_out * (1.0 if k == len(points) - 2 else 0.5)
        arcs.append(_round_one(points[k - 1], points[k], points[k + 1], room_in, room_out, free, chord_turn))
    return arcs


def _joined(arcs: list[list[Point]], goal: Point) -> list[Point]:
    out: list[Point] = []
    for arc in arcs:
        out += [p for p in arc if not out or math.dist(p, out[-1]) > 1e-4]
    return [*out, goal]


def round_corners(
    start: Point,
    waypoints: Sequence[Point],
    free: SegmentFree,
    capacity: int,
) -> list[Point]:
    """The waypoints with their corners rounded where there is room, at most `capacity` of them:
    coarser arcs if the fine ones do not fit, and if even those do not, the coarse arcs of the
    sharpest corners that fit (a gentle corner costs the cart least when left sharp)."""
    points = [start, *waypoints]
    if len(points) < 3:
        return list(waypoints)
    coarse: list[list[Point]] = []
    for chord_turn in (CHORD_TURN_RAD, 2 * CHORD_TURN_RAD, 3 * CHORD_TURN_RAD):
        coarse = _arcs(points, free, chord_turn)
        out = _joined(coarse, points[-1])
        if len(out) <= capacity:
            return out
    chosen = [[p] for p in points[1:-1]]
    spare = capacity - len(waypoints)
    by_turn = sorted(range(len(chosen)), key=lambda k: -_turn(points[k], points[k + 1], points[k + 2]))
    for k in by_turn:
        extra = len(coarse[k]) - 1
        if extra <= spare:
            chosen[k], spare = coarse[k], spare - extra
    return _joined(chosen, points[-1]) if spare >= 0 else list(waypoints)


def _angle_between(u: Point, w: Point) -> float:
    """The angle between two unit vectors."""
    return math.acos(max(-1.0, min(1.0, u[0] * w[0] + u[1] * w[1])))


def _turn(before: Point, corner: Point, after: Point) -> float:
    return _angle_between(_unit(before, corner)[0], _unit(corner, after)[0])

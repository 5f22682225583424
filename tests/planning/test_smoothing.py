"""Rounded corners (cart2d/planning/smoothing.py): arcs where there is room, every chord free."""

from __future__ import annotations

import itertools
import math

from cart2d.planning import Grid, GridGraph, Point
from cart2d.planning.smoothing import CHORD_TURN_RAD, RADIUS_M, round_corners


def turns(points: list[Point]) -> list[float]:
    out = []
    for a, b, c in zip(points, points[1:], points[2:], strict=False):
        h1 = math.atan2(b[1] - a[1], b[0] - a[0])
        h2 = math.atan2(c[1] - b[1], c[0] - b[0])
        out.append(abs((h2 - h1 + math.pi) % (2 * math.pi) - math.pi))
    return out


def always_free(_a: Point, _b: Point) -> bool:
    return True


def test_a_right_angle_in_the_open_becomes_an_arc_of_small_turns() -> None:
    start, corner, goal = (0.0, 0.0), (1.0, 0.0), (1.0, 1.0)
    out = round_corners(start, [corner, goal], always_free, capacity=32)
    assert out[-1] == goal
    assert all(t <= CHORD_TURN_RAD + 1e-9 for t in turns([start, *out]))
    # tangent to both segments, RADIUS_M from the corner's far side: (1 - R, 0) ... (1, R)
    assert math.dist(out[0], (1.0 - RADIUS_M, 0.0)) < 1e-9
    assert math.dist(out[-2], (1.0, RADIUS_M)) < 1e-9
    # on the arc around (1 - R, R)
    for p in out[:-1]:
        assert abs(math.dist(p, (1.0 - RADIUS_M, RADIUS_M)) - RADIUS_M) < 1e-9


def test_straight_paths_and_gentle_bends_are_left_alone() -> None:
    assert round_corners((0.0, 0.0), [(1.0, 0.0), (2.0, 0.0)], always_free, 32) == [(1.0, 0.0), (2.0, 0.0)]
    gentle = [(1.0, 0.0), (2.0, 0.1)]  # 5.7 deg
    assert round_corners((0.0, 0.0), gentle, always_free, 32) == gentle
    assert round_corners((0.0, 0.0), [(1.0, 0.0)], always_free, 32) == [(1.0, 0.0)]


def test_the_arc_shrinks_until_its_chords_are_free_of_obstacles() -> None:
    # Up beside a wall (cells x >= 0.95, y <= 1.15), then right over its end, 0.175 m clear of
    # it: the full arc would pass 0.165 m from the wall's corner.
    grid = Grid(cols=21, rows=21, step_m=0.1)
    wall = [(i, j) for i in range(10, 21) for j in range(0, 12)]
    graph = GridGraph(grid, wall, 0.17)
    start, corner, goal = (0.775, 0.4), (0.775, 1.325), (1.6, 1.325)
    assert graph.segment_free(start, corner) and graph.segment_free(corner, goal)
    out = round_corners(start, [corner, goal], graph.segment_free, 32)
    for p, q in itertools.pairwise([start, *out]):
        assert graph.segment_free(p, q)
    free_arc = round_corners(start, [corner, goal], always_free, 32)
    assert len(out) == len(free_arc) and out != free_arc  # a tighter arc
    assert math.dist(out[0], corner) < math.dist(free_arc[0], corner)


def test_never_more_waypoints_than_the_firmware_holds() -> None:
    zigzag = [(0.5 * k, 0.5 * (k % 2)) for k in range(1, 12)]
    for capacity in (11, 20, 32):
        out = round_corners((0.0, 0.0), zigzag, always_free, capacity)
        assert len(out) <= capacity
        assert out[-1] == zigzag[-1]

"""Exact geometry of discs, segments and axis-aligned squares (any consistent unit; the planner
uses grid units), one at a time in plain Python and elementwise over numpy arrays (the same
operations in the same order, so the same results)."""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from cart2d.planning.grid import Point


def point_square_distance(p: Point, centre: Point, half_side: float) -> float:
    """Distance from p to the closed axis-aligned square (0 inside it)."""
    dx = max(abs(p[0] - centre[0]) - half_side, 0.0)
    dy = max(abs(p[1] - centre[1]) - half_side, 0.0)
    return math.hypot(dx, dy)


def _point_segment_d2(px: float, py: float, ax: float, ay: float, bx: float, by: float) -> float:
    dx, dy = bx - ax, by - ay
    length2 = dx * dx + dy * dy
    t = 0.0 if length2 == 0.0 else min(max(((px - ax) * dx + (py - ay) * dy) / length2, 0.0), 1.0)
    ex, ey = ax + t * dx - px, ay + t * dy - py
    return ex * ex + ey * ey


def point_segment_distance(p: Point, a: Point, b: Point) -> float:
    """Distance from p to the segment ab."""
    return math.sqrt(_point_segment_d2(p[0], p[1], a[0], a[1], b[0], b[1]))


def point_polyline_distance(p: Point, line: Sequence[Point]) -> float:
    """Distance from p to the nearest point of a polyline (of one point or more)."""
    if len(line) == 1:
        return math.dist(p, line[0])
    return min(point_segment_distance(p, a, b) for a, b in itertools.pairwise(line))


def _point_box_d2(px: float, py: float, x0: float, x1: float, y0: float, y1: float) -> float:
    dx = x0 - px if px < x0 else (px - x1 if px > x1 else 0.0)
    dy = y0 - py if py < y0 else (py - y1 if py > y1 else 0.0)
    return dx * dx + dy * dy


def _segment_meets_box(
    ax: float, ay: float, bx: float, by: float, x0: float, x1: float, y0: float, y1: float
) -> bool:
    """Liang-Barsky: does the segment share a point with the closed box?"""
    t0, t1 = 0.0, 1.0
    dx, dy = bx - ax, by - ay
    for p, q in ((-dx, ax - x0), (dx, x1 - ax), (-dy, ay - y0), (dy, y1 - ay)):
        if p == 0.0:
            if q < 0.0:
                return False
        else:
            t = q / p
            if p < 0.0:
                t0 = max(t0, t)
            else:
                t1 = min(t1, t)
            if t0 > t1:
                return False
    return True


def _segment_box_d2(
    ax: float, ay: float, bx: float, by: float, x0: float, x1: float, y0: float, y1: float
) -> float:
    if _segment_meets_box(ax, ay, bx, by, x0, x1, y0, y1):
        return 0.0
    # Disjoint convex sets: the closest pair includes a vertex of one of them.
    return min(
        _point_box_d2(ax, ay, x0, x1, y0, y1),
        _point_box_d2(bx, by, x0, x1, y0, y1),
        _point_segment_d2(x0, y0, ax, ay, bx, by),
        _point_segment_d2(x1, y0, ax, ay, bx, by),
        _point_segment_d2(x0, y1, ax, ay, bx, by),
        _point_segment_d2(x1, y1, ax, ay, bx, by),
    )


def segment_square_distance(a: Point, b: Point, centre: Point, half_side: float) -> float:
    """Exact distance between the segment ab and the closed axis-aligned square (0 if they meet)."""
    cx, cy = centre
    h = half_side
    return math.sqrt(_segment_box_d2(a[0], a[1], b[0], b[1], cx - h, cx + h, cy - h, cy + h))


# the same, elementwise over arrays (the same operations in the same order, so the same results)

FloatArray = npt.NDArray[np.float64]
IndexArray = npt.NDArray[np.int32]


def _point_segment_d2_v(
    px: FloatArray, py: FloatArray, ax: FloatArray, ay: FloatArray, bx: FloatArray, by: FloatArray
) -> FloatArray:
    dx, dy = bx - ax, by - ay
    length2 = dx * dx + dy * dy
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.minimum(np.maximum(((px - ax) * dx + (py - ay) * dy) / length2, 0.0), 1.0)
    t = np.where(length2 == 0.0, 0.0, t)
    ex, ey = ax + t * dx - px, ay + t * dy - py
    out: FloatArray = ex * ex + ey * ey
    return out


def _point_box_d2_v(
    px: FloatArray, py: FloatArray, x0: FloatArray, x1: FloatArray, y0: FloatArray, y1: FloatArray
) -> FloatArray:
    dx = np.where(px < x0, x0 - px, np.where(px > x1, px - x1, 0.0))
    dy = np.where(py < y0, y0 - py, np.where(py > y1, py - y1, 0.0))
    out: FloatArray = dx * dx + dy * dy
    return out


def _segment_box_d2_v(
    ax: FloatArray,
    ay: FloatArray,
    bx: FloatArray,
    by: FloatArray,
    x0: FloatArray,
    x1: FloatArray,
    y0: FloatArray,
    y1: FloatArray,
) -> FloatArray:
    dx, dy = bx - ax, by - ay
    # Liang-Barsky as in _segment_meets_box: t0 only grows and t1 only shrinks, so testing
    # t0 > t1 once at the end decides as the early returns do
    t0 = np.zeros_like(ax)
    t1 = np.ones_like(ax)
    outside = np.zeros(ax.shape, dtype=np.bool_)
    with np.errstate(divide="ignore", invalid="ignore"):
        for p, q in ((-dx, ax - x0), (dx, x1 - ax), (-dy, ay - y0), (dy, y1 - ay)):
            outside |= (p == 0.0) & (q < 0.0)
            t = q / p
            t0 = np.where(p < 0.0, np.maximum(t0, t), t0)
            t1 = np.where(p > 0.0, np.minimum(t1, t), t1)
    meets = ~outside & (t0 <= t1)
    d2 = np.minimum.reduce(
        [
            _point_box_d2_v(ax, ay, x0, x1, y0, y1),
            _point_box_d2_v(bx, by, x0, x1, y0, y1),
            _point_segment_d2_v(x0, y0, ax, ay, bx, by),
            _point_segment_d2_v(x1, y0, ax, ay, bx, by),
            _point_segment_d2_v(x0, y1, ax, ay, bx, by),
            _point_segment_d2_v(x1, y1, ax, ay, bx, by),
        ]
    )
    out: FloatArray = np.where(meets, 0.0, d2)
    return out


def polyline_length(points: Sequence[Point] | np.ndarray) -> float:
    """The length of the polyline through the points (0 for fewer than two)."""
    steps = np.diff(np.asarray(points, dtype=np.float64).reshape(-1, 2), axis=0)
    return math.fsum(np.hypot(steps[:, 0], steps[:, 1]).tolist())

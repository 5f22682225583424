"""A grid path made into a few straight segments that stay free: collinear points dropped, the
string pulled, the corners pulled taut off the nodes, sharp bends given more corners."""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from cart2d.planning.geometry import FloatArray
from cart2d.planning.graph import GridGraph, _expand
from cart2d.planning.grid import Point


def _drop_collinear(points: np.ndarray) -> np.ndarray:
    """Indices of the points that remain once repeated points and straight-through points are
    dropped (the first and last always remain)."""
    u = points[1:-1] - points[:-2]  # into each inner point
    v = points[2:] - points[1:-1]  # out of it
    nu, nv = np.hypot(u[:, 0], u[:, 1]), np.hypot(v[:, 0], v[:, 1])
    cross = u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]
    dot = u[:, 0] * v[:, 0] + u[:, 1] * v[:, 1]
    through = (np.abs(cross) <= 1e-12 * nu * nv) & (dot > 0.0)
    turns = np.flatnonzero(~((nu == 0.0) | (nv == 0.0) | through)) + 1
    return np.concatenate(([0], turns, [len(points) - 1]))


# String pulling looks this many points ahead: from each point kept, on to the farthest of the
# next _PULL_WINDOW points that it reaches by a free segment; and when it reaches them all, on
# along the path as long as it reaches every point. On a path of up to _PULL_WINDOW + 1 points
# that is the farthest point reached, as the planner always did; on longer paths too, in practice
# (a point seen again after one hidden comes within a few points): on 300 random plans of 10 x 10
# to 41 x 41 nodes, of up to 21 points, a window of 6 already gave the same waypoints.
_PULL_WINDOW = 8
_PULL_CELLS = 1 << 20  # cells visited per array check, about (bounds the memory)


def _clear_all(graph: GridGraph, a: FloatArray, b: FloatArray) -> npt.NDArray[np.bool_]:
    """graph._segments_clear, in chunks of about _PULL_CELLS cells."""
    band = 2.0 * graph._r + 3.0  # the width of a segment's band of cells, about
    size = (np.maximum(np.abs(b[:, 0] - a[:, 0]), np.abs(b[:, 1] - a[:, 1])) + band) * band
    ends = np.searchsorted(np.cumsum(size), np.arange(1, int(size.sum() // _PULL_CELLS) + 1) * _PULL_CELLS)
    cuts = [0, *np.unique(np.maximum(ends, 1)).tolist(), len(a)]
    return np.concatenate(
        [graph._segments_clear(a[i:j], b[i:j]) for i, j in itertools.pairwise(cuts) if j > i]
        or [np.ones(0, dtype=np.bool_)]
    )


def _string_pull(graph: GridGraph, points: FloatArray) -> list[int]:
    """The indices of the points (grid units) kept: from each point kept, on to the farthest of
    the next _PULL_WINDOW points that it reaches by a free segment, or, when it reaches them all,
    on along the path while it reaches every point. Consecutive points are joined by free grid
    edges or connections, so a point always reaches the next one.

    The segments are checked as arrays, for all the points at once: first, in rounds, how far
    along the path each point reaches every point; then, for the points that stop short of their
    window's end, the later points of the window."""
    last = len(points) - 1
    index = np.arange(last + 1)
    # sees[k]: k reaches k + 1 .. k + sees[k]
    sees = np.ones(last + 1, dtype=np.int64)
    open_ = index[: max(last - 1, 0)]  # the points that may reach farther
    t = 2
    while open_.size and t <= _PULL_WINDOW:
        open_ = open_[_clear_all(graph, points[open_], points[open_ + t])]
        sees[open_] = t
        open_ = open_[open_ + t < last]
        t += 1
    onward = np.zeros(last + 1, dtype=np.bool_)
    onward[open_] = True  # reaches its whole window, and the path goes on
    far = index + sees
    # beyond the first point that k does not reach: the rest of its window
    first = far + 2  # the first candidate after the point not reached
    count = np.maximum(np.minimum(index + _PULL_WINDOW, last) - first + 1, 0)
    owner, later = _expand(first, count)
    clear = _clear_all(graph, points[owner], points[later])
    np.maximum.at(far, owner[clear], later[clear])
    keep = [0]
    i = 0
    while i < last:
        j = int(far[i])
        batch = 8
        while onward[i] and j < last:
            ahead = np.arange(j + 1, min(j + batch, last) + 1)
            clear = _clear_all(graph, np.broadcast_to(points[i], (len(ahead), 2)), points[ahead])
            if not clear.all():
                j = int(ahead[np.argmin(clear)]) - 1
                break
            j = int(ahead[-1])
            batch *= 2
        keep.append(j)
        i = j
    return keep


# Tightening: at most this many sweeps over the corners, each corner found by this many halvings;
# paths with more corners than _TIGHTEN_MAX (mazes, not a path the cart can hold) stay as pulled.
_TIGHTEN_SWEEPS = 30
_TIGHTEN_HALVINGS = 8
_TIGHTEN_MAX = 100
_TIGHTEN_MARGIN = 1e-4  # grid units


def _slide(pts: list[Point], k: int, clear: Callable[[Point, Point], bool]) -> float:
    """Slides corner k towards the chord of its neighbours as far as both of its segments stay
    free (deleting it when it reaches the chord); returns how far it moved."""
    (ax, ay), (vx, vy), (bx, by) = pts[k - 1], pts[k], pts[k + 1]
    dx, dy = bx - ax, by - ay
    span = dx * dx + dy * dy
    t = 0.0 if span == 0.0 else min(1.0, max(0.0, ((vx - ax) * dx + (vy - ay) * dy) / span))
    px, py = ax + t * dx, ay + t * dy  # the nearest point of the chord
    if clear(pts[k - 1], (px, py)) and clear((px, py), pts[k + 1]):
        del pts[k]
        return math.hypot(px - vx, py - vy)
    lo, hi = 0.0, 1.0
    for _ in range(_TIGHTEN_HALVINGS):
        mid = (lo + hi) / 2
        q = (vx + mid * (px - vx), vy + mid * (py - vy))
        if clear(pts[k - 1], q) and clear(q, pts[k + 1]):
            lo = mid
        else:
            hi = mid
    if lo > 0.0:
        pts[k] = (vx + lo * (px - vx), vy + lo * (py - vy))
    return lo * math.hypot(px - vx, py - vy)


def _clear_with_margin(graph: GridGraph) -> Callable[[Point, Point], bool]:
    # a hair more than the radius: a corner pulled up to the obstacle must stay free whatever
    # the rounding of any later check
    return functools.partial(graph._segment_clear, margin=_TIGHTEN_MARGIN)


def _tighten(graph: GridGraph, points: list[Point]) -> list[Point]:
    """The pulled path (grid units) pulled taut: each corner slides towards the chord of its
    neighbours as far as both of its segments stay free, sweep after sweep, until nothing moves
    by more than a hundredth of a step. Every move shortens the path (the two segments' length
    only falls on the way to the chord), and a corner that reaches the chord is dropped. Grid
    corners sit on nodes, up to a step further from the obstacles than the disc needs: taut, the
    path touches them as the true shortest path does, only with one corner per bend."""
    pts = list(points)
    if len(pts) < 3 or len(pts) > _TIGHTEN_MAX:
        return pts
    clear = _clear_with_margin(graph)
    for _ in range(_TIGHTEN_SWEEPS):
        moved = 0.0
        k = 1
        while k < len(pts) - 1:
            before = len(pts)
            moved = max(moved, _slide(pts, k, clear))
            k += len(pts) == before  # a deleted corner's successor is now at k
        if moved < 1e-2:
            break
    return pts


# A bend sharper than this gets two more corners before it is pulled taut again, twice over: one
# corner per bend leaves the path up to r (2 tan(a/2) - a) longer than the arc of radius r it
# stands for (9 cm for r = 0.2 m and a = 90 deg); three corners leave less than a centimetre.
_BEND_RAD = math.radians(30.0)
_BEND_ROUNDS = 2
_BEND_SHARE = 0.3  # where the new corners go: this share of each segment from the bend
# Corners are added for length only while the path keeps at most this many points, so that it
# still goes to the firmware in one piece (it holds 32) with room for rounded corners.
_SPLIT_MAX = 24


def _split_bends(graph: GridGraph, points: list[Point]) -> list[Point]:
    """The points with two more on the segments next to every bend sharper than _BEND_RAD; the
    bend itself then slides towards the chord of the new pair (before anything else can: the
    new points lie on the old segments, so a sweep would drop them at once). The points as they
    are if that would make more than _SPLIT_MAX."""
    out = [points[0]]
    bends = []
    for k in range(1, len(points) - 1):
        (ax, ay), (vx, vy), (bx, by) = points[k - 1], points[k], points[k + 1]
        ux, uy, wx, wy = vx - ax, vy - ay, bx - vx, by - vy
        cos_turn = (ux * wx + uy * wy) / max(math.hypot(ux, uy) * math.hypot(wx, wy), 1e-12)
        if cos_turn < math.cos(_BEND_RAD):
            out.append((vx - _BEND_SHARE * ux, vy - _BEND_SHARE * uy))
            bends.append(len(out))
            out += [points[k], (vx + _BEND_SHARE * wx, vy + _BEND_SHARE * wy)]
        else:
            out.append(points[k])
    out.append(points[-1])
    if len(out) > _SPLIT_MAX:
        return points
    clear = _clear_with_margin(graph)
    for k in reversed(bends):  # from the end: a deletion does not shift the bends before it
        _slide(out, k, clear)
    return out


def _taut(graph: GridGraph, points: list[Point]) -> list[Point]:
    """The pulled path pulled taut, its sharp bends given more corners so that they wrap the
    obstacles' rounded corners closely (see _tighten and _split_bends)."""
    pts = _tighten(graph, points)
    for _ in range(_BEND_ROUNDS):
        split = _split_bends(graph, pts)
        if len(split) == len(pts):
            break
        pts = _tighten(graph, split)
    return pts


def simplify(graph: GridGraph, path_g: FloatArray) -> FloatArray:
    """A grid path (grid units) with as few corners as stay clear: collinear nodes dropped, the
    rest string-pulled, then pulled taut off the nodes."""
    kept = _drop_collinear(path_g)
    pulled = kept[_string_pull(graph, path_g[kept])]
    return np.array(_taut(graph, [(float(u), float(v)) for u, v in path_g[pulled]]))

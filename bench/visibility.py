"""The true shortest collision-free path for a disc among square obstacle cells: the reference
that grid plans are measured against.

The disc's centre must stay out of every obstacle cell grown by the radius (a square with
rounded corners; touching ones merged with shapely) and inside a rectangle. Shortest paths
among such shapes are straight lines tangent to the grown obstacles and arcs around their
corners; the arcs are replaced by polygons of QUAD_SEGMENTS sides per quarter circle, inscribed
in them (the length found is a lower bound of the true one) or circumscribed (an upper bound).
The path bends only at convex corners of the grown obstacles, so Dijkstra runs over the free
bitangent segments between them (a pruned visibility graph; Lozano-Perez and Wesley, 1979).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any

import numpy as np
import numpy.typing as npt
import shapely
from scipy.sparse import csr_array
from scipy.sparse.csgraph import dijkstra

from cart2d.params import robot
from cart2d.planning import Grid, Node, Point

QUAD_SEGMENTS = 16  # per quarter circle of a grown corner


def node_bounds(grid: Grid) -> tuple[float, float, float, float]:
    """The rectangle the planner keeps the cart's centre in: the one spanned by the nodes."""
    (x0, y0), (w, h) = grid.origin, grid.size_m
    return x0, y0, x0 + w, y0 + h


def arena_bounds(grid: Grid, radius_m: float) -> tuple[float, float, float, float]:
    """The rectangle the walls leave a disc's centre (robot.toml's arena margin beyond the nodes)."""
    margin = float(robot()["sim"]["arena_margin_m"]) - radius_m
    x0, y0, x1, y1 = node_bounds(grid)
    return x0 - margin, y0 - margin, x1 + margin, y1 + margin


def grown_obstacles(grid: Grid, obstacles: Iterable[Node], grow_m: float) -> tuple[Any, list[Any]]:
    """The obstacle cells (squares of one step around their nodes) grown by `grow_m`, touching
    ones merged, with rounded corners of QUAD_SEGMENTS segments per quarter circle (shapely): the
    geometry and its polygons (empty without obstacles)."""
    half = grid.step_m / 2
    ij = np.array(list(obstacles), dtype=np.float64).reshape(-1, 2)
    if not len(ij):
        return shapely.Polygon(), []
    x = grid.origin[0] + ij[:, 0] * grid.step_m
    y = grid.origin[1] + ij[:, 1] * grid.step_m
    union = shapely.union_all(shapely.box(x - half, y - half, x + half, y + half))
    grown = union.buffer(grow_m, quad_segs=QUAD_SEGMENTS)
    return grown, list(getattr(grown, "geoms", [grown]))


def true_shortest(
    grid: Grid,
    obstacles: Iterable[Node],
    radius_m: float,
    start: Point,
    goal: Point,
    bounds: tuple[float, float, float, float],
    circumscribed: bool = False,
) -> tuple[float, list[Point]]:
    """(length, points) of the shortest path for the disc among the grown obstacles, its centre
    inside `bounds` (x0, y0, x1, y1), the rounded corners inscribed (a lower bound) or
    circumscribed (an upper bound); inf if none."""
    grow = radius_m / math.cos(math.pi / (4 * QUAD_SEGMENTS)) if circumscribed else radius_m
    grown, polygons = grown_obstacles(grid, obstacles, grow)
    x0, y0, x1, y1 = bounds
    # a shortest path bends only at convex corners of the grown obstacles (inside the bounds)
    corners, before, after = [np.array([start, goal])], [np.zeros((2, 2))], [np.zeros((2, 2))]
    for polygon in polygons:
        polygon = shapely.geometry.polygon.orient(polygon)  # the obstacle on the left of each ring
        for ring in (polygon.exterior, *polygon.interiors):
            p = np.asarray(ring.coords)[:-1]
            a, c = np.roll(p, 1, axis=0), np.roll(p, -1, axis=0)
            convex = (p[:, 0] - a[:, 0]) * (c[:, 1] - p[:, 1]) - (p[:, 1] - a[:, 1]) * (c[:, 0] - p[:, 0]) > 0
            inside = (p[:, 0] > x0) & (p[:, 0] < x1) & (p[:, 1] > y0) & (p[:, 1] < y1)
            keep = convex & inside
            corners.append(p[keep])
            before.append(a[keep])
            after.append(c[keep])
    pts, prev, nxt = np.vstack(corners), np.vstack(before), np.vstack(after)
    m = len(pts)
    # candidate segments: tangent to the obstacle at both ends (start and goal: any direction)
    heads, tails = [], []
    for lo in range(0, m, 256):
        a_idx = np.arange(lo, min(lo + 256, m))[:, None]
        b_idx = np.arange(m)[None, :]
        dx, dy = pts[b_idx, 0] - pts[a_idx, 0], pts[b_idx, 1] - pts[a_idx, 1]

        def side(q: npt.NDArray[np.float64], at: npt.NDArray[np.int64]) -> npt.NDArray[np.float64]:
            out: npt.NDArray[np.float64] = dx * (q[at, 1] - pts[at, 1]) - dy * (q[at, 0] - pts[at, 0])  # noqa: B023
            return out

        tangent_a = (a_idx < 2) | (side(prev, a_idx) * side(nxt, a_idx) >= 0)
        tangent_b = (b_idx < 2) | (side(prev, b_idx) * side(nxt, b_idx) >= 0)
        ii, jj = np.nonzero((b_idx > a_idx) & tangent_a & tangent_b)
        heads.append(a_idx[ii, 0])
        tails.append(jj)
    head, tail = np.concatenate(heads), np.concatenate(tails)
    if not grown.is_empty:
        # touching a grown obstacle is allowed: test against a hair-thinner copy
        solid = grown.buffer(-1e-7)
        shapely.prepare(solid)
        free = ~shapely.intersects(solid, shapely.linestrings(np.stack([pts[head], pts[tail]], axis=1)))
        head, tail = head[free], tail[free]
    length = np.hypot(pts[tail, 0] - pts[head, 0], pts[tail, 1] - pts[head, 1])
    both = (np.concatenate([length, length]), (np.concatenate([head, tail]), np.concatenate([tail, head])))
    dist, pred = dijkstra(csr_array(both, shape=(m, m)), indices=[0], return_predecessors=True)
    if not np.isfinite(dist[0][1]):
        return math.inf, []
    path = [1]
    while path[-1] != 0:
        path.append(int(pred[0][path[-1]]))
    return float(dist[0][1]), [(float(pts[k, 0]), float(pts[k, 1])) for k in reversed(path)]


def shortest_length(
    grid: Grid, obstacles: Iterable[Node], radius_m: float, start: Point, goal: Point
) -> float:
    """The physical lower bound: the shortest path for the disc between the arena's walls."""
    return true_shortest(grid, obstacles, radius_m, start, goal, arena_bounds(grid, radius_m))[0]

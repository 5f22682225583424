"""The true shortest collision-free path for a disc among square obstacle cells: the reference
that grid plans are measured against.

The cart's centre must stay out of every obstacle cell grown by the footprint radius (a square
with rounded corners) and inside the arena walls shrunk by it. Shortest paths among such shapes
are straight lines that touch the grown obstacles and arcs around their corners; the arcs are
replaced by polygons inscribed in them (shapely's buffer), so the polygonal path found is never
longer than the true one: a lower bound, within a fraction of a millimetre per corner. The path
runs over the visibility graph of the polygons' vertices (Lozano-Perez and Wesley, 1979).
"""

from __future__ import annotations

import heapq
import itertools
import math
from collections.abc import Iterable

import numpy as np
import shapely
from shapely.geometry import LineString, MultiPolygon, Polygon, box
from shapely.ops import unary_union

from cart2d.params import robot
from cart2d.planner import Grid, Node, Point

QUAD_SEGMENTS = 8  # per quarter circle: a chord falls short of the arc by r (1 - cos(pi / 32)), 0.8 mm


def grown_obstacles(grid: Grid, obstacles: Iterable[Node], radius_m: float) -> Polygon | MultiPolygon:
    half = grid.step_m / 2
    cells = [
        box(x - half, y - half, x + half, y + half) for x, y in (grid.node_xy(i, j) for i, j in obstacles)
    ]
    if not cells:
        return Polygon()
    grown = unary_union(cells).buffer(radius_m, quad_segs=QUAD_SEGMENTS)
    assert isinstance(grown, Polygon | MultiPolygon)
    return grown


def _convex_vertices(shape: Polygon | MultiPolygon) -> list[Point]:
    """The vertices where the free space is concave, the only places a shortest path bends:
    convex corners of the obstacles' outlines (and reflex corners of holes inside them)."""
    polygons = [shape] if isinstance(shape, Polygon) else list(shape.geoms)
    out: list[Point] = []
    for polygon in polygons:
        polygon = shapely.geometry.polygon.orient(polygon)  # exterior CCW, holes CW
        for ring in [polygon.exterior, *polygon.interiors]:
            pts = list(ring.coords)[:-1]
            for k, (bx, by) in enumerate(pts):
                ax, ay = pts[k - 1]
                cx, cy = pts[(k + 1) % len(pts)]
                if (bx - ax) * (cy - by) - (by - ay) * (cx - bx) > 0:  # a left turn: convex
                    out.append((float(bx), float(by)))
    return out


def shortest_path(
    grid: Grid, obstacles: Iterable[Node], radius_m: float, start: Point, goal: Point
) -> tuple[float, list[Point]]:
    """(length, points) of the shortest path from start to goal for a disc of `radius_m`; the
    length is inf when the goal cannot be reached."""
    margin = float(robot()["sim"]["arena_margin_m"]) - radius_m
    width, height = grid.size_m
    ox, oy = grid.origin
    arena = box(ox - margin, oy - margin, ox + width + margin, oy + height + margin)
    grown = grown_obstacles(grid, list(obstacles), radius_m)
    # Touching a grown obstacle is allowed (that is where shortest paths run): test against a
    # hair-thinner copy.
    solid = grown.buffer(-1e-7) if not grown.is_empty else grown
    shapely.prepare(solid)
    nodes = [start, goal] + [p for p in _convex_vertices(grown) if arena.contains(shapely.Point(p))]
    pairs = list(itertools.combinations(range(len(nodes)), 2))
    lines = np.array([LineString([nodes[a], nodes[b]]) for a, b in pairs], dtype=object)
    blocked = shapely.intersects(solid, lines) if not solid.is_empty else np.zeros(len(pairs), dtype=bool)
    graph: list[list[tuple[int, float]]] = [[] for _ in nodes]
    for (a, b), hit in zip(pairs, blocked, strict=True):
        if not hit:
            d = math.dist(nodes[a], nodes[b])
            graph[a].append((b, d))
            graph[b].append((a, d))
    dist = [math.inf] * len(nodes)
    prev = [-1] * len(nodes)
    dist[0] = 0.0
    heap = [(0.0, 0)]
    while heap:
        d, k = heapq.heappop(heap)
        if k == 1:
            break
        if d > dist[k]:
            continue
        for k2, w in graph[k]:
            if d + w < dist[k2]:
                dist[k2], prev[k2] = d + w, k
                heapq.heappush(heap, (d + w, k2))
    if math.isinf(dist[1]):
        return math.inf, []
    path = [1]
    while path[-1] != 0:
        path.append(prev[path[-1]])
    return dist[1], [nodes[k] for k in reversed(path)]


def shortest_length(
    grid: Grid, obstacles: Iterable[Node], radius_m: float, start: Point, goal: Point
) -> float:
    return shortest_path(grid, obstacles, radius_m, start, goal)[0]

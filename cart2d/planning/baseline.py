"""The seed's path planning, reproduced as a baseline to measure cart2d against.

The seed's ESP32 ("Fixed Graph") kept a 10 x 10 grid graph with unit edge weights, 8-connected;
an obstacle cleared the edges out of its node, so it was simply a node that no path crosses;
Dijkstra ran from the node where the cart was, and every node of the shortest path was sent to
the Nano as a waypoint. Nothing knew the cart's size. Its firmware stopped within 0.1 m of a
point and used unit gains in the polar controller: `SEED_SETTINGS`.

Only `cart2d mission --behaviour seed` and the benchmarks use this module.
"""

from __future__ import annotations

import heapq
from collections.abc import Iterable

from cart2d.planning import DIRECTIONS, Grid, Node, Point, Unreachable

# The firmware settings that make our firmware behave as the seed's did (by name, see
# config/robot.toml): unit polar gains, 10 cm tolerances, no speed feedforward.
SEED_SETTINGS: dict[str, float] = {
    "pos_rho_kp": 1.0,
    "pos_phase_kp": 1.0,
    "tol_final_m": 0.1,
    "tol_pass_m": 0.1,
    "speed_kff": 0.0,
}


def seed_path(grid: Grid, obstacles: Iterable[Node], start: Point, goal: Point) -> list[Point]:
    """The seed's waypoints from the node nearest `start` to the node nearest `goal`: every node
    of a fewest-moves 8-connected path that avoids the obstacle nodes (the start node excluded)."""
    blocked = set(obstacles)
    source, target = grid.nearest_node(*start), grid.nearest_node(*goal)
    if target in blocked:
        raise Unreachable(f"the goal's node {target} holds an obstacle")
    hops = {source: 0}
    previous: dict[Node, Node] = {}
    queue: list[tuple[int, Node]] = [(0, source)]
    while queue:
        d, node = heapq.heappop(queue)
        if node == target:
            break
        if d > hops[node]:
            continue
        for di, dj in DIRECTIONS:
            nxt = (node[0] + di, node[1] + dj)
            if grid.has_node(*nxt) and nxt not in blocked and d + 1 < hops.get(nxt, d + 2):
                hops[nxt] = d + 1
                previous[nxt] = node
                heapq.heappush(queue, (d + 1, nxt))
    if target not in hops:
        raise Unreachable(f"no path of free nodes joins {source} and {target}")
    nodes = [target]
    while nodes[-1] != source:
        nodes.append(previous[nodes[-1]])
    nodes.reverse()
    return [grid.node_xy(*n) for n in nodes[1:]] or [grid.node_xy(*target)]

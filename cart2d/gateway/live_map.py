"""The map as the gateway keeps it, and the checks that decide a replan.

- `planner_for`: the planner of a MapSettings: the seed's node grid (walls a margin outside the
  nodes), or a floor plan planned on blocks of its cells (cart2d/maps/occupancy.py), whose
  footprint must stay on the map's cells, unknown cells blocked unless allowed; `layout_for`
  the same map on a finer grid, for the camera's small obstacles (cart2d/gateway/perceived.py).
- `world_for`: the simulator's physical world for that map: the arena's walls around the node
  grid, or the floor plan's occupied cells as walls and a boundary at its edge. Unknown cells are
  floor in the simulated world: what is unknown is the gateway's belief, not the world.
- `route_blocked`, `off_route_m`: the rest of a driven route against the map (footprint plus
  clearance, the planner's own check), and how far the cart is off it.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from cart2d.maps import OCCUPIED, UNKNOWN, OccupancyMap
from cart2d.maps.world import WallGrid, World, arena_world
from cart2d.params import planning_radius_m, robot
from cart2d.planning import CellKinds, Grid, GridGraph, Node, Planner, Point, point_segment_distance
from cart2d.planning.refine import occupied_cells, odd_factor, refined_cells, refined_grid
from cart2d.store import MapSettings

# A grid made finer for small obstacles has at most this many nodes: it is rebuilt whenever the
# camera's cells change, up to a few times a second (at this size ~3 ms to build, ~60 ms for a
# plan across it, on this project's 2-core machine).
FINE_PLANNING_NODES = 250_000


@dataclass(frozen=True)
class Layout:
    """What a Planner is built from (see GridGraph): the grid, the user's obstacle nodes, the
    other blocked cells and whether the footprint must stay on the cells."""

    grid: Grid
    obstacles: tuple[Node, ...]
    blocked: npt.NDArray[np.bool_] | None
    outside_blocked: bool
    start_slack_m: float = 0.0  # made finer: the map's own half step (plan_path)
    kinds: CellKinds | None = None  # a floor plan's: which blocked cells are walls, which unknown

    def planner(self, also_blocked: npt.NDArray[np.bool_] | None = None) -> Planner:
        blocked, kinds = self.blocked, self.kinds
        if also_blocked is not None:
            blocked = also_blocked if blocked is None else blocked | also_blocked
            if kinds is not None:  # what the camera saw is an obstacle, whatever the plan says
                seen = ~also_blocked
                kinds = CellKinds(*(None if a is None else a & seen for a in (kinds.unknown, kinds.walls)))
        return Planner(
            self.grid,
            planning_radius_m(),
            self.obstacles,
            blocked,
            self.outside_blocked,
            self.start_slack_m,
            kinds,
        )


def planner_for(m: MapSettings) -> Planner:
    return layout_for(m).planner()


def layout_for(m: MapSettings, finest_m: float | None = None) -> Layout:
    """The planner's layout of the map; with `finest_m`, on a grid whose step is at most that (as
    far as FINE_PLANNING_NODES allows) blocking the same floor, for smaller obstacles to be added
    (cart2d/planning/refine.py): the user's obstacles are then blocked cells, no longer nodes."""
    if m.floor_plan is None:
        grid = Grid(cols=m.cols, rows=m.rows, step_m=m.step_m, origin=m.origin_m)
        factor = (
            1 if finest_m is None else odd_factor(m.step_m, finest_m, m.cols, m.rows, FINE_PLANNING_NODES)
        )
        if factor == 1:
            return Layout(grid, tuple(m.obstacles), None, False)
        occupied = refined_cells(occupied_cells(grid, m.obstacles), factor)
        return Layout(refined_grid(grid, factor), (), occupied, False, m.step_m / 2)
    occupancy = m.floor_plan.occupancy()
    k = occupancy.planning_factor(m.planning_step_m, planning_radius_m())
    coarse = occupancy.coarsened(k)
    fine_k = k if finest_m is None else _floor_plan_factor(occupancy, k, finest_m)
    if fine_k == k:
        kinds = _kinds(coarse, m.unknown_is_free)
        return Layout(coarse.grid(), tuple(m.obstacles), coarse.blocked(m.unknown_is_free), True, kinds=kinds)
    # a floor plan's grid is its own cells in blocks: finer blocks of a divisor of k, so that
    # each of the map's cells (the user's obstacles) is exactly q x q of them
    fine, q = occupancy.coarsened(fine_k), k // fine_k
    users = np.kron(occupied_cells(coarse.grid(), m.obstacles), np.ones((q, q), dtype=np.bool_))
    users = users[: fine.height, : fine.width].astype(np.bool_)
    blocked = fine.blocked(m.unknown_is_free) | users
    kinds = _kinds(fine, m.unknown_is_free, users)
    return Layout(fine.grid(), (), blocked, True, coarse.grid().step_m / 2, kinds)


def _kinds(
    plan: OccupancyMap, unknown_is_free: bool, users: npt.NDArray[np.bool_] | None = None
) -> CellKinds:
    """The floor plan's walls and (when blocked) unknown cells, without the user's obstacles."""
    unknown = None if unknown_is_free else plan.cells == UNKNOWN
    walls = plan.cells == OCCUPIED
    if users is not None:
        unknown, walls = (None if unknown is None else unknown & ~users), walls & ~users
    return CellKinds(unknown, walls)


def _floor_plan_factor(occupancy: OccupancyMap, k: int, finest_m: float) -> int:
    """The block size for planning finer than k: the largest divisor of k whose step is at most
    `finest_m` (1 if none), grown to the next divisor while the grid is over FINE_PLANNING_NODES."""
    divisors = [d for d in range(1, k + 1) if k % d == 0]
    fitting = [d for d in divisors if d * occupancy.resolution_m <= finest_m + 1e-9]
    chosen = max(fitting) if fitting else 1
    for d in divisors:
        if d >= chosen and -(-occupancy.width // d) * -(-occupancy.height // d) <= FINE_PLANNING_NODES:
            return d
    return k


def world_for(m: MapSettings) -> World:
    if m.floor_plan is None:
        return arena_world(m.cols, m.rows, m.step_m, origin=m.origin_m)
    occupancy = m.floor_plan.occupancy()
    walls = WallGrid(
        occupancy.origin_m,
        occupancy.resolution_m,
        occupancy.width,
        occupancy.height,
        tuple((occupancy.cells == 100).reshape(-1).tolist()),
    )
    return World(walls=walls, boundary=True)


def arena(m: MapSettings) -> dict[str, float]:
    """Where the walls around the map are: a margin outside the nodes, or the floor plan's edge."""
    if m.floor_plan is not None:
        x0, y0, x1, y1 = m.floor_plan.occupancy().extent_m
        return {"x_min": x0, "y_min": y0, "x_max": x1, "y_max": y1}
    margin = float(robot()["sim"]["arena_margin_m"])  # walls outside the grid (the brief)
    ox, oy = m.origin_m
    return {
        "x_min": ox - margin,
        "y_min": oy - margin,
        "x_max": ox + (m.cols - 1) * m.step_m + margin,
        "y_max": oy + (m.rows - 1) * m.step_m + margin,
    }


def projection(p: Point, a: Point, b: Point) -> Point:
    """The point of segment ab nearest p."""
    dx, dy = b[0] - a[0], b[1] - a[1]
    length2 = dx * dx + dy * dy
    t = 0.0 if length2 == 0.0 else min(max(((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / length2, 0.0), 1.0)
    return (a[0] + t * dx, a[1] + t * dy)


@dataclass(frozen=True)
class RouteAhead:
    """What is left of a driven route: from the point of the current segment nearest the cart
    (`entry`) through the waypoints not yet reached."""

    entry: Point
    points: tuple[Point, ...]

    @classmethod
    def of(cls, start: Point, waypoints: Sequence[Point], index: int, pose: Point) -> RouteAhead:
        """`waypoints`: the route as sent (without its start); `index`: the waypoint the cart
        drives to (the firmware's waypoint index)."""
        index = min(max(index, 0), len(waypoints) - 1)
        before = start if index == 0 else waypoints[index - 1]
        return cls(projection(pose, before, waypoints[index]), tuple(waypoints[index:]))

    def blocked(self, graph: GridGraph) -> bool:
        """Whether a segment of it is no longer free for the planner's disc (footprint plus
        clearance): the check the planner made when it planned them."""
        return any(not graph.segment_free(a, b) for a, b in itertools.pairwise((self.entry, *self.points)))

    def distance(self, pose: Point) -> float:
        line = (self.entry, *self.points)
        if len(line) == 1:
            return math.dist(pose, line[0])
        return min(point_segment_distance(pose, a, b) for a, b in itertools.pairwise(line))


@dataclass(frozen=True)
class Replan:
    """One replan of a mission, for the report and viewers."""

    reason: str  # why: the map changed (what), or the cart left its path
    at_s: float  # seconds since the mission started (monotonic)
    sim_t: float | None  # the simulator's time when the new path was in the firmware, if simulated
    plan_time_s: float  # planning (search, simplification, rounding), wall-clock
    length_m: float  # the new path's length, from the cart's position
    waypoints: int
    outcome: str  # "replanned", or why no path remains


def cells_text(counts: dict[str, int]) -> str:
    return ", ".join(f"{n} {what}" for what, n in counts.items())

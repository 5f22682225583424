"""Plans from the cart's measured position to a goal, and the Planner that keeps the map."""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from cart2d.planning.geometry import polyline_length
from cart2d.planning.graph import GridGraph
from cart2d.planning.grid import (
    EPS,
    SQRT2,
    GoalBlocked,
    Grid,
    Node,
    OffMap,
    Point,
    StartBlocked,
    Unreachable,
    _finite,
    _fmt,
)
from cart2d.planning.search import _search
from cart2d.planning.simplification import simplify


@dataclass(frozen=True)
class Plan:
    """A path from the cart's measured position to the goal, in metres.

    `path`: the optimal grid path (start, nodes, goal); `waypoints`: the simplified path the cart
    drives in straight lines (without the start, ending exactly at the goal); their lengths."""

    start: Point
    goal: Point
    path: tuple[Point, ...]
    waypoints: tuple[Point, ...]
    grid_length_m: float
    length_m: float


@dataclass(frozen=True)
class CellKinds:
    """Which of a planner's blocked cells, (rows, cols), are a floor plan's unknown space and its
    walls (the rest: the user's obstacles, what the camera saw): a refusal says what is in the
    way, and gives advice that can be followed (a wall cannot be removed; unknown space can be
    planned through)."""

    unknown: npt.NDArray[np.bool_] | None = None
    walls: npt.NDArray[np.bool_] | None = None

    def what_blocks(self, graph: GridGraph, u: float, v: float) -> str:
        """'edge', 'unknown', 'wall' or 'obstacle': what keeps the disc at (u, v) (grid units) off."""
        cells = graph._point_blockers(u, v)
        if not cells:
            return "edge" if not graph._inside(u, v) else "obstacle"
        unknown = [bool(self.unknown.flat[k]) if self.unknown is not None else False for k in cells]
        walls = [bool(self.walls.flat[k]) if self.walls is not None else False for k in cells]
        if all(unknown):
            return "unknown"
        if all(a or b for a, b in zip(unknown, walls, strict=True)):
            return "wall"
        return "obstacle"


_BLOCKED_WORDS = {
    "edge": "too close to the map's edge for the cart, which keeps {r:g} m inside it",
    "unknown": "in unknown space (cells the floor plan does not know) or too close to it for the cart, "
    "which keeps {r:g} m from it",
    "wall": "inside a wall of the floor plan or too close to one for the cart, which keeps {r:g} m from "
    "walls",
    "obstacle": "inside an obstacle or too close to one for the cart, which keeps {r:g} m from obstacles",
}
_START_ADVICE = {
    "edge": "set the pose where the cart really stands on the map (Set pose, POST /api/pose)",
    "unknown": "set the pose where the cart really stands, or plan through unknown cells (unknown_is_free)",
    "wall": "set the pose where the cart really stands on the floor plan (Set pose, POST /api/pose), "
    "or load the plan with an origin that puts the cart where it stands",
    "obstacle": "remove that obstacle or move the cart",
}
_GOAL_ADVICE = {
    "unknown": ": pick a goal on known floor, or plan through unknown cells (unknown_is_free)",
}


def _blocked(graph: GridGraph, point: Point, kinds: CellKinds | None) -> tuple[str, str]:
    """What keeps the cart off `point` (metres; the planner found it blocked), and in words."""
    u, v = graph.grid.to_grid(*point)
    kind = (kinds or CellKinds()).what_blocks(graph, u, v)
    return kind, _BLOCKED_WORDS[kind].format(r=graph.footprint_radius_m)


def blocked_words(graph: GridGraph, point: Point, kinds: CellKinds | None, start: bool) -> str:
    """Why the cart cannot stand at `point` (metres; the planner found it blocked), with advice."""
    kind, words = _blocked(graph, point, kinds)
    if start:
        return f"the cart's position {_fmt(*point)} is {words}: {_START_ADVICE[kind]}"
    return f"the goal {_fmt(*point)} is {words}{_GOAL_ADVICE.get(kind, '')}"


def plan_path(
    graph: GridGraph,
    start: Point,
    goal: Point,
    start_slack_m: float = 0.0,
    kinds: CellKinds | None = None,
) -> Plan:
    """The shortest grid path from the measured `start` to the exact `goal` (metres), and its
    simplification. Raises OffMap, StartBlocked, GoalBlocked or Unreachable; changes nothing.
    `kinds`: what the blocked cells are, for the refusals' words."""
    grid = graph.grid
    sx, sy = float(start[0]), float(start[1])
    gx, gy = float(goal[0]), float(goal[1])
    r = graph.footprint_radius_m
    _finite(sx, sy, "the cart's position")
    _finite(gx, gy, "the goal")
    # The measured position may stray a little outside the node rectangle (odometry noise at an
    # edge node): accept it up to half a step out, as for obstacles, or `start_slack_m` (the map's
    # own half step, on a grid made finer: cart2d/planning/refine.py), from the rectangle's edge.
    slack_m = max(grid.step_m / 2, start_slack_m)
    if not grid.within(sx, sy, slack_m):
        raise OffMap(
            f"the cart's position {_fmt(sx, sy)} is off the map: it must lie within "
            f"{grid.bounds_text(slack_m)}"
        )
    if not grid.on_map(sx, sy):
        sx, sy = grid.clamp(sx, sy)
    if not grid.inside(gx, gy):
        raise OffMap(
            f"the goal {_fmt(gx, gy)} is off the map: the cart's centre must stay within {grid.bounds_text()}"
        )
    s, g = grid.to_grid(sx, sy), grid.to_grid(gx, gy)
    if not graph._point_clear(*s):
        raise StartBlocked(blocked_words(graph, (sx, sy), kinds, start=True))
    if not graph._point_clear(*g):
        raise GoalBlocked(blocked_words(graph, (gx, gy), kinds, start=False))

    direct_m = math.dist((sx, sy), (gx, gy))
    # The goal is one more neighbour of the start when it lies as close as the start's nodes do.
    near = math.dist(s, g) <= SQRT2 + EPS and graph._segment_clear(s, g)
    bound = direct_m if near else math.inf
    # Search first within twice the octile distance (plus the ends): most goals are reached
    # without visiting the whole map; the search widens only when that finds nothing.
    du, dv = abs(g[0] - s[0]), abs(g[1] - s[1])
    hint = 2.0 * (max(du, dv) + (SQRT2 - 1.0) * min(du, dv) + 4.0) * grid.step_m
    found = _search(graph, graph._connections(*s), graph._connections(*g), bound, hint)
    if found is not None:
        nodes = found[1]
        ij = np.column_stack((nodes % grid.cols, nodes // grid.cols)).astype(np.float64)
        path_g = np.vstack((s, ij, g))
        path_m = np.vstack(((sx, sy), np.asarray(grid.origin) + ij * grid.step_m, (gx, gy)))
        # a node that is the start or the goal itself appears once, as the exact point
        if math.dist(path_g[0], path_g[1]) <= EPS:
            path_g, path_m = np.delete(path_g, 1, axis=0), np.delete(path_m, 1, axis=0)
        if len(path_g) > 2 and math.dist(path_g[-2], path_g[-1]) <= EPS:
            path_g, path_m = np.delete(path_g, -2, axis=0), np.delete(path_m, -2, axis=0)
    elif near or graph._segment_clear(s, g):
        # in sight: the straight segment (also when no grid route exists, e.g. a pocket)
        path_g, path_m = np.array([s, g]), np.array([(sx, sy), (gx, gy)])
    else:
        raise Unreachable(
            f"the goal {_fmt(gx, gy)} cannot be reached from the cart's position {_fmt(sx, sy)}: "
            f"obstacles wall it off for the cart, which keeps {r:g} m from obstacles"
        )

    simple = np.asarray(grid.origin) + simplify(graph, path_g) * grid.step_m
    simple[0], simple[-1] = path_m[0], path_m[-1]  # exactly the measured start and the goal
    points = tuple(zip(path_m[:, 0].tolist(), path_m[:, 1].tolist(), strict=True))
    waypoints = tuple(zip(simple[1:, 0].tolist(), simple[1:, 1].tolist(), strict=True))
    return Plan(
        start=(sx, sy),
        goal=(gx, gy),
        path=points,
        waypoints=waypoints,
        grid_length_m=polyline_length(path_m),
        length_m=polyline_length(simple),
    )


class Planner:
    """The map (grid, footprint, obstacle nodes, and a floor plan's blocked cells) and its plans;
    the graph is rebuilt lazily after the obstacles change. Obstacles are edited by a point in
    metres, rounded to the nearest node. `blocked` and `outside_blocked`: see GridGraph."""

    def __init__(
        self,
        grid: Grid | None = None,
        footprint_radius_m: float = 0.0,
        obstacles: Iterable[Node] = (),
        blocked: npt.NDArray[np.bool_] | None = None,
        outside_blocked: bool = False,
        start_slack_m: float = 0.0,
        kinds: CellKinds | None = None,
    ) -> None:
        self.grid = grid if grid is not None else Grid()
        self.start_slack_m = start_slack_m  # see plan_path
        self.kinds = kinds  # see plan_path
        self.blocked = None if blocked is None else np.array(blocked, dtype=np.bool_)
        self.outside_blocked = outside_blocked
        self._graph = self._build(obstacles, footprint_radius_m)  # validates everything
        self.footprint_radius_m = self._graph.footprint_radius_m
        self._obstacles = set(self._graph.obstacles)
        self._stale = False

    def _build(self, obstacles: Iterable[Node], radius_m: float) -> GridGraph:
        return GridGraph(self.grid, obstacles, radius_m, self.blocked, self.outside_blocked)

    @property
    def obstacles(self) -> frozenset[Node]:
        return frozenset(self._obstacles)

    @property
    def graph(self) -> GridGraph:
        if self._stale:
            self._graph = self._build(self._obstacles, self.footprint_radius_m)
            self._stale = False
        return self._graph

    def add_obstacle(self, x: float, y: float) -> Node:
        """Puts an obstacle on the node nearest to (x, y); returns that node."""
        node = self.grid.nearest_node(x, y)
        if node not in self._obstacles:
            self._obstacles.add(node)
            self._stale = True
        return node

    def remove_obstacle(self, x: float, y: float) -> Node:
        """Clears the node nearest to (x, y) (nothing happens if it holds no obstacle); returns it."""
        node = self.grid.nearest_node(x, y)
        if node in self._obstacles:
            self._obstacles.discard(node)
            self._stale = True
        return node

    def toggle_obstacle(self, x: float, y: float) -> bool:
        """Flips the node nearest to (x, y); True when it now holds an obstacle."""
        node = self.grid.nearest_node(x, y)
        if node in self._obstacles:
            self._obstacles.discard(node)
            present = False
        else:
            self._obstacles.add(node)
            present = True
        self._stale = True
        return present

    def set_obstacles(self, nodes: Iterable[Node]) -> None:
        """Replaces every obstacle (node indices); refused as a whole if one is off the grid."""
        graph = self._build(nodes, self.footprint_radius_m)
        self._graph, self._obstacles, self._stale = graph, set(graph.obstacles), False

    def plan(self, start: Point, goal: Point) -> Plan:
        """A plan from the cart's measured position `start` to `goal` (metres); see plan_path."""
        return plan_path(self.graph, start, goal, self.start_slack_m, self.kinds)

    def start_problem(self, position: Point, advice: bool = True) -> str | None:
        """Why a plan could not start at `position` (off the map, blocked), with what to do on a
        gateway (`advice`: set the pose, move the plan); None if it could."""
        x, y = position
        _finite(x, y, "the cart's position")
        if not self.grid.inside(x, y):
            kind, words = "wall", f"off the map, which spans {self.grid.bounds_text()}"
        elif self.graph._point_clear(*self.grid.to_grid(x, y)):
            return None
        else:
            kind, words = _blocked(self.graph, position, self.kinds)
        said = f"the cart's position {_fmt(x, y)} is {words}"
        return f"{said}: {_START_ADVICE[kind]}" if advice else said

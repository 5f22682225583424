"""Tests of the path planner (cart2d/planning/).

Expectations come from hand calculation or from an independent reference written here: its own
disc-square distance (nearest point by clamping), its own segment check (ternary search of the
convex distance along the segment), its own graph and Floyd-Warshall all-pairs shortest paths.
"""

from __future__ import annotations

import heapq
import itertools
import math
import random
from dataclasses import dataclass
from functools import cache

import pytest
from numpy import array as np_array
from numpy import int64 as np_int64
from numpy import isfinite as np_isfinite

from cart2d.planning import (
    GoalBlocked,
    Grid,
    GridGraph,
    Node,
    OffMap,
    Plan,
    PlanError,
    Planner,
    Point,
    StartBlocked,
    Unreachable,
    plan_path,
    segment_square_distance,
    shortest_path,
)
from cart2d.planning import search as search_module
from cart2d.planning import simplification as simplify_module

STEP = 0.2
TOL = 1e-9  # metres: the reference's contact tolerance (touching = blocked) and length tolerance


# --- the independent reference -----------------------------------------------------------------


def ref_point_distance(p: Point, centre: Point, half: float) -> float:
    """Distance from p to the nearest point of the square, found by clamping p into it."""
    nx = min(max(p[0], centre[0] - half), centre[0] + half)
    ny = min(max(p[1], centre[1] - half), centre[1] + half)
    return math.hypot(p[0] - nx, p[1] - ny)


def ref_segment_distance(a: Point, b: Point, centre: Point, half: float) -> float:
    """The distance to a convex set is convex along a segment: ternary search finds its minimum."""

    def f(t: float) -> float:
        return ref_point_distance((a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])), centre, half)

    lo, hi = 0.0, 1.0
    for _ in range(90):
        m1, m2 = lo + (hi - lo) / 3, hi - (hi - lo) / 3
        if f(m1) <= f(m2):
            hi = m2
        else:
            lo = m1
    return min(f(0.0), f(1.0), f((lo + hi) / 2))


def ref_centres(grid: Grid, obstacles: set[Node]) -> list[Point]:
    return [grid.node_xy(i, j) for i, j in obstacles]


def ref_segment_blocked(a: Point, b: Point, centres: list[Point], radius: float, half: float) -> bool:
    half_length = math.dist(a, b) / 2
    mid = ((a[0] + b[0]) / 2, (a[1] + b[1]) / 2)
    for c in centres:
        if ref_point_distance(mid, c, half) > half_length + radius + 1e-6:
            continue  # no point of the segment can come within the radius
        if ref_segment_distance(a, b, c, half) <= radius + TOL:
            return True
    return False


def min_clearance(points: list[Point], centres: list[Point], half: float, samples: int = 400) -> float:
    """Smallest distance from sampled points of the polyline to the obstacle squares."""
    best = math.inf
    for p, q in itertools.pairwise(points):
        for s in range(samples + 1):
            t = s / samples
            x, y = p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])
            for c in centres:
                best = min(best, ref_point_distance((x, y), c, half))
    return best


def floyd_warshall(n: int, edges: dict[tuple[int, int], float]) -> list[list[float]]:
    dist = [[0.0 if i == j else math.inf for j in range(n)] for i in range(n)]
    for (a, b), w in edges.items():
        dist[a][b] = min(dist[a][b], w)
    for k in range(n):
        row_k = dist[k]
        for i in range(n):
            dik = dist[i][k]
            if dik == math.inf:
                continue
            row_i = dist[i]
            dist[i] = [min(x, dik + y) for x, y in zip(row_i, row_k, strict=True)]
    return dist


def polyline(plan: Plan) -> list[Point]:
    return [plan.start, *plan.waypoints]


def length(points: list[Point]) -> float:
    return sum(math.dist(p, q) for p, q in itertools.pairwise(points))


# --- Grid --------------------------------------------------------------------------------------


def test_grid_defaults_are_the_seed_map() -> None:
    grid = Grid()
    assert (grid.cols, grid.rows, grid.step_m, grid.origin) == (10, 10, 0.2, (0.0, 0.0))
    assert grid.size_m == pytest.approx((1.8, 1.8))


@pytest.mark.parametrize(
    "kwargs",
    [
        {"cols": 1},
        {"rows": 0},
        {"cols": 2.5},
        {"step_m": 0.0},
        {"step_m": -0.2},
        {"step_m": math.nan},
        {"step_m": math.inf},
        {"origin": (math.nan, 0.0)},
        {"origin": (0.0,)},
    ],
)
def test_grid_rejects_bad_shapes(kwargs: dict[str, object]) -> None:
    with pytest.raises(ValueError):
        Grid(**kwargs)  # type: ignore[arg-type]


def test_grid_node_metres_round_trip_with_an_origin() -> None:
    grid = Grid(cols=5, rows=4, step_m=0.5, origin=(1.0, -2.0))
    assert grid.node_xy(0, 0) == (1.0, -2.0)
    assert grid.node_xy(4, 3) == (3.0, -0.5)
    assert grid.nearest_node(2.24, -1.26) == (2, 1)  # (1.48, 1.48) steps from the origin
    assert grid.nearest_node(0.76, -2.24) == (0, 0)  # within half a step outside the corner node
    assert grid.nearest_node(3.24, -0.26) == (4, 3)
    assert grid.index(4, 3) == 19 and grid.node(19) == (4, 3)


def test_grid_points_beyond_half_a_step_are_off_the_map() -> None:
    grid = Grid()
    for x, y in [(-0.11, 0.5), (1.91, 0.5), (0.5, -0.11), (0.5, 1.91), (math.nan, 0.0)]:
        with pytest.raises(OffMap):
            grid.nearest_node(x, y)
    assert grid.on_map(-0.09, 1.89) and not grid.inside(-0.09, 1.0)
    assert grid.inside(0.0, 1.8) and not grid.inside(1.81, 1.0)


# --- geometry ----------------------------------------------------------------------------------


def test_segment_square_distance_known_values() -> None:
    assert segment_square_distance((0, 0), (2, 0), (1, 1), 0.5) == pytest.approx(0.5)
    assert segment_square_distance((0, 1), (2, 1), (1, 1), 0.5) == 0.0  # crosses it
    assert segment_square_distance((0, 0), (1, 1), (1, 0), 0.5) == pytest.approx(0.0, abs=1e-15)  # corner
    assert segment_square_distance((3, 3), (3, 3), (1, 1), 0.5) == pytest.approx(math.hypot(1.5, 1.5))
    # the line x + y = 3 against the corner (0.5, 0.5)
    assert segment_square_distance((0, 3), (3, 0), (0, 0), 0.5) == pytest.approx((3 - 1) / math.sqrt(2))


def test_segment_square_distance_matches_the_reference() -> None:
    rng = random.Random(7)
    for _ in range(500):
        a = (rng.uniform(-2, 2), rng.uniform(-2, 2))
        b = (rng.uniform(-2, 2), rng.uniform(-2, 2))
        c = (rng.uniform(-1, 1), rng.uniform(-1, 1))
        h = rng.uniform(0.05, 0.6)
        assert segment_square_distance(a, b, c, h) == pytest.approx(
            ref_segment_distance(a, b, c, h), abs=1e-9
        )


# --- optimality against the brute-force reference ----------------------------------------------


@dataclass
class RefMap:
    """A random map, the planner's graph of it, and the reference's own view of it."""

    grid: Grid
    radius: float
    obstacles: set[Node]
    graph: GridGraph
    centres: list[Point]
    free: set[Node]
    index: dict[Node, int]
    edges: dict[tuple[int, int], float]
    dist: list[list[float]]

    def blocked(self, a: Point, b: Point) -> bool:
        return ref_segment_blocked(a, b, self.centres, self.radius, STEP / 2)

    def point_free(self, p: Point) -> bool:
        return all(ref_point_distance(p, c, STEP / 2) > self.radius + TOL for c in self.centres)

    def connections(self, p: Point) -> dict[Node, float]:
        """Free nodes within √2 steps of p, seen through a free segment."""
        out = {}
        for n in self.free:
            q = self.grid.node_xy(*n)
            if math.dist(p, q) <= math.sqrt(2) * STEP + 1e-12 and not self.blocked(p, q):
                out[n] = math.dist(p, q)
        return out


def random_maps(seed: int, count: int) -> list[RefMap]:
    rng = random.Random(seed)
    maps = []
    for case in range(count):
        cols, rows = rng.randint(5, 8), rng.randint(5, 8)
        origin = (round(rng.uniform(-1, 1), 2), round(rng.uniform(-1, 1), 2))
        grid = Grid(cols, rows, STEP, origin)
        # exact ties first: radius 0 (shared corners) and half a step (touching the next cell)
        radius = [0.0, 0.0, 0.1][case] if case < 3 else rng.uniform(0.0, 0.15)
        density = rng.uniform(0.05, 0.35)
        obstacles = {(i, j) for i in range(cols) for j in range(rows) if rng.random() < density}
        centres = ref_centres(grid, obstacles)
        nodes = [(i, j) for j in range(rows) for i in range(cols)]
        ref = RefMap(grid, radius, obstacles, GridGraph(grid, obstacles, radius), centres, set(), {}, {}, [])
        ref.free = {n for n in nodes if ref.point_free(grid.node_xy(*n))}
        ref.index = {n: k for k, n in enumerate(nodes)}
        for a in ref.free:
            for di in (-1, 0, 1):
                for dj in (-1, 0, 1):
                    b = (a[0] + di, a[1] + dj)
                    pa, pb = grid.node_xy(*a), grid.node_xy(*b)
                    if b != a and b in ref.free and not ref.blocked(pa, pb):
                        ref.edges[ref.index[a], ref.index[b]] = math.dist(pa, pb)
        ref.dist = floyd_warshall(len(nodes), ref.edges)
        maps.append(ref)
    return maps


@cache
def maps() -> list[RefMap]:
    return random_maps(2024, 50)


def test_graph_matches_the_reference_nodes_and_edges() -> None:
    for case, ref in enumerate(maps()):
        grid, graph = ref.grid, ref.graph
        nodes = [(i, j) for j in range(grid.rows) for i in range(grid.cols)]
        assert {n for n in nodes if graph.node_free(*n)} == ref.free, f"case {case}"
        for a in nodes:
            for b in nodes:
                if a != b and max(abs(a[0] - b[0]), abs(a[1] - b[1])) == 1:
                    expected = (ref.index[a], ref.index[b]) in ref.edges
                    assert graph.edge_free(a, b) == expected, f"case {case}: edge {a}-{b}"


def check_plan(ref: RefMap, plan: Plan, start: Point, goal: Point) -> None:
    """The plan's path uses reference connections and edges, its simplification free segments."""
    grid = ref.grid
    inner = [grid.nearest_node(*p) for p in plan.path[1:-1]]
    assert all(grid.node_xy(*n) == p for n, p in zip(inner, plan.path[1:-1], strict=True))
    if inner:
        assert inner[0] in ref.connections(start) and inner[-1] in ref.connections(goal)
    for a, b in itertools.pairwise(inner):
        assert (ref.index[a], ref.index[b]) in ref.edges
    for p, q in itertools.pairwise(polyline(plan)):
        assert not ref.blocked(p, q)
    assert plan.path[0] == start and plan.path[-1] == goal and plan.waypoints[-1] == goal
    assert plan.grid_length_m == pytest.approx(length(list(plan.path)), abs=TOL)
    assert math.dist(start, goal) - TOL <= plan.length_m <= plan.grid_length_m + TOL


def test_plans_between_nodes_are_optimal_against_floyd_warshall() -> None:
    rng = random.Random(5)
    checked = detours = unreachable = 0
    for case, ref in enumerate(maps()):
        free_nodes = sorted(ref.free)
        for _ in range(8):
            if len(free_nodes) < 2:
                break
            s, g = rng.sample(free_nodes, 2)
            start, goal = ref.grid.node_xy(*s), ref.grid.node_xy(*g)
            expected = ref.dist[ref.index[s]][ref.index[g]]
            if expected == math.inf:
                if ref.blocked(start, goal):
                    with pytest.raises(Unreachable):
                        plan_path(ref.graph, start, goal)
                    unreachable += 1
                continue
            plan = plan_path(ref.graph, start, goal)
            assert plan.grid_length_m == pytest.approx(expected, abs=TOL), f"case {case}: {s} -> {g}"
            check_plan(ref, plan, start, goal)
            checked += 1
            detours += expected > math.dist(start, goal) + 1e-6
    # the random maps exercised the interesting cases
    assert checked >= 200 and detours >= 50 and unreachable >= 10, (checked, detours, unreachable)


def test_plans_between_any_points_are_optimal_against_floyd_warshall() -> None:
    rng = random.Random(6)
    outcomes = {"plan": 0, "start": 0, "goal": 0, "unreachable": 0}
    for case, ref in enumerate(maps()):
        grid = ref.grid
        w, h = grid.size_m
        for _ in range(16):
            start = (grid.origin[0] + rng.uniform(0, w), grid.origin[1] + rng.uniform(0, h))
            goal = (grid.origin[0] + rng.uniform(0, w), grid.origin[1] + rng.uniform(0, h))
            if not ref.point_free(start):
                with pytest.raises(StartBlocked):
                    plan_path(ref.graph, start, goal)
                outcomes["start"] += 1
                continue
            if not ref.point_free(goal):
                with pytest.raises(GoalBlocked):
                    plan_path(ref.graph, start, goal)
                outcomes["goal"] += 1
                continue
            near = math.dist(start, goal) <= math.sqrt(2) * STEP and not ref.blocked(start, goal)
            expected = math.dist(start, goal) if near else math.inf
            ends = ref.connections(goal)
            for a, cost_a in ref.connections(start).items():
                for b, cost_b in ends.items():
                    expected = min(expected, cost_a + ref.dist[ref.index[a]][ref.index[b]] + cost_b)
            if expected == math.inf and not ref.blocked(start, goal):
                expected = math.dist(start, goal)  # no grid route, but in sight
            if expected == math.inf:
                with pytest.raises(Unreachable):
                    plan_path(ref.graph, start, goal)
                outcomes["unreachable"] += 1
                continue
            plan = plan_path(ref.graph, start, goal)
            assert plan.grid_length_m == pytest.approx(expected, abs=TOL), f"case {case}: {start} -> {goal}"
            check_plan(ref, plan, start, goal)
            outcomes["plan"] += 1
    assert outcomes["plan"] >= 200 and min(outcomes.values()) >= 10, outcomes


# --- corners, clearance, diagonals --------------------------------------------------------------


def test_no_corner_cutting_between_diagonal_obstacles() -> None:
    grid = Grid()
    graph = GridGraph(grid, {(3, 2), (2, 3)}, 0.0)
    assert not graph.edge_free((2, 2), (3, 3))
    assert not graph.edge_free((3, 3), (2, 2))
    assert graph.edge_free((2, 2), (1, 1))  # the same diagonal away from the obstacles is an edge
    plan = plan_path(graph, grid.node_xy(2, 2), grid.node_xy(3, 3))
    assert plan.grid_length_m > math.sqrt(2) * STEP + 0.1  # it had to go around
    centres = ref_centres(grid, {(3, 2), (2, 3)})
    for points in (list(plan.path), polyline(plan)):
        for p, q in itertools.pairwise(points):
            assert all(ref_segment_distance(p, q, c, STEP / 2) > 1e-6 for c in centres)


def test_a_node_boxed_in_by_two_diagonal_obstacles_is_unreachable() -> None:
    # (0, 0)'s only way out is between (1, 0) and (0, 1), through their shared corner
    planner = Planner(Grid(), 0.0, {(1, 0), (0, 1)})
    with pytest.raises(Unreachable):
        planner.plan((0.0, 0.0), (0.2, 0.2))


def test_clearance_blocks_the_ring_around_an_obstacle() -> None:
    graph = GridGraph(Grid(), {(5, 5)}, 0.17)
    for i in range(4, 7):
        for j in range(4, 7):
            assert not graph.node_free(i, j), (i, j)  # 0.1 m (side) or 0.141 m (diagonal) < 0.17 m
    for node in [(7, 5), (5, 7), (3, 5), (5, 3), (7, 7), (3, 3), (6, 7), (7, 4)]:
        assert graph.node_free(*node), node  # 0.3 m and more from the square


def test_paths_keep_the_footprint_clear_of_obstacles() -> None:
    obstacles = {(5, 5), (5, 4)}
    planner = Planner(Grid(), 0.17, obstacles)
    plan = planner.plan((0.2, 1.0), (1.8, 0.9))
    centres = ref_centres(planner.grid, obstacles)
    assert min_clearance(polyline(plan), centres, STEP / 2) >= 0.17 - 1e-9
    assert min_clearance(list(plan.path), centres, STEP / 2) >= 0.17 - 1e-9
    assert 2 <= len(plan.waypoints) <= 11  # around the block: two bends, up to five corners each
    assert math.dist((0.2, 1.0), (1.8, 0.9)) < plan.length_m <= plan.grid_length_m


def test_diagonal_moves_cost_root_two_steps() -> None:
    planner = Planner(Grid(), 0.0)
    plan = planner.plan((0.0, 0.0), (0.6, 0.6))
    assert plan.path == ((0.0, 0.0), (0.2, 0.2), (0.4, 0.4), (0.6, 0.6))
    assert plan.grid_length_m == pytest.approx(3 * math.sqrt(2) * STEP, abs=1e-12)  # not 3 steps
    # two diagonals and three straight steps (the octile distance), not five unit moves
    plan = planner.plan((0.0, 0.0), (1.0, 0.4))
    assert plan.grid_length_m == pytest.approx(2 * math.sqrt(2) * STEP + 3 * STEP, abs=1e-12)
    assert plan.waypoints == ((1.0, 0.4),)
    assert plan.length_m == pytest.approx(math.hypot(1.0, 0.4), abs=1e-12)


# --- start and goal off the nodes ---------------------------------------------------------------


def test_start_and_goal_between_nodes_join_the_grid_exactly() -> None:
    plan = Planner(Grid(), 0.0).plan((0.05, 0.0), (0.55, 0.0))
    # start -> (1, 0) 0.15 m, -> (2, 0) 0.2 m, -> goal 0.15 m: nothing shorter reaches a node
    assert plan.path == ((0.05, 0.0), (0.2, 0.0), (0.4, 0.0), (0.55, 0.0))
    assert plan.grid_length_m == pytest.approx(0.5, abs=1e-12)
    assert plan.waypoints == ((0.55, 0.0),)


def test_plans_start_from_the_measured_pose_and_stop_exactly_at_the_goal() -> None:
    obstacles = {(4, 3)}
    planner = Planner(Grid(), 0.17, obstacles)
    start, goal = (0.33, 0.07), (1.23, 1.41)
    plan = planner.plan(start, goal)
    assert plan.start == start and plan.path[0] == start
    assert plan.path[-1] == goal and plan.waypoints[-1] == goal
    assert math.dist(start, plan.path[1]) <= math.sqrt(2) * STEP + 1e-12
    assert math.dist(plan.path[-2], goal) <= math.sqrt(2) * STEP + 1e-12
    for node in plan.path[1:-1]:  # the inner points are nodes
        assert planner.grid.node_xy(*planner.grid.nearest_node(*node)) == node
    assert len(plan.waypoints) >= 2  # the obstacle sits on the straight line
    assert min_clearance(polyline(plan), ref_centres(planner.grid, obstacles), STEP / 2) >= 0.17 - 1e-9
    assert math.dist(start, goal) < plan.length_m <= plan.grid_length_m
    assert plan.grid_length_m == pytest.approx(length(list(plan.path)), abs=1e-12)
    assert plan.length_m == pytest.approx(length(polyline(plan)), abs=1e-12)


def test_goal_next_to_the_start_is_reached_directly() -> None:
    plan = Planner(Grid(), 0.17).plan((0.31, 0.52), (0.36, 0.55))
    assert plan.path == ((0.31, 0.52), (0.36, 0.55))
    assert plan.waypoints == ((0.36, 0.55),)
    assert plan.grid_length_m == pytest.approx(math.hypot(0.05, 0.03), abs=1e-12)


def test_start_slightly_outside_the_node_rectangle_is_accepted() -> None:
    # odometry noise around the origin node; half a step out is still on the map
    plan = Planner(Grid(), 0.17).plan((-0.004, -0.002), (0.6, 0.0))
    assert plan.waypoints == ((0.6, 0.0),)
    with pytest.raises(OffMap, match="off the map"):
        Planner(Grid(), 0.17).plan((-0.15, 0.0), (0.6, 0.0))


# --- errors --------------------------------------------------------------------------------------


def test_walled_in_goal_is_unreachable() -> None:
    ring = {(i, j) for i in range(3, 8) for j in range(3, 8) if max(abs(i - 5), abs(j - 5)) == 2}
    planner = Planner(Grid(), 0.0, ring)
    with pytest.raises(Unreachable, match=r"cannot be reached") as info:
        planner.plan((0.0, 0.0), (1.0, 1.0))
    assert "(1.000, 1.000)" in str(info.value) and "(0.000, 0.000)" in str(info.value)
    assert planner.obstacles == ring  # nothing changed
    assert planner.plan((1.0, 1.0), (1.2, 1.1)).waypoints == ((1.2, 1.1),)  # inside the ring is fine


@pytest.mark.parametrize("goal", [(1.0, 1.0), (1.1, 1.0), (1.25, 1.0), (1.12, 1.12)])
def test_goal_inside_or_too_close_to_an_obstacle(goal: Point) -> None:
    planner = Planner(Grid(), 0.17, {(5, 5)})
    with pytest.raises(GoalBlocked, match=r"goal .* inside an obstacle or too close to one") as info:
        planner.plan((0.0, 0.0), goal)
    assert f"({goal[0]:.3f}, {goal[1]:.3f})" in str(info.value) and "0.17 m" in str(info.value)


def test_goal_just_clear_of_an_obstacle_is_accepted() -> None:
    plan = Planner(Grid(), 0.17, {(5, 5)}).plan((0.0, 0.0), (1.28, 1.0))  # 0.18 m from the square
    assert plan.waypoints[-1] == (1.28, 1.0)


@pytest.mark.parametrize("goal", [(2.0, 0.5), (-0.01, 0.5), (0.5, 1.81), (math.nan, 0.5), (0.5, math.inf)])
def test_goal_off_the_map(goal: Point) -> None:
    with pytest.raises(OffMap, match="goal"):
        Planner(Grid(), 0.17).plan((0.0, 0.0), goal)


def test_start_inside_an_obstacle() -> None:
    planner = Planner(Grid(), 0.17, {(2, 0)})
    with pytest.raises(StartBlocked, match=r"cart's position \(0\.330, 0\.070\) is inside an obstacle"):
        planner.plan((0.33, 0.07), (1.0, 1.0))


def test_errors_share_one_base_class() -> None:
    for error in (OffMap, GoalBlocked, StartBlocked, Unreachable):
        assert issubclass(error, PlanError) and issubclass(error, ValueError)


# --- simplification ------------------------------------------------------------------------------


def test_diagonal_then_straight_becomes_one_straight_drive() -> None:
    plan = Planner(Grid(), 0.17).plan((0.0, 0.0), (1.8, 0.6))
    assert len(plan.path) == 10  # 3 diagonal + 6 straight grid moves
    assert plan.grid_length_m == pytest.approx(3 * math.sqrt(2) * STEP + 6 * STEP, abs=1e-12)
    assert plan.waypoints == ((1.8, 0.6),)  # open map: the goal is in sight
    assert plan.length_m == pytest.approx(math.hypot(1.8, 0.6), abs=1e-12)


def test_an_l_shaped_corridor_keeps_only_its_corner() -> None:
    # radius 0; row 3 walled for x <= 7, columns 7 and 9 walled above: the only way from (0, 2)
    # to (8, 9) runs along row 2 to (8, 2), then up column 8 (entering it diagonally from (7, 2)
    # would cut the corner of (7, 3))
    walls = {(i, 3) for i in range(8)} | {(7, j) for j in range(4, 10)} | {(9, j) for j in range(2, 10)}
    plan = Planner(Grid(), 0.0, walls).plan((0.0, 0.4), (1.6, 1.8))
    assert plan.grid_length_m == pytest.approx(8 * STEP + 7 * STEP, abs=1e-12)
    assert len(plan.path) == 16
    # pulled taut, the one corner slides from the node (1.6, 0.4) to the wall's corner (1.5, 0.5)
    corner, goal = plan.waypoints
    assert goal == (1.6, 1.8)
    assert math.dist(corner, (1.5, 0.5)) < 0.02
    graph = Planner(Grid(), 0.0, walls).graph
    assert graph.segment_free((0.0, 0.4), corner) and graph.segment_free(corner, goal)
    assert plan.length_m < plan.grid_length_m - 0.05


def test_shortcuts_never_lengthen_a_path() -> None:
    rng = random.Random(11)
    grid = Grid(20, 20, STEP)
    for _ in range(30):
        obstacles = {(i, j) for i in range(20) for j in range(20) if rng.random() < 0.2}
        planner = Planner(grid, rng.uniform(0.0, 0.09), obstacles)
        free = [(i, j) for j in range(20) for i in range(20) if planner.graph.node_free(i, j)]
        start, goal = (grid.node_xy(*n) for n in rng.sample(free, 2))
        try:
            plan = planner.plan(start, goal)
        except Unreachable:
            continue
        assert plan.length_m <= plan.grid_length_m + 1e-12
        assert plan.length_m >= math.dist(start, goal) - 1e-12
        # taut corners only replace or drop pulled ones; sharp bends get more, up to a bound
        assert len(plan.waypoints) <= max(len(plan.path) - 1, simplify_module._SPLIT_MAX)


# --- obstacles by metres ------------------------------------------------------------------------


def test_obstacles_round_to_the_nearest_node() -> None:
    planner = Planner(Grid(), 0.0)
    assert planner.add_obstacle(0.29, 0.51) == (1, 3)
    assert planner.obstacles == {(1, 3)}
    assert planner.add_obstacle(0.21, 0.59) == (1, 3)  # the same node again: no duplicate
    assert planner.obstacles == {(1, 3)}
    assert planner.remove_obstacle(0.25, 0.55) == (1, 3)
    assert planner.obstacles == frozenset()
    assert planner.toggle_obstacle(0.21, 0.59) is True
    assert planner.obstacles == {(1, 3)}
    assert planner.toggle_obstacle(0.19, 0.61) is False
    assert planner.obstacles == frozenset()
    assert planner.add_obstacle(1.89, -0.09) == (9, 0)  # within half a step outside the corner


@pytest.mark.parametrize("point", [(1.91, 0.5), (-0.11, 0.0), (0.5, 2.0), (math.nan, 0.0)])
def test_obstacles_off_the_map_are_refused(point: Point) -> None:
    planner = Planner(Grid(), 0.0, {(2, 2)})
    for edit in (planner.add_obstacle, planner.remove_obstacle, planner.toggle_obstacle):
        with pytest.raises(OffMap):
            edit(*point)
    assert planner.obstacles == {(2, 2)}


def test_obstacle_edits_change_the_next_plan() -> None:
    planner = Planner(Grid(), 0.0)
    assert planner.plan((0.0, 0.0), (0.8, 0.0)).waypoints == ((0.8, 0.0),)
    planner.add_obstacle(0.4, 0.0)
    plan = planner.plan((0.0, 0.0), (0.8, 0.0))
    assert len(plan.waypoints) >= 2 and plan.grid_length_m > 0.8
    planner.toggle_obstacle(0.4, 0.0)
    assert planner.plan((0.0, 0.0), (0.8, 0.0)).waypoints == ((0.8, 0.0),)


def test_obstacle_nodes_must_be_on_the_grid() -> None:
    with pytest.raises(OffMap):
        Planner(Grid(), 0.0, {(10, 0)})
    planner = Planner(Grid(), 0.0, {(1, 1)})
    with pytest.raises(OffMap):
        planner.set_obstacles({(2, 2), (-1, 0)})
    with pytest.raises(ValueError, match="integer"):
        planner.set_obstacles({(2, 2), (1.5, 0)})  # type: ignore[arg-type]
    assert planner.obstacles == {(1, 1)}


@pytest.mark.parametrize("radius", [-0.1, math.nan, math.inf])
def test_footprint_radius_is_validated(radius: float) -> None:
    with pytest.raises(ValueError):
        Planner(Grid(), radius)


def test_a_grid_far_finer_than_the_footprint_is_refused_not_exhausted() -> None:
    with pytest.raises(PlanError, match="too fine"):
        Planner(Grid(cols=10, rows=10, step_m=0.001), 0.17)


# --- large grids: the array-built graph, scipy's search, the array segment checks ---------------


def heap_dijkstra(graph: GridGraph, sources: dict[Node, float]) -> dict[Node, float]:
    """Textbook Dijkstra (heapq, no scipy) over the edges that `edge_free` reports."""
    grid = graph.grid
    dist = dict(sources)
    heap = [(cost, node) for node, cost in sources.items()]
    heapq.heapify(heap)
    done: set[Node] = set()
    while heap:
        d, a = heapq.heappop(heap)
        if a in done:
            continue
        done.add(a)
        for di, dj in itertools.product((-1, 0, 1), repeat=2):
            b = (a[0] + di, a[1] + dj)
            if b != a and grid.has_node(*b) and graph.edge_free(a, b):
                nd = d + math.hypot(di, dj) * grid.step_m
                if nd < dist.get(b, math.inf):
                    dist[b] = nd
                    heapq.heappush(heap, (nd, b))
    return dist


def maze_obstacles(cells: int, seed: int) -> tuple[int, set[Node]]:
    """A perfect maze (depth-first) of cells x cells rooms, 3 nodes wide, behind walls 1 node
    thick: (nodes per side, obstacle nodes)."""
    rng = random.Random(seed)
    n = 4 * cells + 1
    free: set[Node] = set()
    seen = {(0, 0)}
    stack = [(0, 0)]
    while stack:
        ci, cj = stack[-1]
        free.update((4 * ci + 1 + a, 4 * cj + 1 + b) for a in range(3) for b in range(3))
        options = [
            (ci + di, cj + dj)
            for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1))
            if 0 <= ci + di < cells and 0 <= cj + dj < cells and (ci + di, cj + dj) not in seen
        ]
        if not options:
            stack.pop()
            continue
        ni, nj = rng.choice(options)
        wall_i, wall_j = 4 * max(ci, ni), 4 * max(cj, nj)
        if ni != ci:
            free.update((wall_i, 4 * cj + 1 + b) for b in range(3))
        else:
            free.update((4 * ci + 1 + a, wall_j) for a in range(3))
        seen.add((ni, nj))
        stack.append((ni, nj))
    return n, {(i, j) for i in range(n) for j in range(n) if (i, j) not in free}


@dataclass
class Scene:
    name: str
    grid: Grid
    radius: float
    obstacles: set[Node]


@cache
def large_scenes() -> list[Scene]:
    rng = random.Random(12)
    n = 90
    field = {(i, j) for i in range(n) for j in range(n) if rng.random() < 0.2}
    cells = 20
    size, maze = maze_obstacles(cells, 3)
    return [
        Scene("random 20 %", Grid(n, n, 0.4), 0.17, field),
        Scene("maze", Grid(size, size, 0.2), 0.17, maze),
    ]


@pytest.mark.parametrize("case", range(2))
def test_large_grid_plans_are_optimal_against_a_heap_dijkstra(
    case: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    scene = large_scenes()[case]
    planner = Planner(scene.grid, scene.radius, scene.obstacles)
    graph = planner.graph
    grid = scene.grid
    free = [(i, j) for j in range(grid.rows) for i in range(grid.cols) if graph.node_free(i, j)]
    # the two free nodes nearest the corners, then random pairs
    corner = min(free, key=lambda n: n[0] + n[1]), max(free, key=lambda n: n[0] + n[1])
    rng = random.Random(case)
    pairs = [corner, *(tuple(rng.sample(free, 2)) for _ in range(3))]
    searches: list[float] = []
    run = search_module._Search.run

    def counting_run(self: search_module._Search, sources: dict[int, float], limit: float) -> object:
        searches.append(limit)
        return run(self, sources, limit)

    monkeypatch.setattr(search_module._Search, "run", counting_run)
    for s, g in pairs:
        dist = heap_dijkstra(graph, {s: 0.0})
        start, goal = grid.node_xy(*s), grid.node_xy(*g)
        if g not in dist:
            with pytest.raises(Unreachable):
                planner.plan(start, goal)
            continue
        plan = planner.plan(start, goal)
        assert plan.grid_length_m == pytest.approx(dist[g], rel=1e-12), (scene.name, s, g)
        inner = [grid.nearest_node(*p) for p in plan.path]
        assert inner[0] == s and inner[-1] == g
        assert all(graph.edge_free(a, b) for a, b in itertools.pairwise(inner))
        for p, q in itertools.pairwise(polyline(plan)):
            assert graph.segment_free(p, q)
        assert math.dist(start, goal) - TOL <= plan.length_m <= plan.grid_length_m + TOL
    if scene.name == "maze":  # its detours exceed the first, bounded search: it widened
        assert any(limit == math.inf for limit in searches) and any(limit < math.inf for limit in searches)


def test_large_footprints_match_the_reference_nodes_and_edges() -> None:
    """Footprints of several steps: stencils of many rows, runs of any width, obstacles at the
    map's border; exact ties (a radius of a whole or half number of steps) included."""
    rng = random.Random(21)
    for radius_steps in (0.5, 1.0, 1.5, 2.3, 3.0):
        cols, rows = 15, 13
        grid = Grid(cols, rows, STEP)
        radius = radius_steps * STEP
        obstacles = {(i, j) for i in range(cols) for j in range(rows) if rng.random() < 0.04}
        obstacles |= {(0, rng.randrange(rows)), (cols - 1, rng.randrange(rows)), (rng.randrange(cols), 0)}
        graph = GridGraph(grid, obstacles, radius)
        centres = ref_centres(grid, obstacles)
        for i, j in itertools.product(range(cols), range(rows)):
            p = grid.node_xy(i, j)
            expected = all(ref_point_distance(p, c, STEP / 2) > radius + TOL for c in centres)
            assert graph.node_free(i, j) == expected, (radius_steps, (i, j))
            for di, dj in ((1, 0), (1, 1), (0, 1), (-1, 1)):
                b = (i + di, j + dj)
                if grid.has_node(*b):
                    q = grid.node_xy(*b)
                    free_edge = expected and not ref_segment_blocked(p, q, centres, radius, STEP / 2)
                    assert graph.edge_free((i, j), b) == free_edge, (radius_steps, (i, j), b)
                    assert graph.edge_free(b, (i, j)) == free_edge


def test_array_segment_checks_agree_with_the_one_by_one_checks() -> None:
    rng = random.Random(8)
    grid = Grid(25, 20, STEP)
    obstacles = {(i, j) for i in range(25) for j in range(20) if rng.random() < 0.12}
    for radius in (0.0, 0.1, 0.17, 0.2, 0.26):  # 0.1 and 0.2: half and one step, exact ties
        graph = GridGraph(grid, obstacles, radius)
        a, b = [], []
        for k in range(400):
            p = (rng.uniform(-0.5, 24.5), rng.uniform(-0.5, 19.5))
            q = (p[0] + rng.uniform(-4, 4), p[1] + rng.uniform(-4, 4))
            if k % 4 == 0:  # between nodes
                p, q = (round(p[0]), round(p[1])), (round(q[0]), round(q[1]))
            elif k % 4 == 1:  # upright, level, or a point
                q = rng.choice([(p[0], q[1]), (q[0], p[1]), p])
            a.append(p)
            b.append(q)
        batch = graph._segments_clear(np_array(a, dtype=float), np_array(b, dtype=float))
        one_by_one = [graph._segment_clear(p, q) for p, q in zip(a, b, strict=True)]
        assert batch.tolist() == one_by_one, radius
        assert 40 < sum(one_by_one) < 360, radius  # both outcomes well represented


def test_shortest_path_takes_any_number_of_sources() -> None:
    graph = GridGraph(Grid(), {(5, j) for j in range(9)}, 0.0)  # a wall with a gap at the top
    sources = {(i, j): 0.1 * j for i in range(3) for j in range(10)}  # 30 of them
    expected = heap_dijkstra(graph, sources)[(9, 0)]
    found = shortest_path(graph, {i + 10 * j: c for (i, j), c in sources.items()}, {9: 0.0})
    assert found is not None
    cost, path = found
    assert cost == pytest.approx(expected, abs=1e-12) and cost > 1.5  # through the gap
    assert graph.grid.node(path[0]) in sources and path[-1] == 9
    assert shortest_path(graph, {0: 0.0}, {9: 0.0}, bound=1.0) is None
    assert shortest_path(graph, {k: 0.0 for k in range(3)}, {9: 0.0}, bound=expected) is None


def test_a_near_goal_on_a_large_map_is_planned_without_searching_it_all(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    grid = Grid(400, 400, 0.2)
    planner = Planner(grid, 0.17, {(200, j) for j in range(195, 206)})  # a wall 2 m long
    searches: list[tuple[float, int]] = []
    run = search_module._Search.run

    def spy(self: search_module._Search, sources: dict[int, float], limit: float) -> object:
        dist, pred = run(self, sources, limit)
        searches.append((limit, int(np_isfinite(dist).sum())))
        return dist, pred

    monkeypatch.setattr(search_module._Search, "run", spy)
    plan = planner.plan((39.0, 40.03), (41.6, 40.0))  # across the wall's middle
    assert 3.0 < plan.grid_length_m < 5.0  # around the wall
    # one search, within twice the octile distance (plus the ends), that reached few nodes
    ((limit, reached),) = searches
    assert limit == pytest.approx(2 * (13 + 0.15 * (math.sqrt(2) - 1) + 4) * 0.2)
    assert reached < grid.node_count / 20
    with pytest.raises(Unreachable):
        Planner(grid, 0.17, {(i, 2) for i in range(400)}).plan((0.0, 0.0), (70.0, 70.0))


def test_obstacles_are_taken_as_any_iterable_of_integer_pairs() -> None:
    expected = {(1, 2), (3, 4)}
    assert Planner(Grid(), 0.0, [[1, 2], [3, 4]]).obstacles == expected  # type: ignore[list-item]
    assert Planner(Grid(), 0.0, ((i, i + 1) for i in (1, 3))).obstacles == expected
    planner = Planner(Grid(), 0.0, expected)
    for bad in [(True, 2), (np_int64(1), 2), ("1", 2)]:
        with pytest.raises(ValueError, match="integer"):
            planner.set_obstacles([(0, 0), bad])  # type: ignore[list-item]
    for off in [(2**70, 0), (0, -(2**70)), (10, 0)]:
        with pytest.raises(OffMap, match="not on the 10 x 10 grid"):
            planner.set_obstacles([(0, 0), off])
    with pytest.raises(ValueError):
        planner.set_obstacles([(1, 2, 3)])  # type: ignore[list-item]
    assert planner.obstacles == expected


def farthest_in_sight(graph: GridGraph, points: list[Point], window: int) -> list[int]:
    """String pulling as specified: from each point kept, on to the farthest of the next `window`
    points that it sees; when it sees them all, on as long as it sees every point."""
    keep = [0]
    last = len(points) - 1
    while keep[-1] < last:
        i = keep[-1]
        end = min(i + window, last)
        seen = [j for j in range(i + 2, end + 1) if graph._segment_clear(points[i], points[j])]
        j = max(seen, default=i + 1)
        if j == end == i + window and len(seen) == window - 1:  # all of the window: on
            while j < last and graph._segment_clear(points[i], points[j + 1]):
                j += 1
        keep.append(j)
    return keep


def pulled_path(planner: Planner, plan: Plan) -> tuple[list[Point], list[int]]:
    """The plan's points after the collinear ones are dropped (grid units), and the indices of
    those that string pulling keeps."""
    grid = planner.grid
    inner = [grid.nearest_node(*p) for p in plan.path[1:-1]]
    points = np_array([grid.to_grid(*plan.path[0]), *inner, grid.to_grid(*plan.path[-1])], dtype=float)
    corners = points[simplify_module._drop_collinear(points)]
    pulled = simplify_module._string_pull(planner.graph, corners)
    return [(float(u), float(v)) for u, v in corners.tolist()], pulled


@pytest.mark.parametrize("scene", ["sparse", "dense", "maze"])
def test_string_pulling_on_long_paths_follows_its_specification(
    scene: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    rng = random.Random(4)
    if scene == "maze":
        n, obstacles = maze_obstacles(12, 5)
        grid, start, goal = Grid(n, n, 0.2), (0.4, 0.4), ((n - 3) * 0.2, (n - 3) * 0.2)
    else:
        n, density = {"sparse": (100, 0.04), "dense": (60, 0.2)}[scene]
        obstacles = {(i, j) for i in range(n) for j in range(n) if rng.random() < density}
        obstacles -= {(0, 0), (1, 0), (0, 1), (n - 1, n - 1), (n - 2, n - 1), (n - 1, n - 2)}
        grid, start, goal = Grid(n, n, 0.4), (0.0, 0.0), ((n - 1) * 0.4, (n - 1) * 0.4)
    planner = Planner(grid, 0.17, obstacles)
    # string pulling alone: the plan's waypoints are then the pulled corners, not pulled taut
    monkeypatch.setattr(simplify_module, "_taut", lambda _graph, points: points)
    plan = planner.plan(start, goal)
    corners, pulled = pulled_path(planner, plan)
    assert len(corners) > simplify_module._PULL_WINDOW + 1
    assert pulled == farthest_in_sight(planner.graph, corners, simplify_module._PULL_WINDOW)
    monkeypatch.setattr(simplify_module, "_PULL_CELLS", 40)  # a few segments at a time: the same
    assert simplify_module._string_pull(planner.graph, np_array(corners)) == pulled
    assert [corners[k] for k in pulled[1:]] == [
        tuple(map(float, grid.nearest_node(*w))) for w in plan.waypoints
    ]


def test_string_pulling_on_small_maps_keeps_the_farthest_point_in_sight() -> None:
    """Paths of up to _PULL_WINDOW + 1 points: from each point kept, on to the farthest point
    reached by a free segment, wherever the points in between are."""
    rng = random.Random(9)
    checked = 0
    for ref in maps():
        planner = Planner(ref.grid, ref.radius, ref.obstacles)
        free_nodes = sorted(ref.free)
        for _ in range(4):
            if len(free_nodes) < 2:
                break
            s, g = rng.sample(free_nodes, 2)
            try:
                plan = planner.plan(ref.grid.node_xy(*s), ref.grid.node_xy(*g))
            except Unreachable:
                continue
            corners, pulled = pulled_path(planner, plan)
            if len(corners) > simplify_module._PULL_WINDOW + 1:
                continue
            keep = [0]
            while keep[-1] < len(corners) - 1:
                i = keep[-1]
                keep.append(
                    max(
                        j
                        for j in range(i + 1, len(corners))
                        if j == i + 1 or planner.graph._segment_clear(corners[i], corners[j])
                    )
                )
            assert pulled == keep
            checked += 1
    assert checked >= 100


def test_string_pulling_follows_a_long_line_of_sight() -> None:
    # a zigzag that stays in sight of its start (beyond the look-ahead window), around an
    # obstacle on the line, and on: kept are the last point in sight, and the end
    graph = GridGraph(Grid(60, 30, 0.2), {(30, 10)}, 0.0)
    zigzag = [(float(k), 10.0 + 0.5 * (k % 2)) for k in range(26)]
    points = np_array([*zigzag, (28.0, 10.0), (29.0, 11.0), (31.0, 11.0), (32.0, 10.0), (40.0, 10.0)])
    assert len(zigzag) + 2 > simplify_module._PULL_WINDOW
    assert simplify_module._string_pull(graph, points) == [0, len(zigzag) + 2, len(points) - 1]
    assert simplify_module._string_pull(graph, points[:2]) == [0, 1]
    # from (29, 11): (31, 11) in sight, (32, 10) not (the segment touches the obstacle's corner),
    # (40, 10) again
    assert simplify_module._string_pull(graph, points[-4:]) == [0, 3]


def test_pulled_taut_the_path_nears_the_true_shortest_and_stays_free() -> None:
    # Out of a U-shaped wall: the pulled path turns at nodes, up to a step off the wall; taut,
    # its corners touch the grown wall, so it is shorter, and every segment is still free.
    grid = Grid(10, 10, 0.2)
    wall = {(i, 6) for i in range(2, 7)} | {(2, j) for j in range(2, 7)} | {(6, j) for j in range(2, 7)}
    planner = Planner(grid, 0.17, wall)
    plan = planner.plan((0.8, 0.6), (0.8, 1.6))
    points = [plan.start, *plan.waypoints]
    for p, q in itertools.pairwise(points):
        assert planner.graph.segment_free(p, q)
    pulled = simplify_module._string_pull(
        planner.graph, np_array([grid.to_grid(*p) for p in plan.path], dtype=float)
    )
    pulled_length = math.fsum(math.dist(plan.path[a], plan.path[b]) for a, b in itertools.pairwise(pulled))
    assert plan.length_m < pulled_length - 0.1
    assert plan.length_m > 1.0  # it still goes round the wall

"""Planner: how fast cart2d plans on grids from the seed's 10 x 10 nodes to 1000 x 1000, and how
long its paths are against independent references.

All in one process, with the disc the gateway plans with (`planning_radius_m`: the footprint
plus the clearance margin, 0.20 m), corner to corner:

- random fields: each node an obstacle with probability 10, 20 or 30 % (fixed seeds; the corners
  kept clear; a field whose corners are not joined is drawn again with the next seed), on a
  0.5 m grid: the disc (0.4 steps) then passes between two single-cell obstacles, so the graph
  is the classic 8-connected grid without corner cutting and the world grows with the grid;
- mazes: a perfect maze (depth-first, fixed seed) of 0.6 m corridors (3 nodes) between 0.2 m
  walls on the seed's 0.2 m grid, one lane wide for the disc;
- the seed-like scenes of bench/scenes.py (10 x 10 at 0.2 m and 41 x 41 at 0.1 m).

Times: `Planner.set_obstacles` (the graph from the obstacle list) plus `Planner.plan` (search
and simplification), median and range over repeats. References: scipy's Dijkstra on the same
graph (built here from the planner's edge masks with scipy's own constructor; search only),
whose grid cost must equal ours; the `pathfinding` package's Dijkstra (pure Python; diagonals
only between free orthogonal neighbours, on the grid of free nodes), search only; and the true
shortest path for the disc from a visibility graph: every obstacle cell grown by the radius,
touching ones merged (shapely), the rounded corners replaced by polygons of 16 segments per
quarter circle, once inscribed (a lower bound of the true length) and once circumscribed (an
upper bound); the shortest path bends only at convex corners of the grown obstacles inside the
node rectangle, so it is found by Dijkstra over the free bitangent segments between them.
"""

from __future__ import annotations

import gc
import itertools
import math
import random
import statistics
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import numpy.typing as npt
from matplotlib.patches import Rectangle
from pathfinding.core.diagonal_movement import DiagonalMovement
from pathfinding.core.grid import Grid as PathfindingGrid
from pathfinding.finder.dijkstra import DijkstraFinder
from scipy.sparse import csr_array
from scipy.sparse.csgraph import dijkstra

from bench.common import Section, section_main, spread, table
from bench.scenes import scenes as seed_scenes
from bench.visibility import QUAD_SEGMENTS, grown_obstacles, node_bounds, true_shortest
from cart2d.params import planning_radius_m
from cart2d.planning import DIRECTIONS, Grid, GridGraph, Node, Plan, Planner, Point, Unreachable, simplify

FULL_SIZES = (10, 20, 50, 100, 200, 500, 1000)
QUICK_SIZES = (10, 20, 50, 100, 200)
DENSITIES = (0.1, 0.2, 0.3)
RANDOM_STEP_M = 0.5
MAZE_STEP_M = 0.2
PATHFINDING_MAX = {True: 200, False: 500}  # nodes per side, quick or full: it is pure Python
# visibility references: (family, nodes per side) where the visibility graph stays small
VISIBILITY_CASES = (
    ("random 5 %", 10),
    ("random 5 %", 20),
    ("random 5 %", 30),
    ("random 5 %", 50),
    ("random 10 %", 10),
    ("random 10 %", 20),
    ("random 10 %", 30),
    ("random 20 %", 10),
    ("random 20 %", 20),
    ("maze", 10),
    ("maze", 20),
)
OPTIMAL_REL = 1e-9
LENGTH_TARGET = 1.05
TIME_TARGET_S = 1.0


@dataclass
class Case:
    family: str
    grid: Grid
    obstacles: list[Node]  # in row order, as a caller would pass them
    start: Point
    goal: Point
    seed: int = 0

    @property
    def label(self) -> str:
        return f"{self.family}, {self.grid.cols} x {self.grid.rows}"


@dataclass
class Result:
    case: Case
    total_s: list[float] = field(default_factory=list)
    build_s: list[float] = field(default_factory=list)
    plan_s: list[float] = field(default_factory=list)
    simplify_s: list[float] = field(default_factory=list)
    scipy_s: list[float] = field(default_factory=list)
    pathfinding_s: list[float] = field(default_factory=list)
    grid_m: float = math.nan
    simple_m: float = math.nan
    waypoints: int = 0
    scipy_m: float = math.nan
    pathfinding_m: float = math.nan
    true_low_m: float = math.nan
    true_high_m: float = math.nan
    true_path: list[Point] = field(default_factory=list)
    plan: Plan | None = None


# --- scenes ------------------------------------------------------------------------------------


def _occupancy_case(
    family: str, grid: Grid, occupied: npt.NDArray[np.bool_], start: Node, goal: Node
) -> Case:
    jj, ii = np.nonzero(occupied)
    nodes = list(zip(ii.tolist(), jj.tolist(), strict=True))
    return Case(family, grid, nodes, grid.node_xy(*start), grid.node_xy(*goal))


def random_case(n: int, density: float, seed: int = 1) -> Case:
    """Cells occupied with probability `density`, the 3 x 3 nodes at both corners clear; drawn
    again with the next seed until the corners are joined."""
    grid = Grid(n, n, RANDOM_STEP_M)
    for attempt in range(100):
        rng = np.random.default_rng(seed + attempt)
        occupied = rng.random((n, n)) < density
        occupied[:3, :3] = occupied[-3:, -3:] = False
        case = _occupancy_case(f"random {round(100 * density)} %", grid, occupied, (0, 0), (n - 1, n - 1))
        case.seed = seed + attempt
        try:
            Planner(grid, planning_radius_m(), case.obstacles).plan(case.start, case.goal)
        except Unreachable:
            continue
        return case
    raise RuntimeError(f"no random field of {n} x {n} at {density} joins its corners")


def maze_case(n: int, seed: int = 1) -> Case:
    """A perfect maze (depth-first) of rooms 3 nodes wide behind walls 1 node thick, from the
    first room's centre to the last one's."""
    cells = max((n - 1) // 4, 1)
    size = 4 * cells + 1
    rng = random.Random(seed)
    occupied = np.ones((size, size), dtype=np.bool_)
    seen = np.zeros((cells, cells), dtype=np.bool_)
    stack = [(0, 0)]
    seen[0, 0] = True
    while stack:
        ci, cj = stack[-1]
        occupied[4 * cj + 1 : 4 * cj + 4, 4 * ci + 1 : 4 * ci + 4] = False
        options = [
            (ci + di, cj + dj)
            for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1))
            if 0 <= ci + di < cells and 0 <= cj + dj < cells and not seen[cj + dj, ci + di]
        ]
        if not options:
            stack.pop()
            continue
        ni, nj = options[rng.randrange(len(options))]
        if ni != ci:  # the wall between the two rooms
            occupied[4 * cj + 1 : 4 * cj + 4, 4 * max(ci, ni)] = False
        else:
            occupied[4 * max(cj, nj), 4 * ci + 1 : 4 * ci + 4] = False
        seen[nj, ni] = True
        stack.append((ni, nj))
    grid = Grid(size, size, MAZE_STEP_M)
    case = _occupancy_case("maze", grid, occupied, (2, 2), (size - 3, size - 3))
    case.seed = seed
    return case


def family_case(family: str, n: int) -> Case:
    if family == "maze":
        return maze_case(n)
    return random_case(n, int(family.split()[1]) / 100)


# --- measurements ------------------------------------------------------------------------------


def _timed(fn: Callable[..., Any], *args: Any) -> tuple[float, Any]:
    t0 = time.perf_counter()
    value = fn(*args)
    return time.perf_counter() - t0, value


def measure_ours(result: Result, repeats: int) -> GridGraph:
    """Times the planner; returns its graph (immutable), the one the last repeat planned on."""
    case = result.case
    gc.collect()
    for _ in range(repeats):
        planner = Planner(case.grid, planning_radius_m())  # empty: not timed
        build, _ = _timed(planner.set_obstacles, case.obstacles)
        plan_s, plan = _timed(planner.plan, case.start, case.goal)
        result.build_s.append(build)
        result.plan_s.append(plan_s)
        result.total_s.append(build + plan_s)
        # the simplification alone, again on the same path
        graph = planner.graph
        path = np.array([graph.grid.to_grid(*p) for p in plan.path])
        t0 = time.perf_counter()
        simplify(graph, path)
        result.simplify_s.append(time.perf_counter() - t0)
    result.plan = plan
    result.grid_m, result.simple_m, result.waypoints = plan.grid_length_m, plan.length_m, len(plan.waypoints)
    return graph


def scipy_graph(graph: GridGraph) -> csr_array:
    """The planner's graph (its edge masks) as scipy builds a sparse matrix from (row, column,
    length) triplets."""
    grid = graph.grid
    rows, cols, lengths = [], [], []
    for d, (di, dj) in enumerate(DIRECTIONS):
        k = np.flatnonzero(graph.edges & (1 << d))
        rows.append(k)
        cols.append(k + di + dj * grid.cols)
        lengths.append(np.full(len(k), grid.step_m * math.hypot(di, dj)))
    n = grid.node_count
    return csr_array((np.concatenate(lengths), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))


def _node_index(grid: Grid, p: Point) -> int:
    return grid.index(*grid.nearest_node(*p))


def measure_scipy(result: Result, graph: GridGraph, repeats: int) -> None:
    case = result.case
    matrix = scipy_graph(graph)
    source, target = _node_index(case.grid, case.start), _node_index(case.grid, case.goal)
    gc.collect()
    for _ in range(repeats):
        seconds, dist = _timed(dijkstra, matrix, True, [source])
        result.scipy_s.append(seconds)
    result.scipy_m = float(dist[0][target])


def measure_pathfinding(result: Result, graph: GridGraph, repeats: int) -> None:
    case = result.case
    grid = case.grid
    matrix = graph.free.reshape(grid.rows, grid.cols).astype(np.int8)
    (si, sj), (gi, gj) = grid.nearest_node(*case.start), grid.nearest_node(*case.goal)
    gc.collect()
    for _ in range(repeats):
        pf_grid = PathfindingGrid(matrix=matrix)  # its node objects: not timed
        finder = DijkstraFinder(diagonal_movement=DiagonalMovement.only_when_no_obstacle)
        seconds, (path, _) = _timed(finder.find_path, pf_grid.node(si, sj), pf_grid.node(gi, gj), pf_grid)
        result.pathfinding_s.append(seconds)
    steps = [(node.x, node.y) for node in path]
    result.pathfinding_m = math.fsum(math.dist(a, b) for a, b in itertools.pairwise(steps)) * grid.step_m


# --- the true shortest path: a visibility graph -----------------------------------------------


def measure_true(result: Result) -> None:
    c = result.case
    bounds = node_bounds(c.grid)
    low, path = true_shortest(c.grid, c.obstacles, planning_radius_m(), c.start, c.goal, bounds)
    high, _ = true_shortest(
        c.grid, c.obstacles, planning_radius_m(), c.start, c.goal, bounds, circumscribed=True
    )
    result.true_low_m, result.true_high_m, result.true_path = low, high, path


# --- the report --------------------------------------------------------------------------------


def _repeats(n: int, quick: bool) -> int:
    if n <= 50:
        return 7 if quick else 15
    if n <= 200:
        return 5 if quick else 9
    return 5


def _ms(values: Sequence[float]) -> str:
    return spread([1e3 * v for v in values]).text(".3g") if values else "n/a"


def _median(values: Sequence[float]) -> float:
    return statistics.median(values) if values else math.nan


def _ratio(a: Sequence[float], b: Sequence[float]) -> str:
    return f"{_median(a) / _median(b):.3g}" if a and b else "n/a"


def _rel(a: float, b: float) -> float:
    return abs(a - b) / b if b else abs(a - b)


def _plot_times(results: list[Result], families: Sequence[str], out: Path) -> None:
    fig, axes = plt.subplots(1, len(families), figsize=(4.2 * len(families), 4), sharey=True)
    for ax, family in zip(axes, families, strict=True):
        rows = [r for r in results if r.case.family == family]
        n = [r.case.grid.node_count for r in rows]
        for label, values, style in (
            ("cart2d (graph + plan)", [r.total_s for r in rows], "o-"),
            ("cart2d plan only", [r.plan_s for r in rows], "o:"),
            ("scipy Dijkstra (search only)", [r.scipy_s for r in rows], "s--"),
            ("pathfinding Dijkstra (search only)", [r.pathfinding_s for r in rows], "^-."),
        ):
            xs = [x for x, v in zip(n, values, strict=True) if v]
            ys = [_median(v) for v in values if v]
            if xs:
                ax.loglog(xs, ys, style, label=label)
        ax.axhline(TIME_TARGET_S, color="grey", lw=0.8)
        ax.set_title(family)
        ax.set_xlabel("grid nodes")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("seconds (median)")
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "planner_time.png", dpi=120)
    plt.close(fig)


def _plot_lengths(results: list[Result], out: Path) -> None:
    rows = [r for r in results if math.isfinite(r.true_low_m)]
    fig, ax = plt.subplots(figsize=(9, 4))
    x = np.arange(len(rows))
    ax.bar(x - 0.2, [r.grid_m / r.true_low_m for r in rows], 0.4, label="grid path / true shortest")
    ax.bar(x + 0.2, [r.simple_m / r.true_low_m for r in rows], 0.4, label="simplified / true shortest")
    ax.axhline(LENGTH_TARGET, color="red", lw=0.8, label=f"target {LENGTH_TARGET}")
    ax.set_xticks(x, [r.case.label for r in rows], rotation=60, ha="right", fontsize=7)
    ax.set_ylim(0.98, max(1.1, *(r.grid_m / r.true_low_m + 0.01 for r in rows)))
    ax.set_ylabel("length ratio")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "planner_lengths.png", dpi=120)
    plt.close(fig)


def _plot_path(result: Result, out: Path) -> None:
    case, plan = result.case, result.plan
    assert plan is not None
    grid = case.grid
    fig, ax = plt.subplots(figsize=(6.5, 6.5))
    for i, j in case.obstacles:
        x, y = grid.node_xy(i, j)
        ax.add_patch(
            Rectangle((x - grid.step_m / 2, y - grid.step_m / 2), grid.step_m, grid.step_m, color="0.3")
        )
    for polygon in grown_obstacles(grid, case.obstacles, planning_radius_m())[1]:
        ax.plot(*polygon.exterior.xy, color="0.6", lw=0.6)
    px, py = zip(*plan.path, strict=True)
    ax.plot(px, py, color="tab:blue", lw=0.8, label=f"grid path {plan.grid_length_m:.2f} m")
    wx, wy = zip(plan.start, *plan.waypoints, strict=False)
    ax.plot(wx, wy, "o-", color="tab:green", lw=2, ms=3, label=f"simplified {plan.length_m:.2f} m")
    tx, ty = zip(*result.true_path, strict=True)
    ax.plot(tx, ty, "--", color="tab:red", lw=1.5, label=f"true shortest {result.true_low_m:.2f} m")
    (x0, y0), (w, h) = grid.origin, grid.size_m
    ax.add_patch(Rectangle((x0, y0), w, h, fill=False, lw=0.6))
    ax.set_aspect("equal")
    ax.set_xlim(x0 - grid.step_m, x0 + w + grid.step_m)
    ax.set_ylim(y0 - grid.step_m, y0 + h + grid.step_m)
    ax.set_title(f"{case.label} nodes, {grid.step_m:g} m step, disc {planning_radius_m():g} m")
    ax.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "planner_path.png", dpi=120)
    plt.close(fig)


def _result_data(r: Result) -> dict[str, Any]:
    def stats(values: list[float]) -> dict[str, float] | None:
        return spread(values).as_dict() if values else None

    def number(x: float) -> float | None:  # JSON has no NaN: not measured
        return x if math.isfinite(x) else None

    return {
        "family": r.case.family,
        "cols": r.case.grid.cols,
        "rows": r.case.grid.rows,
        "step_m": r.case.grid.step_m,
        "obstacles": len(r.case.obstacles),
        "seed": r.case.seed,
        "total_s": stats(r.total_s),
        "build_s": stats(r.build_s),
        "plan_s": stats(r.plan_s),
        "simplify_s": stats(r.simplify_s),
        "scipy_s": stats(r.scipy_s),
        "pathfinding_s": stats(r.pathfinding_s),
        "grid_m": r.grid_m,
        "simple_m": r.simple_m,
        "waypoints": r.waypoints,
        "scipy_m": number(r.scipy_m),
        "pathfinding_m": number(r.pathfinding_m),
        "true_low_m": number(r.true_low_m),
        "true_high_m": number(r.true_high_m),
    }


def run(out: Path, quick: bool) -> Section:
    sizes = QUICK_SIZES if quick else FULL_SIZES
    families = [f"random {round(100 * d)} %" for d in DENSITIES] + ["maze"]
    timed: list[Result] = []
    for family in families:
        for n in sizes:
            result = Result(family_case(family, n))
            repeats = _repeats(n, quick)
            graph = measure_ours(result, repeats)  # the planner's own graph
            measure_scipy(result, graph, repeats)
            if n <= PATHFINDING_MAX[quick]:
                measure_pathfinding(result, graph, 3 if n <= 100 else 1)
            timed.append(result)
    seeds: list[Result] = []
    for scene in seed_scenes():
        case = Case(
            f"{scene.name} ({scene.arena})", scene.grid, sorted(scene.obstacles), scene.start[:2], scene.goal
        )
        result = Result(case)
        measure_ours(result, 7 if quick else 21)
        measure_true(result)
        seeds.append(result)
    lengths: list[Result] = []
    for family, n in VISIBILITY_CASES:
        result = Result(family_case(family, n))
        measure_ours(result, 3)
        measure_true(result)
        lengths.append(result)

    _plot_times(timed, families, out)
    _plot_lengths(seeds + lengths, out)
    _plot_path(next(r for r in lengths if r.case.label == "random 5 %, 50 x 50"), out)

    # targets
    optimal = all(_rel(r.grid_m, r.scipy_m) <= OPTIMAL_REL for r in timed)
    compared = seeds + lengths
    worst = max(compared, key=lambda r: r.simple_m / r.true_low_m)
    short_enough = all(r.simple_m <= LENGTH_TARGET * r.true_low_m for r in compared)
    gap = max(r.true_high_m / r.true_low_m - 1 for r in compared)
    big = [r for r in timed if r.case.grid.cols >= 900 and r.case.family in ("random 20 %", "maze")]
    fast = all(_median(r.total_s) < TIME_TARGET_S for r in big)
    small = [r for r in seeds if r.case.grid.cols == 10]

    def mark(ok: bool) -> str:
        return "met" if ok else "**missed**"

    groups = {
        "the seed's 10 x 10 map at 0.2 m": [r for r in seeds if r.case.grid.cols == 10],
        "the same scenes at 0.1 m (41 x 41)": [r for r in seeds if r.case.grid.cols != 10],
        "mazes at 0.2 m": [r for r in lengths if r.case.family == "maze"],
        "random fields at 0.5 m": [r for r in lengths if r.case.family != "maze"],
    }

    def worst_ratio(rows: list[Result]) -> float:
        return max(r.simple_m / r.true_low_m for r in rows)

    targets = [
        f"- optimal grid cost, equal to scipy's Dijkstra on the same graph within {OPTIMAL_REL:g} "
        f"(relative) on all {len(timed)} timed grids: {mark(optimal)} (largest difference "
        f"{max(_rel(r.grid_m, r.scipy_m) for r in timed):.1e})",
        f"- simplified path within {100 * (LENGTH_TARGET - 1):.0f} % of the true shortest on all "
        f"{len(compared)} compared scenes: {mark(short_enough)} "
        f"(worst {worst.simple_m / worst.true_low_m:.3f}, {worst.case.label}"
        + (
            f"; over the target: {', '.join(r.case.label for r in long)})"
            if (long := [r for r in compared if r.simple_m > LENGTH_TARGET * r.true_low_m])
            else ")"
        ),
    ]
    if big:
        worst_big = max(big, key=lambda r: _median(r.total_s))
        targets.append(
            f"- 1000 x 1000 (random 20 % and maze) planned in under {TIME_TARGET_S:g} s (wall clock: "
            f"reported): {mark(fast)} "
            f"(slowest median {_median(worst_big.total_s):.3f} s, {worst_big.case.label})"
        )
    else:
        targets.append("- 1000 x 1000 in under 1 s: not measured in quick mode (grids up to 200 x 200)")
    ok = optimal and short_enough
    slow = [] if fast else [f"1000 x 1000 planned in under {TIME_TARGET_S:g} s"]

    header = [
        "scene",
        "obstacles",
        "cart2d: graph + plan, ms",
        "graph, ms",
        "plan, ms",
        "of which simplify, ms",
        "scipy search, ms",
        "cart2d / scipy",
        "pathfinding search, ms",
        "pathfinding / cart2d",
        "grid cost, m",
        "= scipy",
        "pathfinding cost / ours",
        "waypoints",
    ]
    time_rows = [
        [
            r.case.label,
            len(r.case.obstacles),
            _ms(r.total_s),
            _ms(r.build_s),
            _ms(r.plan_s),
            _ms(r.simplify_s),
            _ms(r.scipy_s),
            _ratio(r.total_s, r.scipy_s),
            _ms(r.pathfinding_s),
            _ratio(r.pathfinding_s, r.total_s),
            f"{r.grid_m:.3f}",
            "yes" if _rel(r.grid_m, r.scipy_m) <= OPTIMAL_REL else f"**no** ({r.scipy_m:.6f})",
            f"{r.pathfinding_m / r.grid_m:.4f}" if math.isfinite(r.pathfinding_m) else "n/a",
            r.waypoints,
        ]
        for r in timed
    ]
    seed_rows = [
        [r.case.label, len(r.case.obstacles), _ms(r.total_s), _ms(r.build_s), _ms(r.plan_s)] for r in seeds
    ]
    length_rows = [
        [
            r.case.label,
            f"{r.case.grid.step_m:g}",
            len(r.case.obstacles),
            f"{r.true_low_m:.3f} .. {r.true_high_m:.3f}",
            f"{r.grid_m / r.true_low_m:.3f}",
            f"{r.simple_m / r.true_low_m:.3f}",
            "yes" if r.simple_m <= LENGTH_TARGET * r.true_low_m else "**no**",
            r.waypoints,
        ]
        for r in compared
    ]
    markdown = "\n".join(
        [
            "## Planner",
            "",
            f"The grid planner (cart2d/planning/) on grids of {sizes[0]} x {sizes[0]} to "
            f"{sizes[-1]} x {sizes[-1]} nodes, planning corner to corner for the disc the gateway uses "
            f"({planning_radius_m():g} m: the footprint plus the clearance margin). Random fields: each "
            f"node an obstacle with the given probability (fixed seeds), {RANDOM_STEP_M:g} m step; "
            f"mazes: 0.6 m corridors between 0.2 m walls, {MAZE_STEP_M:g} m step. Time = "
            "`Planner.set_obstacles` (the graph from the obstacle list) + `Planner.plan` (search, path, "
            "simplification), median (range) over "
            f"{', '.join(str(_repeats(n, quick)) for n in sorted({50, 200, sizes[-1]}))} repeats by "
            "size; one process, one thread. The references search the same graph: scipy's Dijkstra "
            "(compiled; the graph built by scipy from the planner's edges; search only, single source) "
            "and the `pathfinding` package's Dijkstra (pure Python, search only, up to "
            f"{PATHFINDING_MAX[quick]} x {PATHFINDING_MAX[quick]} nodes; diagonal moves only between free "
            "orthogonal neighbours, on the grid of nodes free for the disc: the same graph as ours in "
            "the random fields, where the disc spans 0.4 steps, and not quite in the mazes).",
            "",
            *targets,
            "",
            "![plan time against grid size](planner_time.png)",
            "",
            table(header, time_rows),
            f"The seed-like scenes (bench/scenes.py), where the gateway plans on every goal "
            f"(10 x 10 median: {1e3 * _median([_median(r.total_s) for r in small]):.2f} ms):",
            "",
            table(["scene", "obstacles", "graph + plan, ms", "graph, ms", "plan, ms"], seed_rows),
            "Path lengths against the true shortest path for the disc. Reference: a visibility graph "
            "on the obstacle cells grown by the radius (touching ones merged with shapely), whose "
            f"rounded corners are polygons of {QUAD_SEGMENTS} segments per quarter circle, inscribed (a "
            "lower bound of the true length) and circumscribed (an upper bound): the true length lies "
            f"in the range given, whose width is at most {100 * gap:.3f} %. Ratios are to the lower "
            "bound (so at most that much too high). The grid path is the optimal 8-connected one; the "
            "simplified path is what the cart drives. The grid path bends at nodes, which keep up to a "
            "step more than the disc's radius from the obstacles (the true path grazes them at "
            "the radius), and the simplification can only join points of the grid path: the coarser the "
            "grid against the disc, the longer the path. Worst simplified / true: "
            + "; ".join(f"{name} {worst_ratio(rows):.3f}" for name, rows in groups.items() if rows)
            + ".",
            "",
            "![length ratios](planner_lengths.png)",
            "",
            table(
                [
                    "scene",
                    "step, m",
                    "obstacles",
                    "true shortest, m",
                    "grid / true",
                    "simplified / true",
                    f"within {100 * (LENGTH_TARGET - 1):.0f} %",
                    "waypoints",
                ],
                length_rows,
            ),
            "![a planned path and the true shortest one](planner_path.png)",
            "",
        ]
    )
    data = {
        "radius_m": planning_radius_m(),
        "quick": quick,
        "timed": [_result_data(r) for r in timed],
        "seed_scenes": [_result_data(r) for r in seeds],
        "lengths": [_result_data(r) for r in lengths],
        "targets": {"optimal": optimal, "length": short_enough, "time_1000": fast if big else None},
    }
    return Section("planner", markdown, data, ok, slow)


if __name__ == "__main__":
    sys.exit(section_main(run))

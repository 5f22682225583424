"""The benchmark missions: open floor, a wall with a gap, a U-trap, a slalom and a seeded
cluttered field, in the seed's 1.8 m arena (10 x 10 nodes, 0.2 m) and in a 4 m x 4 m arena with
a finer grid (41 x 41 nodes, 0.1 m). Obstacles are node indices (each blocks its cell)."""

from __future__ import annotations

import random
from dataclasses import dataclass

from cart2d.params import planning_radius_m
from cart2d.planning import Grid, Node, PlanError, Planner

Pose = tuple[float, float, float]


@dataclass(frozen=True)
class Scene:
    name: str
    arena: str  # "1.8 m" or "4 m"
    grid: Grid
    obstacles: frozenset[Node]
    start: Pose
    goal: tuple[float, float]

    def mission(self, behaviour: str = "cart2d") -> dict[str, object]:
        """The `cart2d mission` file for this scene."""
        g = self.grid
        return {
            "grid": {"cols": g.cols, "rows": g.rows, "step": g.step_m},
            "obstacles": [list(g.node_xy(i, j)) for i, j in sorted(self.obstacles)],
            "start": list(self.start),
            "goals": [list(self.goal)],
            "behaviour": behaviour,
            "timeout_s": 120.0,
        }


SMALL = Grid(cols=10, rows=10, step_m=0.2)
LARGE = Grid(cols=41, rows=41, step_m=0.1)


def _line(i0: int, j0: int, i1: int, j1: int) -> set[Node]:
    """The nodes of a horizontal or vertical run, ends included."""
    return {(i, j) for i in range(min(i0, i1), max(i0, i1) + 1) for j in range(min(j0, j1), max(j0, j1) + 1)}


def _random_field(grid: Grid, density: float, seed: int, start: Pose, goal: tuple[float, float]) -> set[Node]:
    """Seeded random obstacle nodes that leave the start and the goal reachable: draws again with
    the next seed until the planner finds a path."""
    for attempt in range(100):
        rng = random.Random(seed + attempt)
        cells = {(i, j) for i in range(grid.cols) for j in range(grid.rows) if rng.random() < density}
        cells -= _near(grid, start, goal)
        try:
            Planner(grid, planning_radius_m(), cells).plan(start[:2], goal)
        except PlanError:
            continue
        return cells
    raise RuntimeError(f"no reachable random field for seed {seed}")


def scenes() -> list[Scene]:
    small = [
        Scene("open floor", "1.8 m", SMALL, frozenset(), (0.2, 0.2, 0.0), (1.6, 1.4)),
        Scene(
            "wall with a gap",
            "1.8 m",
            SMALL,
            frozenset(_line(4, 0, 4, 3) | _line(4, 7, 4, 9)),
            (0.2, 0.4, 0.0),
            (1.6, 1.4),
        ),
        Scene(
            "U-trap",
            "1.8 m",
            SMALL,
            frozenset(_line(2, 6, 6, 6) | _line(2, 2, 2, 6) | _line(6, 2, 6, 6)),
            (0.8, 0.6, 1.5708),
            (0.8, 1.6),
        ),
        Scene(
            "slalom",
            "1.8 m",
            SMALL,
            frozenset(_line(2, 0, 2, 5) | _line(6, 4, 6, 9)),
            (0.0, 0.2, 1.5708),
            (1.8, 1.6),
        ),
    ]
    u_start, u_goal = (2.0, 1.5, 1.5708), (2.0, 3.5)
    large = [
        Scene("open floor", "4 m", LARGE, frozenset(), (0.3, 0.3, 0.0), (3.7, 3.5)),
        Scene(
            "wall with a gap",
            "4 m",
            LARGE,
            frozenset(_line(20, 0, 20, 16) | _line(20, 24, 20, 40)),
            (0.5, 0.5, 0.0),
            (3.5, 3.5),
        ),
        Scene(
            "U-trap",
            "4 m",
            LARGE,
            frozenset(_line(12, 25, 28, 25) | _line(12, 8, 12, 25) | _line(28, 8, 28, 25)),
            u_start,
            u_goal,
        ),
        Scene(
            "slalom",
            "4 m",
            LARGE,
            frozenset(_line(10, 0, 10, 28) | _line(20, 12, 20, 40) | _line(30, 0, 30, 28)),
            (0.4, 0.4, 1.5708),
            (3.6, 3.6),
        ),
    ]
    small_field = ((0.2, 0.2, 0.0), (1.6, 1.6))
    large_field = ((0.3, 0.3, 0.0), (3.7, 3.7))
    fields = [
        Scene(
            "cluttered field",
            "1.8 m",
            SMALL,
            frozenset(_random_field(SMALL, 0.12, 6, *small_field)),
            *small_field,
        ),
        Scene(
            "cluttered field",
            "4 m",
            LARGE,
            frozenset(_random_field(LARGE, 0.03, 6, *large_field)),
            *large_field,
        ),
    ]
    return [*small, fields[0], *large, fields[1]]


def _near(grid: Grid, start: Pose, goal: tuple[float, float]) -> set[Node]:
    """Nodes too close to the start or the goal for an obstacle (the cart must fit there)."""
    reach = planning_radius_m() + grid.step_m
    return {
        (i, j)
        for i in range(grid.cols)
        for j in range(grid.rows)
        for p in (start[:2], goal)
        if abs(grid.node_xy(i, j)[0] - p[0]) <= reach and abs(grid.node_xy(i, j)[1] - p[1]) <= reach
    }

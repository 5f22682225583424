"""The shared grid the fleet's routes run on: nodes every `spacing_m` over the arena where a
cart fits (the map's planner says where its footprint is free), joined to their four
neighbours (no diagonals: two diagonal edges of one square cross between their nodes, where no
node reservation would keep two carts apart)."""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass

Cell = tuple[int, int]
SPACING_M = 0.5  # > 2 x the footprint radius (0.17 m, config/robot.toml): two carts on neighbours pass


@dataclass(frozen=True)
class Lattice:
    origin: tuple[float, float]  # the position of node (0, 0)
    spacing_m: float
    free: frozenset[Cell]

    @classmethod
    def over(
        cls,
        width_m: float,
        height_m: float,
        fits: Callable[[float, float], bool],
        spacing_m: float = SPACING_M,
        origin: tuple[float, float] = (0.0, 0.0),
    ) -> Lattice:
        """Nodes at spacing/2 + k·spacing from `origin` inside width x height, where fits(x, y)."""
        columns, rows = int(width_m // spacing_m), int(height_m // spacing_m)
        start = (origin[0] + spacing_m / 2, origin[1] + spacing_m / 2)
        free = frozenset(
            (i, j)
            for i in range(columns)
            for j in range(rows)
            if fits(start[0] + i * spacing_m, start[1] + j * spacing_m)
        )
        return cls(start, spacing_m, free)

    def position(self, cell: Cell) -> tuple[float, float]:
        return (self.origin[0] + cell[0] * self.spacing_m, self.origin[1] + cell[1] * self.spacing_m)

    def nearest(self, x: float, y: float) -> Cell:
        """The free node nearest (x, y); ValueError if there is none."""
        if not self.free:
            raise ValueError("the arena has no node where a cart fits")
        return min(self.free, key=lambda c: (math.dist(self.position(c), (x, y)), c))

    def neighbours(self, cell: Cell) -> Iterable[Cell]:
        i, j = cell
        for n in ((i + 1, j), (i - 1, j), (i, j + 1), (i, j - 1)):
            if n in self.free:
                yield n

    def route(self, start: Cell, goal: Cell, blocked: frozenset[Cell] = frozenset()) -> list[Cell] | None:
        """The shortest route start .. goal over free nodes not `blocked` (A*, Manhattan);
        None if there is none."""
        if goal in blocked or goal not in self.free:
            return None
        came: dict[Cell, Cell | None] = {start: None}
        cost = {start: 0}
        frontier = [(0, start)]
        while frontier:
            _, cell = heapq.heappop(frontier)
            if cell == goal:
                path = [cell]
                while (previous := came[path[-1]]) is not None:
                    path.append(previous)
                return path[::-1]
            for n in self.neighbours(cell):
                if n in blocked or cost[cell] + 1 >= cost.get(n, 1 << 30):
                    continue
                cost[n] = cost[cell] + 1
                came[n] = cell
                heapq.heappush(frontier, (cost[n] + abs(n[0] - goal[0]) + abs(n[1] - goal[1]), n))
        return None


def node_id(cell: Cell) -> str:
    return f"n{cell[0]}_{cell[1]}"


def cell_of(node: str) -> Cell | None:
    try:
        i, j = node.removeprefix("n").split("_")
        return int(i), int(j)
    except ValueError:
        return None

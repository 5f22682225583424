"""The perceived layer of the live map: cells the camera believes occupied, kept apart from the
user's obstacles (never saved with them, cleared on their own), that the planner keeps the cart
off as it does the user's: they are blocked cells of its graph, inflated by the same footprint
stencils (cart2d/planning/graph.py), and a change runs the same route check and replan as a
change the user makes.

A perceived cell is a square of side `resolution_m` centred on (x, y); it blocks the planner
cells whose nodes it covers, or on a grid coarser than it every planner cell its square overlaps
(the planner's cells are the squares round its nodes), so no perceived obstacle slips between
two nodes (PerceivedLayer.mask). While there are perceived cells, routes are planned on the map
made finer (live_map.layout_for: a step of at most `resolution_m`, the user's obstacles blocking
the same floor as before): on the map's own grid (the seed's 0.2 m) a 2.5 cm cell would block a
whole 0.2 m cell and close passages the cart fits through. The map's own planner (the user's
obstacles as nodes) stays the live map's `map_planner`. Cells off the planner's grid are left out
(the camera sees past the arena's walls): they cannot block a path.

The camera's frames become perceived cells in cart2d/gateway/seeing.py; the camera service
(cart2d/gateway/camera_service.py) edits the layer, the live map (cart2d/gateway/map_service.py)
keeps it and plans with it (`with_perceived`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from cart2d.planning import EPS, Grid

MAX_PERCEIVED_CELLS = 100_000  # a 10 x 10 m room at 3 cm
OCCUPIED_P = 0.5  # a cell at or above this is believed occupied (the contract with vision)
DEFAULT_RESOLUTION_M = 0.05

Cell = tuple[float, float, float]


def parse_cells(cells: Sequence[Sequence[float]]) -> tuple[Cell, ...]:
    """(x_m, y_m, p_occupied) triples, finite, p in [0.5, 1]; ValueError (in words) otherwise."""
    if len(cells) > MAX_PERCEIVED_CELLS:
        raise ValueError(f"{len(cells)} perceived cells: at most {MAX_PERCEIVED_CELLS}")
    out = []
    for k, cell in enumerate(cells):
        if len(cell) != 3:
            raise ValueError(f"perceived cell {k} must be [x_m, y_m, p_occupied], got {len(cell)} numbers")
        x, y, p = (float(v) for v in cell)
        if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(p)):
            raise ValueError(f"perceived cell {k} is not finite")
        if not OCCUPIED_P <= p <= 1.0:
            raise ValueError(
                f"perceived cell {k} has p_occupied {p:g}: cells believed occupied have {OCCUPIED_P:g} to 1"
            )
        out.append((x, y, p))
    return tuple(out)


def check_resolution(resolution_m: float) -> float:
    if not (math.isfinite(resolution_m) and 0.005 <= resolution_m <= 1.0):
        raise ValueError(f"the perceived cells' resolution must be 0.005 to 1 m, got {resolution_m:g}")
    return float(resolution_m)


def _nodes_within(low: float, high: float, count: int) -> range:
    """Nodes k in [low, high) (grid units): one at least when high - low >= 1."""
    return range(max(math.ceil(low - EPS), 0), min(math.ceil(high - EPS), count))


def _span(low: float, high: float, count: int) -> range:
    """Planner cells k (squares [k - 0.5, k + 0.5] in grid units) that [low, high] overlaps."""
    # k - 0.5 < high and k + 0.5 > low, by more than the planner's contact tolerance: squares
    # that only touch (up to rounding) do not overlap
    first = max(math.floor(low - 0.5 + EPS) + 1, 0)
    last = min(math.ceil(high + 0.5 - EPS) - 1, count - 1)
    return range(first, last + 1)


@dataclass(frozen=True)
class PerceivedLayer:
    """What perception believes occupied (immutable: a change is a new layer)."""

    cells: tuple[Cell, ...] = ()
    resolution_m: float = DEFAULT_RESOLUTION_M
    enabled: bool = True
    why: str = ""

    def mask(self, grid: Grid) -> npt.NDArray[np.bool_]:
        """The planner cells that stand for the perceived cells, (rows, cols): on a grid as fine
        as they are, the cells whose centres (nodes) they cover, at least one each, so that what
        is blocked is within half a step of the perceived squares either way (overlap would add up
        to a whole step: a face seen 2 cm too near plus a step closed marginal passages); on a
        coarser grid every cell they overlap, so that none slips between two nodes."""
        out = np.zeros((grid.rows, grid.cols), dtype=np.bool_)
        half = self.resolution_m / 2.0 / grid.step_m
        span = _nodes_within if self.resolution_m >= grid.step_m - EPS else _span
        for x, y, _ in self.cells:
            u, v = grid.to_grid(x, y)
            columns, rows = span(u - half, u + half, grid.cols), span(v - half, v + half, grid.rows)
            if columns and rows:
                out[rows.start : rows.stop, columns.start : columns.stop] = True
        return out

    def view(self) -> dict[str, Any]:
        return {
            "enabled": self.enabled,
            "resolution": self.resolution_m,
            "cells": [list(cell) for cell in self.cells],
            "why": self.why,
        }

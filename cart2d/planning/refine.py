"""The same map on a finer grid: for obstacles smaller than the map's cells.

A user's obstacle fills its node's cell, but what the camera sees is a few centimetres wide: on the
seed's 0.2 m grid a 5 cm perceived cell would block a whole planner cell and close a passage the
cart fits through. Planning on a grid `factor` times finer keeps the map exactly as it was and
lets small obstacles block only what they cover.

With an odd factor f the fine grid keeps the node rectangle (node (i, j) becomes fine node
(f·i, f·j)) and every coarse cell is exactly f x f fine cells, so the user's obstacles and a floor
plan's blocked cells block the same floor as before; the cart's centre keeps the same rectangle.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np
import numpy.typing as npt

from cart2d.planning.grid import Grid, Node

BoolArray = npt.NDArray[np.bool_]


def odd_factor(step_m: float, finest_m: float, cols: int, rows: int, max_nodes: int) -> int:
    """The smallest odd factor whose fine step is at most `finest_m`, reduced (odd, at least 1)
    until the fine grid has at most `max_nodes` nodes."""
    factor = max(1, math.ceil(step_m / finest_m - 1e-9))
    factor += 1 - factor % 2
    while factor > 1 and ((cols - 1) * factor + 1) * ((rows - 1) * factor + 1) > max_nodes:
        factor -= 2
    return factor


def refined_grid(grid: Grid, factor: int) -> Grid:
    """`grid` with `factor` (odd) fine steps per step: the same node rectangle."""
    if factor < 1 or factor % 2 == 0:
        raise ValueError(f"the refinement factor must be an odd integer >= 1, got {factor}")
    return Grid(
        cols=(grid.cols - 1) * factor + 1,
        rows=(grid.rows - 1) * factor + 1,
        step_m=grid.step_m / factor,
        origin=grid.origin,
    )


def refined_cells(cells: BoolArray, factor: int) -> BoolArray:
    """Coarse cells (rows, cols) as the fine cells they cover, cut to the fine grid's rectangle
    (a coarse cell at an edge reaches half a cell past the edge nodes: that half lies outside)."""
    rows, cols = cells.shape
    half = (factor - 1) // 2
    blown_up = np.kron(cells, np.ones((factor, factor), dtype=np.bool_)).astype(np.bool_)
    out: BoolArray = blown_up[half : half + (rows - 1) * factor + 1, half : half + (cols - 1) * factor + 1]
    return out


def occupied_cells(grid: Grid, obstacles: Iterable[Node]) -> BoolArray:
    """The cells the obstacle nodes occupy, (rows, cols)."""
    out = np.zeros((grid.rows, grid.cols), dtype=np.bool_)
    for i, j in obstacles:
        out[j, i] = True
    return out

"""The physical world a simulated cart drives in (sim/README.md, "The world"): walls (a boundary,
a map's occupied cells) and boxes the cart cannot pass. Plain geometry, with no simulator in it:
the gateway's live map says which walls its map stands for (cart2d/gateway/live_map.py), the
simulation package (cart2d/simulation/) puts them in the simulator. It is not the planner's map:
the map holds what the gateway believes, the world what is there.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from cart2d.params import robot


@dataclass(frozen=True)
class Box:
    """An axis-aligned box standing on the floor: centre and size (m); height and colour are for
    the camera (the physics is planar). Boxes with an id can be replaced and removed by it."""

    x: float
    y: float
    sx: float
    sy: float
    height: float = 0.3
    colour: str = "#b8742f"
    id: str | None = None
    material: str | None = None  # "wall": drawn in the look's wall paint (sim/README.md, "The look")

    def message(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "x": self.x,
            "y": self.y,
            "sx": self.sx,
            "sy": self.sy,
            "height": self.height,
            "colour": self.colour,
        }
        if self.id is not None:
            out["id"] = self.id
        if self.material is not None:
            out["material"] = self.material
        return out


def run_lengths(cells: Iterable[bool]) -> list[int]:
    """Runs alternately free and occupied, starting with free (the side channel's "rle")."""
    array = (
        np.fromiter(cells, dtype=np.bool_) if not isinstance(cells, np.ndarray) else cells.astype(np.bool_)
    )
    array = array.reshape(-1)
    if array.size == 0:
        return [0]
    changes = np.flatnonzero(array[1:] != array[:-1]) + 1
    runs = np.diff(np.concatenate(([0], changes, [array.size])))
    out: list[int] = runs.tolist()
    return [0, *out] if array[0] else out


@dataclass(frozen=True)
class WallGrid:
    """An occupancy grid whose occupied cells are walls. Cells row-major from the origin, as in
    ROS's nav_msgs/OccupancyGrid: cell (i, j) is column i (x) of row j (y), row 0 at the lowest
    y; `origin` is the lower-left corner of cell (0, 0)."""

    origin: tuple[float, float]
    resolution: float
    width: int
    height: int
    occupied: tuple[bool, ...]

    @classmethod
    def from_rows(
        cls, rows: Sequence[Sequence[bool]], origin: tuple[float, float], resolution: float
    ) -> WallGrid:
        """From rows of cells, rows[0] the lowest (an image's top row is its highest: reverse it)."""
        width = len(rows[0]) if rows else 0
        if any(len(row) != width for row in rows):
            raise ValueError("every row must have the same number of cells")
        return cls(origin, resolution, width, len(rows), tuple(bool(c) for row in rows for c in row))

    def message(self) -> dict[str, Any]:
        return {
            "origin": list(self.origin),
            "resolution": self.resolution,
            "width": self.width,
            "height": self.height,
            "rle": run_lengths(self.occupied),
        }


@dataclass(frozen=True)
class World:
    """The simulator's physical world: walls from a grid, a boundary (None: around the grid if
    there is one; False: none; or (x_min, y_min, x_max, y_max) in m) and boxes."""

    boxes: tuple[Box, ...] = ()
    walls: WallGrid | None = None
    boundary: tuple[float, float, float, float] | bool | None = None

    def message(self) -> dict[str, Any]:
        out: dict[str, Any] = {"boxes": [b.message() for b in self.boxes]}
        if self.walls is not None:
            out["walls"] = self.walls.message()
        if isinstance(self.boundary, bool):
            out["boundary"] = self.boundary
        elif self.boundary is not None:
            out["boundary"] = list(self.boundary)
        return out


def arena_world(
    cols: int, rows: int, step: float, margin: float | None = None, origin: tuple[float, float] = (0.0, 0.0)
) -> World:
    """Walls `margin` (robot.toml's [sim] arena_margin_m by default) outside a node grid of
    cols x rows nodes `step` apart from `origin`: today's arena, for any size."""
    m = float(robot()["sim"]["arena_margin_m"]) if margin is None else margin
    x0, y0 = origin
    return World(boundary=(x0 - m, y0 - m, x0 + (cols - 1) * step + m, y0 + (rows - 1) * step + m))

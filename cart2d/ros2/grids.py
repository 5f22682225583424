"""The map as nav_msgs/OccupancyGrid, as map_server would publish it: the floor plan's cells
where there is one (else free floor inside the arena's walls), the walls and the user's obstacles
occupied; and the camera's perceived layer as a grid of its own (`perceived_map`), unknown where
the camera has seen nothing, its belief in percent where it has."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from cart2d.maps.occupancy import FREE, OCCUPIED, UNKNOWN, OccupancyMap
from cart2d.ros2 import types as t
from cart2d.ros2.names import Ros2Options

PLAIN_RESOLUTION_M = 0.05  # the grid of a map without a floor plan: finer than the node step (0.2 m)

Cells = npt.NDArray[np.int8]


def _grid(
    options: Ros2Options, when: t.Time, origin: tuple[float, float], resolution: float, cells: Cells
) -> t.OccupancyGrid:
    height, width = cells.shape
    info = t.MapMetaData(
        map_load_time=when,
        resolution=resolution,
        width=width,
        height=height,
        origin=t.Pose(t.Point(origin[0], origin[1], 0.0)),
    )
    return t.OccupancyGrid(t.Header(when, options.frame("map")), info, cells.astype(np.int8).tobytes())


def _walled(view: Mapping[str, Any]) -> tuple[tuple[float, float], Cells]:
    """Free floor inside the arena, its border cells the walls."""
    arena = view["arena"]
    width = max(2, math.ceil((arena["x_max"] - arena["x_min"]) / PLAIN_RESOLUTION_M))
    height = max(2, math.ceil((arena["y_max"] - arena["y_min"]) / PLAIN_RESOLUTION_M))
    cells = np.full((height, width), FREE, dtype=np.int8)
    cells[[0, -1], :] = OCCUPIED
    cells[:, [0, -1]] = OCCUPIED
    return (float(arena["x_min"]), float(arena["y_min"])), cells


def _mark_squares(
    cells: Cells,
    origin: tuple[float, float],
    resolution: float,
    centres: Sequence[Sequence[float]],
    side: float,
    value: int,
) -> None:
    """Sets the cells a square of `side` round each centre covers."""
    height, width = cells.shape
    for x, y in centres:
        i0 = max(0, math.floor((x - side / 2 - origin[0]) / resolution))
        i1 = min(width, math.ceil((x + side / 2 - origin[0]) / resolution))
        j0 = max(0, math.floor((y - side / 2 - origin[1]) / resolution))
        j1 = min(height, math.ceil((y + side / 2 - origin[1]) / resolution))
        if i0 < i1 and j0 < j1:
            cells[j0:j1, i0:i1] = np.maximum(cells[j0:j1, i0:i1], value)


def map_grid(
    options: Ros2Options, when: t.Time, view: Mapping[str, Any], floor_plan: OccupancyMap | None
) -> t.OccupancyGrid:
    """The map (GET /api/map's view and its floor plan): the user's obstacles as squares of the
    node step round their nodes (the cells the planner blocks)."""
    if floor_plan is not None:
        origin, resolution = floor_plan.origin_m, floor_plan.resolution_m
        cells = np.array(floor_plan.cells, dtype=np.int8)
    else:
        (origin, cells), resolution = _walled(view), PLAIN_RESOLUTION_M
    _mark_squares(cells, origin, resolution, view["obstacles"], float(view["step_m"]), OCCUPIED)
    return _grid(options, when, origin, resolution, cells)


def perceived_grid(
    options: Ros2Options, when: t.Time, view: Mapping[str, Any], message: Mapping[str, Any]
) -> t.OccupancyGrid:
    """The perceived layer ([x, y, p] squares of `resolution` centred on x, y) over the arena."""
    arena, resolution = view["arena"], float(message["resolution"])
    origin = (float(arena["x_min"]), float(arena["y_min"]))
    width = max(2, math.ceil((arena["x_max"] - arena["x_min"]) / resolution))
    height = max(2, math.ceil((arena["y_max"] - arena["y_min"]) / resolution))
    cells = np.full((height, width), UNKNOWN, dtype=np.int8)
    for x, y, p in message["cells"]:
        i, j = math.floor((x - origin[0]) / resolution), math.floor((y - origin[1]) / resolution)
        if 0 <= i < width and 0 <= j < height:
            cells[j, i] = max(int(cells[j, i]), round(100 * min(1.0, max(0.0, float(p)))))
    return _grid(options, when, origin, resolution, cells)

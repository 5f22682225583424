"""A map exploration built against the simulated world it explored (issue 26's measures): the
true obstacles drawn on the map's own grid, the floor the cart could cover, and how the map
compares: the share of that floor seen free, the IoU of occupied cells after growing both by a
cell, and the cells believed occupied on open floor.

The true walls are the arena's boundary: the cells just beyond it (within a cell) are the wall's
occupied cells; what lies further out is never seen and not compared."""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy import ndimage

from cart2d.maps.occupancy import FREE, OCCUPIED, OccupancyMap
from cart2d.maps.world import Box
from cart2d.params import robot

Bounds = tuple[float, float, float, float]


def _centres(m: OccupancyMap) -> tuple[np.ndarray, np.ndarray]:
    ox, oy = m.origin_m
    r = m.resolution_m
    xs = ox + (np.arange(m.width) + 0.5) * r
    ys = oy + (np.arange(m.height) + 0.5) * r
    return np.meshgrid(xs, ys)


def _in_box(x: np.ndarray, y: np.ndarray, box: Box, grow: float = 0.0) -> np.ndarray:
    return np.asarray((np.abs(x - box.x) <= box.sx / 2 + grow) & (np.abs(y - box.y) <= box.sy / 2 + grow))


def truth_cells(
    m: OccupancyMap, bounds: Bounds, boxes: tuple[Box, ...], walls: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """(occupied, compared) on m's grid: occupied the boxes and the wall's band just beyond the
    boundary (a cell deep); compared the cells inside the boundary and that band. Without
    `walls`: the boxes only, compared over the floor more than two cells from the walls."""
    x, y = _centres(m)
    r = m.resolution_m
    x0, y0, x1, y1 = bounds
    inside = (x > x0) & (x < x1) & (y > y0) & (y < y1)
    compared = (x > x0 - r) & (x < x1 + r) & (y > y0 - r) & (y < y1 + r)
    occupied = compared & ~inside
    if not walls:
        e = 2 * r
        compared = (x > x0 + e) & (x < x1 - e) & (y > y0 + e) & (y < y1 - e)
        occupied = np.zeros_like(compared)
    for box in boxes:
        occupied |= _in_box(x, y, box)
    return np.asarray(occupied), np.asarray(compared)


def reachable_floor(
    m: OccupancyMap, bounds: Bounds, boxes: tuple[Box, ...], start: tuple[float, float]
) -> np.ndarray:
    """The floor the cart's footprint can cover: cells within its radius of a centre it can
    reach from `start` (footprint plus the planner's clearance from every wall and box)."""
    body = robot()["body"]
    radius = float(body["footprint_radius_m"])
    keep = radius + float(body["clearance_m"])
    x, y = _centres(m)
    x0, y0, x1, y1 = bounds
    floor = (x > x0) & (x < x1) & (y > y0) & (y < y1)
    for box in boxes:
        floor &= ~_in_box(x, y, box)
    centres_ok = (x > x0 + keep) & (x < x1 - keep) & (y > y0 + keep) & (y < y1 - keep)
    for box in boxes:
        centres_ok &= ~_in_box(x, y, box, keep)
    labels, _ = ndimage.label(centres_ok)
    i = int((start[0] - m.origin_m[0]) / m.resolution_m)
    j = int((start[1] - m.origin_m[1]) / m.resolution_m)
    reached = labels == labels[j, i] if labels[j, i] else np.zeros_like(centres_ok)
    within = ndimage.distance_transform_edt(~reached) * m.resolution_m <= radius
    return np.asarray(floor & within)


def seen_share(m: OccupancyMap, floor: np.ndarray) -> float:
    """The share of `floor` m shows free."""
    return float(np.count_nonzero((m.cells == FREE) & floor)) / max(1, int(np.count_nonzero(floor)))


def compare(m: OccupancyMap, bounds: Bounds, boxes: tuple[Box, ...], walls: bool = True) -> dict[str, Any]:
    """The IoU of occupied cells, both grown by a cell, over the compared cells; the cells
    believed occupied on open floor (further than a cell from every true obstacle)."""
    true_occupied, compared = truth_cells(m, bounds, boxes, walls)
    believed = (m.cells == OCCUPIED) & compared
    grow = np.ones((3, 3), dtype=bool)
    true_grown = ndimage.binary_dilation(true_occupied, grow) & compared
    believed_grown = ndimage.binary_dilation(believed, grow) & compared
    union = np.count_nonzero(true_grown | believed_grown)
    iou = float(np.count_nonzero(true_grown & believed_grown)) / max(1, int(union))
    false_cells = int(np.count_nonzero(believed & ~true_grown))
    x, y = _centres(m)
    found = sum(bool(np.any(believed & _in_box(x, y, box, m.resolution_m))) for box in boxes)
    return {
        "boxes_found": found,  # boxes with a cell believed occupied on them or a cell from them
        "iou_grown": round(iou, 3),
        "false_occupied_cells": false_cells,
        "false_occupied_m2": round(false_cells * m.resolution_m**2, 4),
        "believed_occupied_cells": int(np.count_nonzero(believed)),
        "true_occupied_cells": int(np.count_nonzero(true_occupied)),
    }

"""The fleet's shared lattice on a gateway's map (its planner says where a cart fits), and boxes
standing on it (a fleet world's) kept off it."""

from __future__ import annotations

import math
from collections.abc import Iterable

from cart2d.fleet.lattice import SPACING_M, Lattice
from cart2d.gateway.live_map import planner_for
from cart2d.maps.world import Box
from cart2d.params import footprint_radius_m
from cart2d.store import MapSettings

FLEET_MAP = MapSettings(cols=21, rows=21, step_m=0.2)  # the 4 m arena of issue 27


def map_lattice(m: MapSettings, boxes: Iterable[Box] = ()) -> Lattice:
    planner = planner_for(m)
    graph, grid = planner.graph, planner.grid
    width, height = grid.size_m
    standing = list(boxes)
    reach = footprint_radius_m() + 0.05  # the planner's own clearance beside a box

    def fits(x: float, y: float) -> bool:
        clear = all(_rectangle_distance(x, y, b) > reach for b in standing)
        return clear and graph.point_free(x, y)

    # the nodes centred on the map: a floor plan's width is seldom a whole number of spacings
    width, height = width + 1e-9, height + 1e-9
    x0, y0 = grid.node_xy(0, 0)
    origin = (x0 + (width % SPACING_M) / 2, y0 + (height % SPACING_M) / 2)
    return Lattice.over(width, height, fits, origin=origin)


def _rectangle_distance(x: float, y: float, box: Box) -> float:
    return math.hypot(max(abs(x - box.x) - box.sx / 2, 0.0), max(abs(y - box.y) - box.sy / 2, 0.0))

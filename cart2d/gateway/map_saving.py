"""`cart2d map save NAME`, POST /api/map/save and the panel's button (issue 26): what the camera
has seen (cart2d/gateway/seeing.py's grid) written as a ROS map_server map, NAME.yaml and
NAME.pgm in the gateway's maps folder (cart2d/maps/building.py for which cell is what).
`cart2d sim --map FILE` / `serve --map FILE` and POST /api/map load it back as the floor plan."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np

from cart2d.gateway.seeing import Seeing
from cart2d.gateway.state import Refused
from cart2d.maps.building import built_map
from cart2d.maps.occupancy import OccupancyMap
from cart2d.maps.ros import save_ros_map

NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_-]{0,63}$")
MAPS_FOLDER = "maps"


class NothingSeen(Refused):
    """No camera, or no frame taken in yet: there is no map to save."""


def checked_name(name: str) -> str:
    if not NAME.match(name):
        raise ValueError(
            f"a map's name is 1 to 64 letters, digits, '_' or '-', starting with a letter or digit "
            f"(no .yaml): not {name!r}"
        )
    return name


def seen_map(seeing: Seeing | None) -> OccupancyMap:
    grid = seeing.grid if seeing is not None else None
    if grid is None:
        raise NothingSeen(
            "the camera has seen nothing yet: attach a camera and drive the cart round the room"
        )
    r = grid.resolution_m
    xs = grid.origin[0] + (np.arange(grid.width) + 0.5) * r
    ys = grid.origin[1] + (np.arange(grid.height) + 0.5) * r
    centres = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
    observed = grid.observed(centres).reshape(grid.height, grid.width)
    return built_map(grid.probability(), observed, grid.origin, r)


def save_seen_map(seeing: Seeing | None, directory: Path, name: str) -> dict[str, Any]:
    """Writes the map; its YAML's path and the cells it holds, by kind."""
    occupancy = seen_map(seeing)
    folder = directory / MAPS_FOLDER
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{checked_name(name)}.yaml"
    save_ros_map(occupancy, path)
    return {"yaml": str(path), "resolution_m": occupancy.resolution_m, "counts": occupancy.counts()}

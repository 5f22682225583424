"""Maps: occupancy grids of free, occupied and unknown cells (occupancy.py), read and written
as ROS map_server maps and plain images (ros.py)."""

from cart2d.maps.occupancy import (
    FREE,
    MAX_MAP_CELLS,
    MAX_PLANNING_NODES,
    MAX_RESOLUTION_M,
    MIN_RESOLUTION_M,
    OCCUPIED,
    UNKNOWN,
    MapError,
    OccupancyMap,
    empty_map,
)
from cart2d.maps.ros import (
    Thresholds,
    load_ros_map,
    map_from_image,
    map_from_ros,
    save_ros_map,
)

__all__ = [
    "FREE",
    "MAX_MAP_CELLS",
    "MAX_PLANNING_NODES",
    "MAX_RESOLUTION_M",
    "MIN_RESOLUTION_M",
    "OCCUPIED",
    "UNKNOWN",
    "MapError",
    "OccupancyMap",
    "Thresholds",
    "empty_map",
    "load_ros_map",
    "map_from_image",
    "map_from_ros",
    "save_ros_map",
]

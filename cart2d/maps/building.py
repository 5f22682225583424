"""A map built from what the camera saw (issue 26): the perception's log-odds grid
(cart2d/perception/occupancy.py, in the frame the poses were given in) as an occupancy map,
occupied where perception believes it, free where a frame saw floor and nothing believed
there, unknown where no frame ever looked: what `cart2d map save` writes as a ROS map_server map.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from cart2d.maps.occupancy import FREE, OCCUPIED, UNKNOWN, OccupancyMap

OCCUPIED_P = 0.8  # as the live map believes a perceived cell (cart2d/gateway/seeing.py BELIEVED_P)
FREE_P = 0.35  # seen through more often than hit: floor


def built_map(
    probability: npt.NDArray[np.floating],
    observed: npt.NDArray[np.bool_],
    origin_m: tuple[float, float],
    resolution_m: float,
    occupied_p: float = OCCUPIED_P,
) -> OccupancyMap:
    """`probability`: p(occupied) per cell, rows along y from `origin_m`; `observed`: whether
    any frame hit the cell or saw floor in it."""
    cells = np.full(probability.shape, UNKNOWN, dtype=np.int8)
    cells[observed & (probability < FREE_P)] = FREE
    cells[observed & (probability > occupied_p)] = OCCUPIED
    return OccupancyMap(origin_m, resolution_m, cells)

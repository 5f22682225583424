"""A fake world for exploration's tests (no simulator): a room of two halves joined by a door,
and a walled-off pocket whose floor shows through a window but has no way in. The camera
reveals the cells within 0.6 m of where the cart stands."""

from __future__ import annotations

import math

import numpy as np

from cart2d.maps.frontiers import Point
from cart2d.maps.occupancy import FREE, OCCUPIED, UNKNOWN, OccupancyMap

RES = 0.1
N = 30  # 3 m square


def true_room() -> np.ndarray:
    cells = np.full((N, N), FREE, dtype=np.int8)
    cells[0, :] = cells[-1, :] = cells[:, 0] = cells[:, -1] = OCCUPIED
    cells[:, 15] = OCCUPIED  # a wall between the halves...
    cells[5:8, 15] = FREE  # ...with a door
    cells[20:29, 22] = OCCUPIED  # the pocket's wall (x = 2.2 m), a window in it
    cells[20, 22:29] = OCCUPIED
    cells[24, 22] = FREE  # the window: seen through, too narrow to drive (path_length says)
    return cells


class FakeWorld:
    def __init__(self) -> None:
        self.truth = true_room()
        self.seen_cells = np.full((N, N), UNKNOWN, dtype=np.int8)
        self.at: Point = (0.5, 0.5)
        self.look()

    def in_pocket(self, p: Point) -> bool:
        return p[0] > 2.2 and p[1] > 2.0

    def look(self) -> None:
        ys, xs = np.mgrid[0:N, 0:N]
        near = np.hypot((xs + 0.5) * RES - self.at[0], (ys + 0.5) * RES - self.at[1]) < 0.6
        self.seen_cells[near] = self.truth[near]

    def seen(self) -> OccupancyMap:
        return OccupancyMap((0.0, 0.0), RES, self.seen_cells.copy())

    def path_length(self, p: Point) -> float | None:
        return None if self.in_pocket(p) else math.dist(self.at, p) + 1.0

    def go_to(self, p: Point) -> str:
        self.at = p
        self.look()
        return ""

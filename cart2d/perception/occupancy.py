"""The perceived obstacles as an occupancy grid with log-odds (Moravec & Elfes, "High resolution
maps from wide angle sonar", ICRA 1985; Thrun, Burgard & Fox, Probabilistic Robotics, ch. 9):
every cell holds l = log(p / (1 - p)), starting at 0 (p = 0.5, unknown). A detection's hits add
`hit_log_odds` to their cells, the cells its rays cross on their way (free floor seen) add
`free_log_odds`, and l is clamped so that a cell can change its mind after a few frames.

A hit marks its cell and, with `hit_depth_m`, the cells that far behind it along its ray (the
camera sees an obstacle's face, not its depth). A ray is sampled every half cell from min range
to its end: the cells it crosses, each counted once per frame however many rays cross it; a ray
that ends on a hit stops half a cell short of it, and a cell hit in a frame is never also
cleared in that frame.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from cart2d.perception.camera_model import FloatArray
from cart2d.perception.detection import Detection

Pose = tuple[float, float, float]  # x, y (m) and heading theta (rad) of base_link in the map


class LogOddsGrid:
    def __init__(
        self,
        origin: tuple[float, float],
        resolution_m: float,
        width: int,
        height: int,
        hit_log_odds: float = 0.85,  # p = 0.7 per hit
        free_log_odds: float = -0.4,  # p = 0.4 per ray crossing
        min_log_odds: float = -2.0,
        max_log_odds: float = 3.5,  # p = 0.97: cleared by about 9 frames of free rays
        hit_depth_m: float = 0.0,  # how deep behind its face an obstacle is taken to be
    ) -> None:
        if resolution_m <= 0.0 or width < 1 or height < 1:
            raise ValueError("the grid needs a positive resolution and at least one cell")
        self.origin = (float(origin[0]), float(origin[1]))
        self.resolution_m = float(resolution_m)
        self.width, self.height = int(width), int(height)
        self.hit_log_odds, self.free_log_odds = hit_log_odds, free_log_odds
        self.min_log_odds, self.max_log_odds = min_log_odds, max_log_odds
        self.hit_depth_m = float(hit_depth_m)
        self.log_odds = np.zeros((self.height, self.width), dtype=np.float32)

    def clear(self) -> None:
        self.log_odds[:] = 0.0

    def probability(self) -> npt.NDArray[np.float32]:
        """p(occupied) per cell, rows along y from the origin."""
        return np.asarray(1.0 / (1.0 + np.exp(-self.log_odds)), dtype=np.float32)

    def _cells(self, points: FloatArray) -> npt.NDArray[np.int64]:
        """Flat indices of the cells holding `points` (N x 2, map m), those outside dropped."""
        ij = np.floor((points - np.array(self.origin)) / self.resolution_m).astype(np.int64)
        inside = (ij[:, 0] >= 0) & (ij[:, 0] < self.width) & (ij[:, 1] >= 0) & (ij[:, 1] < self.height)
        return np.asarray(ij[inside, 1] * self.width + ij[inside, 0], dtype=np.int64)

    def integrate(self, pose: Pose, detection: Detection) -> None:
        """Adds one detection made with the cart at `pose`."""
        x, y, theta = pose
        c, s = math.cos(theta), math.sin(theta)
        rotation = np.array([[c, -s], [s, c]])

        def to_map(points: FloatArray) -> FloatArray:
            return np.asarray(np.reshape(points, (-1, 2)) @ rotation.T + [x, y], dtype=np.float64)

        origin = to_map(detection.origin)[0]
        hits, ends = to_map(detection.hits), to_map(detection.free)
        ends_on_hit = np.zeros(len(ends), dtype=bool)
        ends_on_hit[: len(hits)] = True  # Detection.free lists the hits first
        hit_cells = np.unique(self._cells(self._behind(origin, hits)))
        free_cells = np.setdiff1d(
            self._free_cells(origin, ends, ends_on_hit, detection.min_range_m), hit_cells
        )
        flat = self.log_odds.reshape(-1)
        for touched, change in ((free_cells, self.free_log_odds), (hit_cells, self.hit_log_odds)):
            flat[touched] = np.clip(flat[touched] + change, self.min_log_odds, self.max_log_odds)

    def _behind(self, origin: FloatArray, hits: FloatArray) -> FloatArray:
        """The hits and, along each ray, the points up to hit_depth_m behind them: a camera sees an
        obstacle's face, never how deep it is, and a cart that plans past a face's ends must not
        cut through the unseen rest. Free rays from other views clear what is not there."""
        if self.hit_depth_m <= 0.0 or len(hits) == 0:
            return hits
        offsets = hits - origin
        directions = offsets / np.maximum(np.linalg.norm(offsets, axis=1), 1e-12)[:, None]
        t = np.arange(0.0, self.hit_depth_m + 1e-9, self.resolution_m / 2)
        return np.asarray((hits[:, None, :] + directions[:, None, :] * t[None, :, None]).reshape(-1, 2))

    def _free_cells(
        self, origin: FloatArray, ends: FloatArray, ends_on_hit: npt.NDArray[np.bool_], min_range_m: float
    ) -> npt.NDArray[np.int64]:
        if len(ends) == 0:
            return np.zeros(0, dtype=np.int64)
        step = self.resolution_m / 2
        offsets = ends - origin
        lengths = np.linalg.norm(offsets, axis=1)
        stop = lengths - np.where(ends_on_hit, step, 0.0)
        t = min_range_m + step * np.arange(max(1, math.ceil((float(stop.max()) - min_range_m) / step) + 1))
        along = t[None, :] <= stop[:, None]
        directions = offsets / np.maximum(lengths, 1e-12)[:, None]
        samples = origin + directions[:, None, :] * t[None, :, None]
        return np.unique(self._cells(samples[along]))

    def cells(self, threshold: float = 0.5) -> list[tuple[float, float, float]]:
        """(x, y, p) of the cells' centres (map m) whose p(occupied) is above `threshold`."""
        p = self.probability()
        rows, cols = np.nonzero(p > threshold)
        xs = self.origin[0] + (cols + 0.5) * self.resolution_m
        ys = self.origin[1] + (rows + 0.5) * self.resolution_m
        return [(float(a), float(b), float(q)) for a, b, q in zip(xs, ys, p[rows, cols], strict=True)]

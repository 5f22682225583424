"""An occupancy map: a floor plan of square cells that are free, occupied or unknown.

The cells are laid out as in ROS's nav_msgs/OccupancyGrid: row-major from the origin, cell (i, j)
is column i (x) of row j (y), row 0 at the lowest y, and `origin_m` is the lower-left corner of
cell (0, 0) in metres (map_server's `origin` without the yaw). The values are OccupancyGrid's:
0 free, 100 occupied, -1 unknown.

The planner works on nodes at the centres of cells (cart2d/planning/): a map becomes a planning
grid, coarsened by blocks of k x k cells when the map is finer than planning needs. A block is
occupied if any of its cells is, else unknown if any is, else free: coarsening never loses an
obstacle nor turns unknown space into free space. Blocks that reach past the map's edge count
the missing cells as unknown.
"""

from __future__ import annotations

import base64
import binascii
import math
import zlib
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from cart2d.planning import Grid

FREE = 0
OCCUPIED = 100
UNKNOWN = -1

# The largest map the gateway takes, cells per side (the API's schema says so), and the most
# nodes the planner is given: a map of more cells is planned on coarser blocks.
MAX_MAP_CELLS = 2000
# A floor plan's cell side, m: what the gateway takes from a file or an upload (finer than a
# millimetre is no floor plan; the planner's own step has its limits in MapSettings)
MIN_RESOLUTION_M, MAX_RESOLUTION_M = 0.001, 10.0
MAX_PLANNING_NODES = 1024 * 1024

CellArray = npt.NDArray[np.int8]
BoolArray = npt.NDArray[np.bool_]


class MapError(ValueError):
    """A map that cannot be read or used; the message says why, for a person."""


@dataclass(frozen=True, eq=False)
class OccupancyMap:
    origin_m: tuple[float, float]
    resolution_m: float
    cells: CellArray  # (height, width), values FREE, OCCUPIED, UNKNOWN

    def __post_init__(self) -> None:
        ox, oy = (float(v) for v in self.origin_m)
        r = float(self.resolution_m)
        if not (math.isfinite(ox) and math.isfinite(oy)):
            raise MapError(f"the map's origin must be finite, got {self.origin_m!r}")
        if not (math.isfinite(r) and r > 0.0):
            raise MapError(f"the map's resolution must be a finite number of metres > 0, got {r!r}")
        cells = np.asarray(self.cells)
        if cells.ndim != 2 or cells.shape[0] < 2 or cells.shape[1] < 2:
            raise MapError(f"a map is a 2-D array of at least 2 x 2 cells, got shape {cells.shape}")
        if not np.isin(cells, (FREE, OCCUPIED, UNKNOWN)).all():
            raise MapError("map cells must be 0 (free), 100 (occupied) or -1 (unknown)")
        cells = cells.astype(np.int8)
        cells.flags.writeable = False
        object.__setattr__(self, "origin_m", (ox, oy))
        object.__setattr__(self, "resolution_m", r)
        object.__setattr__(self, "cells", cells)

    @property
    def width(self) -> int:
        return int(self.cells.shape[1])

    @property
    def height(self) -> int:
        return int(self.cells.shape[0])

    @property
    def extent_m(self) -> tuple[float, float, float, float]:
        """x_min, y_min, x_max, y_max of the map's cells."""
        x0, y0 = self.origin_m
        return (x0, y0, x0 + self.width * self.resolution_m, y0 + self.height * self.resolution_m)

    def counts(self) -> dict[str, int]:
        return {
            "free": int(np.count_nonzero(self.cells == FREE)),
            "occupied": int(np.count_nonzero(self.cells == OCCUPIED)),
            "unknown": int(np.count_nonzero(self.cells == UNKNOWN)),
        }

    def same_cells(self, other: OccupancyMap) -> bool:
        return (
            self.origin_m == other.origin_m
            and self.resolution_m == other.resolution_m
            and np.array_equal(self.cells, other.cells)
        )

    # -- planning ----------------------------------------------------------------------------------
    def coarsened(self, k: int) -> OccupancyMap:
        """Blocks of k x k cells as one cell each (see the module's docstring)."""
        if isinstance(k, bool) or not isinstance(k, int) or k < 1:
            raise MapError(f"the coarsening factor must be an integer >= 1, got {k!r}")
        if k == 1:
            return self
        h, w = self.height, self.width
        rows, cols = -(-h // k), -(-w // k)
        padded = np.full((rows * k, cols * k), UNKNOWN, dtype=np.int8)
        padded[:h, :w] = self.cells
        blocks = padded.reshape(rows, k, cols, k)
        occupied = (blocks == OCCUPIED).any(axis=(1, 3))
        unknown = (blocks == UNKNOWN).any(axis=(1, 3))
        out = np.where(occupied, OCCUPIED, np.where(unknown, UNKNOWN, FREE)).astype(np.int8)
        return OccupancyMap(self.origin_m, self.resolution_m * k, out)

    def planning_factor(self, planning_step_m: float | None, radius_m: float) -> int:
        """The block size k for planning: the largest k whose step k·resolution stays within
        `planning_step_m` (default: half the planning radius, so that coarsening widens
        obstacles by less than that), at least 1, and large enough that the planner gets at
        most MAX_PLANNING_NODES nodes."""
        target = planning_step_m if planning_step_m is not None else radius_m / 2.0
        k = max(1, math.floor(target / self.resolution_m + 1e-9))
        k = min(k, min(self.width, self.height) - 1)  # two nodes per side at least
        while -(-self.width // k) * -(-self.height // k) > MAX_PLANNING_NODES:
            k += 1
        return k

    def grid(self) -> Grid:
        """The planner's grid: a node at the centre of every cell."""
        r = self.resolution_m
        return Grid(
            cols=self.width,
            rows=self.height,
            step_m=r,
            origin=(self.origin_m[0] + r / 2, self.origin_m[1] + r / 2),
        )

    def blocked(self, unknown_is_free: bool = False) -> BoolArray:
        """Cells the planner must keep the cart's footprint off, (rows, cols) as the grid's nodes."""
        cells = self.cells
        out: BoolArray = cells == OCCUPIED
        if not unknown_is_free:
            out = out | (cells == UNKNOWN)
        return out

    # -- storage -------------------------------------------------------------------------------------
    def encode_cells(self) -> str:
        """The cells as text: base64 of the zlib-deflated bytes (int8), row-major from the origin."""
        return base64.b64encode(zlib.compress(self.cells.tobytes(), 6)).decode("ascii")

    @classmethod
    def decode(
        cls, origin_m: tuple[float, float], resolution_m: float, width: int, height: int, cells: str
    ) -> OccupancyMap:
        """The map encode_cells() wrote; MapError if the text is not width x height cells."""
        if not (2 <= width <= MAX_MAP_CELLS and 2 <= height <= MAX_MAP_CELLS):
            raise MapError(f"a map has 2 to {MAX_MAP_CELLS} cells per side, not {width} x {height}")
        try:
            packed = base64.b64decode(cells.encode("ascii"), validate=True)
            inflater = zlib.decompressobj()
            raw = inflater.decompress(packed, width * height + 1)  # no more than it can hold
        except (binascii.Error, UnicodeEncodeError, zlib.error) as exc:
            raise MapError(f"the map's cells are not base64 of zlib data: {exc}") from None
        if len(raw) != width * height:
            raise MapError(f"the map's cells hold {len(raw)} bytes, not width x height = {width * height}")
        array = np.frombuffer(raw, dtype=np.int8).reshape(height, width)
        return cls(origin_m, resolution_m, array)


def empty_map(origin_m: tuple[float, float], resolution_m: float, width: int, height: int) -> OccupancyMap:
    return OccupancyMap(origin_m, resolution_m, np.zeros((height, width), dtype=np.int8))

"""The markers file: AprilTag 36h11 markers placed at surveyed poses in the `map` frame
(docs/localisation.md, "The markers file").

A JSON or YAML document `{"markers": [{"id": 3, "size_m": 0.12, "x": 2.0, "y": 0.5, "z": 0.2,
"yaw_deg": 180, "on": "wall"}, ...]}`: `size_m` the side of the black square (the printed sheet's
white margin outside it), (x, y, z) its centre in `map`, metres. A marker `on` a wall stands
upright and faces the direction `yaw_deg` (its normal, counter-clockwise from map x); one on the
floor lies face up with its top edge (the bitmap's first row) towards `yaw_deg`.

The marker's own frame is OpenCV's (the frame cv2.solvePnP's SOLVEPNP_IPPE_SQUARE takes): origin
at the centre, x to the right of the printed bitmap, y towards its top, z out of the paper.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import cv2
import numpy as np
import numpy.typing as npt
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from cart2d.files import read_regular
from cart2d.maps.ros import bounded_yaml
from cart2d.shown import error_sentences

FloatArray = npt.NDArray[np.float64]
DICTIONARY = cv2.aruco.DICT_APRILTAG_36h11
MAX_MARKERS_BYTES = 256 * 1024
BITMAP_CELLS = 8  # 36h11: 6 x 6 data bits inside a one-cell black border
TAG_IDS = 587  # the ids OpenCV's 36h11 dictionary holds: 0 .. 586


def dictionary() -> cv2.aruco.Dictionary:
    return cv2.aruco.getPredefinedDictionary(DICTIONARY)


def bitmap(tag_id: int) -> npt.NDArray[np.uint8]:
    """The marker's cells, BITMAP_CELLS square, 1 white, 0 black, row 0 the top: OpenCV's own
    bitmap (cv2.aruco.generateImageMarker), what the detector looks for."""
    image = cv2.aruco.generateImageMarker(dictionary(), tag_id, BITMAP_CELLS)
    return (np.asarray(image) > 127).astype(np.uint8)


class MarkerSpec(BaseModel):
    model_config = ConfigDict(extra="forbid")

    id: int = Field(ge=0, lt=TAG_IDS)
    size_m: float = Field(gt=0.01, le=2.0)
    x: float = Field(ge=-1e4, le=1e4)
    y: float = Field(ge=-1e4, le=1e4)
    z: float = Field(default=0.0, ge=-10.0, le=10.0)
    yaw_deg: float = Field(default=0.0, ge=-360.0, le=360.0)
    on: Literal["wall", "floor"] = "wall"


class MarkersSpec(BaseModel):
    model_config = ConfigDict(extra="forbid")

    markers: list[MarkerSpec] = Field(max_length=TAG_IDS)


class MarkersError(ValueError):
    """A markers file that cannot be used; the message is a sentence for the user."""


@dataclass(frozen=True)
class Marker:
    id: int
    size_m: float
    x: float
    y: float
    z: float
    yaw_deg: float
    on: str = "wall"

    def rotation(self) -> FloatArray:
        """Marker -> map: the columns are the marker's x, y and z axes in `map`."""
        c, s = math.cos(math.radians(self.yaw_deg)), math.sin(math.radians(self.yaw_deg))
        if self.on == "floor":
            ex, ey, ez = (s, -c, 0.0), (c, s, 0.0), (0.0, 0.0, 1.0)
        else:  # upright, its normal along yaw: x = up x normal
            ex, ey, ez = (-s, c, 0.0), (0.0, 0.0, 1.0), (c, s, 0.0)
        return np.array([ex, ey, ez], dtype=np.float64).T

    def centre(self) -> FloatArray:
        return np.array([self.x, self.y, self.z], dtype=np.float64)

    def transform(self) -> FloatArray:
        """The 4 x 4 homogeneous transform marker -> map."""
        t = np.eye(4)
        t[:3, :3] = self.rotation()
        t[:3, 3] = self.centre()
        return t

    def corners(self) -> FloatArray:
        """The black square's corners in `map` (4 x 3) in OpenCV's order: top-left, top-right,
        bottom-right, bottom-left of the bitmap."""
        local = object_points(self.size_m)
        return np.asarray(local @ self.rotation().T + self.centre(), dtype=np.float64)

    def as_dict(self) -> dict[str, Any]:
        return {
            "id": self.id,
            "size_m": self.size_m,
            "x": self.x,
            "y": self.y,
            "z": self.z,
            "yaw_deg": self.yaw_deg,
            "on": self.on,
        }


def object_points(size_m: float) -> FloatArray:
    """The square's corners in the marker's frame, in the order SOLVEPNP_IPPE_SQUARE requires
    (and detectMarkers returns): (-s/2, s/2), (s/2, s/2), (s/2, -s/2), (-s/2, -s/2)."""
    h = size_m / 2.0
    return np.array([[-h, h, 0.0], [h, h, 0.0], [h, -h, 0.0], [-h, -h, 0.0]], dtype=np.float64)


@dataclass(frozen=True)
class MarkerMap:
    markers: tuple[Marker, ...] = ()

    def by_id(self) -> dict[int, Marker]:
        return {m.id: m for m in self.markers}

    def as_dict(self) -> dict[str, Any]:
        return {"markers": [m.as_dict() for m in self.markers]}


def parse_markers(text: str, name: str = "the markers file") -> MarkerMap:
    """A markers file's text (JSON, or YAML) -> MarkerMap; MarkersError with a sentence."""
    try:
        data = json.loads(text) if text.lstrip().startswith("{") else bounded_yaml(text)
    except (ValueError, Exception) as exc:  # json's ValueError, yaml.YAMLError
        raise MarkersError(f"{name} is neither JSON nor YAML: {exc}") from None
    return markers_from(data, name)


def markers_from(data: Any, name: str = "the markers") -> MarkerMap:
    try:
        spec = MarkersSpec.model_validate(data)
    except ValidationError as exc:
        raise MarkersError(error_sentences(exc.errors(), name)) from None
    ids = [m.id for m in spec.markers]
    twice = sorted({i for i in ids if ids.count(i) > 1})
    if twice:
        raise MarkersError(f"{name} lists marker id {twice[0]} more than once: each id is one place")
    return MarkerMap(tuple(Marker(**m.model_dump()) for m in spec.markers))


def load_markers(path: Path) -> MarkerMap:
    try:
        data = read_regular(path, MAX_MARKERS_BYTES)
    except OSError as exc:
        raise MarkersError(f"cannot read the markers file {path}: {exc.strerror or exc}") from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise MarkersError(f"the markers file {path} is not UTF-8 text") from None
    return parse_markers(text, f"the markers file {path}")


def arena_markers(
    bounds: tuple[float, float, float, float], spacing_m: float = 1.0, size_m: float = 0.1
) -> MarkerMap:
    """Markers at the foot of the four walls of the rectangle `bounds` (x0, y0, x1, y1), about
    `spacing_m` apart, facing in, 2 mm proud of the wall: the bench's and the demo's (ids from 0).
    At the foot, because the camera looks down (robot.toml [camera] pitch_deg): a marker higher
    up is out of the picture once the cart is more than a few tens of centimetres away."""
    x0, y0, x1, y1 = bounds
    z, proud = size_m / 2 + 0.01, 0.002
    markers: list[Marker] = []

    def along(lo: float, hi: float) -> list[float]:
        n = max(1, round((hi - lo) / spacing_m))
        return [lo + (k + 0.5) * (hi - lo) / n for k in range(n)]

    for y in along(y0, y1):
        markers.append(Marker(len(markers), size_m, x0 + proud, y, z, 0.0))
        markers.append(Marker(len(markers), size_m, x1 - proud, y, z, 180.0))
    for x in along(x0, x1):
        markers.append(Marker(len(markers), size_m, x, y0 + proud, z, 90.0))
        markers.append(Marker(len(markers), size_m, x, y1 - proud, z, -90.0))
    return MarkerMap(tuple(markers))


def floor_markers(
    bounds: tuple[float, float, float, float],
    spacing_m: float = 1.0,
    size_m: float = 0.15,
    first_id: int = 100,
) -> MarkerMap:
    """Markers lying on the floor of the rectangle `bounds` on a square grid `spacing_m` apart
    (half a spacing from the walls), their tops towards map +x: seen from 0.3 to ~1.2 m ahead,
    where wall markers are out of the picture."""
    x0, y0, x1, y1 = bounds
    xs = np.arange(x0 + spacing_m / 2, x1 - spacing_m / 4, spacing_m)
    ys = np.arange(y0 + spacing_m / 2, y1 - spacing_m / 4, spacing_m)
    markers = [
        Marker(first_id + k, size_m, float(x), float(y), 0.0, 0.0, "floor")
        for k, (x, y) in enumerate((x, y) for y in ys for x in xs)
    ]
    return MarkerMap(tuple(markers))

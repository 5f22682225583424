"""ROS map_server maps (a .yaml naming a .pgm/.png) and plain floor-plan images, in and out.

The format is map_server's (wiki.ros.org/map_server, "Map format"): the YAML gives `image` (a
path, relative to the YAML's folder or absolute), `resolution` (m per pixel), `origin` (x, y, yaw
of the lower-left pixel; cart2d takes yaw 0 only), `negate`, `occupied_thresh`, `free_thresh`
and `mode`. A pixel's colour channels are averaged into x in [0, 255] (an alpha channel is
ignored); its occupancy is p = (255 - x) / 255, or x / 255 with negate; mode trinary (the
default, and the only one taken here) makes it occupied (100) when p > occupied_thresh, free (0)
when p < free_thresh, unknown (-1) otherwise. The image's top row is the map's highest.

Export writes what map_saver writes: a trinary PGM (0 occupied, 254 free, 205 unknown) and a YAML
with negate 0, occupied_thresh 0.65 and free_thresh 0.196, which reads back into the same cells.
Images are read and written with Pillow: PGM and PNG only, the formats map_server's maps and floor
plans come in (Pillow opens dozens more, each a parser an upload could reach). YAML is read with
PyYAML's safe loader (no tags, no objects), refusing aliases (a 400-byte alias bomb expands to
gigabytes) and nesting deeper than MAX_YAML_DEPTH (deeper recursion ends in RecursionError).
"""

from __future__ import annotations

import io
import math
import struct
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from PIL import Image, UnidentifiedImageError

from cart2d.files import read_regular
from cart2d.maps.occupancy import (
    FREE,
    MAX_MAP_CELLS,
    MAX_RESOLUTION_M,
    MIN_RESOLUTION_M,
    OCCUPIED,
    UNKNOWN,
    MapError,
    OccupancyMap,
)
from cart2d.shown import clipped, quoted

# map_saver's pixel values and thresholds
SAVED_OCCUPIED, SAVED_FREE, SAVED_UNKNOWN = 0, 254, 205
SAVED_OCCUPIED_THRESH, SAVED_FREE_THRESH = 0.65, 0.196
IMAGE_FORMATS = {".pgm": "PPM", ".png": "PNG"}  # Pillow writes PGM through its PPM plugin
MAX_YAML_BYTES = 64 * 1024
MAX_IMAGE_BYTES = 8 * 1024 * 1024  # a 2000 x 2000 RGB PNG without compression would be 12 MB: none is
READ_FORMATS = ("PNG", "PPM")  # Pillow's PPM plugin reads PGM, PPM and PBM
# What Pillow's parsers raise on a damaged file besides OSError (a PNG chunk's broken type is a
# SyntaxError; a short header an EOFError, struct.error or IndexError)
IMAGE_ERRORS = (
    OSError,
    ValueError,
    SyntaxError,
    EOFError,
    IndexError,
    TypeError,
    struct.error,
    zlib.error,
    Image.DecompressionBombError,
)
MAX_YAML_DEPTH = 16  # a map's YAML is two deep (origin's list in the mapping)


class BoundedYamlLoader(yaml.SafeLoader):
    """PyYAML's SafeLoader without aliases and nested at most MAX_YAML_DEPTH deep."""

    def __init__(self, stream: str) -> None:
        super().__init__(stream)
        self._depth = 0

    def compose_node(self, parent: yaml.Node | None, index: int) -> yaml.Node | None:
        event = self.peek_event()  # type: ignore[no-untyped-call]
        mark: Any = event.start_mark  # where the error's text points
        if isinstance(event, yaml.AliasEvent):
            raise yaml.composer.ComposerError(None, None, "no aliases (*name) in a map's YAML", mark)
        if self._depth >= MAX_YAML_DEPTH:
            raise yaml.composer.ComposerError(None, None, f"nested over {MAX_YAML_DEPTH} deep", mark)
        self._depth += 1
        try:
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1


def bounded_yaml(text: str) -> Any:
    """The YAML document in `text` (BoundedYamlLoader); yaml.YAMLError if it is not one."""
    loader = BoundedYamlLoader(text)
    try:
        return loader.get_single_data()
    finally:
        loader.dispose()


@dataclass(frozen=True)
class Thresholds:
    """How pixels become cells (map_server's YAML fields)."""

    negate: bool = False
    occupied_thresh: float = SAVED_OCCUPIED_THRESH
    free_thresh: float = SAVED_FREE_THRESH

    def __post_init__(self) -> None:
        occ, free = self.occupied_thresh, self.free_thresh
        if not (math.isfinite(occ) and math.isfinite(free) and 0.0 <= free <= occ <= 1.0):
            raise MapError(
                f"thresholds must satisfy 0 <= free_thresh <= occupied_thresh <= 1, got "
                f"free_thresh {free!r} and occupied_thresh {occ!r}"
            )


def cells_from_image(data: bytes, thresholds: Thresholds) -> np.ndarray:
    """The cells (row 0 the lowest) of an image's bytes: PNG, or Netpbm's PGM (PPM and PBM too)."""
    try:
        with Image.open(io.BytesIO(data), formats=READ_FORMATS) as image:
            width, height = image.size
            if not (2 <= width <= MAX_MAP_CELLS and 2 <= height <= MAX_MAP_CELLS):
                raise MapError(
                    f"the image is {width} x {height} pixels: a map has 2 to {MAX_MAP_CELLS} cells per side"
                )
            if image.mode in ("I", "I;16", "I;16B", "I;16L", "F"):
                raise MapError(f"the image has {image.mode} pixels: use 8 bits per channel (PGM or PNG)")
            if image.mode in ("1", "L", "LA", "La"):
                pixels = np.asarray(image.convert("L"), dtype=np.float64)
            else:  # colour: the channels' average, alpha dropped
                pixels = np.asarray(image.convert("RGB"), dtype=np.float64).mean(axis=2)
    except UnidentifiedImageError:
        raise MapError(
            "the image is not a PNG nor a PGM (Netpbm's PPM and PBM are taken too): save the floor plan "
            "as one"
        ) from None
    except IMAGE_ERRORS as exc:
        raise MapError(f"the image cannot be read: {clipped(str(exc) or type(exc).__name__)}") from None
    p = pixels / 255.0 if thresholds.negate else (255.0 - pixels) / 255.0
    cells = np.full(p.shape, UNKNOWN, dtype=np.int8)
    cells[p > thresholds.occupied_thresh] = OCCUPIED
    cells[p < thresholds.free_thresh] = FREE
    return cells[::-1].copy()  # the image's top row is the map's highest


def checked_resolution(resolution_m: float) -> float:
    """`resolution_m` if a floor plan may have cells this wide, else MapError."""
    if not MIN_RESOLUTION_M <= resolution_m <= MAX_RESOLUTION_M:
        raise MapError(
            f"the map's resolution must be from {MIN_RESOLUTION_M} to {MAX_RESOLUTION_M:g} m per pixel, "
            f"got {quoted(resolution_m)}"
        )
    return resolution_m


def map_from_image(
    data: bytes,
    resolution_m: float,
    origin_m: tuple[float, float] = (0.0, 0.0),
    thresholds: Thresholds | None = None,
) -> OccupancyMap:
    """A plain floor-plan image (dark = occupied, light = free) with its resolution."""
    resolution_m = checked_resolution(resolution_m)
    return OccupancyMap(origin_m, resolution_m, cells_from_image(data, thresholds or Thresholds()))


def _number(meta: dict[str, Any], key: str, default: float | None = None) -> float:
    value = meta.get(key, default)
    if value is None:
        raise MapError(f"the map's YAML has no {key!r}")
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise MapError(f"the map's YAML {key!r} must be a finite number, got {quoted(value)}")
    return float(value)


@dataclass(frozen=True)
class RosMapMeta:
    """A map_server YAML, read and checked."""

    image: str
    resolution_m: float
    origin_m: tuple[float, float]
    thresholds: Thresholds


def parse_ros_yaml(text: str) -> RosMapMeta:
    if len(text.encode("utf-8", "surrogatepass")) > MAX_YAML_BYTES:
        raise MapError(f"the map's YAML is over {MAX_YAML_BYTES} bytes")
    try:
        meta = bounded_yaml(text)
    except yaml.YAMLError as exc:
        raise MapError(f"the map's YAML cannot be read: {clipped(str(exc), 300)}") from None
    if not isinstance(meta, dict):
        raise MapError("the map's YAML must be a mapping (image, resolution, origin, ...)")
    image = meta.get("image")
    if not isinstance(image, str) or not image:
        raise MapError("the map's YAML has no 'image' file name")
    mode = meta.get("mode", "trinary")
    if mode != "trinary":
        raise MapError(
            f"the map's mode is {quoted(mode)}: cart2d reads mode trinary only (free, occupied, unknown)"
        )
    origin = meta.get("origin")
    if not isinstance(origin, list) or len(origin) not in (2, 3):
        raise MapError("the map's YAML 'origin' must be [x, y, yaw]")
    x, y, *rest = (_number({"origin": v}, "origin") for v in origin)
    if rest and rest[0] != 0.0:
        raise MapError(f"the map's origin has a yaw of {rest[0]} rad: cart2d takes maps with yaw 0 only")
    resolution = checked_resolution(_number(meta, "resolution"))
    negate = meta.get("negate", 0)
    if negate not in (0, 1) or isinstance(negate, float):
        raise MapError(f"the map's YAML 'negate' must be 0 or 1, got {quoted(negate)}")
    thresholds = Thresholds(
        negate=bool(negate),
        occupied_thresh=_number(meta, "occupied_thresh", SAVED_OCCUPIED_THRESH),
        free_thresh=_number(meta, "free_thresh", SAVED_FREE_THRESH),
    )
    return RosMapMeta(image, resolution, (x, y), thresholds)


def map_from_ros(yaml_text: str, image_data: bytes) -> OccupancyMap:
    """A map_server map from its YAML's text and the bytes of the image it names."""
    meta = parse_ros_yaml(yaml_text)
    return OccupancyMap(meta.origin_m, meta.resolution_m, cells_from_image(image_data, meta.thresholds))


def load_ros_map(yaml_path: Path) -> OccupancyMap:
    """A map_server map from its .yaml file (the image path relative to the YAML's folder); both
    must be regular files within MAX_YAML_BYTES and MAX_IMAGE_BYTES."""
    try:
        raw = read_regular(yaml_path, MAX_YAML_BYTES)
    except (OSError, ValueError) as exc:  # ValueError: a NUL in the name
        raise MapError(f"the map's YAML {quoted(str(yaml_path))} cannot be read: {_why(exc)}") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        raise MapError(f"the map's YAML {quoted(str(yaml_path))} is not UTF-8 text") from None
    meta = parse_ros_yaml(text)
    image_path = Path(meta.image)
    if not image_path.is_absolute():
        image_path = yaml_path.parent / image_path
    try:
        data = read_regular(image_path, MAX_IMAGE_BYTES)
    except (OSError, ValueError) as exc:  # ValueError: a NUL in the name
        raise MapError(f"the map's image {quoted(str(image_path))} cannot be read: {_why(exc)}") from None
    return OccupancyMap(meta.origin_m, meta.resolution_m, cells_from_image(data, meta.thresholds))


def _why(exc: Exception) -> str:
    return clipped(exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc))


def image_bytes(occupancy: OccupancyMap, suffix: str = ".pgm") -> bytes:
    """The map as map_saver's trinary image (PGM or PNG, 8-bit grey), top row the highest."""
    fmt = IMAGE_FORMATS.get(suffix.lower())
    if fmt is None:
        raise MapError(f"maps are written as .pgm or .png, not {suffix!r}")
    pixels = np.full(occupancy.cells.shape, SAVED_UNKNOWN, dtype=np.uint8)
    pixels[occupancy.cells == FREE] = SAVED_FREE
    pixels[occupancy.cells == OCCUPIED] = SAVED_OCCUPIED
    out = io.BytesIO()
    Image.fromarray(pixels[::-1], mode="L").save(out, format=fmt)
    return out.getvalue()


def ros_yaml(occupancy: OccupancyMap, image_name: str) -> str:
    x, y = occupancy.origin_m
    return (
        f"image: {image_name}\n"
        f"mode: trinary\n"
        f"resolution: {occupancy.resolution_m!r}\n"
        f"origin: [{x!r}, {y!r}, 0.0]\n"
        f"negate: 0\n"
        f"occupied_thresh: {SAVED_OCCUPIED_THRESH}\n"
        f"free_thresh: {SAVED_FREE_THRESH}\n"
    )


def save_ros_map(occupancy: OccupancyMap, yaml_path: Path, image_suffix: str = ".pgm") -> Path:
    """Writes YAML_PATH and the image beside it (same stem); returns the image's path."""
    image_path = yaml_path.with_suffix(image_suffix)
    yaml_path.parent.mkdir(parents=True, exist_ok=True)
    image_path.write_bytes(image_bytes(occupancy, image_suffix))
    yaml_path.write_text(ros_yaml(occupancy, image_path.name), encoding="utf-8")
    return image_path

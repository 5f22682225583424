"""The gateway's own settings (network, access token, map and obstacles), kept in the user's
data directory and written atomically: a crash or kill -9 mid-save leaves the previous file or
the new one, never a broken one. It plays the part of the seed's settings.bin (which held the
Wi-Fi data); the settings file a user downloads adds the firmware's settings (SettingsFile)."""

from __future__ import annotations

import contextlib
import ipaddress
import json
import logging
import os
import re
import secrets
import time
from pathlib import Path
from typing import Annotated, Literal

import platformdirs
from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    PrivateAttr,
    Strict,
    ValidationError,
    model_validator,
)

from cart2d.maps import MAX_MAP_CELLS, MAX_RESOLUTION_M, MIN_RESOLUTION_M, MapError, OccupancyMap
from cart2d.params import planning_radius_m, robot
from cart2d.shown import error_sentences

log = logging.getLogger(__name__)

SETTINGS_FILE = "settings.json"
STALE_TMP_S = 60.0  # a save takes milliseconds: a temporary this old was left by a dead writer


def _json_integer(value: object) -> object:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ValueError("an integer is required, not a boolean or a string")
    return value


# JSON Schema's integer: 3 and 3.0, never true or "3" (the models are strict, this one field kind lax).
Integer = Annotated[int, Strict(False), BeforeValidator(_json_integer)]
# A floor plan's planning step, m: the width of the blocks of cells it is planned on.
PlanningStep = Annotated[float, Field(ge=0.01, le=10.0, allow_inf_nan=False)]


def _grid_default(key: str) -> float:
    return float(robot()["sim"][key])


HOST_LABEL = re.compile(r"[a-z0-9]([a-z0-9-]{0,61}[a-z0-9])?", re.IGNORECASE)  # RFC 1123, section 2.1


def address_or_host_name(value: str) -> str:
    """`value` if it is an IP address (no zone: `%eth0`) or a host name (RFC 1123 labels of letters,
    digits and inner hyphens, dot-separated, the last not all digits); else ValueError. Nothing
    else can be bound to, and a newline or a space must not reach the settings file or a log."""
    try:
        if "%" not in value:
            ipaddress.ip_address(value)
            return value
    except ValueError:
        pass
    labels = value.removesuffix(".").split(".")
    if not all(HOST_LABEL.fullmatch(label) for label in labels) or labels[-1].isdigit():
        raise ValueError(
            "the host must be an IP address (such as 127.0.0.1, 0.0.0.0 or ::) or a host name "
            "(letters, digits, hyphens and dots)"
        )
    return value


class NetworkSettings(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)
    host: Annotated[str, AfterValidator(address_or_host_name)] = Field(
        "127.0.0.1",
        min_length=1,
        max_length=253,
        pattern=r"^[A-Za-z0-9.:-]+$",  # what the schema can say; address_or_host_name says the rest
        description="bind address: an IP address or a host name",
    )
    port: Integer = Field(8080, ge=1, le=65535)


# http://HOST[:PORT] as the schema can say it (a host name or IPv4, or an IPv6 address in brackets;
# a port 1 to 65535), so that what the schema allows is taken
_HOST = r"([A-Za-z0-9][A-Za-z0-9.-]*|\[[0-9A-Fa-f:.]+\])"
_PORT = r"(:([1-9][0-9]{0,3}|[1-5][0-9]{4}|6[0-4][0-9]{3}|65[0-4][0-9]{2}|655[0-2][0-9]|6553[0-5]))?"
CAMERA_BASE_URL = rf"^http://{_HOST}{_PORT}/?$"
CAMERA_STREAM_URL = rf"^http://{_HOST}{_PORT}([/?][^\s#]*)?$"


class CameraSettings(BaseModel):
    """The camera the gateway reads at start (cart2d serve's --camera / --camera-stream win)."""

    model_config = ConfigDict(extra="forbid", strict=True)
    url: str | None = Field(
        None,
        max_length=300,
        pattern=CAMERA_BASE_URL,
        description="the ESP32-CAM's base URL, http://HOST[:PORT] (stream on PORT + 1)",
    )
    stream_url: str | None = Field(
        None,
        max_length=300,
        pattern=CAMERA_STREAM_URL,
        description="its MJPEG stream's URL outright (wins over url's)",
    )


Metres = Annotated[float, Field(allow_inf_nan=False, ge=-100_000.0, le=100_000.0)]
# A floor plan's cells as text: base64 of zlib data, 2000 x 2000 cells deflate to far less.
MAX_CELLS_TEXT = 8 * 1024 * 1024


class FloorPlan(BaseModel):
    """A floor plan: an occupancy grid as nav_msgs/OccupancyGrid (cart2d/maps/occupancy.py)."""

    model_config = ConfigDict(extra="forbid", strict=True)
    name: str = Field("", max_length=200, description="where it came from (a file name)")
    origin_m: tuple[Metres, Metres] = Field(description="the lower-left corner of cell (0, 0), m")
    resolution_m: float = Field(
        ge=MIN_RESOLUTION_M, le=MAX_RESOLUTION_M, allow_inf_nan=False, description="cell side, m"
    )
    width: Integer = Field(ge=2, le=MAX_MAP_CELLS, description="cells along x")
    height: Integer = Field(ge=2, le=MAX_MAP_CELLS, description="cells along y")
    cells: str = Field(
        max_length=MAX_CELLS_TEXT,
        description="base64 of the zlib-deflated cells, one signed byte each, row-major from the "
        "origin (row 0 the lowest y): 0 free, 100 occupied, -1 unknown",
    )
    _map: OccupancyMap | None = PrivateAttr(None)

    @model_validator(mode="after")
    def _decodes(self) -> FloorPlan:
        self._map = OccupancyMap.decode(self.origin_m, self.resolution_m, self.width, self.height, self.cells)
        return self

    def occupancy(self) -> OccupancyMap:
        if self._map is None:
            self._map = OccupancyMap.decode(
                self.origin_m, self.resolution_m, self.width, self.height, self.cells
            )
        return self._map

    @classmethod
    def of(cls, occupancy: OccupancyMap, name: str = "") -> FloorPlan:
        plan = cls.model_construct(
            name=name[:200],
            origin_m=occupancy.origin_m,
            resolution_m=occupancy.resolution_m,
            width=occupancy.width,
            height=occupancy.height,
            cells=occupancy.encode_cells(),
        )
        plan._map = occupancy
        try:
            return cls.model_validate(plan.model_dump())  # checked as an uploaded one would be
        except ValidationError as exc:  # an origin past what the settings keep
            problems = error_sentences(exc.errors(), "plan")
            raise MapError(f"the floor plan cannot be kept: {problems}") from None


class MapSettings(BaseModel):
    """The map the gateway plans on: a grid of nodes, or a floor plan planned on blocks of its
    cells (then cols, rows, step_m and origin_m are derived from it)."""

    model_config = ConfigDict(extra="forbid", strict=True)
    cols: Integer = Field(
        int(_grid_default("grid_nodes")), ge=2, le=MAX_MAP_CELLS, description="nodes along x"
    )
    rows: Integer = Field(
        int(_grid_default("grid_nodes")), ge=2, le=MAX_MAP_CELLS, description="nodes along y"
    )
    # at least 1 cm: the planner's footprint stencils grow as (footprint / step)^2
    step_m: float = Field(_grid_default("grid_step_m"), ge=0.01, le=10.0, allow_inf_nan=False)
    origin_m: tuple[Metres, Metres] = Field((0.0, 0.0), description="where node (0, 0) is, m")
    obstacles: list[tuple[Integer, Integer]] = Field(default_factory=list, max_length=4_000_000)
    floor_plan: FloorPlan | None = Field(
        None, description=f"a floor plan of up to {MAX_MAP_CELLS} x {MAX_MAP_CELLS} cells"
    )
    planning_step_m: PlanningStep | None = Field(
        None,
        description="plan a floor plan on blocks of cells at most this wide (default: half the planning "
        "radius); a block is occupied if any of its cells is",
    )
    unknown_is_free: bool = Field(False, description="plan through a floor plan's unknown cells")

    @model_validator(mode="after")
    def _grid_of_the_floor_plan(self) -> MapSettings:
        if self.floor_plan is not None:
            grid = planning_map(self).grid()
            self.cols, self.rows, self.step_m, self.origin_m = grid.cols, grid.rows, grid.step_m, grid.origin
        return self


def planning_map(m: MapSettings) -> OccupancyMap:
    """The floor plan coarsened to the blocks the planner works on; ValueError without one."""
    if m.floor_plan is None:
        raise ValueError("the map has no floor plan")
    occupancy = m.floor_plan.occupancy()
    return occupancy.coarsened(occupancy.planning_factor(m.planning_step_m, planning_radius_m()))


class GatewaySettings(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)
    version: Literal[1] = 1
    network: NetworkSettings = Field(default_factory=NetworkSettings)
    map: MapSettings = Field(default_factory=MapSettings)
    camera: CameraSettings = Field(default_factory=CameraSettings)
    token: str | None = Field(None, min_length=16, max_length=128)


class FirmwareSetting(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)
    id: Integer = Field(ge=0, le=255, description="stable setting id (config/robot.toml)")
    name: str = Field("", max_length=64, description="its name, for people; checked against the id if given")
    value: float = Field(allow_inf_nan=False)


class FirmwareSettings(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)
    settings: list[FirmwareSetting] = Field(max_length=256)


class SettingsFile(GatewaySettings):
    """The settings file (GET/POST /api/settings/file): the gateway's settings without the token,
    and the firmware's settings (its tuning) when the firmware could be read. A file without
    them (an older one) leaves the firmware's settings as they are."""

    firmware: FirmwareSettings | None = Field(
        None, description="every firmware setting by stable id, written back with PARAM_SET on upload"
    )


def default_directory() -> Path:
    """$CART2D_HOME, else the platform's user data directory (~/.local/share/cart2d)."""
    return Path(os.environ.get("CART2D_HOME") or platformdirs.user_data_dir("cart2d"))


def atomic_write(path: Path, data: bytes) -> None:
    """Writes `data` to `path` so that readers see the old or the new content, never a mix."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    try:
        os.write(fd, data)
        os.fsync(fd)
    finally:
        os.close(fd)
    os.replace(tmp, path)  # atomic on POSIX
    dir_fd = os.open(path.parent, os.O_RDONLY)
    try:
        os.fsync(dir_fd)  # make the rename itself durable
    finally:
        os.close(dir_fd)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True  # another user's process
    return True


def remove_stale_temporaries(path: Path, max_age_s: float = STALE_TMP_S) -> list[Path]:
    """Removes what atomic_write left for `path` when its writer died mid-save (kill -9, power
    loss): `.NAME.<pid>.tmp` whose process is gone, or older than `max_age_s` (its pid may have been
    reused). A live writer's file is left alone. Returns the files removed."""
    removed = []
    prefix, suffix = f".{path.name}.", ".tmp"
    for tmp in path.parent.glob(f".{path.name}.*.tmp"):
        pid = tmp.name[len(prefix) : -len(suffix)]
        if not pid.isdigit() or int(pid) == os.getpid():
            continue  # not atomic_write's, or this process's own save in progress
        try:
            if _alive(int(pid)) and time.time() - tmp.stat().st_mtime <= max_age_s:
                continue  # another process is saving right now
            tmp.unlink()
            removed.append(tmp)
        except OSError:
            continue  # gone already, or not ours to remove
    if removed:
        log.info("removed %d temporary file(s) left by an interrupted save of %s", len(removed), path)
    return removed


class Store:
    def __init__(self, directory: Path | None = None) -> None:
        self.directory = directory or default_directory()
        self.path = self.directory / SETTINGS_FILE

    def load(self) -> GatewaySettings:
        """The saved settings; defaults if there are none. An unreadable file is kept aside
        (settings.json.corrupt-<time>) and defaults are used, with a warning. Temporaries of a save
        that was killed are removed (remove_stale_temporaries)."""
        remove_stale_temporaries(self.path)
        try:
            text = self.path.read_text(encoding="utf-8")
        except FileNotFoundError:
            return GatewaySettings()
        try:
            return GatewaySettings.model_validate_json(text)
        except ValidationError as exc:
            aside = self.path.with_name(f"{SETTINGS_FILE}.corrupt-{int(time.time())}")
            with contextlib.suppress(OSError):
                os.replace(self.path, aside)
            log.warning(
                "%s is not valid (%s); kept as %s, using defaults", self.path, exc.errors()[0]["msg"], aside
            )
            return GatewaySettings()

    def save(self, settings: GatewaySettings) -> None:
        self.write(self.encode(settings))

    @staticmethod
    def encode(settings: GatewaySettings) -> bytes:
        """The file's content for `settings` (a tenth of a second with a large plan's obstacles)."""
        return (settings.model_dump_json(indent=2) + "\n").encode()

    def write(self, data: bytes) -> None:
        """Saves what encode() made."""
        atomic_write(self.path, data)

    def ensure_token(self, settings: GatewaySettings) -> GatewaySettings:
        """Settings with an access token, generating and saving one on first use."""
        if settings.token:
            return settings
        updated = settings.model_copy(update={"token": secrets.token_urlsafe(24)})
        self.save(updated)
        return updated


def parse_settings(data: bytes) -> SettingsFile:
    """An uploaded settings file: validated, or ValueError with the reason. Its gateway part is
    gateway_part(file)."""
    try:
        return SettingsFile.model_validate_json(data)
    except ValidationError as exc:
        raise ValueError(f"invalid settings file: {error_sentences(exc.errors(), 'file')}") from exc
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"invalid settings file: {exc}") from exc


def gateway_part(file: SettingsFile) -> GatewaySettings:
    """The gateway's own settings of a settings file (without its firmware section). Its parts were
    validated with the file: taken as they are (validating a large plan's obstacles again took
    longer than parsing the file)."""
    fields = {name: getattr(file, name) for name in GatewaySettings.model_fields}
    return GatewaySettings.model_construct(file.model_fields_set & set(fields), **fields)

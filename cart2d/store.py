"""The gateway's own settings (network, access token, map and obstacles), kept in the user's
data directory and written atomically: a crash or kill -9 mid-save leaves the previous file or
the new one, never a broken one. This is the seed's settings.bin (which held the Wi-Fi data)."""

from __future__ import annotations

import contextlib
import json
import logging
import os
import secrets
import time
from pathlib import Path
from typing import Annotated, Literal

import platformdirs
from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, Strict, ValidationError

from cart2d.params import robot

log = logging.getLogger(__name__)

SETTINGS_FILE = "settings.json"


def _json_integer(value: object) -> object:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ValueError("an integer is required, not a boolean or a string")
    return value


# JSON Schema's integer: 3 and 3.0, never true or "3" (the models are strict, this one field kind lax).
Integer = Annotated[int, Strict(False), BeforeValidator(_json_integer)]


def _grid_default(key: str) -> float:
    return float(robot()["sim"][key])


class NetworkSettings(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)
    host: str = Field("127.0.0.1", min_length=1, max_length=253, description="bind address")
    port: Integer = Field(8080, ge=1, le=65535)


class MapSettings(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)
    cols: Integer = Field(int(_grid_default("grid_nodes")), ge=2, le=1000, description="nodes along x")
    rows: Integer = Field(int(_grid_default("grid_nodes")), ge=2, le=1000, description="nodes along y")
    # at least 1 cm: the planner's footprint stencils grow as (footprint / step)^2
    step_m: float = Field(_grid_default("grid_step_m"), ge=0.01, le=10.0, allow_inf_nan=False)
    obstacles: list[tuple[Integer, Integer]] = Field(default_factory=list, max_length=1_000_000)


class GatewaySettings(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)
    version: Literal[1] = 1
    network: NetworkSettings = Field(default_factory=NetworkSettings)
    map: MapSettings = Field(default_factory=MapSettings)
    token: str | None = Field(None, min_length=16, max_length=128)


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


class Store:
    def __init__(self, directory: Path | None = None) -> None:
        self.directory = directory or default_directory()
        self.path = self.directory / SETTINGS_FILE

    def load(self) -> GatewaySettings:
        """The saved settings; defaults if there are none. An unreadable file is kept aside
        (settings.json.corrupt-<time>) and defaults are used, with a warning."""
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
        atomic_write(self.path, (settings.model_dump_json(indent=2) + "\n").encode())

    def ensure_token(self, settings: GatewaySettings) -> GatewaySettings:
        """Settings with an access token, generating and saving one on first use."""
        if settings.token:
            return settings
        updated = settings.model_copy(update={"token": secrets.token_urlsafe(24)})
        self.save(updated)
        return updated


def parse_settings(data: bytes) -> GatewaySettings:
    """Imported settings (an uploaded file): validated, or ValueError with the reason."""
    try:
        return GatewaySettings.model_validate_json(data)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first["loc"]) or "file"
        raise ValueError(f"invalid settings file: {where}: {first['msg']}") from exc
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"invalid settings file: {exc}") from exc

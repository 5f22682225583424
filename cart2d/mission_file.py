"""A mission file and its report, checked before anything runs (`cart2d mission`): the file is
read, parsed and validated whole, the settings and faults are checked against their ranges,
the start and the obstacles against the map, and the report's folder must take the report.
Each problem is one sentence; the report, written whenever a mission ran, is always valid JSON
(a number that is not finite is written as null)."""

from __future__ import annotations

import errno
import json
import math
import os
import tempfile
from pathlib import Path
from typing import Any, TypeVar

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from cart2d import faults as fault_table
from cart2d.files import read_regular
from cart2d.params import footprint_radius_m, robot, settings_table
from cart2d.planning import Grid, PlanError
from cart2d.shown import clipped, for_people, quoted
from cart2d.simulator import Box

Model = TypeVar("Model", bound=BaseModel)
MAX_COORDINATE_M = 1e5  # what the simulator takes (sim/src/world_change.cpp, kMaxCoordinateM)
MAX_PROBLEMS = 20  # a file's problems listed, then how many more
MAX_FILE_BYTES = 16 * 1024 * 1024  # a mission or world file: 10 000 boxes take about 1 MB


def default_report_path(mission: Path) -> Path:
    """MISSION.report.json beside MISSION.json."""
    return mission.with_name(f"{mission.stem if mission.suffix == '.json' else mission.name}.report.json")


def _where(loc: tuple[int | str, ...]) -> str:
    text = ""
    for part in loc:  # a part may be a key of the file: cut short
        key = clipped(str(part), 40)
        text += f"[{part}]" if isinstance(part, int) else (f".{key}" if text else key)
    return text or "the mission"


def _sentence(error: Any, keys: list[str]) -> str:
    loc = tuple(error["loc"])
    where = _where(loc)
    kind = error["type"]
    if kind == "extra_forbidden":
        parent = _where(loc[:-1]) if len(loc) > 1 else ""
        if parent:
            return f"unknown key {quoted(loc[-1])} in {parent}"
        return f"unknown key {quoted(where)} (a mission has: {', '.join(keys)})"
    if loc == ("goals",) and kind in ("missing", "too_short"):
        return "no goals: a mission needs at least one goal [x, y]"
    if kind == "missing":
        return f"{where} is missing"
    message = clipped(str(error["msg"]))
    return f"{where}: {message[0].lower()}{message[1:]}"


def parse(data: bytes, model: type[Model], name: str) -> tuple[Model | None, list[str]]:
    """The file's content as `model`, or one sentence per problem (not JSON, unknown keys, values
    of the wrong kind or out of range)."""
    try:
        raw = json.loads(data.decode("utf-8"))
    except UnicodeDecodeError:
        return None, [f"{name} is not UTF-8 text"]
    except json.JSONDecodeError as exc:
        return None, [f"{name} is not JSON: {exc.msg} at line {exc.lineno}, column {exc.colno}"]
    except RecursionError:
        return None, [f"{name} is nested too deep to be a mission (lists or objects inside each other)"]
    except ValueError:  # Python's bound on an integer's digits (sys.get_int_max_str_digits)
        return None, [f"{name} holds an integer with too many digits"]
    if not isinstance(raw, dict):
        return None, [f"{name} holds {type(raw).__name__ if raw is not None else 'null'}, not a JSON object"]
    try:
        return model.model_validate(raw), []
    except ValidationError as exc:
        keys = list(model.model_fields)
        errors = exc.errors()
        more = [f"and {len(errors) - MAX_PROBLEMS} more problems"] if len(errors) > MAX_PROBLEMS else []
        return None, [_sentence(error, keys) for error in errors[:MAX_PROBLEMS]] + more


class BoxSpec(BaseModel):
    """A physical box of a mission's world: centre and size (m), axis-aligned; height and colour
    for the camera."""

    model_config = ConfigDict(extra="forbid")
    x: float = Field(ge=-MAX_COORDINATE_M, le=MAX_COORDINATE_M, allow_inf_nan=False)
    y: float = Field(ge=-MAX_COORDINATE_M, le=MAX_COORDINATE_M, allow_inf_nan=False)
    sx: float = Field(gt=0.0, le=100.0, allow_inf_nan=False)
    sy: float = Field(gt=0.0, le=100.0, allow_inf_nan=False)
    height: float = Field(0.3, gt=0.0, le=10.0, allow_inf_nan=False)
    colour: str = Field("#b8742f", pattern=r"^#[0-9a-fA-F]{6}$")
    id: str | None = Field(None, min_length=1, max_length=100)

    def box(self) -> Box:
        return Box(self.x, self.y, self.sx, self.sy, self.height, self.colour, self.id)


class WorldSpec(BaseModel):
    """A mission's physical world beyond the map's walls (issue 14): boxes the cart cannot pass and
    the camera sees, not on the map unless also listed in "obstacles"."""

    model_config = ConfigDict(extra="forbid")
    boxes: list[BoxSpec] = Field(default_factory=list, max_length=10_000)


def world_problems(start: tuple[float, float, float], world: WorldSpec | None) -> list[str]:
    """The start must leave the cart's footprint clear of every box."""
    if world is None:
        return []
    r, (x, y, _) = footprint_radius_m(), start
    problems = []
    for k, b in enumerate(world.boxes):
        dx, dy = max(abs(x - b.x) - b.sx / 2, 0.0), max(abs(y - b.y) - b.sy / 2, 0.0)
        if math.hypot(dx, dy) < r:
            problems.append(
                f"world.boxes[{k}] at ({b.x:g}, {b.y:g}) is under the cart's footprint at the start"
            )
    return problems


def perception_on(perception: bool | None, has_world: bool) -> bool:
    """A mission's "perception" (the simulated camera and the gateway's perception): as given,
    else on exactly when the mission has a physical world to see (issue 14)."""
    return has_world if perception is None else perception


def settings_problems(settings: dict[str, float]) -> list[str]:
    """One sentence per firmware setting that does not exist or whose value is out of its range."""
    table = {entry["name"]: entry for entry in settings_table()}
    problems = []
    for name, value in settings.items():
        entry = table.get(name)
        if entry is None:
            problems.append(
                f"settings: unknown firmware setting {quoted(name)} (config/robot.toml lists them)"
            )
        elif not entry["min"] <= value <= entry["max"]:
            unit = f" {entry['unit']}" if entry["unit"] else ""
            low, high = entry["min"], entry["max"]
            problems.append(f"settings.{name}: {value:g} is out of its range, from {low:g} to {high:g}{unit}")
    return problems


def map_problems(
    grid: Grid, start: tuple[float, float, float], obstacles: list[tuple[float, float]]
) -> list[str]:
    """The start must leave the cart's footprint inside the arena's walls; obstacles must be on
    the map."""
    problems = []
    margin = float(robot()["sim"]["arena_margin_m"])
    width, height = grid.size_m
    r = footprint_radius_m()
    x, y, _ = start
    low, x_high, y_high = r - margin, width + margin - r, height + margin - r
    if not (low <= x <= x_high and low <= y <= y_high):
        problems.append(
            f"start ({x:g}, {y:g}) puts the cart ({r:g} m around its centre) into the arena's walls: "
            f"x from {low:g} to {x_high:g} m, y from {low:g} to {y_high:g} m"
        )
    for k, (ox, oy) in enumerate(obstacles):
        try:
            grid.nearest_node(ox, oy)
        except PlanError as exc:
            problems.append(f"obstacles[{k}]: {exc}")
    return problems


def faults_problems(faults: dict[str, float]) -> list[str]:
    return [f"faults: {p}" for p in fault_table.problems(dict(faults))]


def report_problems(report: Path, mission: Path) -> list[str]:
    """Whether the report can be written where asked, checked before the mission runs."""
    folder = report.parent
    if report.resolve() == mission.resolve():
        return [f"the report {report} would overwrite the mission file: choose another --report"]
    if not folder.is_dir():
        return [f"the report's folder {folder} does not exist: create it, or choose another --report"]
    if report.is_dir():
        return [f"the report {report} is a folder: give a file name with --report"]
    try:  # a file made and removed again: permissions, a read-only file system, root's too
        with tempfile.NamedTemporaryFile(dir=folder, prefix=".cart2d-report-"):
            pass
        if report.exists() and not os.access(report, os.W_OK):
            raise PermissionError(errno.EACCES, "permission denied")
    except OSError as exc:
        return [f"the report {report} cannot be written ({exc.strerror or exc}): choose another --report"]
    return []


def finite(value: Any) -> Any:
    """`value` with every float that is not finite replaced by None (JSON has no NaN)."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {key: finite(v) for key, v in value.items()}
    if isinstance(value, list | tuple):
        return [finite(v) for v in value]
    return value


def write_report(path: Path, report: dict[str, Any]) -> None:
    """The report as JSON for people: no NaN, no float noise (for_people)."""
    text = json.dumps(for_people(finite(report)), indent=2, allow_nan=False)
    path.write_text(text + "\n", encoding="utf-8")


def read_problems(path: Path) -> tuple[bytes | None, list[str]]:
    """The mission file's bytes, or why it cannot be read."""
    try:
        return read_regular(path, MAX_FILE_BYTES), []
    except ValueError:  # a NUL in the name
        return None, [f"the mission file {quoted(str(path))} cannot be read: its name holds a NUL"]
    except FileNotFoundError:
        return None, [f"there is no mission file {path}"]
    except IsADirectoryError:
        return None, [f"{path} is a folder, not a mission file"]
    except OSError as exc:
        return None, [f"the mission file {path} cannot be read: {exc.strerror or exc}"]

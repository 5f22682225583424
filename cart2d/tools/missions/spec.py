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
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from cart2d.files import read_regular
from cart2d.params import footprint_radius_m, robot, settings_table
from cart2d.planning import Grid, PlanError
from cart2d.shown import for_people, quoted
from cart2d.simulation import faults as fault_table
from cart2d.simulation.world_file import MAX_FILE_BYTES, WorldSpec
from cart2d.store import PlanningStep
from cart2d.tools.missions.events import MapEvent

Coordinate = Annotated[float, Field(allow_inf_nan=False)]
Finite = Annotated[float, Field(allow_inf_nan=False)]


class GridSpec(BaseModel):
    model_config = ConfigDict(extra="forbid")
    cols: int = Field(10, ge=2, le=1000)
    rows: int = Field(10, ge=2, le=1000)
    step: float = Field(0.2, ge=0.01, le=10.0, allow_inf_nan=False)


class MissionSpec(BaseModel):
    model_config = ConfigDict(extra="forbid")
    grid: GridSpec = Field(default_factory=GridSpec)
    map: str | None = Field(
        None,
        min_length=1,
        max_length=4096,
        description="a ROS map_server .yaml (relative to the mission file), in place of 'grid'",
    )
    unknown_is_free: bool = Field(False, description="with 'map': plan through unknown cells")
    planning_step: PlanningStep | None = Field(None, description="with 'map': the planning grid's step, m")
    events: list[MapEvent] = Field(
        default_factory=list,
        max_length=1000,
        description="map changes at simulated times: obstacles added and removed (physical in the simulator)",
    )
    obstacles: list[tuple[Coordinate, Coordinate]] = Field(default_factory=list)
    start: tuple[Coordinate, Coordinate, Coordinate] = (0.0, 0.0, 0.0)
    goals: list[tuple[Coordinate, Coordinate]] = Field(min_length=1, max_length=1000)
    settings: dict[str, Finite] = Field(default_factory=dict, description="firmware settings by name")
    faults: dict[str, Finite] = Field(default_factory=dict, description="simulator faults (sim/README.md)")
    timeout_s: float = Field(120.0, gt=0.0, le=1e5, allow_inf_nan=False, description="simulated seconds")
    behaviour: Literal["cart2d", "seed"] = Field(
        "cart2d",
        description="'seed': the seed's planner and settings (cart2d/planning/baseline.py), "
        "to compare against",
    )
    resets_at_s: list[float] = Field(
        default_factory=list,
        max_length=100,
        description="simulated seconds after the first goal's start at which the MCU is reset (reset button)",
    )
    world: WorldSpec | None = Field(None, description="physical boxes the map does not show")
    perception: bool | None = Field(
        None, description="the simulated camera and perception (default: on when the mission has a world)"
    )
    lockstep: bool = Field(
        True,
        description="with perception: the simulator waits while perception is behind "
        "(cart2d/simulation/lockstep.py); false: it drives on, as a cart behind a slow gateway would",
    )

    @model_validator(mode="after")
    def map_or_grid(self) -> MissionSpec:
        if self.map is not None and "grid" in self.model_fields_set:
            raise ValueError("give 'map' or 'grid', not both")
        if self.map is not None and self.behaviour == "seed":
            raise ValueError("the seed's behaviour plans on a node grid only: give 'grid', not 'map'")
        return self

    @field_validator("resets_at_s")
    @classmethod
    def finite_times(cls, times: list[float]) -> list[float]:
        if not all(math.isfinite(t) and t >= 0.0 for t in times):
            raise ValueError("reset times must be finite and not negative")
        return sorted(times)


def default_report_path(mission: Path) -> Path:
    """MISSION.report.json beside MISSION.json."""
    return mission.with_name(f"{mission.stem if mission.suffix == '.json' else mission.name}.report.json")


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

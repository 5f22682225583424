"""The simulated world's file (`cart2d sim --world FILE.json`, a mission's "world", PUT
/api/sim/boxes' boxes) and the JSON-file parser missions share with it: one sentence per problem
(not JSON, unknown keys, values of the wrong kind or out of range)."""

from __future__ import annotations

import json
import math
from typing import Any, Literal, TypeVar

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from cart2d.maps.world import Box
from cart2d.params import footprint_radius_m
from cart2d.shown import clipped, quoted
from cart2d.simulation.look import LookSpec

Model = TypeVar("Model", bound=BaseModel)
MAX_COORDINATE_M = 1e5  # what the simulator takes (sim/src/world_change.cpp, kMaxCoordinateM)
MAX_PROBLEMS = 20  # a file's problems listed, then how many more
MAX_FILE_BYTES = 16 * 1024 * 1024  # a mission or world file: 10 000 boxes take about 1 MB


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
    material: Literal["wall"] | None = Field(None, description="wall: the look's wall paint and skirting")

    def box(self) -> Box:
        return Box(self.x, self.y, self.sx, self.sy, self.height, self.colour, self.id, self.material)


class WorldSpec(BaseModel):
    """A mission's physical world beyond the map's walls (issue 14): boxes the cart cannot pass and
    the camera sees, not on the map unless also listed in "obstacles"."""

    model_config = ConfigDict(extra="forbid")
    boxes: list[BoxSpec] = Field(default_factory=list, max_length=10_000)
    # How the world looks to the camera (issue 24): floor material, wall paint, lamps, the camera's
    # effects (cart2d/simulation/look.py; sim/README.md, "The look").
    look: LookSpec | None = Field(None, description="materials, lights, camera effects")


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

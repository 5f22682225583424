"""The robot parameters of config/robot.toml (the same file the firmware and the simulator
are built from), read once."""

from __future__ import annotations

import tomllib
from functools import cache
from importlib import resources
from typing import Any


@cache
def robot() -> dict[str, Any]:
    text = resources.files("cart2d").joinpath("data/robot.toml").read_text(encoding="utf-8")
    return tomllib.loads(text)


def settings_table() -> list[dict[str, Any]]:
    """The firmware settings: stable id, name, unit, min, max, default, doc."""
    table: list[dict[str, Any]] = robot()["setting"]
    return table


def setting_id(name: str) -> int:
    """The stable id of the firmware setting `name`; ValueError if there is none."""
    for entry in settings_table():
        if entry["name"] == name:
            return int(entry["id"])
    raise ValueError(f"unknown firmware setting {name!r} (config/robot.toml lists them)")


def footprint_radius_m() -> float:
    return float(robot()["body"]["footprint_radius_m"])


def planning_radius_m() -> float:
    """The disc the planner keeps clear of obstacles: the footprint plus the clearance that
    absorbs the path-following error."""
    body = robot()["body"]
    return float(body["footprint_radius_m"]) + float(body["clearance_m"])

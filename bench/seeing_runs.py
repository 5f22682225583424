"""Missions that see, for the perception benches (bench/perception_missions.py's unknown arenas,
bench/hard_rooms.py's rooms): a mission with its boxes unknown run beside the same mission on the
known map, and how well perception mapped the boxes (the measures are described in
bench/perception_missions.py's docstring)."""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from bench.missions import run_one
from bench.perception_sim import FLOOR_BOARDS, HELD
from cart2d.gateway.live_map import arena
from cart2d.perception.calibration import save_calibration
from cart2d.perception.camera_model import FloatArray, Mount
from cart2d.perception.detection import DetectorConfig
from cart2d.tools.camera_calibration.simulated import calibrate_in_simulator, sim_options
from cart2d.tools.camera_calibration.views import SIM_VIEWS
from cart2d.tools.missions.run import mission_map, run_mission
from cart2d.tools.missions.spec import MissionSpec

RECALL_RANGE_M = DetectorConfig().max_range_m
FALSE_MARGIN_M = 0.1

Rect = tuple[float, float, float, float]  # centre x, y and half sizes
Mask = npt.NDArray[np.bool_]


def _rects(boxes: list[dict[str, Any]], grow_m: float = 0.0) -> list[Rect]:
    return [(b["x"], b["y"], b["sx"] / 2 + grow_m, b["sy"] / 2 + grow_m) for b in boxes]


def _overlaps(cells: FloatArray, half: float, rects: list[Rect]) -> Mask:
    """Whether each cell's square (centre, half side) overlaps one of the rectangles (not touching)."""
    hit = np.zeros(len(cells), dtype=bool)
    for x, y, hx, hy in rects:
        hit |= (np.abs(cells[:, 0] - x) < hx + half - 1e-6) & (np.abs(cells[:, 1] - y) < hy + half - 1e-6)
    return hit


def _beyond_walls(cells: FloatArray, half: float, walls: dict[str, float]) -> Mask:
    out: Mask = (
        (cells[:, 0] - half < walls["x_min"] - 1e-6)
        | (cells[:, 0] + half > walls["x_max"] + 1e-6)
        | (cells[:, 1] - half < walls["y_min"] - 1e-6)
        | (cells[:, 1] + half > walls["y_max"] + 1e-6)
    )
    return out


def _distance_to_obstacles(cells: FloatArray, rects: list[Rect], walls: dict[str, float]) -> FloatArray:
    """Each point's distance to the nearest box or to the region beyond the walls."""
    x, y = cells[:, 0], cells[:, 1]
    inside = np.minimum.reduce(
        [x - walls["x_min"], walls["x_max"] - x, y - walls["y_min"], walls["y_max"] - y]
    )
    best = np.maximum(inside, 0.0)
    for bx, by, hx, hy in rects:
        dx = np.maximum(np.abs(x - bx) - hx, 0.0)
        dy = np.maximum(np.abs(y - by) - hy, 0.0)
        best = np.minimum(best, np.hypot(dx, dy))
    return np.asarray(best, dtype=np.float64)


def face_cells(
    boxes: list[dict[str, Any]], walls: dict[str, float], r: float
) -> list[tuple[FloatArray, FloatArray]]:
    """(cell centres N x 2, outward normal) of each box face not against another box or a wall."""
    rects = _rects(boxes)
    faces = []
    for x, y, hx, hy in rects:
        for normal, half_along, along_axis in (
            ((1.0, 0.0), hy, 1),
            ((-1.0, 0.0), hy, 1),
            ((0.0, 1.0), hx, 0),
            ((0.0, -1.0), hx, 0),
        ):
            n = np.array(normal)
            k = max(1, round(2 * half_along / r))
            offsets = -half_along + r / 2 + r * np.arange(k)
            depth = (hx if along_axis == 1 else hy) - r / 2
            centres = np.tile([x, y], (k, 1)) + n * depth
            centres[:, along_axis] += offsets
            beyond = centres + n * r
            against = _overlaps(beyond, r / 4, rects) | _beyond_walls(beyond, r / 4, walls)
            if (~against).any():
                faces.append((centres[~against], n))
    return faces


def mapping_quality(
    cells_xyp: list[list[float]],
    resolution_m: float,
    boxes: list[dict[str, Any]],
    walls: dict[str, float],
    trace_xy: FloatArray,
) -> dict[str, Any]:
    cells = np.array([c[:2] for c in cells_xyp], dtype=float).reshape(-1, 2)
    half = resolution_m / 2
    wall_cells = _beyond_walls(cells, half, walls)
    on_box = _overlaps(cells, half, _rects(boxes))
    on_grown = _overlaps(cells, half, _rects(boxes, resolution_m))
    n = len(cells)
    false = _distance_to_obstacles(cells, _rects(boxes), walls) > FALSE_MARGIN_M
    visible, found = 0, 0
    trace = trace_xy[:: max(1, len(trace_xy) // 400)]
    for centres, normal in face_cells(boxes, walls, resolution_m):
        face_points = centres + normal * half
        for centre, face_point in zip(centres, face_points, strict=True):
            ahead = (trace - face_point) @ normal > 0
            near = np.hypot(*(trace - centre).T) <= RECALL_RANGE_M
            if not (ahead & near).any():
                continue
            visible += 1
            if n and (np.max(np.abs(cells - centre), axis=1) <= resolution_m + 1e-6).any():
                found += 1
    return {
        "cells": n,
        "wall_cells": int(wall_cells.sum()),
        "precision": float((on_box | wall_cells).sum() / n) if n else None,
        "precision_cell": float((on_grown | wall_cells).sum() / n) if n else None,
        "visible_box_cells": visible,
        "found_box_cells": found,
        "recall": found / visible if visible else None,
        "false_cells": int(false.sum()),
    }


def calibration_file(directory: Path, mount: Mount) -> tuple[Path, float]:
    """The calibration made once in the simulator, saved; and how long it took (s)."""
    start = time.perf_counter()
    result = calibrate_in_simulator(
        HELD, next(iter(FLOOR_BOARDS.values())), SIM_VIEWS, mount, sim_options(seed=1), say=lambda _: None
    )
    return save_calibration(result, directory / "camera_calibration.json"), time.perf_counter() - start


def see(mission: dict[str, Any], calibration: Path, seed: int) -> dict[str, Any]:
    """The mission run with the simulated camera and perception, seeing with `calibration`."""
    return run_mission(
        MissionSpec.model_validate_json(json.dumps(mission)), seed=seed, camera_calibration=calibration
    )


def first_goal(report: dict[str, Any]) -> dict[str, Any]:
    goals = report.get("goals") or [{}]
    return dict(goals[0])


def waited(report: dict[str, Any]) -> float | None:
    """The wall seconds the simulator waited for perception (the lockstep's report)."""
    lockstep = (report.get("perception") or {}).get("lockstep") or {}
    waited: float | None = lockstep.get("perception_wait_s")
    return waited


@dataclass(frozen=True)
class PairedRun:
    """One mission with its boxes unknown (`unknown`, seeing) and on the known map (`known`)."""

    unknown: dict[str, Any]
    known: dict[str, Any]
    goal: dict[str, Any]  # the unknown run's first goal
    known_goal: dict[str, Any]
    trace: FloatArray  # the unknown run's driven trace (ground truth), N x 2
    mapping: dict[str, Any]

    def row(self) -> dict[str, Any]:
        """The figures both benches report of a paired run."""
        g, k, unknown = self.goal, self.known_goal, self.unknown
        reached = bool(g.get("reached")) and bool(k.get("reached"))
        # from the request: the look before driving off counts, and so does the known map's planning
        ratio = (g["start_s"] + g["time_s"]) / (k["start_s"] + k["time_s"]) if reached else None
        return {
            "reached": bool(g.get("reached")),
            "reason": g.get("reason", unknown.get("error", "")),
            "known_reached": bool(k.get("reached")),
            "collisions": unknown.get("collisions"),
            "box_contacts": unknown.get("box_contacts"),
            "time_s": g.get("time_s"),
            "start_s": g.get("start_s"),
            "known_time_s": k.get("time_s"),
            "known_start_s": k.get("start_s"),
            "time_ratio": ratio,
            "frames": unknown.get("perception", {}).get("frames", 0),
            "perception_wait_s": waited(unknown),
            "real_time_factor": unknown.get("real_time_factor"),
            "mapping": self.mapping,
        }


def paired_run(
    unknown_mission: dict[str, Any],
    known_mission: dict[str, Any],
    boxes: list[dict[str, Any]],
    calibration: Path,
    seed: int,
) -> PairedRun:
    """Both runs with the same simulator seed, and the unknown run's mapping of `boxes`."""
    unknown = see(unknown_mission, calibration, seed)
    known = run_one(known_mission, seed=seed)
    goal = first_goal(unknown)
    walls = arena(mission_map(MissionSpec.model_validate_json(json.dumps(unknown_mission))))
    trace = np.array([p[1:] for p in goal.get("trace", [])], dtype=float).reshape(-1, 2)
    perception = unknown.get("perception", {})
    quality = mapping_quality(
        perception.get("cells", []), perception.get("resolution_m", 0.05), boxes, walls, trace
    )
    return PairedRun(unknown, known, goal, first_goal(known), trace, quality)

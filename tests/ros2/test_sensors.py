"""The map, the perceived layer, the virtual scan, the camera's info and the diagnostics as ROS 2
messages (cart2d/ros2/grids.py, sensors.py): pure functions of the gateway's views."""

from __future__ import annotations

import logging
import math

import numpy as np
import pytest

from cart2d.maps.occupancy import OccupancyMap
from cart2d.perception.camera_model import Intrinsics
from cart2d.ros2 import grids, sensors
from cart2d.ros2 import types as t
from cart2d.ros2.names import Ros2Options

WHEN = t.Time(5, 0)
ARENA = {"x_min": -0.25, "y_min": -0.25, "x_max": 2.05, "y_max": 2.05}
VIEW = {"arena": ARENA, "obstacles": [[1.0, 1.0]], "step_m": 0.2}


def cell(grid: t.OccupancyGrid, x: float, y: float) -> int:
    info = grid.info
    i = math.floor((x - info.origin.position.x) / info.resolution)
    j = math.floor((y - info.origin.position.y) / info.resolution)
    return int(np.frombuffer(bytes(grid.data), dtype=np.int8)[j * info.width + i])


def test_the_map_without_a_floor_plan_is_the_arena_walled_with_the_users_obstacles() -> None:
    grid = grids.map_grid(Ros2Options(), WHEN, VIEW, None)
    assert grid.header.frame_id == "map" and grid.info.resolution == pytest.approx(0.05)
    assert len(grid.data) == grid.info.width * grid.info.height == 46 * 46
    assert cell(grid, -0.24, 0.5) == 100  # the wall
    assert cell(grid, 1.0, 1.0) == 100 and cell(grid, 1.09, 0.91) == 100  # the obstacle's square
    assert cell(grid, 0.5, 0.5) == 0 and cell(grid, 1.15, 1.0) == 0


def test_the_map_with_a_floor_plan_keeps_its_cells() -> None:
    cells = np.zeros((20, 30), dtype=np.int8)
    cells[0, :] = -1
    plan = OccupancyMap((-0.5, -0.25), 0.1, cells)
    grid = grids.map_grid(Ros2Options(), WHEN, {**VIEW, "obstacles": []}, plan)
    assert (grid.info.width, grid.info.height) == (30, 20)
    assert (grid.info.origin.position.x, grid.info.origin.position.y) == (-0.5, -0.25)
    assert cell(grid, 0.0, -0.2) == -1 and cell(grid, 0.0, 0.5) == 0


def test_the_perceived_layer_is_unknown_but_where_the_camera_saw() -> None:
    grid = grids.perceived_grid(
        Ros2Options(), WHEN, VIEW, {"resolution": 0.05, "cells": [[1.025, 0.525, 0.8]]}
    )
    assert cell(grid, 1.02, 0.52) == 80 and cell(grid, 0.5, 0.5) == -1


def test_the_virtual_scan_has_a_hit_ahead_at_its_bearing_and_range() -> None:
    # the cart at (0.5, 0.5) facing +y; a hit 0.6 m ahead, 0.1 m to its left (-x)
    camera = {"t": 1.0, "fov": [[0.2, 1.4], [0.8, 1.4], [0.6, 0.7], [0.4, 0.7]], "hits": [[0.4, 1.1]]}
    scan = sensors.virtual_scan(Ros2Options(namespace="/cart1"), WHEN, camera, (0.5, 0.5, math.pi / 2))
    assert scan.header.frame_id == "cart1/camera_link"
    hit = [k for k, r in enumerate(scan.ranges) if math.isfinite(r)]
    assert len(hit) == 1
    bearing = scan.angle_min + hit[0] * scan.angle_increment
    assert bearing == pytest.approx(math.atan2(0.1, 0.6), abs=math.radians(0.6))
    assert scan.ranges[hit[0]] == pytest.approx(math.hypot(0.1, 0.6))
    assert scan.range_max == pytest.approx(math.hypot(0.3, 0.9))
    assert scan.angle_min == pytest.approx(-math.radians(27.5), abs=0.01)


def test_camera_info_is_the_calibrations_pinhole() -> None:
    lens = Intrinsics(320, 240, 300.0, 301.0, 160.0, 120.0, (-0.1, 0.02, 0.0, 0.0, 0.0))
    info = sensors.camera_info(Ros2Options(), WHEN, lens)
    assert (info.width, info.height, info.distortion_model) == (320, 240, "plumb_bob")
    assert list(info.k) == [300.0, 0.0, 160.0, 0.0, 301.0, 120.0, 0.0, 0.0, 1.0]
    assert list(info.d) == [-0.1, 0.02, 0.0, 0.0, 0.0]
    assert info.header.frame_id == "camera_optical_frame"
    nominal = sensors.camera_info(Ros2Options(), WHEN, None)
    assert nominal.k[0] == pytest.approx(160 / math.tan(math.radians(27.5)))


def test_diagnostics_warn_of_a_bumper_and_an_unexpected_restart() -> None:
    tel = {"mode_name": "IDLE", "flag_names": ["BUMPER"], "tick": 7}
    reset = {"expected": False, "cause_words": "the watchdog", "time": "2026-11-28T12:00:00Z"}
    array = sensors.diagnostics(WHEN, tel, [reset], link_up=True)
    levels = {s.name: s.level for s in array.status}
    assert levels == {"cart2d: firmware": 1, "cart2d: link": 0, "cart2d: restarts": 1}


def test_a_log_record_is_a_rosout_line() -> None:
    record = logging.LogRecord(
        "cart2d.gateway", logging.WARNING, "core.py", 12, "stopped: %s", ("why",), None
    )
    line = sensors.log_line(WHEN, record)
    assert (line.level, line.name, line.msg, line.line) == (30, "cart2d.gateway", "stopped: why", 12)

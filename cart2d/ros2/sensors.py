"""The camera as ROS 2 sensors: its hits as a virtual LaserScan in camera_link (Nav2's obstacle
layer and slam_toolbox read scans), its frames as CompressedImage with their CameraInfo; the
cart's health as diagnostics; the gateway's log lines as rosout."""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping, Sequence
from typing import Any

from cart2d.perception.camera_model import Intrinsics, Mount
from cart2d.ros2 import types as t
from cart2d.ros2.frames import geometry
from cart2d.ros2.names import Ros2Options

SCAN_STEP_RAD = math.radians(1.0)
SCAN_RANGE_MIN_M = 0.05
CAMERA_HZ = 15.0  # the simulated camera's frame rate (robot.toml [sim.camera] fps): the scan's period
# Firmware flags that need a look (docs/protocol.md): a warning on the diagnostics' firmware line.
WARNING_FLAGS = frozenset(
    {"SWITCH_LEFT", "SWITCH_RIGHT", "ROUTINE_FAILED", "SETTINGS_DEFAULTED", "STALLED", "BUMPER", "STARVED"}
)
ROS_LEVELS = {
    logging.DEBUG: 10,
    logging.INFO: 20,
    logging.WARNING: 30,
    logging.ERROR: 40,
    logging.CRITICAL: 50,
}


def camera_in_map(pose: Sequence[float]) -> tuple[float, float, float]:
    """camera_link's x, y and heading in the map for the cart's pose (x, y, theta)."""
    x, y, theta = pose
    cx, cy, _ = geometry()["camera_xyz"]
    return (
        x + cx * math.cos(theta) - cy * math.sin(theta),
        y + cx * math.sin(theta) + cy * math.cos(theta),
        theta,
    )


def virtual_scan(
    options: Ros2Options, when: t.Time, camera: Mapping[str, Any], pose: Sequence[float]
) -> t.LaserScan:
    """The camera's hits (obstacle bases, map m) seen from camera_link at the cart's pose, the
    nearest in each degree of its field of view; +inf where it saw the floor (REP 117), its
    range the farthest point of its view on the floor."""
    half_fov = math.radians(Mount.from_robot().hfov_deg) / 2
    x0, y0, heading = camera_in_map(pose)
    bins = round(2 * half_fov / SCAN_STEP_RAD) + 1
    ranges = [math.inf] * bins
    reach = [math.hypot(px - x0, py - y0) for px, py in camera["fov"]]
    range_max = max(reach, default=2.0)
    for hx, hy in camera["hits"]:
        bearing = math.remainder(math.atan2(hy - y0, hx - x0) - heading, math.tau)
        k = round((bearing + half_fov) / SCAN_STEP_RAD)
        distance = math.hypot(hx - x0, hy - y0)
        if 0 <= k < bins and SCAN_RANGE_MIN_M <= distance <= range_max:
            ranges[k] = min(ranges[k], distance)
    return t.LaserScan(
        header=t.Header(when, options.frame("camera_link")),
        angle_min=-half_fov,
        angle_max=-half_fov + (bins - 1) * SCAN_STEP_RAD,
        angle_increment=SCAN_STEP_RAD,
        time_increment=0.0,
        scan_time=1.0 / CAMERA_HZ,
        range_min=SCAN_RANGE_MIN_M,
        range_max=range_max,
        ranges=ranges,
        intensities=[],
    )


def camera_info(options: Ros2Options, when: t.Time, intrinsics: Intrinsics | None) -> t.CameraInfo:
    """The calibration's pinhole and distortion (plumb_bob: k1, k2, p1, p2, k3), else the stock lens's."""
    k = intrinsics or Intrinsics.nominal()
    d = [*k.dist, 0.0, 0.0, 0.0, 0.0, 0.0][:5]
    return t.CameraInfo(
        header=t.Header(when, options.frame("camera_optical_frame")),
        height=k.height,
        width=k.width,
        distortion_model="plumb_bob",
        d=d,
        k=[k.fx, 0.0, k.cx, 0.0, k.fy, k.cy, 0.0, 0.0, 1.0],
        r=[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        p=[k.fx, 0.0, k.cx, 0.0, 0.0, k.fy, k.cy, 0.0, 0.0, 0.0, 1.0, 0.0],
    )


def compressed_image(options: Ros2Options, when: t.Time, jpeg: bytes) -> t.CompressedImage:
    return t.CompressedImage(t.Header(when, options.frame("camera_optical_frame")), "jpeg", jpeg)


def _status(name: str, level: int, message: str, values: Mapping[str, Any]) -> t.DiagnosticStatus:
    return t.DiagnosticStatus(
        level=level,
        name=f"cart2d: {name}",
        message=message,
        hardware_id="cart2d",
        values=[t.KeyValue(str(key), str(value)) for key, value in values.items()],
    )


def diagnostics(
    when: t.Time, tel: Mapping[str, Any], resets: Sequence[Mapping[str, Any]], link_up: bool
) -> t.DiagnosticArray:
    """The firmware (mode, flags), the link (telemetry flowing) and the restarts seen."""
    flags = list(tel.get("flag_names", []))
    worrying = sorted(WARNING_FLAGS.intersection(flags))
    firmware = _status(
        "firmware",
        1 if worrying else 0,
        f"{tel.get('mode_name', '?')}" + (f": {', '.join(worrying)}" if worrying else ""),
        {"mode": tel.get("mode_name", "?"), "flags": " ".join(flags), "tick": tel.get("tick", "?")},
    )
    link = _status("link", 0 if link_up else 2, "telemetry flowing" if link_up else "no telemetry", {})
    last = resets[-1] if resets else None
    restarts = _status(
        "restarts",
        1 if last is not None and not last.get("expected", False) else 0,
        str(last.get("cause_words", "")) if last else "none seen",
        {"seen": len(resets), "last": last.get("time", "") if last else ""},
    )
    return t.DiagnosticArray(t.Header(when, ""), [firmware, link, restarts])


def log_line(when: t.Time, record: logging.LogRecord) -> t.Log:
    return t.Log(
        stamp=when,
        level=ROS_LEVELS.get(record.levelno, 20),
        name=record.name,
        msg=record.getMessage(),
        file=record.pathname,
        function=record.funcName,
        line=record.lineno,
    )

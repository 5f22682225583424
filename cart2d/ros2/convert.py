"""The gateway's /ws messages (gateway/messages.py, as dicts) as ROS 2 messages: pure functions
of the message, the bridge's options and a stamp."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from cart2d.ros2 import types as t
from cart2d.ros2.frames import LEFT_JOINT, RIGHT_JOINT, geometry, rpy_quaternion, transform, wheel_transforms
from cart2d.ros2.names import Ros2Options

TICK_HZ = 125.0  # the firmware's control ticks, which telemetry counts (robot.toml [control] tick_hz)
# Odometry's covariances (diagonal): measured wheels are good to a few mm over a metre (UMBmark);
# z, roll and pitch do not move (a large variance: ROS's convention for "not measured").
POSE_VARIANCES = (1e-4, 1e-4, 1e6, 1e6, 1e6, 1e-3)
TWIST_VARIANCES = (1e-4, 1e-4, 1e6, 1e6, 1e6, 1e-3)


def _diagonal(variances: Sequence[float]) -> list[float]:
    out = [0.0] * 36
    for i, v in enumerate(variances):
        out[i * 7] = v
    return out


def odometry(options: Ros2Options, when: t.Time, tel: Mapping[str, Any]) -> t.Odometry:
    x, y, theta = float(tel["x"]), float(tel["y"]), float(tel["theta"])
    return t.Odometry(
        header=t.Header(when, options.frame("odom")),
        child_frame_id=options.frame("base_footprint"),
        pose=t.PoseWithCovariance(
            t.Pose(t.Point(x, y, 0.0), rpy_quaternion(0.0, 0.0, theta)), _diagonal(POSE_VARIANCES)
        ),
        twist=t.TwistWithCovariance(
            t.Twist(t.Vector3(float(tel["v"]), 0.0, 0.0), t.Vector3(0.0, 0.0, float(tel["omega"]))),
            _diagonal(TWIST_VARIANCES),
        ),
    )


@dataclass
class WheelAngles:
    """The measuring wheels' angles, integrated from telemetry's wheel speeds over its ticks
    (telemetry carries the speeds, not the counts)."""

    left_rad: float = 0.0
    right_rad: float = 0.0
    last_tick: int | None = None

    def update(self, tel: Mapping[str, Any]) -> None:
        tick = int(tel["tick"])
        if self.last_tick is not None and 0 < tick - self.last_tick < 10 * TICK_HZ:
            dt = (tick - self.last_tick) / TICK_HZ
            radius = geometry()["encoder_radius"]
            self.left_rad = math.remainder(self.left_rad + float(tel["v_left"]) * dt / radius, math.tau)
            self.right_rad = math.remainder(self.right_rad + float(tel["v_right"]) * dt / radius, math.tau)
        self.last_tick = tick


def joint_state(when: t.Time, angles: WheelAngles, tel: Mapping[str, Any]) -> t.JointState:
    radius = geometry()["encoder_radius"]
    return t.JointState(
        header=t.Header(when, ""),
        name=[LEFT_JOINT, RIGHT_JOINT],
        position=[angles.left_rad, angles.right_rad],
        velocity=[float(tel["v_left"]) / radius, float(tel["v_right"]) / radius],
        effort=[],
    )


def moving_transforms(
    options: Ros2Options,
    when: t.Time,
    tel: Mapping[str, Any],
    angles: WheelAngles,
    map_to_odom: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> t.TFMessage:
    """map -> odom (the pose filter's, cart2d/gateway/localisation.py; the identity without
    markers; left out for slam_toolbox or AMCL to publish), odom -> base_footprint, the wheels."""
    x, y, theta = float(tel["x"]), float(tel["y"]), float(tel["theta"])
    moving = [
        transform(options, when, "odom", "base_footprint", (x, y, 0.0), rpy_quaternion(0.0, 0.0, theta)),
        *wheel_transforms(options, when, angles.left_rad, angles.right_rad),
    ]
    if not options.base_only:
        mx, my, myaw = map_to_odom
        moving.insert(
            0, transform(options, when, "map", "odom", (mx, my, 0.0), rpy_quaternion(0.0, 0.0, myaw))
        )
    return t.TFMessage(moving)


# (x, y, yaw) of the filter's 3 x 3 covariance in ROS's 6 x 6 one of (x, y, z, roll, pitch, yaw)
_PLANAR = (0, 1, 5)


def pose_with_covariance(
    options: Ros2Options, when: t.Time, pose: Sequence[float], covariance: Sequence[float]
) -> t.PoseWithCovarianceStamped:
    """The cart's pose in map and its uncertainty (robot_localization's and AMCL's message); z,
    roll and pitch are fixed by the floor: their variances 0."""
    full = [0.0] * 36
    for i, row in enumerate(_PLANAR):
        for j, col in enumerate(_PLANAR):
            full[row * 6 + col] = float(covariance[i * 3 + j])
    x, y, theta = (float(v) for v in pose)
    return t.PoseWithCovarianceStamped(
        t.Header(when, options.frame("map")),
        t.PoseWithCovariance(t.Pose(t.Point(x, y, 0.0), rpy_quaternion(0.0, 0.0, theta)), full),
    )


def pose_stamped(options: Ros2Options, when: t.Time, x: float, y: float, theta: float = 0.0) -> t.PoseStamped:
    return t.PoseStamped(
        t.Header(when, options.frame("map")), t.Pose(t.Point(x, y, 0.0), rpy_quaternion(0.0, 0.0, theta))
    )


def path(options: Ros2Options, when: t.Time, plan: Mapping[str, Any] | None) -> t.Path:
    """The mission's plan (start and waypoints, map m), each pose facing the next; empty: none."""
    points: list[Sequence[float]] = []
    if plan is not None:
        points = [plan["start"], *plan["waypoints"]]
    poses = []
    for i, (x, y) in enumerate(points):
        nx, ny = points[min(i + 1, len(points) - 1)]
        heading = math.atan2(ny - y, nx - x) if (nx, ny) != (x, y) else 0.0
        poses.append(pose_stamped(options, when, float(x), float(y), heading))
    return t.Path(t.Header(when, options.frame("map")), poses)

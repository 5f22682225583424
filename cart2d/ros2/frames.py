"""The cart's frames (REP-103 axes, REP-105 names) from config/robot.toml, as ROS 2 transforms.

`odom` -> `base_footprint` is the firmware's odometry; `map` -> `odom` is the gateway's map
frame (identity: the odometry is the map's pose until localisation corrects it). Fixed:
`base_footprint` -> `base_link` at the traction wheels' axle height; `base_link` ->
`camera_link` at the lens, level (its x forward: the virtual scan's plane), -> `camera_optical_frame`
pitched down by the mount's pitch and turned to the optical convention (z forward, x right, y
down); the measuring wheels on their axle (their angle from the odometry, joint_states) and the
traction wheels and caster where robot.toml puts them."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from cart2d.params import robot
from cart2d.ros2 import types as t
from cart2d.ros2.names import Ros2Options

LEFT_JOINT, RIGHT_JOINT = "left_encoder_wheel_joint", "right_encoder_wheel_joint"


def stamp(seconds: float) -> t.Time:
    whole = math.floor(seconds)
    return t.Time(int(whole), min(round((seconds - whole) * 1e9), 999_999_999))


def rpy_quaternion(roll: float, pitch: float, yaw: float) -> t.Quaternion:
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return t.Quaternion(
        x=sr * cp * cy - cr * sp * sy,
        y=cr * sp * cy + sr * cp * sy,
        z=cr * cp * sy - sr * sp * cy,
        w=cr * cp * cy + sr * sp * sy,
    )


def yaw_of(q: t.Quaternion) -> float:
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


@dataclass(frozen=True)
class Fixed:
    """A fixed joint: parent, child, xyz (m), rpy (rad)."""

    parent: str
    child: str
    xyz: tuple[float, float, float]
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)


def geometry() -> dict[str, Any]:
    """The numbers of robot.toml the frames are made of."""
    r = robot()
    camera = r["camera"]
    return {
        "axle_z": float(r["traction"]["radius_m"]),
        "traction_radius": float(r["traction"]["radius_m"]),
        "traction_track": float(r["traction"]["track_m"]),
        "encoder_radius": float(r["encoders"]["radius_m"]),
        "encoder_track": float(r["encoders"]["track_m"]),
        "footprint_radius": float(r["body"]["footprint_radius_m"]),
        "caster_x": float(r["caster"]["swivel_x_m"]),
        "camera_xyz": (float(camera["mount_x_m"]), float(camera["mount_y_m"]), float(camera["height_m"])),
        "camera_pitch": math.radians(float(camera["pitch_deg"])),
    }


def fixed_joints() -> list[Fixed]:
    """The cart's fixed joints, unprefixed (the measuring wheels' are continuous: wheel_transforms)."""
    g = geometry()
    z = g["axle_z"]
    cx, cy, cz = g["camera_xyz"]
    half = g["traction_track"] / 2
    return [
        Fixed("base_footprint", "base_link", (0.0, 0.0, z)),
        Fixed("base_link", "camera_link", (cx, cy, cz - z)),
        # pitched down, then the optical axes: z forward, x right, y down
        Fixed("camera_link", "camera_optical_frame", (0.0, 0.0, 0.0), optical_rpy(g["camera_pitch"])),
        Fixed("base_link", "left_wheel", (0.0, half, 0.0)),
        Fixed("base_link", "right_wheel", (0.0, -half, 0.0)),
        Fixed("base_link", "caster", (g["caster_x"], 0.0, g["traction_radius"] / 2 - z)),
    ]


def optical_rpy(pitch: float) -> tuple[float, float, float]:
    """camera_link -> camera_optical_frame as fixed-axis roll, pitch, yaw: the optical axes (z
    forward, x right, y down) of a camera pitched down by `pitch`: roll -(pi/2 + pitch), yaw -pi/2."""
    return (-math.pi / 2 - pitch, 0.0, -math.pi / 2)


def transform(
    options: Ros2Options,
    when: t.Time,
    parent: str,
    child: str,
    xyz: tuple[float, float, float],
    rotation: t.Quaternion,
) -> t.TransformStamped:
    return t.TransformStamped(
        header=t.Header(when, options.frame(parent)),
        child_frame_id=options.frame(child),
        transform=t.Transform(t.Vector3(*xyz), rotation),
    )


def static_transforms(options: Ros2Options, when: t.Time) -> t.TFMessage:
    return t.TFMessage(
        [transform(options, when, j.parent, j.child, j.xyz, rpy_quaternion(*j.rpy)) for j in fixed_joints()]
    )


def wheel_transforms(
    options: Ros2Options, when: t.Time, left_rad: float, right_rad: float
) -> list[t.TransformStamped]:
    """base_link -> the measuring wheels, turned by their joint angles."""
    g = geometry()
    half, z = g["encoder_track"] / 2, g["encoder_radius"] - g["axle_z"]
    return [
        transform(
            options,
            when,
            "base_link",
            "left_encoder_wheel",
            (0.0, half, z),
            rpy_quaternion(0.0, left_rad, 0.0),
        ),
        transform(
            options,
            when,
            "base_link",
            "right_encoder_wheel",
            (0.0, -half, z),
            rpy_quaternion(0.0, right_rad, 0.0),
        ),
    ]

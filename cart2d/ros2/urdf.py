"""The cart's URDF for /robot_description, generated from config/robot.toml (frames.py's joints):
RViz's RobotModel draws it from the topic, its frames prefixed as robot_state_publisher's
frame_prefix would in a namespace."""

from __future__ import annotations

from xml.sax.saxutils import quoteattr

from cart2d.ros2.frames import LEFT_JOINT, RIGHT_JOINT, fixed_joints, geometry
from cart2d.ros2.names import Ros2Options

BODY_HEIGHT_M = 0.12  # drawn only: robot.toml has the footprint, not the body's height


def _xyz(values: tuple[float, float, float]) -> str:
    return " ".join(f"{v:.6g}" for v in values)


def _visual(shape: str, colour: str, rpy: str = "0 0 0") -> str:
    return (
        f'<visual><origin xyz="0 0 0" rpy="{rpy}"/><geometry>{shape}</geometry>'
        f'<material name="{colour}"/></visual>'
    )


def robot_description(options: Ros2Options) -> str:
    g = geometry()
    f = options.frame
    wheel = f'<cylinder radius="{g["traction_radius"]:.6g}" length="0.02"/>'
    encoder = f'<cylinder radius="{g["encoder_radius"]:.6g}" length="0.01"/>'
    sideways = "1.5708 0 0"
    shapes = {
        "base_link": _visual(
            f'<cylinder radius="{g["footprint_radius"]:.6g}" length="{BODY_HEIGHT_M}"/>', "body"
        ),
        "left_wheel": _visual(wheel, "tyre", sideways),
        "right_wheel": _visual(wheel, "tyre", sideways),
        "caster": _visual(f'<sphere radius="{g["traction_radius"] / 2:.6g}"/>', "tyre"),
        "camera_link": _visual('<box size="0.02 0.04 0.03"/>', "camera"),
        "left_encoder_wheel": _visual(encoder, "encoder", sideways),
        "right_encoder_wheel": _visual(encoder, "encoder", sideways),
    }
    links = ["base_footprint", "camera_optical_frame", *shapes]
    parts = [
        f"<robot name={quoteattr(options.namespace.strip('/') or 'cart2d')}>",
        '<material name="body"><color rgba="0.2 0.45 0.8 0.8"/></material>',
        '<material name="tyre"><color rgba="0.1 0.1 0.1 1"/></material>',
        '<material name="encoder"><color rgba="0.8 0.6 0.1 1"/></material>',
        '<material name="camera"><color rgba="0.9 0.9 0.9 1"/></material>',
    ]
    parts += [f"<link name={quoteattr(f(name))}>{shapes.get(name, '')}</link>" for name in links]
    for j in fixed_joints():
        parts.append(
            f'<joint name={quoteattr(f(j.child + "_joint"))} type="fixed">'
            f"<parent link={quoteattr(f(j.parent))}/>"
            f'<child link={quoteattr(f(j.child))}/><origin xyz="{_xyz(j.xyz)}" rpy="{_xyz(j.rpy)}"/></joint>'
        )
    half, z = g["encoder_track"] / 2, g["encoder_radius"] - g["axle_z"]
    for name, child, y in (
        (LEFT_JOINT, "left_encoder_wheel", half),
        (RIGHT_JOINT, "right_encoder_wheel", -half),
    ):
        parts.append(
            f'<joint name="{name}" type="continuous"><parent link={quoteattr(f("base_link"))}/>'
            f'<child link={quoteattr(f(child))}/><origin xyz="{_xyz((0.0, y, z))}" rpy="0 0 0"/>'
            '<axis xyz="0 1 0"/></joint>'
        )
    parts.append("</robot>")
    return "\n".join(parts)

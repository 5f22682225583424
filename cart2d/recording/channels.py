"""The channels a session publishes, their topics and how a gateway value becomes a message.

Frames follow REP-105: `map` (the arena's coordinates, the simulator's world) → `odom` (where
odometry starts; the identity, since the gateway has no correction of its own) → `base_link` (the
cart, from the odometry pose). The true pose of the simulator is given in `map`.

Two kinds of channel: the Foxglove SDK's built-in schemas (protobuf) for the Foxglove app and
Lichtblick, and `/cart2d/ws` (JSON, each /ws message as the panel gets it) plus `/cart2d/map_view`
(JSON, the /api/map answer) that `cart2d replay` reads back: they need nothing but `json` to decode.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import foxglove
from foxglove import channels as ch
from foxglove import messages as fm

MAP_FRAME = "map"
ODOM_FRAME = "odom"
BASE_FRAME = "base_link"
CAMERA_FRAME = "camera"

TOPIC_TF = "/tf"
TOPIC_ODOM_POSE = "/odom/pose"
TOPIC_TRUTH_POSE = "/truth/pose"
TOPIC_PLAN_SCENE = "/plan/scene"
TOPIC_PLAN_POSES = "/plan/poses"
TOPIC_MAP_NODES = "/map/nodes"
TOPIC_MAP_FLOOR_PLAN = "/map/floor_plan"
TOPIC_TELEMETRY = "/telemetry"
TOPIC_LOG = "/log"
TOPIC_CAMERA = "/camera/image/compressed"
TOPIC_WS = "/cart2d/ws"
TOPIC_MAP_VIEW = "/cart2d/map_view"

OCCUPIED = 100  # nav_msgs/OccupancyGrid's value for an occupied cell, as the floor plan's cells

# The telemetry frame's fields (cart2d/link/protocol.py, Telemetry) and the gateway's names.
TELEMETRY_SCHEMA: dict[str, Any] = {
    "type": "object",
    "title": "cart2d.Telemetry",
    "description": "One telemetry frame of the firmware (docs/protocol.md), as the gateway publishes it",
    "properties": {
        **{
            name: {"type": "number"}
            for name in (
                "x",
                "y",
                "theta",
                "v_left",
                "v_right",
                "v_left_target",
                "v_right_target",
                "pwm_left",
                "pwm_right",
                "v",
                "omega",
                "v_target",
                "omega_target",
                "distance_to_waypoint",
                "waypoint_index",
                "state",
            )
        },
        "tick": {"type": "integer"},
        "mode_name": {"type": "string"},
        "flag_names": {"type": "array", "items": {"type": "string"}},
    },
}
WS_SCHEMA: dict[str, Any] = {
    "type": "object",
    "title": "cart2d.WsMessage",
    "description": "A message of the gateway's /ws stream (telemetry, truth, map, mission, ...)",
    "properties": {"type": {"type": "string"}},
    "required": ["type"],
}
MAP_VIEW_SCHEMA: dict[str, Any] = {
    "type": "object",
    "title": "cart2d.MapView",
    "description": "The gateway's GET /api/map answer",
    "properties": {"version": {"type": "integer"}, "cols": {"type": "integer"}, "rows": {"type": "integer"}},
}


class Channels:
    """Every channel of one session, in its own foxglove.Context (so that two sessions in one
    process, as in the tests, do not see each other's messages)."""

    def __init__(self, context: foxglove.Context) -> None:
        self.context = context
        self.tf = ch.FrameTransformsChannel(TOPIC_TF, context=context)
        self.odom_pose = ch.PoseInFrameChannel(TOPIC_ODOM_POSE, context=context)
        self.truth_pose = ch.PoseInFrameChannel(TOPIC_TRUTH_POSE, context=context)
        self.plan_scene = ch.SceneUpdateChannel(TOPIC_PLAN_SCENE, context=context)
        self.plan_poses = ch.PosesInFrameChannel(TOPIC_PLAN_POSES, context=context)
        self.map_nodes = ch.GridChannel(TOPIC_MAP_NODES, context=context)
        self.map_floor_plan = ch.GridChannel(TOPIC_MAP_FLOOR_PLAN, context=context)
        self.log = ch.LogChannel(TOPIC_LOG, context=context)
        self.camera = ch.CompressedImageChannel(TOPIC_CAMERA, context=context)
        self.telemetry = foxglove.Channel(TOPIC_TELEMETRY, schema=TELEMETRY_SCHEMA, context=context)
        self.ws = foxglove.Channel(TOPIC_WS, schema=WS_SCHEMA, context=context)
        self.map_view = foxglove.Channel(TOPIC_MAP_VIEW, schema=MAP_VIEW_SCHEMA, context=context)


def stamp(ns: int) -> fm.Timestamp:
    return fm.Timestamp(sec=ns // 1_000_000_000, nsec=ns % 1_000_000_000)


def yaw(theta_rad: float) -> fm.Quaternion:
    """The rotation by theta about z."""
    return fm.Quaternion(x=0.0, y=0.0, z=math.sin(theta_rad / 2.0), w=math.cos(theta_rad / 2.0))


def pose(x_m: float, y_m: float, theta_rad: float = 0.0) -> fm.Pose:
    return fm.Pose(position=fm.Vector3(x=x_m, y=y_m, z=0.0), orientation=yaw(theta_rad))


def frame_tree(ns: int, x_m: float, y_m: float, theta_rad: float) -> fm.FrameTransforms:
    """map → odom (identity) → base_link (the odometry pose)."""
    t = stamp(ns)
    return fm.FrameTransforms(
        transforms=[
            fm.FrameTransform(
                timestamp=t,
                parent_frame_id=MAP_FRAME,
                child_frame_id=ODOM_FRAME,
                translation=fm.Vector3(),
                rotation=yaw(0.0),
            ),
            fm.FrameTransform(
                timestamp=t,
                parent_frame_id=ODOM_FRAME,
                child_frame_id=BASE_FRAME,
                translation=fm.Vector3(x=x_m, y=y_m, z=0.0),
                rotation=yaw(theta_rad),
            ),
        ]
    )


def path_scene(ns: int, points: Sequence[Sequence[float]]) -> fm.SceneUpdate:
    """The planned path as one line strip in `map` (an empty path deletes it)."""
    if len(points) < 2:
        return fm.SceneUpdate(deletions=[fm.SceneEntityDeletion(timestamp=stamp(ns), id="plan")])
    line = fm.LinePrimitive(
        type=fm.LinePrimitiveLineType.LineStrip,
        pose=pose(0.0, 0.0),
        thickness=0.02,
        points=[fm.Point3(x=p[0], y=p[1], z=0.01) for p in points],
        color=fm.Color(r=0.1, g=0.6, b=1.0, a=1.0),
    )
    entity = fm.SceneEntity(timestamp=stamp(ns), frame_id=MAP_FRAME, id="plan", lines=[line])
    return fm.SceneUpdate(entities=[entity])


def occupancy_grid(
    ns: int, origin_m: Sequence[float], cell_m: float, columns: int, cells: bytes, signed: bool = False
) -> fm.Grid:
    """A grid of one `occupancy` byte per cell (int8 with `signed`: nav_msgs/OccupancyGrid's -1
    for unknown), row 0 at the lowest y, in `map`."""
    numeric = fm.PackedElementFieldNumericType.Int8 if signed else fm.PackedElementFieldNumericType.Uint8
    return fm.Grid(
        timestamp=stamp(ns),
        frame_id=MAP_FRAME,
        pose=pose(float(origin_m[0]), float(origin_m[1])),
        column_count=columns,
        cell_size=fm.Vector2(x=cell_m, y=cell_m),
        row_stride=columns,
        cell_stride=1,
        fields=[fm.PackedElementField(name="occupancy", offset=0, type=numeric)],
        data=cells,
    )


def node_grid(ns: int, view: dict[str, Any]) -> fm.Grid:
    """The planning nodes of a map view as cells centred on them: occupied (100) where the user's
    obstacles are, else 0."""
    cols, rows, step = int(view["cols"]), int(view["rows"]), float(view["step_m"])
    ox, oy = (float(v) for v in view["origin_m"])
    cells = bytearray(cols * rows)
    for x, y in view["obstacles"]:
        i, j = round((x - ox) / step), round((y - oy) / step)
        if 0 <= i < cols and 0 <= j < rows:
            cells[j * cols + i] = OCCUPIED
    return occupancy_grid(ns, (ox - step / 2.0, oy - step / 2.0), step, cols, bytes(cells))

"""What a panel knows at a point of a recording: the map, the world, the mission, the camera, the
cart's pose and trails, rebuilt by applying the recording's entries in order up to that point.

The player keeps one up to date as it plays; a seek, or a panel that opens late, gets one built
from the start of the recording (`ReplayState.at`), and `messages()` turns it into the /ws
messages that bring a panel to it (a kind the recording has but that has not come yet is sent
empty, so that a seek back takes away what came later).
"""

from __future__ import annotations

import math
from typing import Any

from cart2d.gateway.messages import CameraMessage, MissionMessage, PerceivedMessage, SimWorldMessage, wire
from cart2d.gateway.perceived import DEFAULT_RESOLUTION_M
from cart2d.recording.channels import TOPIC_MAP_VIEW, TOPIC_WS
from cart2d.recording.recorded import Entry, Frame, Recorded

# The /ws messages that are a state (the latest one says it all), in the order a panel takes them:
# the map before what is drawn on it, the pose last. The others (reset, replan, goal) are events.
STATE_KINDS = (
    "sim_world",
    "perceived",
    "camera",
    "pose_trust",
    "routine",
    "simulator",
    "mission",
    "telemetry",
    "truth",
)
# What a kind is before its first message: the gateway's own messages, checked by their models.
EMPTY: dict[str, dict[str, Any]] = {
    m.type: wire(m)
    for m in (
        SimWorldMessage(version=None, boxes=[]),
        PerceivedMessage(resolution=DEFAULT_RESOLUTION_M, cells=[]),
        CameraMessage(t=None, fov=[], hits=[]),
        MissionMessage(state="idle", goal=None, reason="", elapsed_s=0.0, plan=None, replans=[]),
    )
}
# The trails sent to a panel that joins: a point where the cart moved this far (the panel's own
# trails keep a point every 4 mm, 3000 at most: web/src/map.ts), the newest TRAIL_POINTS.
TRAIL_STEP_M = 0.01
TRAIL_POINTS = 3000

Point = tuple[float, float]


def _extend(trail: list[Point], message: dict[str, Any]) -> None:
    x, y = float(message["x"]), float(message["y"])
    if trail and math.hypot(x - trail[-1][0], y - trail[-1][1]) < TRAIL_STEP_M:
        return
    trail.append((round(x, 4), round(y, 4)))
    if len(trail) > 2 * TRAIL_POINTS:  # trimmed now and then, not at every point
        del trail[:-TRAIL_POINTS]


class ReplayState:
    def __init__(self, recorded: Recorded) -> None:
        self.recorded = recorded
        self.map_view: dict[str, Any] = recorded.first_map_view() or {}
        self.latest: dict[str, dict[str, Any]] = {}  # by /ws type
        self.frame: Frame | None = None
        self.frame_at_s = 0.0
        self.frames = 0  # camera frames up to here (the frame's number in the re-stream)
        self.trail: list[Point] = []  # odometry
        self.truth_trail: list[Point] = []

    @classmethod
    def at(cls, recorded: Recorded, index: int) -> ReplayState:
        """The state once the entries before `index` have been played."""
        state = cls(recorded)
        for entry in recorded.entries[:index]:
            state.apply(entry)
        return state

    def apply(self, entry: Entry) -> None:
        topic, message = entry.topic, entry.message
        if isinstance(message, Frame):
            self.frame = message
            self.frame_at_s = entry.at_s
            self.frames += 1
        elif topic == TOPIC_MAP_VIEW:
            self.map_view = message
        elif topic == TOPIC_WS:
            kind = str(message.get("type"))
            if kind in STATE_KINDS:
                self.latest[kind] = message
            if kind == "telemetry":
                _extend(self.trail, message)
            elif kind == "truth":
                _extend(self.truth_trail, message)

    def mission(self) -> dict[str, Any]:
        """The mission as /api/status and /ws hello give it."""
        mission = self.latest.get("mission", EMPTY["mission"])
        return {k: v for k, v in mission.items() if k != "type"}

    def perception(self) -> dict[str, Any]:
        """/api/perception's answer, from the latest perceived cells."""
        perceived = self.latest.get("perceived", EMPTY["perceived"])
        return {"enabled": True, "resolution": perceived["resolution"], "cells": perceived["cells"]}

    def sim_world(self) -> dict[str, Any]:
        world = self.latest.get("sim_world", EMPTY["sim_world"])
        return {k: v for k, v in world.items() if k != "type"}

    def trails(self) -> dict[str, list[Point]]:
        return {"trail": self.trail[-TRAIL_POINTS:], "truth_trail": self.truth_trail[-TRAIL_POINTS:]}

    def messages(self) -> list[dict[str, Any]]:
        """The /ws messages that bring a panel to this state, the map's version first."""
        out: list[dict[str, Any]] = []
        version = self.map_view.get("version")
        if version is not None:
            out.append({"type": "map", "version": version, "why": "the replay's position"})
        kinds = self.recorded.kinds
        for kind in STATE_KINDS:
            message = self.latest.get(kind) or (EMPTY.get(kind) if kind in kinds else None)
            if message is not None:
                out.append(message)
        return out

"""The reset routine as started through the gateway (docs/protocol.md, RESET_ROUTINE): the cart
creeps to the wall in front and squares up against it; the pose is trusted again once it ended
squared up at the configured reset pose (not with ROUTINE_FAILED, not interrupted).

It is followed to its end by the monitor (monitor.py) and ended, as failed, by every fault that
ends a mission (Missions.abort), by a path that replaces it, and by a stop. Starting it tells the
bus (RoutineStarted): the mission it replaces ends there (missions.py)."""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from typing import Any

from cart2d.gateway import messages
from cart2d.gateway.bus import EventBus, RoutineStarted, ViewerMessage
from cart2d.gateway.state import (
    ROUTINE_HEADING_TOLERANCE_RAD,
    ROUTINE_POSE_TOLERANCE_M,
    Routine,
    RoutineEnd,
    pose_text,
)
from cart2d.link import firmware

Pose = tuple[float, float, float]


class ResetRoutine:
    def __init__(
        self,
        lock: threading.RLock,
        bus: EventBus,
        read_pose: Callable[[], Pose],
        trust: Callable[[str], None],
    ) -> None:
        """`lock`: the missions' (a fault ends the mission and the routine together under it);
        `read_pose`: POSE; `trust(how)`: the pose is right again (restarts.py)."""
        self._lock = lock
        self.bus = bus
        self._read_pose = read_pose
        self._trust = trust
        self.routine = Routine()

    def _publish(self, message: messages.LiveMessage) -> None:
        self.bus.publish(ViewerMessage(message))

    def view(self) -> dict[str, Any]:
        with self._lock:
            return {"state": self.routine.state, "words": self.routine.words}

    def running(self) -> bool:
        return self.routine.state == "running"

    def start(self, expected_pose: Pose) -> None:
        """The firmware took RESET_ROUTINE: what drove before ends (RoutineStarted), then the
        routine runs towards `expected_pose`."""
        with self._lock:
            self.bus.publish(RoutineStarted())
            self.routine = Routine("running", "driving slowly to the wall in front", expected_pose)
            self._publish(messages.RoutineMessage(**self.view()))

    def fail(self, words: str, routine: Routine | None = None) -> None:
        """Ends the routine running now as failed with `words`; `routine`: only if it is still
        that one (what started since is not the caller's to end)."""
        with self._lock:
            if (routine is None or self.routine is routine) and self.routine.state == "running":
                self._end("failed", words)

    def _end(self, state: RoutineEnd, words: str) -> None:
        self.routine = Routine(state, words)
        self._publish(messages.RoutineMessage(**self.view()))

    # -- followed by the monitor (monitor.py) ---------------------------------------------------
    def busy(self) -> bool:
        with self._lock:
            return self.running()

    def before_status(self) -> Routine:
        with self._lock:
            return self.routine

    def after_status(self, status: firmware.Status, routine: Routine) -> None:
        """Ends `routine` (the one running when `status` was asked for) once `status` shows the
        firmware no longer runs it: done if the cart stands at the reset pose, else failed."""
        if routine.state != "running" or status.mode == "RESET_ROUTINE":
            return
        pose = self._read_pose()
        with self._lock:
            if self.routine is not routine:
                return  # ended meanwhile (a stop, a restart)
            if status.has("ROUTINE_FAILED"):
                self._end("failed", "it found no wall in time: the pose is unchanged")
                return
            expected = routine.expected_pose or pose
            off_m = math.hypot(pose[0] - expected[0], pose[1] - expected[1])
            off_rad = abs(math.remainder(pose[2] - expected[2], 2 * math.pi))
            if off_m > ROUTINE_POSE_TOLERANCE_M or off_rad > ROUTINE_HEADING_TOLERANCE_RAD:
                self._end("failed", "it was interrupted before it squared up")
                return
            self._end("done", f"squared up against the wall: pose {pose_text(*pose)}")
        self._trust(f"the reset routine squared the cart up against the wall: pose {pose_text(*pose)}")

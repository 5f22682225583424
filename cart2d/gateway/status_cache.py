"""The firmware's STATUS and pose as the gateway last read them, for /api/status.

A read of /api/status used to make two exchanges on the serial link (STATUS, then POSE), so a
hundred readers queued a hundred pairs, in the server's thread pool and on the link (issue 22).
The gateway's monitor reads STATUS a few times a second anyway (monitor.py); every STATUS
and POSE the gateway reads, for whatever reason, is kept here with when it was read, and so is
the pose of each telemetry frame (25 Hz, for nothing on the link; the monitor reads POSE only
while telemetry does not come). /api/status answers from it: no request of a reader reaches the
link.
"""

from __future__ import annotations

import threading
import time
from dataclasses import asdict, dataclass, replace
from typing import Any

from cart2d.link import firmware

Pose = tuple[float, float, float]
# A pose read with POSE stands this long against telemetry's: a frame dispatched after the read
# may have been decoded before it (before a SET_POSE, a restart).
POSE_READ_STANDS_S = 0.5


@dataclass(frozen=True)
class Seen:
    """The newest STATUS and pose read (None until read), when (time.monotonic()), and why the
    last read failed if it failed after them."""

    status: firmware.Status | None = None
    status_at: float = 0.0
    pose: Pose | None = None
    pose_at: float = 0.0
    error: str = ""
    pose_from_read: bool = True  # a POSE reply, not a telemetry frame
    telemetry_at: float = float("-inf")  # when the last telemetry frame came


class StatusCache:
    """Thread-safe: the gateway's threads write, the server's read."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._seen = Seen()

    def status_read(self, status: firmware.Status) -> None:
        with self._lock:
            self._seen = replace(self._seen, status=status, status_at=time.monotonic(), error="")

    def pose_read(self, pose: Pose) -> None:
        with self._lock:
            self._seen = replace(self._seen, pose=pose, pose_at=time.monotonic(), pose_from_read=True)

    def pose_of_telemetry(self, pose: Pose) -> None:
        now = time.monotonic()
        with self._lock:
            seen = self._seen
            if seen.pose is not None and seen.pose_from_read and now - seen.pose_at < POSE_READ_STANDS_S:
                self._seen = replace(seen, telemetry_at=now)
            else:
                self._seen = replace(seen, pose=pose, pose_at=now, pose_from_read=False, telemetry_at=now)

    def telemetry_age_s(self) -> float:
        """How long ago the last telemetry frame came (infinite before the first)."""
        with self._lock:
            return time.monotonic() - self._seen.telemetry_at

    def read_failed(self, why: str) -> None:
        with self._lock:
            self._seen = replace(self._seen, error=why)

    def view(self) -> dict[str, Any]:
        """The parts of /api/status it gives: `status` and `pose` as last read (absent until
        read), `status_age_s` (how old the STATUS is) and `error` (the last read failed)."""
        with self._lock:
            seen = self._seen
        view: dict[str, Any] = {}
        if seen.status is not None:
            view["status"] = asdict(seen.status)
            view["status_age_s"] = round(time.monotonic() - seen.status_at, 3)
        if seen.pose is not None:
            view["pose"] = dict(zip(("x", "y", "theta"), seen.pose, strict=True))
        if seen.error:
            view["error"] = seen.error
        return view

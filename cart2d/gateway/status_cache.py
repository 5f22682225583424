"""The firmware's STATUS and pose as the gateway last read them, for /api/status.

A read of /api/status used to make two exchanges on the serial link (STATUS, then POSE), so a
hundred readers queued a hundred pairs, in the server's thread pool and on the link (issue 22).
The gateway's monitor reads both a few times a second anyway (core.py, _watch); every STATUS
and POSE the gateway reads, for whatever reason, is kept here, with when it was read, and
/api/status answers from it: no request of a reader reaches the link.
"""

from __future__ import annotations

import threading
import time
from dataclasses import asdict, dataclass
from typing import Any

from cart2d.link import firmware

Pose = tuple[float, float, float]


@dataclass(frozen=True)
class Seen:
    """The newest STATUS and pose read (None until read), when (time.monotonic()), and why the
    last read failed if it failed after them."""

    status: firmware.Status | None = None
    status_at: float = 0.0
    pose: Pose | None = None
    pose_at: float = 0.0
    error: str = ""


class StatusCache:
    """Thread-safe: the gateway's threads write, the server's read."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._seen = Seen()

    def status_read(self, status: firmware.Status) -> None:
        with self._lock:
            self._seen = Seen(status, time.monotonic(), self._seen.pose, self._seen.pose_at)

    def pose_read(self, pose: Pose) -> None:
        with self._lock:
            seen = self._seen
            self._seen = Seen(seen.status, seen.status_at, pose, time.monotonic(), seen.error)

    def read_failed(self, why: str) -> None:
        with self._lock:
            seen = self._seen
            self._seen = Seen(seen.status, seen.status_at, seen.pose, seen.pose_at, why)

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

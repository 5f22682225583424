"""The camera's re-stream to the panels (its routes: routes/camera.py).

The ESP32-CAM streams to one client, the gateway; any number of panels watch the gateway's
re-stream, /api/camera/stream. Each watcher has its own queue of the newest CAMERA_BACKLOG
frames: one that reads slower than the camera sends loses the older frames (counted) and holds
no more than that, while the others and the camera's reader go on undisturbed. At most
MAX_CAMERA_VIEWERS at a time (503 beyond). A re-stream without a frame for STREAM_IDLE_S ends.
"""

from __future__ import annotations

import asyncio
import contextlib
import threading
from collections import deque
from collections.abc import AsyncIterator
from typing import Any

from fastapi import HTTPException

from cart2d.gateway.camera import Shown
from cart2d.server.models import errors
from cart2d.server.source import Camera

MAX_CAMERA_VIEWERS = 16
# A re-stream that has had no frame for this long ends (the camera is away: a dropped Wi-Fi, a
# wrong address); the panel opens it again once the camera is back. A live camera's never ends.
STREAM_IDLE_S = 3.0
CAMERA_BACKLOG = 2  # frames a watcher may be behind: the newest matter, not every one
BOUNDARY = "cart2d-frame"

CAMERA_ERRORS = {
    404: "no camera (start the gateway with --camera, or PUT /api/settings/camera), or no frame from it yet",
    503: f"more than {MAX_CAMERA_VIEWERS} viewers of the camera at a time: try again later",
}


def camera_errors(*codes: int) -> dict[int | str, dict[str, Any]]:
    """errors(), with what 404 and 503 mean for the camera."""
    out = errors(*codes)
    for code, words in CAMERA_ERRORS.items():
        if code in out:
            out[code] = {**out[code], "description": words}
    return out


class Watcher:
    def __init__(self, loop: asyncio.AbstractEventLoop) -> None:
        self.loop = loop
        self.queue: deque[Shown] = deque(maxlen=CAMERA_BACKLOG)
        self.ready = asyncio.Event()
        self.dropped = 0

    def put(self, shown: Shown) -> None:
        if len(self.queue) == self.queue.maxlen:
            self.dropped += 1
        self.queue.append(shown)
        self.ready.set()


class Watchers:
    """The panels watching the camera of one feed."""

    def __init__(self, feed: Camera) -> None:
        self.feed = feed
        self.watchers: frozenset[Watcher] = frozenset()  # replaced, never changed in place
        self._lock = threading.Lock()
        self._unsubscribe = feed.subscribe(self._shown)

    def _shown(self, shown: Shown) -> None:
        """The feed's thread: one hop into each watcher's event loop."""
        for watcher in self.watchers:
            with contextlib.suppress(RuntimeError):  # its loop is closing
                watcher.loop.call_soon_threadsafe(watcher.put, shown)

    async def stream(self) -> AsyncIterator[bytes]:
        watcher = Watcher(asyncio.get_running_loop())
        with self._lock:
            if len(self.watchers) >= MAX_CAMERA_VIEWERS:
                raise HTTPException(
                    503, f"at most {MAX_CAMERA_VIEWERS} camera viewers at a time: try again later"
                )
            self.watchers = self.watchers | {watcher}
        return self._parts(watcher)

    async def _parts(self, watcher: Watcher) -> AsyncIterator[bytes]:
        try:
            shown = self.feed.shown()
            if shown is not None:
                watcher.put(shown)  # the newest frame at once, not after the camera's next
            while True:
                try:
                    await asyncio.wait_for(watcher.ready.wait(), STREAM_IDLE_S)
                except TimeoutError:
                    return  # no frame for a while: the camera is away
                watcher.ready.clear()
                while watcher.queue:
                    shown = watcher.queue.popleft()
                    stamp = "" if shown.stamp_s is None else f"X-Timestamp: {shown.stamp_s:.6f}\r\n"
                    head = (
                        f"--{BOUNDARY}\r\nContent-Type: image/jpeg\r\nContent-Length: {len(shown.jpeg)}\r\n"
                        f"X-Frame: {shown.seq}\r\n{stamp}\r\n"
                    )
                    yield head.encode() + shown.jpeg + b"\r\n"
        finally:
            with self._lock:
                self.watchers = self.watchers - {watcher}


class CameraWatchers:
    """The Watchers of each feed an app has served (a feed set after the app was made gets its own),
    made once a feed: each subscribes to its feed for good."""

    def __init__(self) -> None:
        self.by_feed: dict[int, Watchers] = {}  # by the feed's id
        self._lock = threading.Lock()

    def of(self, feed: Camera) -> Watchers:
        with self._lock:
            known = self.by_feed.get(id(feed))
            if known is None or known.feed is not feed:
                known = self.by_feed[id(feed)] = Watchers(feed)
            return known

    def values(self) -> list[Watchers]:
        return list(self.by_feed.values())

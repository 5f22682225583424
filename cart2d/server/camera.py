"""The API's camera routes (added to the app by create_app; perception's are routes/perception.py).

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

from fastapi import FastAPI, HTTPException, Response
from fastapi.params import Depends
from fastapi.responses import StreamingResponse

from cart2d.gateway import Gateway
from cart2d.gateway.camera import CameraFeed, Shown
from cart2d.server.answers import CameraOut
from cart2d.server.models import errors
from cart2d.store import CameraSettings

MAX_CAMERA_VIEWERS = 16
# A re-stream that has had no frame for this long ends (the camera is away: a dropped Wi-Fi, a
# wrong address); the panel opens it again once the camera is back. A live camera's never ends.
STREAM_IDLE_S = 3.0
CAMERA_BACKLOG = 2  # frames a watcher may be behind: the newest matter, not every one
BOUNDARY = "cart2d-frame"
NO_CAMERA = "this gateway has no camera: start it with --camera http://HOST (or --camera-stream URL)"

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

    def __init__(self, feed: CameraFeed) -> None:
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


def add_camera_routes(app: FastAPI, gateway: Gateway, guarded: Depends) -> None:
    watchers: dict[int, Watchers] = {}  # by the feed's id: a feed set after the app was made
    app.state.camera_watchers = watchers  # for tests and benchmarks, as app.state.viewers

    def feed() -> CameraFeed:
        if gateway.camera is None:
            raise HTTPException(404, NO_CAMERA)
        return gateway.camera

    def watchers_of(camera: CameraFeed) -> Watchers:
        return watchers.setdefault(id(camera), Watchers(camera))

    @app.get(
        "/api/camera",
        response_model=CameraOut,
        response_model_exclude_unset=True,  # without a camera: `camera` false and a `message` only
        summary="the camera: its stream (connected, fps, reconnects) and its frames (taken in, refused; "
        "seeing or blind, and why)",
    )
    def camera_state() -> dict[str, Any]:
        camera = gateway.camera
        if camera is None:
            return {"camera": False, "message": NO_CAMERA}
        state = camera.status()
        return {
            **state,
            "camera": True,
            "url": camera.base_url,
            "stream_url": camera.reader.url,
            "viewers": len(watchers_of(camera).watchers),
            "calibration": gateway.calibration_summary(),
        }

    @app.get(
        "/api/camera/frame.jpg",
        summary="the newest frame, with what perception drew on it",
        responses={200: {"content": {"image/jpeg": {}}}, **camera_errors(404)},
        response_class=Response,
    )
    def frame() -> Response:
        shown = feed().shown()
        if shown is None:
            raise HTTPException(404, "no frame from the camera yet: GET /api/camera says why")
        return Response(shown.jpeg, media_type="image/jpeg", headers={"Cache-Control": "no-store"})

    @app.get(
        "/api/camera/stream",
        summary="the camera's frames as MJPEG (multipart/x-mixed-replace), for any number of viewers",
        responses={200: {"content": {"multipart/x-mixed-replace": {}}}, **camera_errors(404, 503)},
        response_class=StreamingResponse,
    )
    async def stream() -> StreamingResponse:
        parts = await watchers_of(feed()).stream()
        return StreamingResponse(
            parts,
            media_type=f"multipart/x-mixed-replace; boundary={BOUNDARY}",
            headers={"Cache-Control": "no-store"},
        )

    @app.put(
        "/api/settings/camera",
        dependencies=[guarded],
        summary="the camera to read: saved, and read from now on (null for both: no camera)",
        description="`url` is the stock CameraWebServer's base, http://HOST[:PORT] (its stream on PORT + 1); "
        "`stream_url` an MJPEG stream outright (ESPHome's esp32_camera_web_server), which wins. The command "
        "line's --camera and --camera-stream apply to their run only.",
        responses=errors(400, 401, 422),
        response_model=CameraOut,
        response_model_exclude_unset=True,
    )
    def set_camera(body: CameraSettings) -> dict[str, Any]:
        try:
            gateway.set_camera(body)
        except ValueError as exc:
            raise HTTPException(422, f"url: {exc}") from exc
        return camera_state()

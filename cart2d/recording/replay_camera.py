"""The replay's camera routes: the recorded frames (with what perception drew on them) at the
replay's position, in the shape of the gateway's (cart2d/server/camera.py), so that the panel's
camera card shows them as it shows a live camera. The MJPEG re-stream is the gateway's own
(Watchers), fed by the player instead of a camera."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from fastapi import FastAPI, HTTPException, Response
from fastapi.responses import StreamingResponse

from cart2d.gateway.camera import Shown
from cart2d.recording.recorded import Frame, Recorded
from cart2d.recording.replay import Player
from cart2d.server.camera import BOUNDARY, Watchers, camera_errors

NO_FRAMES = "this recording holds no camera frames"


class RecordedCamera:
    """The part of a CameraFeed (cart2d/gateway/camera.py) the re-stream uses, from the player."""

    def __init__(self, player: Player) -> None:
        self.player = player

    def subscribe(self, sink: Callable[[Shown], None]) -> Callable[[], None]:
        return self.player.subscribe_frames(
            lambda frame, number: sink(Shown(number, frame.stamp_s, frame.jpeg))
        )

    def shown(self) -> Shown | None:
        return self.player.read(
            lambda now: None if now.frame is None else Shown(now.frames, now.frame.stamp_s, now.frame.jpeg)
        )


def recorded_fps(recorded: Recorded) -> float:
    """The rate the camera was recorded at: frames over the time between the first and the last."""
    times = [e.at_s for e in recorded.entries if isinstance(e.message, Frame)]
    return (len(times) - 1) / (times[-1] - times[0]) if len(times) > 1 and times[-1] > times[0] else 0.0


def add_replay_camera_routes(app: FastAPI, player: Player) -> None:
    frames = player.recorded.frames
    fps = round(recorded_fps(player.recorded), 2)
    watchers = Watchers(RecordedCamera(player))  # type: ignore[arg-type]  # the part of a feed it uses
    app.state.camera_watchers = {0: watchers}

    def state() -> dict[str, Any]:
        position_s, frame_at_s, seen = player.read(lambda now: (player.position_s, now.frame_at_s, now.frame))
        return {
            "camera": True,
            "recorded_frames": frames,
            "connected": seen is not None,  # from the first frame on: the panel opens the stream then
            "fps": fps,
            "age_s": None if seen is None else round(max(position_s - frame_at_s, 0.0), 3),
            "reconnects": 0,
            "url": None,
            "stream_url": "/api/camera/stream",
            "viewers": len(watchers.watchers),
            "calibration": None,
        }

    @app.get("/api/camera", summary="the recorded camera at the replay's position (fps: the recorded rate)")
    def camera_state() -> dict[str, Any]:
        return state() if frames else {"camera": False, "message": NO_FRAMES}

    @app.get(
        "/api/camera/frame.jpg",
        summary="the recorded frame at the replay's position, with what perception drew on it",
        responses={200: {"content": {"image/jpeg": {}}}, **camera_errors(404)},
        response_class=Response,
    )
    def frame() -> Response:
        shown = RecordedCamera(player).shown()
        if shown is None:
            raise HTTPException(
                404, NO_FRAMES if not frames else "no camera frame yet at this point of the replay"
            )
        return Response(shown.jpeg, media_type="image/jpeg", headers={"Cache-Control": "no-store"})

    @app.get(
        "/api/camera/stream",
        summary="the recorded frames as MJPEG, as the replay plays them (the frame shown again while paused)",
        responses={200: {"content": {"multipart/x-mixed-replace": {}}}, **camera_errors(404, 503)},
        response_class=StreamingResponse,
    )
    async def stream() -> StreamingResponse:
        if not frames:
            raise HTTPException(404, NO_FRAMES)
        parts = await watchers.stream()
        return StreamingResponse(
            parts,
            media_type=f"multipart/x-mixed-replace; boundary={BOUNDARY}",
            headers={"Cache-Control": "no-store"},
        )

"""The replay's camera: the recorded frames (with what perception drew on them) at the replay's
position, in the shape of the gateway's, so that the live camera routes (cart2d/server/routes/
camera.py) show them as they show a live camera: the MJPEG re-stream is the gateway's own
(Watchers), fed by the player instead of a camera."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from cart2d.gateway.camera import Shown
from cart2d.recording.recorded import Frame, Recorded
from cart2d.recording.replay import Player

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


def camera_view(player: Player, frames: int, fps: float) -> dict[str, Any]:
    """/api/camera's answer at the replay's position, in the shape of the gateway's (but viewers);
    `frames`, `fps`: the recording's (recorded_fps)."""
    if not frames:
        return {"camera": False, "message": NO_FRAMES}
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
        "calibration": None,
    }

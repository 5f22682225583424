"""A session's sinks: the Foxglove SDK's WebSocket server (`--foxglove [PORT]`) and its MCAP writer
(`cart2d mission`, `--record DIR`), both fed by one Publisher on one foxglove.Context."""

from __future__ import annotations

import contextlib
import datetime
import logging
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import foxglove
from foxglove.websocket import ChannelView, Client, ServerListener, WebSocketServer

from cart2d.recording import channels as c
from cart2d.recording.publisher import GatewayLike, Publisher

log = logging.getLogger(__name__)

DEFAULT_FOXGLOVE_PORT = 8765  # the Foxglove app's default for a "Foxglove WebSocket" connection
# The camera frames a second a recording keeps: the simulated camera's frame with its overlay is
# ~4.5 KiB, so its 14 fps would be ~60 KiB/s, seven times the rest of the recording (README).
DEFAULT_CAMERA_FPS = 2.0
MAP_TOPICS = frozenset({c.TOPIC_MAP_NODES, c.TOPIC_MAP_FLOOR_PLAN, c.TOPIC_MAP_VIEW})


def session_file_name(now: datetime.datetime | None = None) -> str:
    """cart2d-YYYYmmdd-HHMMSS.mcap, in local time (sortable; one a second at most)."""
    now = now or datetime.datetime.now()
    return f"cart2d-{now:%Y%m%d-%H%M%S}.mcap"


class _MapOnSubscribe(ServerListener):
    """Publishes the map again when a Foxglove viewer subscribes to it: the map is sent when it
    changes, and a viewer that connects later would otherwise not see it until then."""

    def __init__(self) -> None:
        self.publisher: Publisher | None = None

    def on_subscribe(self, client: Client, channel: ChannelView) -> None:
        if self.publisher is not None and channel.topic in MAP_TOPICS:
            self.publisher.refresh_map()


class Recording:
    """One gateway's publisher and the sinks it feeds; close() stops the server and finishes the file.
    `camera_fps`: the camera's frames kept a second at most (0: none; None: every frame)."""

    def __init__(self, gateway: GatewayLike, camera_fps: float | None = None) -> None:
        self.context = foxglove.Context()
        self.gateway = gateway
        self.camera_fps = camera_fps
        self._camera_kept_ns: int | None = None
        self.publisher: Publisher | None = None
        self.server: WebSocketServer | None = None
        self.mcap_path: Path | None = None
        self._writer: Any = None
        self._listener = _MapOnSubscribe()

    def record_to(self, path: Path, overwrite: bool = False) -> Recording:
        """Writes every channel to the MCAP file `path` (which must not exist yet, unless `overwrite`)."""
        path.parent.mkdir(parents=True, exist_ok=True)
        self._writer = foxglove.open_mcap(path, allow_overwrite=overwrite, context=self.context)
        self.mcap_path = path
        return self

    def serve(self, port: int, host: str = "127.0.0.1") -> Recording:
        """Starts the SDK's WebSocket server for the Foxglove app (port 0: any free one)."""
        self.server = foxglove.start_server(
            name="cart2d", host=host, port=port, context=self.context, server_listener=self._listener
        )
        return self

    def start(self) -> Recording:
        """Starts publishing (after the sinks: the channels are made once they exist)."""
        simulated = bool(getattr(self.gateway, "simulated", False))
        self.publisher = Publisher(self.gateway, self.context, simulated).start()
        self._listener.publisher = self.publisher
        return self

    def close(self) -> None:
        if self.publisher is not None:
            self.publisher.close()
            if self.publisher.dropped:
                log.warning(
                    "the recorder dropped %d messages it could not keep up with", self.publisher.dropped
                )
        if self._writer is not None:
            self._writer.close()
            self._writer = None
        if self.server is not None:
            self.server.stop()
            self.server = None

    def publish_camera_jpeg(self, jpeg: bytes, stamp_ns: int) -> None:
        """The camera's hook: a JPEG frame taken at stamp_ns (wall clock, ns), kept if it comes at
        least 1 / camera_fps after the last frame kept."""
        if self.publisher is None or self.camera_fps == 0:
            return
        last = self._camera_kept_ns
        if self.camera_fps is not None and last is not None and stamp_ns - last < 1e9 / self.camera_fps:
            return
        self._camera_kept_ns = stamp_ns
        self.publisher.publish_camera_jpeg(jpeg, stamp_ns)

    def publish_event(self, message: dict[str, Any]) -> None:
        """A /ws-shaped message of the session's own (a mission's goals), recorded with the gateway's."""
        if self.publisher is not None:
            self.publisher.on_message(message)


@contextlib.contextmanager
def open_recording(
    gateway: GatewayLike,
    mcap_path: Path | None = None,
    foxglove_port: int | None = None,
    host: str = "127.0.0.1",
    overwrite: bool = False,
    camera_fps: float = DEFAULT_CAMERA_FPS,
) -> Iterator[Recording | None]:
    """A Recording with the sinks asked for, closed on exit; None when neither is asked for. The
    camera is kept at camera_fps when there is a file (the live view shares its channel), else
    whole."""
    if mcap_path is None and foxglove_port is None:
        yield None
        return
    recording = Recording(gateway, camera_fps if mcap_path is not None else None)
    add_camera_sink = getattr(gateway, "add_camera_sink", None)  # a gateway that may have a camera
    stop_camera: Callable[[], None] | None = None
    try:
        if mcap_path is not None:
            recording.record_to(mcap_path, overwrite)
        if foxglove_port is not None:
            recording.serve(foxglove_port, host)
        if add_camera_sink is not None:
            stop_camera = add_camera_sink(
                lambda shown: recording.publish_camera_jpeg(shown.jpeg, time.time_ns())
            )
        yield recording.start()
    finally:
        if stop_camera is not None:
            stop_camera()
        recording.close()


def start_live_view(gateway: GatewayLike, port: int, host: str = "127.0.0.1") -> Recording:
    """The Foxglove live view alone, started; close() it."""
    return Recording(gateway).serve(port, host).start()

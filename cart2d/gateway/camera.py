"""The camera on the gateway: its MJPEG stream read (cart2d/perception/mjpeg.py), the newest frame
decoded, handed to the processors (perception plugs in here) and shown to the panel with what
they drew on it.

The ESP32-CAM serves one stream client, and the gateway is it; the panel watches the gateway's
re-stream (/api/camera/stream). Frames are processed in a thread of their own, newest first: a
processor slower than the camera skips frames rather than letting them queue (the stream's
reader never waits for it), so what the panel and the planner see is never older than one
processing step.
"""

from __future__ import annotations

import contextlib
import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any
from urllib.parse import urlsplit, urlunsplit

import cv2
import numpy as np

from cart2d.perception.mjpeg import Frame, MjpegReader

log = logging.getLogger(__name__)

JPEG_QUALITY = 80  # the overlaid frames the panel sees (the stock sketch streams at about this)


@dataclass(frozen=True)
class Overlay:
    """What a processor shows on a frame: `draw(bgr)` draws on the panel's copy (with cv2)."""

    draw: Callable[[np.ndarray], object]  # what it returns is not used (cv2 returns the image)


Processor = Callable[[Frame, np.ndarray], Overlay | None]


@dataclass(frozen=True)
class Shown:
    """A frame as the panel sees it: the reader's seq, the camera's stamp, the JPEG with overlays."""

    seq: int
    stamp_s: float | None
    jpeg: bytes


def stream_url_for(base_url: str) -> str:
    """The stock CameraWebServer's stream for its base URL: http://HOST[:P] -> http://HOST:(P+1)/stream
    (the sketch serves /capture and /control on P, default 80, and the stream on P + 1)."""
    parts = urlsplit(base_url)
    if parts.scheme != "http" or not parts.hostname:
        raise ValueError(f"the camera's URL must be http://HOST[:PORT], got {base_url!r}")
    if parts.path not in ("", "/") or parts.query:
        raise ValueError(
            f"the camera's URL is its base, http://HOST[:PORT], got {base_url!r}: give a stream's own URL "
            "with --camera-stream"
        )
    port = (parts.port or 80) + 1
    host = f"[{parts.hostname}]" if ":" in parts.hostname else parts.hostname
    return urlunsplit(("http", f"{host}:{port}", "/stream", "", ""))


class CameraFeed:
    """The camera's reader, its newest decoded frame, the processors and what the panel sees."""

    def __init__(self, stream_url: str, base_url: str | None = None, stale_after_s: float = 2.0) -> None:
        self.base_url = base_url
        self.reader = MjpegReader(stream_url, self._arrived, stale_after_s)
        self._processors: tuple[Processor, ...] = ()
        self._viewers: tuple[Callable[[Shown], None], ...] = ()
        self._lock = threading.Lock()
        self._arrival = threading.Condition(self._lock)
        self._pending: Frame | None = None
        self._image: tuple[Frame, np.ndarray] | None = None
        self._shown: Shown | None = None
        self._stop = threading.Event()
        self._worker = threading.Thread(target=self._work, name="camera frames", daemon=True)
        self.decoded = 0
        self.decode_errors = 0
        self.processor_errors = 0
        self._failed: set[int] = set()  # processors whose failure was logged
        self.skipped = 0  # frames that came while the one before was still being processed
        self.process_ms = 0.0  # the last frame's decoding, processing and re-encoding

    @classmethod
    def of(cls, camera: str | None, stream: str | None) -> CameraFeed | None:
        """The feed of `cart2d serve --camera URL` / `--camera-stream URL` (the stream wins)."""
        if stream:
            return cls(stream, camera)
        if camera:
            return cls(stream_url_for(camera), camera)
        return None

    def same_camera(self, other: CameraFeed) -> bool:
        return (self.base_url, self.reader.url) == (other.base_url, other.reader.url)

    def start(self) -> CameraFeed:
        self._worker.start()
        self.reader.start()
        return self

    def stop(self) -> None:
        self.reader.stop()
        self._stop.set()
        with self._arrival:
            self._arrival.notify_all()
        if self._worker.is_alive():
            self._worker.join(timeout=5.0)

    def add_processor(self, processor: Processor) -> None:
        with self._lock:
            self._processors = (*self._processors, processor)

    def subscribe(self, viewer: Callable[[Shown], None]) -> Callable[[], None]:
        """viewer(shown) for every frame shown (in the feed's thread: it must not block)."""
        with self._lock:
            self._viewers = (*self._viewers, viewer)

        def unsubscribe() -> None:
            with self._lock:
                self._viewers = tuple(v for v in self._viewers if v is not viewer)

        return unsubscribe

    def latest_image(self) -> tuple[Frame, np.ndarray] | None:
        """The newest decoded frame (BGR), as the processors saw it."""
        return self._image

    def shown(self) -> Shown | None:
        """The newest frame as the panel sees it (with the overlays)."""
        return self._shown

    def status(self) -> dict[str, Any]:
        image = self._image
        return {
            **self.reader.status(),
            "base_url": self.base_url,
            "decoded": self.decoded,
            "decode_errors": self.decode_errors,
            "processor_errors": self.processor_errors,
            "skipped": self.skipped,
            "process_ms": round(self.process_ms, 2),
            "processors": len(self._processors),
            "width": None if image is None else int(image[1].shape[1]),
            "height": None if image is None else int(image[1].shape[0]),
        }

    # -- the feed's thread ------------------------------------------------------------------
    def _arrived(self, frame: Frame) -> None:
        """The reader's thread: hands the frame over, dropping one not yet processed."""
        with self._arrival:
            if self._pending is not None:
                self.skipped += 1
            self._pending = frame
            self._arrival.notify()

    def _work(self) -> None:
        while True:
            with self._arrival:
                while self._pending is None and not self._stop.is_set():
                    self._arrival.wait()
                if self._stop.is_set():
                    return
                frame, self._pending = self._pending, None
                processors, viewers = self._processors, self._viewers
            assert frame is not None
            shown = self._process(frame, processors)
            if shown is None:
                continue
            self._shown = shown
            for viewer in viewers:
                viewer(shown)

    def _process(self, frame: Frame, processors: tuple[Processor, ...]) -> Shown | None:
        started = time.perf_counter()
        image = cv2.imdecode(np.frombuffer(frame.jpeg, np.uint8), cv2.IMREAD_COLOR)
        if image is None:
            self.decode_errors += 1
            return None
        self.decoded += 1
        self._image = (frame, image)
        overlays = []
        for processor in processors:
            try:
                overlay = processor(frame, image)
            except Exception:  # a processor's bug must not stop the camera: counted, logged once
                self.processor_errors += 1
                if id(processor) not in self._failed:
                    self._failed.add(id(processor))
                    log.exception("a camera frame processor failed (said once; /api/camera counts them)")
                continue
            if overlay is not None:
                overlays.append(overlay)
        jpeg = frame.jpeg
        if overlays:
            canvas = image.copy()
            for overlay in overlays:
                with contextlib.suppress(cv2.error):
                    overlay.draw(canvas)
            ok, data = cv2.imencode(".jpg", canvas, [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY])
            if ok:
                jpeg = data.tobytes()
        self.process_ms = (time.perf_counter() - started) * 1000.0
        return Shown(frame.seq, frame.stamp_s, jpeg)

"""The camera on the gateway: its MJPEG stream read (cart2d/perception/mjpeg.py), the newest frame
decoded, handed to the processors (perception plugs in here) and shown to the panel with what
they drew on it.

The ESP32-CAM serves one stream client, and the gateway is it; the panel watches the gateway's
re-stream (/api/camera/stream). Frames are processed in a thread of their own, newest first: a
processor slower than the camera skips frames rather than letting them queue (the stream's
reader never waits for it), so what the panel and the planner see is never older than one
processing step.

No frame ends the feed's thread: a frame is checked before it is decoded (its size in bytes and
the resolution its JPEG header declares, within what an OV2640 sends), and whatever goes wrong
with one (it does not decode, a processor or an overlay fails, a viewer raises) is counted, logged
once per kind and left behind for the next frame. What the thread last took in, and why nothing
since if so, is what status() reports: its liveness, not the stream's.
"""

from __future__ import annotations

import io
import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any
from urllib.parse import urlsplit, urlunsplit

import cv2
import numpy as np
from PIL import JpegImagePlugin

from cart2d.params import robot
from cart2d.perception.mjpeg import MAX_PART_BYTES, Frame, MjpegReader

log = logging.getLogger(__name__)

JPEG_QUALITY = 80  # the overlaid frames the panel sees (the stock sketch streams at about this)
# The largest frame an OV2640 sends (UXGA): a JPEG declaring more is refused before it is decoded
# (one declaring 10000 x 10000 in 586 KB took the gateway from 178 to 1008 MB, and a framesize
# the perception's calibration is not for is refused by perception, which says so).
MAX_WIDTH_PX, MAX_HEIGHT_PX = 1600, 1200


def frame_problem(jpeg: bytes) -> str | None:
    """Why a frame is not decoded, in words (None: it may be): larger than a frame buffer, not a
    JPEG whose header Pillow reads, or a resolution an OV2640 does not send. Only the header is
    read (Pillow's JPEG parser), not the image."""
    if len(jpeg) > MAX_PART_BYTES:
        return f"a frame of {len(jpeg)} bytes was refused (a camera's frame buffer holds {MAX_PART_BYTES})"
    try:
        width, height = JpegImagePlugin.JpegImageFile(io.BytesIO(jpeg)).size
    except Exception as exc:  # Pillow's parser raises what the bytes lead it to (OSError, SyntaxError, ...)
        return f"a frame that is not a readable JPEG was refused ({exc or type(exc).__name__})"
    if not (0 < width <= MAX_WIDTH_PX and 0 < height <= MAX_HEIGHT_PX):
        return (
            f"a frame of {width} x {height} pixels was refused (an OV2640 sends at most "
            f"{MAX_WIDTH_PX} x {MAX_HEIGHT_PX})"
        )
    return None


def blind_after_s() -> float:
    """No frame taken in for this long is a blind camera (robot.toml [planning] camera_blind_s)."""
    return float(robot()["planning"]["camera_blind_s"])


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

    def __init__(
        self,
        stream_url: str,
        base_url: str | None = None,
        stale_after_s: float = 2.0,
        blind_s: float | None = None,
    ) -> None:
        """`stale_after_s`: no frame decoded for this long ends the stream's connection (the reader
        connects again); `blind_s`: no frame taken in for this long is reported blind (robot.toml)."""
        self.base_url = base_url
        self.reader = MjpegReader(stream_url, self._arrived, stale_after_s, decodes_frames=True)
        self.blind_s = blind_after_s() if blind_s is None else blind_s
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
        self.refused = 0  # frames refused before decoding (frame_problem)
        self.processor_errors = 0
        self.overlay_errors = 0
        self.worker_errors = 0  # anything else that went wrong with a frame (a viewer, a re-encoding)
        self.taken = 0  # frames decoded that every processor took in without an error
        self.taken_s: float | None = None  # time.monotonic() of the last of them
        self.problem = ""  # what went wrong with the frames since the last one taken in, in words
        self.in_hand: int | None = None  # the seq of the frame the processors are working on
        self._logged: set[str] = set()  # the kinds of failure logged (once each)
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
        """The stream's state (the reader's) and the frame thread's: what it took in, how long ago
        (`age_s`), and whether that makes the camera blind, with why (`problem`)."""
        image = self._image
        reader = self.reader.status()
        age = None if self.taken_s is None else round(time.monotonic() - self.taken_s, 3)
        return {
            **reader,
            "received_age_s": reader["age_s"],  # the newest frame the stream delivered
            "age_s": age,  # the newest frame the processors took in: what the panel and perception see
            "state": "blind" if age is None or age > self.blind_s else "seeing",
            "problem": self.blindness() if age is None or age > self.blind_s else "",
            "worker": "running"
            if self._worker.is_alive()
            else ("stopped" if self._stop.is_set() else "ended"),
            "base_url": self.base_url,
            "decoded": self.decoded,
            "taken": self.taken,
            "refused": self.refused,
            "decode_errors": self.decode_errors,
            "processor_errors": self.processor_errors,
            "overlay_errors": self.overlay_errors,
            "worker_errors": self.worker_errors,
            "skipped": self.skipped,
            "process_ms": round(self.process_ms, 2),
            "processors": len(self._processors),
            "width": None if image is None else int(image[1].shape[1]),
            "height": None if image is None else int(image[1].shape[0]),
        }

    def blindness(self) -> str:
        """Why no frame has been taken in lately, as far as the feed knows, in words."""
        if not self._worker.is_alive():
            return "the camera's frame thread is not running" + (f" ({self.problem})" if self.problem else "")
        if self.problem:
            return self.problem
        reader = self.reader.status()
        if not reader["connected"]:
            return "the camera's stream is not connected" + (
                f" ({reader['last_error']})" if reader["last_error"] else ""
            )
        return "no frame came from the camera"

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
            try:  # whatever a frame does, the next one is processed
                shown = self._process(frame, processors)
                if shown is None:
                    continue
                self._shown = shown
                for viewer in viewers:
                    viewer(shown)
            except Exception as exc:
                self.worker_errors += 1
                self.problem = self._failed("a camera frame could not be shown", exc)

    def _failed(self, what: str, exc: Exception) -> str:
        """Logs each kind of failure once, with its traceback (status() counts them); what went
        wrong, in words. Called in an except block."""
        if f"{what}/{type(exc).__name__}" not in self._logged:
            self._logged.add(f"{what}/{type(exc).__name__}")
            log.exception("%s (said once for this kind; /api/camera counts them)", what)
        return f"{what}: {type(exc).__name__}" + (f": {exc}" if str(exc) else "")

    def _process(self, frame: Frame, processors: tuple[Processor, ...]) -> Shown | None:
        started = time.perf_counter()
        image = self._decoded(frame.jpeg)
        if image is None:
            return None
        self._image = (frame, image)
        overlays = self._take_in(frame, image, processors)
        jpeg = self._drawn(image, overlays) if overlays else frame.jpeg
        self.process_ms = (time.perf_counter() - started) * 1000.0
        return Shown(frame.seq, frame.stamp_s, jpeg)

    def _decoded(self, jpeg: bytes) -> np.ndarray | None:
        """The frame decoded (BGR), or None once why not is counted: refused before decoding
        (frame_problem), or not decoded."""
        problem = frame_problem(jpeg)
        if problem is not None:
            self.refused += 1
            self.problem = problem
            if "refused" not in self._logged:
                self._logged.add("refused")
                log.warning("%s (said once; /api/camera counts refused frames)", problem)
            return None
        image = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR)
        if image is None:
            self.decode_errors += 1
            self.problem = "a frame did not decode (a damaged JPEG)"
            return None
        self.decoded += 1
        self.reader.frame_decoded()  # the stream's stall timer runs on these
        return image

    def _take_in(self, frame: Frame, image: np.ndarray, processors: tuple[Processor, ...]) -> list[Overlay]:
        """Each processor's take on the frame; the frame is taken in if none failed."""
        overlays, failed = [], False
        self.in_hand = frame.seq
        try:
            for processor in processors:
                try:
                    overlay = processor(frame, image)
                except Exception as exc:  # a processor's bug, or a frame it cannot take: counted
                    self.processor_errors += 1
                    self.problem = self._failed("a camera frame processor failed", exc)
                    failed = True
                    continue
                if overlay is not None:
                    overlays.append(overlay)
        finally:
            self.in_hand = None
        if not failed:
            self.taken += 1
            self.taken_s = time.monotonic()
            self.problem = ""
        return overlays

    def _drawn(self, image: np.ndarray, overlays: list[Overlay]) -> bytes:
        """The frame as the panel sees it: a copy with the overlays drawn, as a JPEG."""
        canvas = image.copy()
        for overlay in overlays:
            try:
                overlay.draw(canvas)
            except Exception as exc:  # a drawing of another frame's size: the frame shows without it
                self.overlay_errors += 1
                self._failed("an overlay could not be drawn on a camera frame", exc)
        ok, data = cv2.imencode(".jpg", canvas, [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY])
        if not ok:
            raise ValueError("the frame with its overlays could not be encoded as a JPEG")
        return bytes(data.tobytes())

"""The camera's MJPEG stream, read the way the ESP32-CAM serves it, robustly.

The stock CameraWebServer sketch (and ESPHome's esp32_camera_web_server) answers GET /stream on
port 81 with `multipart/x-mixed-replace; boundary=...` and then, forever, parts of
`Content-Type: image/jpeg`, `Content-Length: N` and `X-Timestamp: sec.usec` followed by the JPEG.
HTTP (status, headers, chunked transfer) is http.client's; the per-part headers are parsed by
http.client.parse_headers (email's parser); all that is done here is finding the declared
boundary between parts.

What goes wrong with a camera on Wi-Fi, and what the reader does:
- the connection drops (Wi-Fi, a reboot): it connects again, with a back-off that doubles from
  `min_backoff_s` to `max_backoff_s` and starts over once a connection delivers a frame;
- the stream stalls (the socket stays open, nothing, garbage or a byte now and then comes): no
  frame for `stale_after_s` counts as a dropped connection. The timer runs on frames, never on
  bytes (a camera trickling a byte every 1.5 s inside a part was once connected for good): a
  watchdog thread ends the connection. With `decodes_frames`, the frames that count are those the
  caller decoded and said so with frame_decoded() (the gateway's camera feed), else those read;
- the camera serves one stream client only (the stock sketch answers a second one with an error
  or never): a refused connection is retried with the same back-off, and `stop()` closes the
  connection at once so the camera is free for whoever comes next;
- a frame whose X-Timestamp is not newer than the last one's (a repeated or stale frame) is
  dropped and counted; the last stamp is forgotten on a new connection, as a camera that
  rebooted starts its clock again, and when a stamp is over CLOCK_RESTART_S behind it (a clock
  that started again without the connection dropping: the simulator restarted);
- bytes between parts that are not a boundary are skipped (counted), up to MAX_SKIP_BYTES.

`on_frame` runs in the reader's thread: it must be quick (hand the frame over and return).
"""

from __future__ import annotations

import contextlib
import http.client
import logging
import math
import socket
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from email.message import Message
from typing import Any
from urllib.parse import urlsplit

log = logging.getLogger(__name__)

MAX_LINE_BYTES = 4096  # a line between parts is read in pieces of at most this (garbage is binary)
# A part larger than a camera's frame buffer: esp32-camera's JPEG buffer is width x height / 5
# (384 000 bytes at UXGA, the OV2640's largest), 1 MiB in builds that fix it.
MAX_PART_BYTES = 1024 * 1024
MAX_SKIP_BYTES = 1024 * 1024  # garbage without a boundary in it: the stream is broken, reconnect
FPS_WINDOW = 30  # frames the rate is measured over
# A stamp this far behind the last one is not a stale frame but a camera whose clock started
# again on the same connection (the simulator restarted under the camera's server): a stale
# frame is at most a buffer's worth (a frame or two) old.
CLOCK_RESTART_S = 2.0


@dataclass(frozen=True)
class Frame:
    """One JPEG of the stream. `stamp_s`: the camera's capture time (X-Timestamp) if it sent one;
    `received_s`: time.monotonic() when it arrived; `seq`: counts the frames delivered."""

    jpeg: bytes
    seq: int
    stamp_s: float | None
    received_s: float


class StreamError(Exception):
    """The stream cannot go on (the message says why); the reader connects again."""


def boundary_of(content_type: str) -> bytes:
    """The boundary a multipart Content-Type declares (email's parser: quotes, parameters)."""
    message = Message()
    message["content-type"] = content_type
    boundary = message.get_boundary()
    if message.get_content_maintype() != "multipart" or not boundary:
        raise StreamError(f"not an MJPEG stream: Content-Type {content_type!r} (multipart with a boundary)")
    return boundary.encode("latin-1")


def _stamp(text: str | None) -> float | None:
    if text is None:
        return None
    try:
        value = float(text.strip())
    except ValueError:
        return None
    return value if math.isfinite(value) else None


class MjpegReader:
    def __init__(
        self,
        stream_url: str,
        on_frame: Callable[[Frame], None],
        stale_after_s: float = 2.0,
        min_backoff_s: float = 0.1,
        max_backoff_s: float = 2.0,
        decodes_frames: bool = False,
    ) -> None:
        parts = urlsplit(stream_url)
        if parts.scheme != "http" or not parts.hostname:
            raise ValueError(f"the camera's stream must be an http:// URL, got {stream_url!r}")
        self.url = stream_url
        self._host = parts.hostname
        self._port = parts.port or 80
        self._path = (parts.path or "/") + (f"?{parts.query}" if parts.query else "")
        self.on_frame = on_frame
        self.stale_after_s = stale_after_s
        self.min_backoff_s = min_backoff_s
        self.max_backoff_s = max_backoff_s
        self.decodes_frames = decodes_frames
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._watchdog: threading.Thread | None = None
        self._fresh_s = 0.0  # time.monotonic() of this connection's start or its last frame
        self._stalled = ""  # why the watchdog ended the connection
        self._lock = threading.Lock()  # the counters, the latest frame and the connection
        self._conn: http.client.HTTPConnection | None = None
        self._sock: socket.socket | None = None
        self._latest: Frame | None = None
        self._received: deque[float] = deque(maxlen=FPS_WINDOW)
        self._last_stamp: float | None = None
        self._seq = 0
        self.connected = False
        self.connections = 0  # connections that answered with a stream
        self.reconnects = 0  # connections given up (dropped, stalled, refused) and tried again
        self.errors = 0  # what went wrong: dropped or refused connections, broken parts
        self.stale = 0  # frames dropped because their stamp was not newer than the last one's
        self.skipped_bytes = 0  # garbage between parts
        self.clock_restarts = 0  # stamps that went back by more than CLOCK_RESTART_S
        self.last_error = ""

    # -- the caller's side: none of these blocks on the camera --------------------------------
    def start(self) -> MjpegReader:
        if self._thread is None:
            self._thread = threading.Thread(target=self._run, name="mjpeg reader", daemon=True)
            self._watchdog = threading.Thread(target=self._watch, name="mjpeg watchdog", daemon=True)
            self._thread.start()
            self._watchdog.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        self._close_connection()
        for thread in (self._thread, self._watchdog):
            if thread is not None and thread is not threading.current_thread():
                thread.join(timeout=5.0)

    def frame_decoded(self) -> None:
        """A frame of this stream decoded (with `decodes_frames`): the stall timer starts again."""
        self._fresh_s = time.monotonic()

    def latest(self) -> Frame | None:
        return self._latest

    def status(self) -> dict[str, Any]:
        now = time.monotonic()
        with self._lock:
            times = list(self._received)
            latest = self._latest
            fps = (
                (len(times) - 1) / (times[-1] - times[0]) if len(times) > 1 and times[-1] > times[0] else 0.0
            )
            return {
                "url": self.url,
                "connected": self.connected,
                "fps": round(fps, 2),
                "age_s": None if latest is None else round(now - latest.received_s, 3),
                "frames": self._seq,
                "reconnects": self.reconnects,
                "errors": self.errors,
                "stale": self.stale,
                "skipped_bytes": self.skipped_bytes,
                "clock_restarts": self.clock_restarts,
                "last_error": self.last_error,
            }

    # -- the reader's thread ---------------------------------------------------------------
    def _run(self) -> None:
        backoff = self.min_backoff_s
        while not self._stop.is_set():
            frames_before = self._seq
            try:
                self._read_once()
            except Exception as exc:  # whatever broke this connection (StreamError, OSError, http.client's
                # errors, and theirs when stop() pulls the socket away mid-read): try another
                if self._stop.is_set():
                    break
                words = self._stalled or str(exc) or type(exc).__name__
                with self._lock:
                    self.errors += 1
                    self.last_error = words
                log.info("camera stream %s: %s; connecting again in %.1f s", self.url, words, backoff)
            finally:
                self._close_connection()
            if self._stop.is_set():
                break
            with self._lock:
                self.reconnects += 1
            if self._seq != frames_before:
                backoff = self.min_backoff_s  # that connection worked: this is a fresh drop
            self._stop.wait(backoff)
            backoff = min(backoff * 2.0, self.max_backoff_s)

    def _watch(self) -> None:
        """The watchdog's thread: ends a connection that has had no frame for stale_after_s (its
        reads then fail, and the reader connects again)."""
        period = min(0.1, self.stale_after_s / 4.0)
        while not self._stop.wait(period):
            with self._lock:
                sock = self._sock
                late = (
                    sock is not None
                    and not self._stalled
                    and time.monotonic() - self._fresh_s > self.stale_after_s
                )
                if late:
                    what = "decoded" if self.decodes_frames else "read"
                    self._stalled = f"no frame {what} for {self.stale_after_s:g} s: the stream stalled"
            if late and sock is not None:
                with contextlib.suppress(OSError):
                    sock.shutdown(socket.SHUT_RDWR)  # wakes the reader's blocked read

    def _read_once(self) -> None:
        """One connection, read until it fails (StreamError and friends) or stop()."""
        with self._lock:
            self._fresh_s, self._stalled = time.monotonic(), ""
        conn = http.client.HTTPConnection(self._host, self._port, timeout=self.stale_after_s)
        conn.connect()
        with self._lock:
            # the socket itself: http.client lets go of it once a response that ends with the
            # connection has begun (it lives on in the response), and stop() must wake its reads
            self._conn, self._sock = conn, conn.sock
        if self._stop.is_set():
            return
        conn.request("GET", self._path, headers={"Accept": "multipart/x-mixed-replace, image/jpeg"})
        response = conn.getresponse()
        if response.status != 200:
            raise StreamError(
                f"the camera answered {response.status} {response.reason} (busy with another client?)"
            )
        delimiter = b"--" + boundary_of(response.getheader("Content-Type", ""))
        with self._lock:
            self.connected = True
            self.connections += 1
            self._last_stamp = None  # a camera that rebooted restarts its clock
        at_boundary = False
        while not self._stop.is_set():
            if not at_boundary:
                self._seek(response, delimiter)
            headers = http.client.parse_headers(response)
            jpeg, at_boundary = self._part(response, headers, delimiter)
            kind = headers.get_content_type() if "content-type" in headers else "image/jpeg"
            if kind != "image/jpeg" or not jpeg.startswith(b"\xff\xd8"):
                with self._lock:
                    self.errors += 1
                    self.last_error = f"a part that is not a JPEG ({kind}, {len(jpeg)} bytes) was skipped"
                continue
            self._take(jpeg, _stamp(headers.get("X-Timestamp")), time.monotonic())

    def _seek(self, response: http.client.HTTPResponse, delimiter: bytes) -> None:
        """Reads up to and including the next boundary line, skipping anything else."""
        skipped = 0
        while True:
            line = response.readline(MAX_LINE_BYTES)
            if not line:
                raise StreamError("the camera closed the stream")
            text = line.rstrip(b"\r\n")
            if text in (delimiter, delimiter[2:]) and text:  # some servers write the boundary bare
                return
            if text == delimiter + b"--":
                raise StreamError("the camera ended the stream")
            if text.strip():
                skipped += len(line)
                with self._lock:
                    self.skipped_bytes += len(line)
                if skipped > MAX_SKIP_BYTES:
                    raise StreamError(f"{skipped} bytes without a boundary: not the stream it declared")

    def _part(
        self, response: http.client.HTTPResponse, headers: Message, delimiter: bytes
    ) -> tuple[bytes, bool]:
        """The part's body, and whether the next boundary line was read with it (a part without
        Content-Length ends at the boundary)."""
        length_text = headers.get("Content-Length")
        if length_text is not None:
            try:
                length = int(length_text)
            except ValueError:
                raise StreamError(f"a part's Content-Length is not a number: {length_text!r}") from None
            if not 0 <= length <= MAX_PART_BYTES:
                raise StreamError(f"a part of {length} bytes (at most {MAX_PART_BYTES})")
            body = response.read(length)
            if len(body) != length:
                raise StreamError(f"the connection dropped in a part ({len(body)} of {length} bytes)")
            return body, False
        lines: list[bytes] = []
        size = 0
        while True:
            line = response.readline(MAX_LINE_BYTES)
            if not line:
                raise StreamError("the connection dropped in a part")
            if line.rstrip(b"\r\n") == delimiter:
                body = b"".join(lines)
                return body[:-2] if body.endswith(b"\r\n") else body, True  # the CRLF before it
            size += len(line)
            if size > MAX_PART_BYTES:
                raise StreamError(f"a part without Content-Length over {MAX_PART_BYTES} bytes")
            lines.append(line)

    def _take(self, jpeg: bytes, stamp_s: float | None, received_s: float) -> None:
        with self._lock:
            last = self._last_stamp
            if stamp_s is not None and last is not None and stamp_s <= last:
                if last - stamp_s <= CLOCK_RESTART_S:
                    self.stale += 1
                    return
                self.clock_restarts += 1
            if stamp_s is not None:
                self._last_stamp = stamp_s
            self._seq += 1
            frame = Frame(jpeg, self._seq, stamp_s, received_s)
            self._latest = frame
            self._received.append(received_s)
            if not self.decodes_frames:
                self._fresh_s = received_s
        self.on_frame(frame)

    def _close_connection(self) -> None:
        with self._lock:
            conn, self._conn = self._conn, None
            sock, self._sock = self._sock, None
            self.connected = False
        if sock is not None:
            with contextlib.suppress(OSError):
                sock.shutdown(socket.SHUT_RDWR)  # wakes a read blocked in the reader's thread
        if conn is not None:
            conn.close()

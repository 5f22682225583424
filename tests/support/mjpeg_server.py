"""A test camera: an MJPEG server on 127.0.0.1 shaped like the ESP32-CAM's stock CameraWebServer
(one stream client at a time, the second answered 503), that misbehaves on purpose.

Each connection plays the next script of `scripts` (a list of steps), then streams frames with
increasing stamps until the client goes away. Steps:
  ("frame", stamp)            a part with Content-Length and X-Timestamp (stamp None: no header)
  ("bare", stamp)             a part without Content-Length (it ends at the next boundary)
  ("garbage", bytes)          bytes between parts
  ("cut", stamp)              a part whose connection drops halfway through its JPEG
  ("stall", seconds)          nothing is sent for that long (the socket stays open)
  ("trickle", (where, s))     a part sent one byte every s seconds, where = "headers" (the
                              boundary and the part's headers; then its JPEG at once) or "body"
                              (the headers at once, then the JPEG), until the client hangs up
  ("image", (stamp, jpeg))    a part with that JPEG
The server is http.server's (the test side of HTTP is a library too); JPEGs by cv2.imencode.
"""

from __future__ import annotations

import http.server
import io
import itertools
import select
import socket
import struct
import threading
import time
from typing import Any

import cv2
import numpy as np
from PIL import JpegImagePlugin

BOUNDARY = "123456789000000000000987654321"  # the stock sketch's


def jpeg_of(level: int, width: int = 32, height: int = 24) -> bytes:
    """A grey JPEG whose level tells which frame it is."""
    ok, data = cv2.imencode(".jpg", np.full((height, width, 3), level, dtype=np.uint8))
    assert ok
    return bytes(data)


def declaring(jpeg: bytes, width: int, height: int) -> bytes:
    """`jpeg` with its frame header (SOF0) declaring `width` x `height`: what a hostile camera
    sends, a decompression bomb of a few hundred bytes (Pillow reads the size back)."""
    at = jpeg.index(b"\xff\xc0") + 5  # the marker, its length (2) and precision (1): height, width
    out = jpeg[:at] + struct.pack(">HH", height, width) + jpeg[at + 4 :]
    assert JpegImagePlugin.JpegImageFile(io.BytesIO(out)).size == (width, height)  # no bomb warning
    return out


def level_for(stamp: float) -> int:
    return round(stamp * 10) % 200 + 20


def part(stamp: float | None, length: bool = True, jpeg: bytes | None = None) -> bytes:
    jpeg = jpeg if jpeg is not None else jpeg_of(level_for(stamp or 0.0))
    head = "Content-Type: image/jpeg\r\n"
    if length:
        head += f"Content-Length: {len(jpeg)}\r\n"
    if stamp is not None:
        head += f"X-Timestamp: {int(stamp)}.{round((stamp % 1) * 1e6):06d}\r\n"
    return f"\r\n--{BOUNDARY}\r\n{head}\r\n".encode() + jpeg


class MjpegServer:
    def __init__(
        self,
        scripts: list[list[tuple[str, Any]]],
        then_every_s: float = 0.02,
        stamp_now: bool = False,
        jpeg: bytes | None = None,
    ) -> None:
        """`stamp_now`: the endless frames are stamped time.monotonic() as they are sent (latency
        measurements on this machine); `jpeg`: the endless frames' image instead of the grey one."""
        self.scripts = list(scripts)
        self.then_every_s = then_every_s
        self.stamp_now = stamp_now
        self.jpeg = jpeg
        self.busy = threading.Lock()  # one stream client at a time, like the ESP32-CAM
        self.connections = 0
        self.refused = 0
        self.stamps = itertools.count(100)  # the endless part after the scripts: stamps 10.0, 10.1, ...
        self.closing = threading.Event()
        server = self

        class Handler(http.server.BaseHTTPRequestHandler):
            def log_message(self, *args: Any) -> None:
                pass

            def do_GET(self) -> None:
                if not server.busy.acquire(blocking=False):
                    server.refused += 1
                    self.send_error(503, "Only one stream client")
                    return
                try:
                    server.connections += 1
                    script = server.scripts.pop(0) if server.scripts else []
                    self.send_response(200)
                    self.send_header("Content-Type", f"multipart/x-mixed-replace;boundary={BOUNDARY}")
                    self.end_headers()
                    server.play(self, script)
                except (BrokenPipeError, ConnectionResetError):
                    pass
                finally:
                    server.busy.release()

        self.httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.httpd.daemon_threads = True
        self.url = f"http://127.0.0.1:{self.httpd.server_address[1]}/stream"
        self.thread = threading.Thread(target=self.httpd.serve_forever, daemon=True)

    def play(self, handler: http.server.BaseHTTPRequestHandler, script: list[tuple[str, Any]]) -> None:
        out = handler.wfile
        for step, value in script:
            if step == "frame":
                out.write(part(value))
            elif step == "bare":
                out.write(part(value, length=False))
            elif step == "garbage":
                out.write(value)
            elif step == "cut":
                data = part(value)
                out.write(data[: len(data) - 100])
                out.flush()
                return  # the handler returns: the server closes the connection mid-part
            elif step == "stall":
                out.flush()
                self.wait(handler, value)
                return  # the handler returns: the server closes the connection
            elif step == "trickle":
                self.trickle(handler, *value)
                return
            elif step == "image":
                out.write(part(value[0], jpeg=value[1]))
            out.flush()
        while not self.closing.is_set():
            stamp = time.monotonic() if self.stamp_now else next(self.stamps) / 10
            out.write(part(stamp, jpeg=self.jpeg))
            out.flush()
            time.sleep(self.then_every_s)

    def wait(self, handler: http.server.BaseHTTPRequestHandler, seconds: float) -> bool:
        """Sends nothing for `seconds`; True as soon as the client hung up (or the server closes),
        as the ESP32 notices a client that went away and takes the next."""
        end = time.monotonic() + seconds
        while time.monotonic() < end and not self.closing.is_set():
            readable, _, _ = select.select([handler.connection], [], [], 0.05)
            if readable and handler.connection.recv(1, socket.MSG_PEEK) == b"":
                return True
        return self.closing.is_set()

    def trickle(self, handler: http.server.BaseHTTPRequestHandler, where: str, every_s: float) -> None:
        """A part one byte every `every_s` (its headers, or its JPEG), until the client hangs up."""
        data = part(next(self.stamps) / 10)
        split = data.index(b"\r\n\r\n", 2) + 4  # the end of the part's headers
        fast, slow, rest = (
            (b"", data[:split], data[split:]) if where == "headers" else (data[:split], data[split:], b"")
        )
        handler.wfile.write(fast)
        for byte in slow:
            handler.wfile.write(bytes([byte]))
            handler.wfile.flush()
            if self.wait(handler, every_s):
                return
        handler.wfile.write(rest)
        handler.wfile.flush()

    def __enter__(self) -> MjpegServer:
        self.thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.closing.set()
        self.httpd.shutdown()
        self.httpd.server_close()


def main() -> None:
    """`python -m tests.support.mjpeg_server`: a well-behaved test camera until killed (the panel's tests;
    one stopped with SIGSTOP stalls)."""
    import argparse
    import signal

    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--every-s", type=float, default=0.1)
    parser.add_argument("--width", type=int, help="frames of this size, a plain grey (default 32 x 24)")
    parser.add_argument("--height", type=int)
    args = parser.parse_args()
    stop = {signal.SIGINT, signal.SIGTERM}
    signal.pthread_sigmask(signal.SIG_BLOCK, stop)  # waited for below, so the server closes
    jpeg = jpeg_of(128, args.width, args.height) if args.width and args.height else None
    with MjpegServer([], then_every_s=args.every_s, jpeg=jpeg) as server:
        print(server.url, flush=True)
        signal.sigwait(stop)


if __name__ == "__main__":
    main()

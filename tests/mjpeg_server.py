"""A test camera: an MJPEG server on 127.0.0.1 shaped like the ESP32-CAM's stock CameraWebServer
(one stream client at a time, the second answered 503), that misbehaves on purpose.

Each connection plays the next script of `scripts` (a list of steps), then streams frames with
increasing stamps until the client goes away. Steps:
  ("frame", stamp)            a part with Content-Length and X-Timestamp (stamp None: no header)
  ("bare", stamp)             a part without Content-Length (it ends at the next boundary)
  ("garbage", bytes)          bytes between parts
  ("cut", stamp)              a part whose connection drops halfway through its JPEG
  ("stall", seconds)          nothing is sent for that long (the socket stays open)
The server is http.server's (the test side of HTTP is a library too); JPEGs by cv2.imencode.
"""

from __future__ import annotations

import http.server
import itertools
import select
import socket
import threading
import time
from typing import Any

import cv2
import numpy as np

BOUNDARY = "123456789000000000000987654321"  # the stock sketch's


def jpeg_of(level: int, width: int = 32, height: int = 24) -> bytes:
    """A grey JPEG whose level tells which frame it is."""
    ok, data = cv2.imencode(".jpg", np.full((height, width, 3), level, dtype=np.uint8))
    assert ok
    return bytes(data)


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
                if self.stall(handler, value):
                    return
            out.flush()
        while not self.closing.is_set():
            stamp = time.monotonic() if self.stamp_now else next(self.stamps) / 10
            out.write(part(stamp, jpeg=self.jpeg))
            out.flush()
            time.sleep(self.then_every_s)

    def stall(self, handler: http.server.BaseHTTPRequestHandler, seconds: float) -> bool:
        """Sends nothing for `seconds`; True as soon as the client hung up (or the server closes),
        as the ESP32 notices a client that went away and takes the next."""
        end = time.monotonic() + seconds
        while time.monotonic() < end and not self.closing.is_set():
            readable, _, _ = select.select([handler.connection], [], [], 0.05)
            if readable and handler.connection.recv(1, socket.MSG_PEEK) == b"":
                return True
        return True

    def __enter__(self) -> MjpegServer:
        self.thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.closing.set()
        self.httpd.shutdown()
        self.httpd.server_close()


def main() -> None:
    """`python -m tests.mjpeg_server`: a well-behaved test camera until killed (the panel's tests)."""
    import argparse
    import signal

    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--every-s", type=float, default=0.1)
    args = parser.parse_args()
    stop = {signal.SIGINT, signal.SIGTERM}
    signal.pthread_sigmask(signal.SIG_BLOCK, stop)  # waited for below, so the server closes
    with MjpegServer([], then_every_s=args.every_s) as server:
        print(server.url, flush=True)
        signal.sigwait(stop)


if __name__ == "__main__":
    main()

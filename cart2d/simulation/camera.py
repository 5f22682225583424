"""The simulated ESP32-CAM at the stock CameraWebServer's URLs, so that the gateway reads the
simulator's camera by the same code path as a real one (docs/camera.md):

- `http://HOST:P/capture`: one JPEG (a frame newer than the request);
- `http://HOST:P/status`: the settings as JSON (framesize, quality, ...);
- `http://HOST:P/control?var=framesize&val=N` (and quality, and the sketch's other variables);
- `http://HOST:(P+1)/stream`: MJPEG (multipart/x-mixed-replace with the sketch's boundary), each
  part with Content-Type, Content-Length and X-Timestamp: the frame's SIMULATED capture time.

As on the board, the stream serves one client at a time: its server task is busy streaming, so a
second client's request waits until the first leaves. Frames come from the simulator's side
channel on a connection of our own; the simulator renders only while someone here wants frames.
HTTP is starlette on uvicorn (no hand-written parsing)."""

from __future__ import annotations

import asyncio
import contextlib
import logging
import socket
import threading
import time
from collections.abc import AsyncIterator, Callable
from dataclasses import dataclass, field
from typing import Any

import anyio.to_thread
import uvicorn
from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import JSONResponse, PlainTextResponse, Response, StreamingResponse
from starlette.routing import Route

from cart2d.params import robot
from cart2d.simulation.controls import CameraTimeout, SimFrame, wait_frame
from cart2d.simulation.side_channel import SideChannel, SimulatorError

log = logging.getLogger(__name__)

# esp32-camera's framesize_t (sensor.h), the index /control?var=framesize takes.
FRAMESIZES: tuple[tuple[int, int], ...] = (
    (96, 96),  # 0 FRAMESIZE_96X96
    (160, 120),  # 1 QQVGA
    (176, 144),  # 2 QCIF
    (240, 176),  # 3 HQVGA
    (240, 240),  # 4 240X240
    (320, 240),  # 5 QVGA
    (400, 296),  # 6 CIF
    (480, 320),  # 7 HVGA
    (640, 480),  # 8 VGA
    (800, 600),  # 9 SVGA
    (1024, 768),  # 10 XGA
    (1280, 720),  # 11 HD
    (1280, 1024),  # 12 SXGA
    (1600, 1200),  # 13 UXGA
)
# CameraWebServer's app_httpd.cpp: PART_BOUNDARY and its stream part header.
PART_BOUNDARY = "123456789000000000000987654321"
STREAM_CONTENT_TYPE = f"multipart/x-mixed-replace;boundary={PART_BOUNDARY}"
# The sketch's other /control variables: accepted and reported by /status, not simulated.
OTHER_VARIABLES = {
    "brightness": 0, "contrast": 0, "saturation": 0, "sharpness": 0, "special_effect": 0, "wb_mode": 0,
    "awb": 1, "awb_gain": 1, "aec": 1, "aec2": 0, "ae_level": 0, "aec_value": 168, "agc": 1,
    "agc_gain": 0, "gainceiling": 0, "bpc": 0, "wpc": 1, "raw_gma": 1, "lenc": 1, "hmirror": 0,
    "vflip": 0, "dcw": 1, "colorbar": 0, "led_intensity": 0,
}  # fmt: skip
FRAME_WAIT_S = 5.0  # a /capture waits this long (wall) for a frame: the simulator may be paused
HOST = "127.0.0.1"  # the simulated camera serves this machine


def timestamp_text(t_s: float) -> str:
    """X-Timestamp as the sketch writes it: "%d.%06d" of seconds and microseconds."""
    sec, usec = divmod(round(t_s * 1e6), 1_000_000)
    return f"{sec}.{usec:06d}"


def ov2640_quality(jpeg_quality: int) -> int:
    """The sensor's quality register (0-63, lower is better, the sketch's default 10) for a
    libjpeg quality (robot.toml's 80 <-> 10)."""
    return max(0, min(63, round((100 - jpeg_quality) / 2)))


def jpeg_quality_of(ov2640: int) -> int:
    return max(1, min(100, 100 - 2 * ov2640))


@dataclass
class CameraState:
    framesize: int = 5
    quality: int = 10
    others: dict[str, int] = field(default_factory=lambda: dict(OTHER_VARIABLES))

    @classmethod
    def from_robot(cls) -> CameraState:
        cam, sim = robot()["camera"], robot()["sim"]["camera"]
        size = (int(cam["width_px"]), int(cam["height_px"]))
        index = FRAMESIZES.index(size) if size in FRAMESIZES else 5
        return cls(framesize=index, quality=ov2640_quality(int(sim["jpeg_quality"])))

    def settings(self) -> dict[str, Any]:
        width, height = FRAMESIZES[self.framesize]
        return {"width": width, "height": height, "jpeg_quality": jpeg_quality_of(self.quality)}


class FrameSource:
    """Frames from the simulator on a side-channel connection of our own: the camera is on while
    at least one holder wants frames; the connection is made again after a simulator restart."""

    def __init__(self, address: Callable[[], str], state: CameraState) -> None:
        self._address = address
        self.state = state
        self._lock = threading.Lock()
        self._side: SideChannel | None = None
        self._wanted = 0
        self._on = False
        self._sent_settings: dict[str, Any] | None = None

    def want(self, delta: int) -> None:
        with self._lock:
            self._wanted += delta
            self._sync()

    def configure(self) -> None:
        with self._lock:
            self._sync()

    def _connection(self) -> SideChannel:
        if self._side is not None and self._side.closed:
            self._side = None
        if self._side is None:
            address = self._address()
            if not address:
                raise SimulatorError("the simulator is not running")
            self._side = SideChannel(address)
            self._on, self._sent_settings = False, None
        return self._side

    def _sync(self) -> None:
        try:
            side = self._connection()
            want = self._wanted > 0
            settings = self.state.settings()
            if want != self._on or settings != self._sent_settings:
                side.request({"type": "camera", "on": want, **settings})
                self._on, self._sent_settings = want, settings
        except (SimulatorError, OSError) as exc:
            log.warning("simulated camera: %s", exc)
            self._side = None

    def latest_seq(self) -> int:
        with self._lock:
            side = self._side
        frame = side.frame if side is not None else None
        return int(frame["seq"]) if frame is not None else -1

    def next_frame(self, after_seq: int, timeout_s: float) -> SimFrame:
        with self._lock:
            if self._side is None or self._side.closed:
                self._sync()  # the simulator restarted: connect and turn it on again
            side = self._side
        if side is None:
            raise CameraTimeout("the simulator is not running")
        return wait_frame(side, after_seq, timeout_s)

    def close(self) -> None:
        with self._lock:
            if self._side is not None:
                self._side.close()
                self._side = None


def _jpeg_headers(frame: SimFrame) -> dict[str, str]:
    return {"X-Timestamp": timestamp_text(frame.t), "Access-Control-Allow-Origin": "*"}


def control_app(source: FrameSource) -> Starlette:
    """Port P: /capture, /status, /control."""

    async def capture(request: Request) -> Response:
        source.want(+1)
        try:
            after = source.latest_seq()
            frame = await anyio.to_thread.run_sync(source.next_frame, after, FRAME_WAIT_S)
        except CameraTimeout as exc:
            return PlainTextResponse(f"Camera capture failed: {exc}", status_code=500)
        finally:
            source.want(-1)
        headers = {**_jpeg_headers(frame), "Content-Disposition": "inline; filename=capture.jpg"}
        return Response(frame.jpeg, media_type="image/jpeg", headers=headers)

    async def status(request: Request) -> Response:
        s = source.state
        body = {"framesize": s.framesize, "quality": s.quality, **s.others}
        return JSONResponse(body, headers={"Access-Control-Allow-Origin": "*"})

    async def control(request: Request) -> Response:
        var, val = request.query_params.get("var"), request.query_params.get("val")
        try:
            value = int(val) if val is not None else None
        except ValueError:
            value = None
        s = source.state
        if var is None or value is None:
            return PlainTextResponse("", status_code=404)
        if var == "framesize" and 0 <= value < len(FRAMESIZES):
            s.framesize = value
        elif var == "quality" and 0 <= value <= 63:
            s.quality = value
        elif var in s.others:
            s.others[var] = value
        else:  # the sketch answers an unknown variable or a refused value with 500
            return PlainTextResponse("", status_code=500)
        await anyio.to_thread.run_sync(source.configure)
        return Response(b"", headers={"Access-Control-Allow-Origin": "*"})

    routes = [Route("/capture", capture), Route("/status", status), Route("/control", control)]
    return Starlette(routes=routes)


def stream_app(source: FrameSource) -> Starlette:
    """Port P+1: /stream, one client at a time."""
    busy = asyncio.Lock()

    async def parts() -> AsyncIterator[bytes]:
        async with busy:  # the sketch's stream server has one task: the next client waits here
            source.want(+1)
            try:
                seq = source.latest_seq()  # from the next frame on, as a fresh stream
                while True:
                    try:
                        frame = await anyio.to_thread.run_sync(source.next_frame, seq, 1.0)
                    except CameraTimeout:
                        continue  # paused or between frames: keep the connection, as the sketch does
                    seq = frame.seq
                    head = (
                        f"\r\n--{PART_BOUNDARY}\r\nContent-Type: image/jpeg\r\n"
                        f"Content-Length: {len(frame.jpeg)}\r\nX-Timestamp: {timestamp_text(frame.t)}\r\n\r\n"
                    )
                    yield head.encode() + frame.jpeg
            finally:
                source.want(-1)

    async def stream(request: Request) -> Response:
        return StreamingResponse(
            parts(), media_type=STREAM_CONTENT_TYPE, headers={"Access-Control-Allow-Origin": "*"}
        )

    return Starlette(routes=[Route("/stream", stream)])


class SimCameraServer:
    """The two servers (control on port, stream on port + 1) in threads of their own."""

    def __init__(
        self,
        address: Callable[[], str],
        port: int,
        host: str = HOST,
        sockets: list[socket.socket] | None = None,
    ) -> None:
        """`sockets`: listening on port and port + 1 already (cart2d sim opens them before anything
        starts, so that a port in use is said in a sentence); else the servers bind them."""
        self.host, self.port = host, port
        self._sockets = sockets
        self.source = FrameSource(address, CameraState.from_robot())
        self._servers: list[uvicorn.Server] = []
        self._threads: list[threading.Thread] = []

    @property
    def url(self) -> str:
        """The base URL, as a user would give it for a real camera (`--camera URL`)."""
        return f"http://{self.host}:{self.port}"

    @property
    def stream_url(self) -> str:
        return f"http://{self.host}:{self.port + 1}/stream"

    def start(self, timeout_s: float = 10.0) -> SimCameraServer:
        apps = ((control_app(self.source), self.port), (stream_app(self.source), self.port + 1))
        for k, (app, port) in enumerate(apps):
            config = uvicorn.Config(app, host=self.host, port=port, log_level="warning", lifespan="off")
            server = uvicorn.Server(config)
            sockets = {"sockets": [self._sockets[k]]} if self._sockets else {}
            thread = threading.Thread(
                target=server.run, kwargs=sockets, name=f"sim camera :{port}", daemon=True
            )
            thread.start()
            self._servers.append(server)
            self._threads.append(thread)
        deadline = time.monotonic() + timeout_s
        while not all(s.started for s in self._servers):
            if time.monotonic() > deadline or not all(t.is_alive() for t in self._threads):
                self.stop()
                raise SimulatorError(
                    f"the simulated camera cannot listen on {self.host}:{self.port}/{self.port + 1}"
                )
            time.sleep(0.01)
        return self

    def stop(self) -> None:
        for server in self._servers:
            server.should_exit = True
            server.force_exit = True  # a stream in progress never ends by itself
        for thread in self._threads:
            thread.join(timeout=5.0)
        self._servers, self._threads = [], []
        self.source.close()

    def __enter__(self) -> SimCameraServer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        with contextlib.suppress(Exception):
            self.stop()

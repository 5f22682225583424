"""The camera on the gateway (cart2d/gateway/camera.py, cart2d/server/camera.py): the feed of a
test camera (tests/support/mjpeg_server.py), its frames with the processors' overlays, and the re-stream
to any number of panels, a slow one of which loses frames and holds no more than its backlog;
frames an OV2640 does not send refused before decoding, no frame ending the feed's thread, and
/api/camera saying whether the frames are taken in, and why not."""

from __future__ import annotations

import socket
import threading
from collections.abc import Iterator
from types import SimpleNamespace
from typing import Any, cast

import cv2
import numpy as np
import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient

from cart2d.gateway.camera import CameraFeed, Overlay, frame_problem, stream_url_for
from cart2d.gateway.camera_service import CameraService
from cart2d.perception.mjpeg import MAX_PART_BYTES, Frame, MjpegReader
from cart2d.server import create_app, serving
from cart2d.server.camera import CAMERA_BACKLOG, CameraWatchers
from cart2d.server.routes import camera as camera_routes
from tests.support.mjpeg_server import MjpegServer, declaring, jpeg_of
from tests.support.server import Rig
from tests.support.waiting import wait_for


@pytest.fixture
def camera() -> Iterator[MjpegServer]:
    with MjpegServer([], then_every_s=0.01) as server:
        yield server


def decoded(jpeg: bytes) -> np.ndarray:
    image = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR)
    assert image is not None
    return image


def test_without_a_camera_the_api_says_how_to_give_one(rig: Rig) -> None:
    state = rig.client.get("/api/camera").json()
    assert state["camera"] is False and "--camera" in state["message"]
    for path in ("/api/camera/frame.jpg", "/api/camera/stream"):
        answer = rig.client.get(path)
        assert answer.status_code == 404 and "--camera" in answer.json()["detail"]


def test_frames_are_shown_with_the_processors_overlays(rig: Rig, camera: MjpegServer) -> None:
    feed = CameraFeed(camera.url, "http://127.0.0.1:1")
    seen: list[tuple[Frame, tuple[int, ...]]] = []

    def box(frame: Frame, bgr: np.ndarray) -> Overlay:
        seen.append((frame, bgr.shape))
        return Overlay(lambda canvas: cv2.rectangle(canvas, (0, 0), (7, 7), (255, 255, 255), cv2.FILLED))

    def broken(frame: Frame, bgr: np.ndarray) -> Overlay | None:
        raise RuntimeError("a processor's bug")

    feed.add_processor(broken)
    feed.add_processor(box)
    rig.gateway.camera = feed.start()
    try:
        wait_for(lambda: feed.shown() is not None and len(seen) >= 3, 10.0)
        answer = rig.client.get("/api/camera/frame.jpg")
        assert answer.status_code == 200 and answer.headers["content-type"] == "image/jpeg"
        image = decoded(answer.content)
        assert image.shape == (24, 32, 3)
        assert image[2:6, 2:6].mean() > 240  # the overlay's white box
        assert image[12:20, 16:28].mean() < 230  # the camera's grey elsewhere
        assert seen[0][1] == (24, 32, 3)  # processors see the decoded BGR frame
        state = rig.client.get("/api/camera").json()
        assert state["camera"] and state["connected"] and state["fps"] > 0
        assert state["url"] == "http://127.0.0.1:1" and state["stream_url"] == camera.url
        assert state["processor_errors"] >= 1 and state["width"] == 32 and state["height"] == 24
    finally:
        feed.stop()


class Served:
    """The app served as `cart2d serve` does (its capped send buffers), in a thread."""

    def __init__(self, app: Any) -> None:
        self.sock = serving.listening_socket("127.0.0.1", 0)
        self.port = self.sock.getsockname()[1]
        self.server = serving.server(app)
        self.thread = threading.Thread(target=self.server.run, kwargs={"sockets": [self.sock]}, daemon=True)
        self.thread.start()
        wait_for(lambda: self.server.started, 10.0)

    def close(self) -> None:
        self.server.should_exit = True
        self.thread.join(timeout=10.0)
        self.sock.close()


def test_the_restream_serves_many_panels_and_a_slow_one_loses_frames(rig: Rig, camera: MjpegServer) -> None:
    feed = CameraFeed(camera.url)
    rig.gateway.camera = feed.start()
    app = create_app(rig.gateway, simulation=rig.simulation.add_routes)
    served = Served(app)
    readers: list[MjpegReader] = []
    slow = socket.create_connection(("127.0.0.1", served.port))
    try:
        # a panel that asks for the stream and never reads it
        slow.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        slow.sendall(b"GET /api/camera/stream HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")
        got: list[list[Frame]] = [[], [], []]
        for frames in got:
            url = f"http://127.0.0.1:{served.port}/api/camera/stream"
            readers.append(MjpegReader(url, frames.append).start())
        wait_for(lambda: all(len(frames) >= 30 for frames in got), 20.0)
        for frames in got:  # every panel got whole frames of the camera's, with its stamps
            assert all(decoded(f.jpeg).shape == (24, 32, 3) for f in frames)
            assert all(f.stamp_s is not None and f.stamp_s >= 10.0 for f in frames)
        assert all(r.status()["errors"] == 0 for r in readers)
        (watchers,) = app.state.camera_watchers.values()
        assert len(watchers.watchers) == 4
        wait_for(lambda: max(w.dropped for w in watchers.watchers) > 10, 30.0)  # the slow one loses frames...
        stuck = max(watchers.watchers, key=lambda w: w.dropped)
        assert len(stuck.queue) <= CAMERA_BACKLOG  # ...and holds no more than its backlog
        # while it is stuck, the other panels go on getting frames
        counts = [len(frames) for frames in got]
        wait_for(lambda: all(len(f) >= n + 20 for f, n in zip(got, counts, strict=True)), 20.0)
        for reader in readers:
            reader.stop()
        slow.close()
        wait_for(lambda: len(watchers.watchers) == 0, 10.0)  # panels that left are forgotten
    finally:
        for reader in readers:
            reader.stop()
        slow.close()
        served.close()
        feed.stop()


def test_the_stream_url_of_a_base_url_is_the_stock_sketchs() -> None:
    assert stream_url_for("http://192.168.4.1") == "http://192.168.4.1:81/stream"
    assert stream_url_for("http://cam.local:8180/") == "http://cam.local:8181/stream"
    assert stream_url_for("http://[fe80::1]:80") == "http://[fe80::1]:81/stream"
    for bad in ("ftp://cam", "http://cam/stream", "cam:80"):
        with pytest.raises(ValueError):
            stream_url_for(bad)
    assert CameraFeed.of(None, None) is None
    feed = CameraFeed.of("http://cam:80", "http://cam:9000/video")
    assert feed is not None and feed.reader.url == "http://cam:9000/video"


def test_the_camera_set_through_the_api_is_saved_and_read_at_once(rig: Rig, camera: MjpegServer) -> None:
    answer = rig.client.put("/api/settings/camera", json={"stream_url": camera.url})
    assert answer.status_code == 200, answer.text
    assert answer.json()["camera"] and answer.json()["stream_url"] == camera.url
    wait_for(lambda: rig.client.get("/api/camera/frame.jpg").status_code == 200, 10.0)
    assert rig.store.load().camera.stream_url == camera.url
    feed = rig.gateway.camera
    assert feed is not None
    for body, words in [
        ({"url": "http://cam/stream"}, "url: String should match pattern '^http://"),
        ({"url": "ftp://cam"}, "url: String should match pattern"),
        ({"url": "http://cam:65536"}, "url: String should match pattern"),
        ({"stream_url": "http://cam:81/a b"}, "stream_url: String should match pattern"),
        ({"stream_url": 81}, "stream_url"),
        ({"url": "http://cam", "extra": 1}, "extra"),
    ]:
        refused = rig.client.put("/api/settings/camera", json=body)
        assert refused.status_code == 422 and words in refused.json()["detail"], refused.json()
        assert rig.gateway.camera is feed and rig.store.load().camera.stream_url == camera.url
    # no camera: the feed is stopped (the camera is free for another client) and that is saved
    gone = rig.client.put("/api/settings/camera", json={"url": None, "stream_url": None}).json()
    assert gone["camera"] is False and rig.gateway.camera is None
    assert not feed.reader.status()["connected"] and rig.store.load().camera.stream_url is None
    assert rig.client.get("/api/camera/frame.jpg").status_code == 404


def test_a_settings_file_with_a_camera_switches_to_it(rig: Rig, camera: MjpegServer) -> None:
    file = rig.client.get("/api/settings/file").json()
    answer = rig.client.post("/api/settings/file", json={**file, "camera": {"stream_url": camera.url}})
    assert answer.status_code == 200, answer.text
    wait_for(lambda: rig.client.get("/api/camera").json().get("connected") is True, 10.0)
    bad = {**file, "camera": {"url": "http://cam/stream"}}
    refused = rig.client.post("/api/settings/file", json=bad)
    assert refused.status_code == 422 and "camera.url" in refused.json()["detail"]
    assert rig.store.load().camera.stream_url == camera.url
    rig.gateway.use_camera(None)


def test_no_camera_through_the_api_stops_a_camera_the_command_line_gave(
    rig: Rig, camera: MjpegServer
) -> None:
    feed = CameraFeed(camera.url)
    rig.gateway.use_camera(feed.start())  # as `cart2d serve --camera-stream URL`: not saved
    wait_for(lambda: feed.reader.status()["connected"], 10.0)
    assert rig.store.load().camera.stream_url is None
    gone = rig.client.put("/api/settings/camera", json={"url": None, "stream_url": None})
    assert gone.status_code == 200 and gone.json()["camera"] is False
    assert rig.gateway.camera is None and not feed.reader.status()["connected"]


def test_a_restream_without_frames_for_a_while_ends() -> None:
    """The camera sends one frame and stalls: the panel's stream ends (it opens it again later)."""
    with MjpegServer([[("frame", 1.0), ("stall", 60.0)]]) as stalled:
        feed = CameraFeed(stalled.url, stale_after_s=60.0).start()
        try:
            wait_for(lambda: feed.shown() is not None, 10.0)
            with camera_api(feed) as client:
                answer = client.get("/api/camera/stream")
            assert answer.status_code == 200
            assert answer.headers["content-type"] == "multipart/x-mixed-replace; boundary=cart2d-frame"
            assert answer.content.count(b"--cart2d-frame\r\n") == 1
            assert b"X-Timestamp: 1.000000\r\n" in answer.content
        finally:
            feed.stop()


def camera_api(feed: CameraFeed) -> TestClient:
    """/api/camera and friends for `feed` alone (no gateway, no simulator): the Gateway's own
    camera_view (the camera service's), over a stand-in that has only the feed."""
    holder = cast(CameraService, SimpleNamespace(camera=feed, calibration_summary=lambda: None))
    app = FastAPI()
    app.state.source = SimpleNamespace(
        camera_feed=lambda: feed, camera_view=lambda: CameraService.camera_view(holder)
    )
    app.state.camera_watchers = CameraWatchers()
    app.router.routes.extend(camera_routes.router.routes)
    return TestClient(app)


def test_an_overlay_that_cannot_be_drawn_leaves_the_frames_coming() -> None:
    # Once, the overlay drawn for a frame of the size before (the camera's framesize changed)
    # raised IndexError: only cv2.error was suppressed, the feed's thread ended for good and
    # /api/camera still said connected at 15 fps.
    def stale_drawing(frame: Frame, bgr: np.ndarray) -> Overlay:
        return Overlay(lambda canvas: canvas.__setitem__((239, 319), 255))  # a QVGA pixel, on 32 x 24

    with MjpegServer([], then_every_s=0.01) as camera:
        feed = CameraFeed(camera.url)
        feed.add_processor(stale_drawing)
        feed.start()
        try:
            wait_for(lambda: feed.decoded >= 20, 30.0)
            state = camera_api(feed).get("/api/camera").json()
            assert state["worker"] == "running" and state["state"] == "seeing"
            assert state["overlay_errors"] >= 19 and state["taken"] >= 20 and state["worker_errors"] == 0
            assert state["age_s"] is not None and state["problem"] == ""
        finally:
            feed.stop()
    assert feed.status()["worker"] == "stopped"


def test_frames_larger_than_an_ov2640_sends_are_refused_before_decoding() -> None:
    # Once, a 586 KB JPEG decoding to 10000 x 10000 took the gateway from 178 to 1008 MB.
    bomb = declaring(jpeg_of(128), 10_000, 10_000)  # declared in a few hundred bytes
    frames = [bomb, jpeg_of(128, 1601, 1200), jpeg_of(128)]
    feed = CameraFeed("http://127.0.0.1:1/stream")  # frames handed over as the reader does
    feed.start()
    try:
        for k, jpeg in enumerate(frames):
            feed._arrived(Frame(jpeg, k + 1, float(k), 0.0))
            wait_for(lambda n=k: feed.refused + feed.decoded > n, 30.0)  # type: ignore[misc]
        state = feed.status()
    finally:
        feed.stop()
    assert state["refused"] == 2 and state["decoded"] == 1 and state["decode_errors"] == 0
    assert (state["width"], state["height"]) == (32, 24)  # only the grey frame after them was decoded


def test_the_frame_problem_says_why_in_words() -> None:
    assert frame_problem(jpeg_of(128, 1600, 1200)) is None
    assert frame_problem(jpeg_of(128, 1601, 1200)) == (
        "a frame of 1601 x 1200 pixels was refused (an OV2640 sends at most 1600 x 1200)"
    )
    too_big = frame_problem(b"\xff\xd8" + bytes(MAX_PART_BYTES))
    assert too_big is not None and "bytes was refused" in too_big
    damaged = frame_problem(b"\xff\xd8\xff\xe0 not a header")
    assert damaged is not None and damaged.startswith("a frame that is not a readable JPEG was refused")


def test_a_camera_whose_frames_perception_cannot_take_is_reported_blind_with_why() -> None:
    def vga_only(frame: Frame, bgr: np.ndarray) -> None:
        raise ValueError(f"a {bgr.shape[1]} x {bgr.shape[0]} image; the calibration is for (640, 480)")

    with MjpegServer([], then_every_s=0.01) as camera:
        feed = CameraFeed(camera.url, blind_s=0.2)
        feed.add_processor(vga_only)
        feed.start()
        try:
            wait_for(lambda: feed.decoded >= 5, 30.0)
            state = camera_api(feed).get("/api/camera").json()
        finally:
            feed.stop()
    assert state["connected"] and state["worker"] == "running"  # the stream and the thread are fine...
    assert state["state"] == "blind" and state["age_s"] is None and state["taken"] == 0  # ...the eyes are not
    assert state["problem"] == (
        "a camera frame processor failed: ValueError: a 32 x 24 image; the calibration is for (640, 480)"
    )

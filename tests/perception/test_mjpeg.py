"""The MJPEG reader (cart2d/perception/mjpeg.py) against a test camera that misbehaves on purpose
(tests/support/mjpeg_server.py): dropped connections, a stalled stream and one trickling bytes, repeated
and stale stamps, garbage between parts, one stream client at a time."""

from __future__ import annotations

import asyncio
import http.client
import itertools
import socket
import threading
from collections.abc import AsyncIterator, Iterator
from typing import Any

import cv2
import numpy as np
import pytest
import uvicorn
from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import StreamingResponse
from starlette.routing import Route

from cart2d.perception.mjpeg import Frame, MjpegReader, StreamError, boundary_of
from tests.support.mjpeg_server import BOUNDARY, MjpegServer, level_for, part
from tests.support.waiting import wait_for


class Collected:
    def __init__(self) -> None:
        self.frames: list[Frame] = []
        self.lock = threading.Lock()

    def __call__(self, frame: Frame) -> None:
        with self.lock:
            self.frames.append(frame)

    def stamps(self) -> list[float | None]:
        with self.lock:
            return [f.stamp_s for f in self.frames]

    def count(self) -> int:
        with self.lock:
            return len(self.frames)


@pytest.fixture
def collected() -> Collected:
    return Collected()


def level(frame: Frame) -> float:
    image = cv2.imdecode(np.frombuffer(frame.jpeg, np.uint8), cv2.IMREAD_GRAYSCALE)
    assert image is not None and image.shape == (24, 32)
    return float(image.mean())


def reading(server: MjpegServer, collected: Collected, **options: Any) -> Iterator[MjpegReader]:
    return reading_url(server.url, collected, **options)


def reading_url(url: str, collected: Collected, **options: Any) -> Iterator[MjpegReader]:
    """The reader, started, for the loop's body; stopped after it."""
    reader = MjpegReader(url, collected, **options).start()
    try:
        yield reader
    finally:
        reader.stop()


def test_frames_arrive_whole_with_their_stamps(collected: Collected) -> None:
    script = [("frame", 1.0), ("frame", 1.1), ("frame", 1.2)]
    with MjpegServer([script]) as server:
        for reader in reading(server, collected):
            wait_for(lambda: collected.count() >= 10, 10.0)
            frames = collected.frames[:10]
            assert [f.stamp_s for f in frames[:3]] == [1.0, 1.1, 1.2]
            for frame in frames:
                assert frame.stamp_s is not None
                assert level(frame) == pytest.approx(level_for(frame.stamp_s), abs=2)
            assert [f.seq for f in frames] == list(range(1, 11))
            status = reader.status()
            assert status["connected"] and status["fps"] > 0 and status["errors"] == 0
            assert reader.latest() is collected.frames[-1] or reader.latest() in collected.frames


def test_a_connection_dropped_mid_part_is_reopened_and_the_cut_frame_never_delivered(
    collected: Collected,
) -> None:
    first = [("frame", 1.0), ("frame", 1.1), ("cut", 1.2)]
    second = [("frame", 2.0)]
    with MjpegServer([first, second]) as server:
        for reader in reading(server, collected):
            wait_for(lambda: 2.0 in collected.stamps(), 10.0)
            stamps = collected.stamps()
            assert stamps[:3] == [1.0, 1.1, 2.0]  # 1.2 was cut: never handed over
            for frame in collected.frames[:3]:
                level(frame)  # every frame handed over decodes
            status = reader.status()
            assert status["reconnects"] >= 1 and status["errors"] >= 1
            assert "dropped in a part" in status["last_error"] or "closed" in status["last_error"]
            assert server.connections >= 2


def test_a_stalled_stream_is_given_up_and_reopened(collected: Collected) -> None:
    first = [("frame", 1.0), ("stall", 30.0)]
    with MjpegServer([first, [("frame", 2.0)]]) as server:
        for reader in reading(server, collected, stale_after_s=0.3):
            wait_for(lambda: 2.0 in collected.stamps(), 10.0)
            assert collected.stamps()[:2] == [1.0, 2.0]
            assert reader.status()["reconnects"] >= 1


@pytest.mark.parametrize("where", ["headers", "body"])
def test_a_camera_trickling_a_byte_at_a_time_inside_a_part_is_called_stalled(
    collected: Collected, where: str
) -> None:
    # A byte every 0.1 s, well within the socket's timeout: once, the reader stayed connected for
    # good (the stall timer ran on bytes), and the frame's age grew without limit.
    first = [("frame", 1.0), ("trickle", (where, 0.1))]
    with MjpegServer([first, [("frame", 2.0)]]) as server:
        for reader in reading(server, collected, stale_after_s=0.5):
            wait_for(lambda: 2.0 in collected.stamps(), 30.0)
            assert collected.stamps()[:2] == [1.0, 2.0]  # the trickled part never handed over
            status = reader.status()
            assert (
                status["reconnects"] >= 1
                and "no frame read for 0.5 s: the stream stalled" in status["last_error"]
            )


def test_with_a_decoder_the_stall_timer_runs_on_frames_it_decoded(collected: Collected) -> None:
    # frames keep coming, but none is said to be decoded: the connection is given up again and again
    with MjpegServer([]) as server:
        for reader in reading(server, collected, stale_after_s=0.3, decodes_frames=True):
            wait_for(lambda r=reader: r.status()["reconnects"] >= 2, 30.0)  # type: ignore[misc]
            assert collected.count() > 0
            assert "no frame decoded for 0.3 s" in reader.status()["last_error"]


def test_repeated_and_stale_stamps_are_dropped_and_counted(collected: Collected) -> None:
    script = [("frame", 1.0), ("frame", 1.1), ("frame", 1.1), ("frame", 1.05), ("frame", 1.2)]
    with MjpegServer([script]) as server:
        for reader in reading(server, collected):
            wait_for(lambda: collected.count() >= 4, 10.0)
            assert collected.stamps()[:4] == [1.0, 1.1, 1.2, 10.0]
            assert reader.status()["stale"] == 2


def test_a_clock_that_starts_again_on_the_same_connection_is_followed(collected: Collected) -> None:
    # the simulator restarted under the camera's server: its time went from 5.1 s back to 0.2 s
    script = [("frame", 5.0), ("frame", 5.1), ("frame", 4.9), ("frame", 0.2), ("frame", 0.3), ("frame", 0.25)]
    with MjpegServer([script]) as server:
        for reader in reading(server, collected):
            wait_for(lambda: collected.count() >= 5, 10.0)
            assert collected.stamps()[:5] == [5.0, 5.1, 0.2, 0.3, 10.0]
            status = reader.status()
            assert status["stale"] == 2 and status["clock_restarts"] == 1 and status["reconnects"] == 0


def test_frames_without_stamps_are_all_taken(collected: Collected) -> None:
    with MjpegServer([[("frame", None), ("frame", None)]]) as server:
        for _ in reading(server, collected):
            wait_for(lambda: collected.count() >= 3, 10.0)
            assert collected.stamps()[:3] == [None, None, 10.0]


def test_garbage_between_parts_is_skipped(collected: Collected) -> None:
    junk = b"\x00\x01junk that is no boundary\r\n--not-the-boundary\r\n\xff\xd8\xff\r\n"
    script = [("frame", 1.0), ("garbage", junk), ("frame", 1.1), ("garbage", b"\r\n\r\n"), ("frame", 1.2)]
    with MjpegServer([script]) as server:
        for reader in reading(server, collected):
            wait_for(lambda: collected.count() >= 4, 10.0)
            assert collected.stamps()[:3] == [1.0, 1.1, 1.2]
            status = reader.status()
            assert status["skipped_bytes"] == len(junk)  # the blank lines before a boundary are not junk
            assert status["errors"] == 0 and status["reconnects"] == 0


def test_a_part_without_content_length_ends_at_the_boundary(collected: Collected) -> None:
    with MjpegServer([[("bare", 1.0), ("bare", 1.1), ("frame", 1.2)]]) as server:
        for _ in reading(server, collected):
            wait_for(lambda: collected.count() >= 3, 10.0)
            assert collected.stamps()[:3] == [1.0, 1.1, 1.2]
            for frame in collected.frames[:3]:
                assert frame.stamp_s is not None
                assert level(frame) == pytest.approx(level_for(frame.stamp_s), abs=2)


def test_a_busy_camera_is_retried_until_it_is_free(collected: Collected) -> None:
    with MjpegServer([]) as server:
        host, port = server.url.removeprefix("http://").split("/")[0].split(":")
        other = http.client.HTTPConnection(host, int(port), timeout=5)
        other.request("GET", "/stream")
        held = other.getresponse()
        assert held.status == 200  # another client holds the only stream
        for reader in reading(server, collected, max_backoff_s=0.2):
            wait_for(lambda: server.refused >= 2, 10.0)
            status = reader.status()
            assert not status["connected"] and collected.count() == 0
            assert "503" in status["last_error"]
            held.close()  # the other client goes: the camera notices at its next write
            wait_for(lambda: collected.count() >= 3, 10.0)
            assert reader.status()["connected"]
        # stop() let the camera go at once: the next client gets the stream
        again = Collected()
        for _ in reading(server, again):
            wait_for(lambda: again.count() >= 1, 10.0)


def test_stop_returns_while_the_stream_stalls(collected: Collected) -> None:
    with MjpegServer([[("frame", 1.0), ("stall", 30.0)]]) as server:
        reader = MjpegReader(server.url, collected, stale_after_s=60.0).start()
        wait_for(lambda: collected.count() == 1, 10.0)
        reader.stop()
        assert reader._thread is not None and not reader._thread.is_alive()
        assert not reader.status()["connected"]


def test_the_boundary_comes_from_the_content_type() -> None:
    assert boundary_of("multipart/x-mixed-replace;boundary=123456789000000000000987654321") == (
        b"123456789000000000000987654321"
    )
    assert boundary_of('multipart/x-mixed-replace; boundary="frame boundary"; x=1') == b"frame boundary"
    for bad in ("image/jpeg", "multipart/x-mixed-replace", ""):
        with pytest.raises(StreamError):
            boundary_of(bad)
    with pytest.raises(ValueError, match="http://"):
        MjpegReader("rtsp://camera/stream", lambda frame: None)


def test_a_chunked_stream_as_the_esp32_sends_it(collected: Collected) -> None:
    """The stock sketch sends its parts with chunked transfer encoding (httpd_resp_send_chunk):
    here uvicorn's, with chunks that split parts and headers anywhere."""

    async def parts() -> AsyncIterator[bytes]:
        for k in itertools.count():
            data = part(1.0 + k / 10)
            yield data[:7]
            yield data[7:50]
            yield data[50 : len(data) // 2]
            yield data[len(data) // 2 :]
            await asyncio.sleep(0.01)

    async def stream(request: Request) -> StreamingResponse:
        return StreamingResponse(parts(), media_type=f"multipart/x-mixed-replace;boundary={BOUNDARY}")

    app = Starlette(routes=[Route("/stream", stream)])
    sock = socket.create_server(("127.0.0.1", 0))
    server = uvicorn.Server(uvicorn.Config(app, log_level="warning", lifespan="off"))
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    try:
        wait_for(lambda: server.started, 10.0)
        url = f"http://127.0.0.1:{sock.getsockname()[1]}/stream"
        for reader in reading_url(url, collected):
            wait_for(lambda: collected.count() >= 5, 10.0)
            assert collected.stamps()[:5] == [1.0, 1.1, 1.2, 1.3, 1.4]
            for frame in collected.frames[:5]:
                assert frame.stamp_s is not None
                assert level(frame) == pytest.approx(level_for(frame.stamp_s), abs=2)
            assert reader.status()["errors"] == 0
    finally:
        server.should_exit = True
        thread.join(timeout=10.0)
        sock.close()

"""Live data does not starve the stop (issue 11, finding 7): telemetry leaves the link's reader
at once, viewers have bounded queues that lose old messages, and their number is capped."""

from __future__ import annotations

import asyncio
import base64
import json
import logging
import os
import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from websockets.asyncio.client import connect
from websockets.exceptions import ConnectionClosed

from cart2d.server import live as live_module
from cart2d.server.live import BURST_SAMPLES, MERGE_AFTER, STATE_KINDS, TRY_AGAIN_LATER, Viewers
from tests.support.live import LiveGateway
from tests.support.server import Rig
from tests.support.waiting import wait_for


@pytest.fixture
def live(tmp_path: Path) -> Iterator[LiveGateway]:
    gateway = LiveGateway(tmp_path)
    yield gateway
    gateway.close()


def test_a_slow_telemetry_listener_does_not_hold_up_the_replies(tmp_path: Path) -> None:
    """However long the fan-out of a telemetry frame takes (here 0.2 s, while frames come every
    40 ms), the link's reader keeps decoding replies: every request is answered."""
    rig = Rig(tmp_path)
    slow = threading.Event()

    def listener(message: dict[str, Any]) -> None:
        if message["type"] == "telemetry" and not slow.is_set():
            time.sleep(0.2)

    try:
        rig.gateway.subscribe(listener)
        failures = []
        for _ in range(40):
            response = rig.client.post("/api/command", json={"name": "POSE", "args": []})
            if response.status_code != 200:
                failures.append(response.text)
        assert not failures, failures[:3]
        assert rig.client.post("/api/stop").status_code == 200
    finally:
        slow.set()
        rig.close()


def stalled_viewer(port: int) -> socket.socket:
    """A WebSocket client that completes the handshake and then never reads a byte."""
    sock = socket.create_connection(("127.0.0.1", port))
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    key = base64.b64encode(os.urandom(16)).decode()
    sock.sendall(
        (
            f"GET /ws HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
            f"Sec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n"
        ).encode()
    )
    return sock


def test_a_viewer_that_never_reads_holds_a_bounded_backlog_and_the_others_go_on(live: LiveGateway) -> None:
    viewers: Viewers = live.app.state.viewers
    stalled = [stalled_viewer(live.port) for _ in range(5)]
    received: list[float] = []
    done = threading.Event()

    async def reader() -> None:
        async with connect(f"ws://127.0.0.1:{live.port}/ws", proxy=None) as ws:
            while not done.is_set():
                json.loads(await ws.recv())
                received.append(time.monotonic())

    thread = threading.Thread(target=asyncio.run, args=(reader(),), daemon=True)
    thread.start()
    try:
        wait_for(lambda: len(viewers.viewers) == 6, 20)
        # Ground truth at 50 simulated Hz with the simulator at full speed: hundreds of messages
        # a second; once the kernel's buffers are full, a stalled viewer's frames are merged.
        wait_for(lambda: sum(v.merged > 0 for v in viewers.viewers) >= 5, 60)
        per_frame = 2 * BURST_SAMPLES + len(STATE_KINDS)  # no events come meanwhile
        for viewer in viewers.viewers:
            assert len(viewer.frames) <= MERGE_AFTER + 1
            assert sum(len(f.items) for f in viewer.frames) <= (MERGE_AFTER + 1) * per_frame
        count = len(received)
        wait_for(lambda: len(received) > count + 100, 30)  # the reading viewer keeps receiving
        assert live.http().call("POST", "/api/stop")[0] == 200
    finally:
        done.set()
        for sock in stalled:
            sock.close()
        thread.join(10)


def test_viewers_beyond_the_cap_are_told_to_try_again_later(
    live: LiveGateway, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The rule, not the number: a cap of 8 here (MAX_VIEWERS, 256, is exercised by make bench,
    # section "control", with 200 viewers).
    monkeypatch.setattr(live_module, "MAX_VIEWERS", 8)
    cap = live_module.MAX_VIEWERS
    url = f"ws://127.0.0.1:{live.port}/ws"

    async def crowd() -> tuple[int, int | None, str]:
        sockets = [await connect(url, proxy=None, open_timeout=30) for _ in range(cap)]
        try:
            served = 0
            for ws in sockets:
                served += json.loads(await ws.recv())[0]["type"] == "hello"
            async with connect(url, proxy=None) as extra:
                with pytest.raises(ConnectionClosed):
                    while True:
                        await extra.recv()
                assert extra.close_code is not None
                return served, extra.close_code, extra.close_reason or ""
        finally:
            await asyncio.gather(*(ws.close() for ws in sockets))

    served, code, reason = asyncio.run(crowd())
    assert served == cap
    assert code == TRY_AGAIN_LATER and f"at most {cap} viewers" in reason
    # Once the crowd has gone, a viewer is served again.
    wait_for(lambda: not live.app.state.viewers.viewers, 20)

    async def one() -> str:
        async with connect(url, proxy=None) as ws:
            kind: str = json.loads(await ws.recv())[0]["type"]
            return kind

    assert asyncio.run(one()) == "hello"


def test_a_viewer_that_goes_away_leaves_no_traceback(
    live: LiveGateway, caplog: pytest.LogCaptureFixture
) -> None:
    """A browser tab closed (a close frame) or a connection dropped (no close frame): the gateway
    logs nothing of it (issue 22: a 65-line WebSocketDisconnect traceback per closed tab)."""
    viewers: Viewers = live.app.state.viewers
    url = f"ws://127.0.0.1:{live.port}/ws"

    async def closed_tab() -> None:
        async with connect(url, proxy=None) as ws:
            await ws.recv()

    async def dropped() -> None:
        ws = await connect(url, proxy=None)
        await ws.recv()
        ws.transport.abort()  # the TCP connection goes without a close frame

    with caplog.at_level(logging.INFO):
        for leave in (closed_tab, dropped):
            asyncio.run(leave())
        wait_for(lambda: not viewers.viewers, 20)
        wait_for(lambda: not live.server.server_state.tasks, 20)  # every ASGI task has ended
    noisy = [r for r in caplog.records if r.exc_info or r.levelno >= logging.WARNING]
    assert not noisy, [r.getMessage() for r in noisy]

"""Reads take turns on the event loop; changes and the stop do not wait for them (server/reads.py).
A fake application: what is counted is who is let in, not time."""

from __future__ import annotations

import asyncio
import itertools
from typing import Any

import pytest

from cart2d.server.reads import Pace, ReadsInTurn


def test_reads_beyond_their_turns_wait_while_a_change_goes_straight_in() -> None:
    async def scenario() -> None:
        inside: list[str] = []
        release = asyncio.Event()

        async def app(scope: dict[str, Any], receive: Any, send: Any) -> None:
            inside.append(f"{scope['method']} {scope['path']}")
            if scope["method"] == "GET":
                await release.wait()

        turns = ReadsInTurn(app, reads_at_once=3)  # type: ignore[arg-type]

        def request(method: str, path: str) -> asyncio.Task[None]:
            scope = {"type": "http", "method": method, "path": path}
            return asyncio.create_task(turns(scope, None, None))  # type: ignore[arg-type]

        reads = [request("GET", "/api/status") for _ in range(10)]
        for _ in range(5):
            await asyncio.sleep(0)
        assert inside == ["GET /api/status"] * 3
        stop = request("POST", "/api/stop")
        await stop
        assert inside[-1] == "POST /api/stop" and len(inside) == 4
        release.set()
        await asyncio.gather(*reads)
        assert inside.count("GET /api/status") == 10

    asyncio.run(scenario())


def test_a_stream_gives_its_turn_back_once_its_answer_starts() -> None:
    """The camera's re-stream lasts as long as its watcher: it must not hold a read's turn."""

    async def scenario() -> None:
        streaming = asyncio.Event()
        answered: list[str] = []

        async def app(scope: dict[str, Any], receive: Any, send: Any) -> None:
            await send({"type": "http.response.start", "status": 200, "headers": []})
            if scope["path"] == "/api/camera/stream":
                await streaming.wait()  # the watcher watches
            answered.append(scope["path"])

        async def send(message: Any) -> None:
            pass

        turns = ReadsInTurn(app, reads_at_once=2)  # type: ignore[arg-type]

        def get(path: str) -> asyncio.Task[None]:
            scope = {"type": "http", "method": "GET", "path": path}
            return asyncio.create_task(turns(scope, None, send))  # type: ignore[arg-type]

        streams = [get("/api/camera/stream") for _ in range(3)]  # more than there are turns
        async with asyncio.timeout(10):  # before: the streams held every turn, for ever
            await get("/api/status")
        assert answered == ["/api/status"]
        streaming.set()
        await asyncio.gather(*streams)

    asyncio.run(scenario())


def test_reads_are_paced_to_their_rate_after_a_burst() -> None:
    """On a fake clock: 1000 reads at once against 200 a second with bursts of 50."""
    pace = Pace(200.0, 50)
    delays = [pace.delay_s(10.0) for _ in range(1000)]
    assert delays[:50] == pytest.approx([0.0] * 50, abs=1e-9)  # a burst goes at once
    assert delays[50] == pytest.approx(1 / 200)
    assert delays[-1] == pytest.approx((1000 - 50) / 200)  # then 200 a second
    assert all(b >= a for a, b in itertools.pairwise(delays))
    # a panel reading once a second never waits
    pace = Pace(200.0, 50)
    assert all(pace.delay_s(float(t)) < 1e-9 for t in range(100))

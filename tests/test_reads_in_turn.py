"""Reads take turns on the event loop; changes and the stop do not wait for them (server/reads.py).
A fake application: what is counted is who is let in, not time."""

from __future__ import annotations

import asyncio
from typing import Any

from cart2d.server.reads import ReadsInTurn


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

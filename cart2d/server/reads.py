"""Reads take turns, so that a flood of them cannot hold up the stop on the event loop.

Every request's work on the event loop (routing, the answer's JSON, its sending) is served in
arrival order: with a hundred clients reading /api/status as fast as they are answered, each
turn of the loop had a hundred answers to finish before the stop's next step, and a stop took
0.1-0.7 s through its three steps on the loop (issue 22). Reads (GET and HEAD) are therefore let
in at most READS_AT_ONCE at a time; the others wait, costing the loop nothing, while changes and
the stop go straight in. A read is not urgent: it is answered a little later, never refused.
"""

from __future__ import annotations

import asyncio

from starlette.types import ASGIApp, Message, Receive, Scope, Send

READS_AT_ONCE = 8  # a panel reads a few things at a time; more would only queue on the loop


class ReadsInTurn:
    """Pure ASGI middleware: GET and HEAD requests wait for one of READS_AT_ONCE turns, held
    until their answer starts."""

    def __init__(self, app: ASGIApp, reads_at_once: int = READS_AT_ONCE) -> None:
        self.app = app
        self.reads_at_once = reads_at_once
        self._turns: dict[asyncio.AbstractEventLoop, asyncio.Semaphore] = {}  # one per event loop

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http" or scope["method"] not in ("GET", "HEAD"):
            await self.app(scope, receive, send)
            return
        loop = asyncio.get_running_loop()
        turns = self._turns.get(loop)
        if turns is None:
            turns = self._turns[loop] = asyncio.Semaphore(self.reads_at_once)
        await turns.acquire()
        held = True

        async def send_then_give_the_turn_back(message: Message) -> None:
            # At the answer's start: the rest is the body, and a stream (the camera's
            # re-stream) may last as long as its watcher, which must hold no turn meanwhile.
            nonlocal held
            if held and message["type"] == "http.response.start":
                held = False
                turns.release()
            await send(message)

        try:
            await self.app(scope, receive, send_then_give_the_turn_back)
        finally:
            if held:
                turns.release()

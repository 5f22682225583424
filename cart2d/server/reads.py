"""Reads take turns, so that a flood of them cannot hold up the stop on the event loop.

Every request's work on the event loop (routing, the answer's JSON, its sending) is served in
arrival order: with a hundred clients reading /api/status as fast as they are answered, each
turn of the loop had a hundred answers to finish before the stop's next step, and a stop took
0.1-0.7 s through its three steps on the loop (issue 22). And a flood of reads takes the
gateway's CPU and its GIL, which the link's reader thread needs to decode the firmware's replies
in time (a stop's reply dropped, resent after 250 ms, three stops in 150 answered 503). Reads
(GET and HEAD) are therefore let in at most READS_AT_ONCE at a time and READS_PER_S a second,
all clients together (Pace); the others wait, costing nothing, while changes and the stop go
straight in. A read is not urgent: it is answered a little later, never refused.
"""

from __future__ import annotations

import asyncio

from starlette.types import ASGIApp, Message, Receive, Scope, Send

READS_AT_ONCE = 8  # a panel reads a few things at a time; more would only queue on the loop
# A panel reads its status once a second and a few things at start: 100 panels' worth. A read
# costs the loop about 0.5 ms: a tenth of a core at most.
READS_PER_S = 200.0
READS_AT_ONCE_IN_A_BURST = 50  # let in at once after a quiet spell (a panel's start: ~20)


class Pace:
    """When each of a stream of requests may go: at most `per_s` a second on average, `burst`
    at once after a quiet spell (the generic cell rate algorithm: each request is given the
    earliest time that keeps the stream within both)."""

    def __init__(self, per_s: float, burst: int) -> None:
        self.spacing_s = 1.0 / per_s
        self.tolerance_s = (burst - 1) * self.spacing_s
        self._due = 0.0  # the theoretical time of the next request

    def delay_s(self, now: float) -> float:
        """How long a request arriving at `now` waits (and it is counted as gone by then)."""
        due = max(self._due, now)
        self._due = due + self.spacing_s
        return max(0.0, due - self.tolerance_s - now)


class ReadsInTurn:
    """Pure ASGI middleware: GET and HEAD requests wait for their time (Pace), then for one of
    READS_AT_ONCE turns, held until their answer starts."""

    def __init__(
        self, app: ASGIApp, reads_at_once: int = READS_AT_ONCE, reads_per_s: float = READS_PER_S
    ) -> None:
        self.app = app
        self.reads_at_once = reads_at_once
        self.pace = Pace(reads_per_s, READS_AT_ONCE_IN_A_BURST)
        self._turns: dict[asyncio.AbstractEventLoop, asyncio.Semaphore] = {}  # one per event loop

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http" or scope["method"] not in ("GET", "HEAD"):
            await self.app(scope, receive, send)
            return
        loop = asyncio.get_running_loop()
        turns = self._turns.get(loop)
        if turns is None:
            turns = self._turns[loop] = asyncio.Semaphore(self.reads_at_once)
        wait_s = self.pace.delay_s(loop.time())
        if wait_s > 0:
            await asyncio.sleep(wait_s)
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

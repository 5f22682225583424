"""Motion requests belong to the stop generation of the moment they arrive; the stop runs in
threads of its own.

A stop cancels every motion request that came before it (cart2d/link/transport.py, stop
generations). "Came before" must mean arrival at the gateway, not the moment a worker thread
gets round to the request: a stop sent after a drive may overtake it on the way through the
middleware and the thread pool, and would otherwise be answered before the drive is even seen.
So the outermost layer of the application, in the first step of the request's task (the event
loop runs those in the order the requests were read), notes the token in the request's scope,
and the motion routes take it from there.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

from starlette.requests import Request
from starlette.types import ASGIApp, Receive, Scope, Send

SCOPE_KEY = "cart2d.motion_token"


class MotionTokens:
    """Pure ASGI middleware (no task of its own, nothing awaited before the note is taken)."""

    def __init__(self, app: ASGIApp, token: Callable[[], int]) -> None:
        self.app = app
        self.token = token  # Gateway.motion_token

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] == "http":
            scope[SCOPE_KEY] = self.token()
        await self.app(scope, receive, send)


def motion_token(request: Request) -> int | None:
    """The token noted as the request arrived (a dependency of the motion routes); None when the
    middleware is not in place (the link then takes the token when the command is sent)."""
    token = request.scope.get(SCOPE_KEY)
    return token if isinstance(token, int) else None


STOP_THREADS = 4  # stops at once, each in a thread of its own (one may wait for a firmware update)


class Stopper:
    """Runs the gateway's stop in threads of its own. Every other route that blocks runs in the
    server's shared thread pool (anyio's, 40 threads): a hundred status reads or goals waiting
    for the link or the gateway's lock fill it, and a stop queued behind them would wait for
    every one (issue 22: 100 concurrent reads held the stop 0.8-1.1 s)."""

    def __init__(self, stop: Callable[[], object]) -> None:
        self._stop = stop
        self._threads = ThreadPoolExecutor(STOP_THREADS, thread_name_prefix="stop")

    async def __call__(self) -> None:
        await asyncio.get_running_loop().run_in_executor(self._threads, self._stop)

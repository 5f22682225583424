"""Motion requests belong to the stop generation of the moment they arrive.

A stop cancels every motion request that came before it (cart2d/link/transport.py, stop
generations). "Came before" must mean arrival at the gateway, not the moment a worker thread
gets round to the request: a stop sent after a drive may overtake it on the way through the
middleware and the thread pool, and would otherwise be answered before the drive is even seen.
So the outermost layer of the application, in the first step of the request's task (the event
loop runs those in the order the requests were read), notes the token in the request's scope,
and the motion routes take it from there.
"""

from __future__ import annotations

from starlette.requests import Request
from starlette.types import ASGIApp, Receive, Scope, Send

from cart2d.link import Link

SCOPE_KEY = "cart2d.motion_token"


class MotionTokens:
    """Pure ASGI middleware (no task of its own, nothing awaited before the note is taken)."""

    def __init__(self, app: ASGIApp, link: Link) -> None:
        self.app = app
        self.link = link

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] == "http":
            scope[SCOPE_KEY] = self.link.motion_token()
        await self.app(scope, receive, send)


def motion_token(request: Request) -> int | None:
    """The token noted as the request arrived (a dependency of the motion routes); None when the
    middleware is not in place (the link then takes the token when the command is sent)."""
    token = request.scope.get(SCOPE_KEY)
    return token if isinstance(token, int) else None

"""What the route modules depend on, wired in one place: create_app puts the gateway (as the
gateway, and as the Source the reading routes answer from), the access token's check and the
stop's threads in `app.state`, and these dependencies hand them to routes. A replay's app
(cart2d/recording/replay_app.py) puts only a Source there and takes only the routes that need
nothing more.

They are `async def` on purpose: FastAPI runs a plain `def` dependency in the shared thread pool,
which a hundred waiting reads fill (issue 22); these only read app.state."""

from __future__ import annotations

import hmac
from typing import Annotated

from fastapi import Depends, HTTPException, Request

from cart2d.gateway import Gateway
from cart2d.server.motion import Stopper, motion_token
from cart2d.server.source import Source


class AccessToken:
    """The access token's check: off loopback, changes and the WebSocket need the token."""

    def __init__(self, token: str | None, needed: bool) -> None:
        self._token = token
        self._needed = needed

    def ok(self, supplied: str | None) -> bool:
        # compared as bytes: compare_digest refuses str with non-ASCII characters (a TypeError, a 500)
        return not self._needed or (
            supplied is not None
            and self._token is not None
            and hmac.compare_digest(supplied.encode("utf-8", "surrogatepass"), self._token.encode())
        )


async def gateway_of(request: Request) -> Gateway:
    gateway: Gateway = request.app.state.gateway
    return gateway


async def source_of(request: Request) -> Source:
    source: Source = request.app.state.source
    return source


async def stopper_of(request: Request) -> Stopper:
    stopper: Stopper = request.app.state.stopper
    return stopper


async def require_token(request: Request) -> None:
    access: AccessToken = request.app.state.access
    supplied = request.headers.get("x-cart2d-token")
    auth = request.headers.get("authorization", "")
    if auth.lower().startswith("bearer "):
        supplied = auth[7:]
    if not access.ok(supplied):
        raise HTTPException(401, "this gateway needs its access token (shown in its terminal) for changes")


GatewayDep = Annotated[Gateway, Depends(gateway_of)]
SourceDep = Annotated[Source, Depends(source_of)]
StopperDep = Annotated[Stopper, Depends(stopper_of)]
Guarded = Depends(require_token)
Motion = Depends(motion_token)  # the stop generation at the request's arrival (server/motion.py)

"""/ws: the live data, to viewers of the same origin that hold the token when one is needed."""

from __future__ import annotations

from fastapi import APIRouter, WebSocket

from cart2d.server.deps import AccessToken
from cart2d.server.live import Viewers
from cart2d.server.models import errors

router = APIRouter(responses=errors(413))  # as the app's own routes (create_app)


@router.websocket("/ws")
async def live(ws: WebSocket) -> None:
    origin = ws.headers.get("origin")
    host = ws.headers.get("host", "")
    if origin is not None and origin.split("://", 1)[-1] != host:
        await ws.close(code=1008, reason="cross-origin WebSocket refused")
        return
    access: AccessToken = ws.app.state.access
    if not access.ok(ws.query_params.get("token")):
        await ws.close(code=1008, reason="this gateway needs its access token")
        return
    await ws.accept()
    viewers: Viewers = ws.app.state.viewers
    await viewers.serve(ws)

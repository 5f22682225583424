"""The fleet manager's live stream (the WebSocket /ws): the fleet page's view pushed to it as it
changes instead of polled. Each message is one views.FleetUpdate (JSON), sent at connection and
then whenever the view differs from the one sent last, looked at STREAM_PERIOD_S apart: the
manager has no event of its own for every change (a cart's pose moves at every state it
publishes), and a view made here costs what the page's poll did, without the HTTP round trip.
Read only: goals, pauses and STOP ALL stay POST requests, behind the same guards."""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Callable

from starlette.concurrency import run_in_threadpool
from starlette.websockets import WebSocket, WebSocketDisconnect

from cart2d.fleet.views import FleetUpdate, FleetView

STREAM_PERIOD_S = 0.1  # the page saw the view every 0.25 s when it polled
MAX_VIEWERS = 16  # each costs a view made 10 times a second


class FleetStream:
    def __init__(self, view: Callable[[], FleetView], period_s: float = STREAM_PERIOD_S) -> None:
        self._view = view
        self._period_s = period_s
        self.viewers = 0

    def _text(self) -> str:
        return FleetUpdate(type="fleet", view=self._view()).model_dump_json()

    async def serve(self, ws: WebSocket) -> None:
        """Streams to `ws` until it closes; refuses it (1013, try again later) beyond MAX_VIEWERS."""
        await ws.accept()
        if self.viewers >= MAX_VIEWERS:
            await ws.close(1013, f"the fleet manager streams to {MAX_VIEWERS} pages at most")
            return
        self.viewers += 1
        closed = asyncio.ensure_future(_until_closed(ws))
        try:
            last = ""
            while not closed.done():
                text = await run_in_threadpool(self._text)  # the manager's lock is not the loop's
                if text != last:
                    await ws.send_text(text)
                    last = text
                await asyncio.wait({closed}, timeout=self._period_s)
        except (WebSocketDisconnect, RuntimeError, OSError):
            pass  # the page went: no error of ours
        finally:
            self.viewers -= 1
            closed.cancel()


async def _until_closed(ws: WebSocket) -> None:
    """Reads until the page closes the socket (it sends nothing the stream wants)."""
    with contextlib.suppress(WebSocketDisconnect, RuntimeError, OSError):
        while (await ws.receive())["type"] != "websocket.disconnect":
            pass

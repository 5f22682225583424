"""The live data on /ws: telemetry, ground truth and the gateway's events, fanned out to viewers.

The gateway hands each message over once (one call into the event loop, whatever the number of
viewers); it is encoded once and put in every viewer's own queue, which holds the newest
VIEWER_BACKLOG messages: a viewer that reads slower than they come, or not at all, loses old ones
and holds no more than that, while the others and the serial link go on undisturbed. At most
MAX_VIEWERS viewers at a time; one more is told so and closed (code 1013, "try again later").
Below the queue, the kernel's send buffer of each connection is capped too
(serving.listening_socket).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import threading
from collections import deque
from collections.abc import Callable
from typing import Any

from starlette.websockets import WebSocket, WebSocketDisconnect

from cart2d.gateway import Gateway

MAX_VIEWERS = 256
# About 1.3 s of messages (telemetry at 25 Hz and ground truth at 50 Hz): enough to ride out a
# pause of the viewer's network, and at most ~130 KiB held per viewer.
VIEWER_BACKLOG = 100
TRY_AGAIN_LATER = 1013  # RFC 6455 §7.4.1 / IANA: the server is overloaded, try again later


class Viewer:
    def __init__(self, loop: asyncio.AbstractEventLoop) -> None:
        self.loop = loop  # the event loop serving it (one for uvicorn; a test client may have several)
        self.queue: deque[str] = deque(maxlen=VIEWER_BACKLOG)
        self.ready = asyncio.Event()
        self.dropped = 0  # messages this viewer lost because it read too slowly

    def put(self, text: str) -> None:
        if len(self.queue) == self.queue.maxlen:
            self.dropped += 1
        self.queue.append(text)
        self.ready.set()


class Viewers:
    """Every /ws viewer of one gateway."""

    def __init__(self, gateway: Gateway) -> None:
        self.gateway = gateway
        # Replaced, never changed in place: the gateway's threads read it without a lock.
        self.viewers: frozenset[Viewer] = frozenset()
        self._lock = threading.Lock()  # viewers joining and leaving
        self._unsubscribe: Callable[[], None] | None = None

    async def serve(self, ws: WebSocket) -> None:
        """Streams to an accepted WebSocket until it closes, or refuses it beyond MAX_VIEWERS."""
        if len(self.viewers) >= MAX_VIEWERS:
            await ws.close(
                code=TRY_AGAIN_LATER,
                reason=f"this gateway serves at most {MAX_VIEWERS} viewers at a time: try again later",
            )
            return
        viewer = Viewer(asyncio.get_running_loop())
        self._join(viewer)
        try:
            viewer.put(json.dumps({"type": "hello", **self.gateway.mission_view()}))
            sending = asyncio.create_task(self._send(ws, viewer))
            receiving = asyncio.create_task(self._receive(ws))
            _, pending = await asyncio.wait({sending, receiving}, return_when=asyncio.FIRST_COMPLETED)
            for task in pending:
                task.cancel()
            await asyncio.gather(*pending, return_exceptions=True)
        finally:
            self._leave(viewer)
            with contextlib.suppress(RuntimeError, OSError):
                await ws.close()

    @staticmethod
    async def _send(ws: WebSocket, viewer: Viewer) -> None:
        with contextlib.suppress(WebSocketDisconnect, RuntimeError, OSError):
            while True:
                await viewer.ready.wait()
                viewer.ready.clear()
                while viewer.queue:
                    await ws.send_text(viewer.queue.popleft())

    @staticmethod
    async def _receive(ws: WebSocket) -> None:
        """Reads (and ignores) what the viewer sends, until it goes away."""
        with contextlib.suppress(WebSocketDisconnect, RuntimeError, OSError):
            while (await ws.receive())["type"] != "websocket.disconnect":
                pass

    def _join(self, viewer: Viewer) -> None:
        with self._lock:
            self.viewers = self.viewers | {viewer}
            if self._unsubscribe is None:
                self._unsubscribe = self.gateway.subscribe(self._from_gateway)

    def _leave(self, viewer: Viewer) -> None:
        with self._lock:
            self.viewers = self.viewers - {viewer}
            if not self.viewers and self._unsubscribe is not None:
                self._unsubscribe()
                self._unsubscribe = None

    def _from_gateway(self, message: dict[str, Any]) -> None:
        """Called in the gateway's threads: one hop into each event loop per message."""
        for loop in {viewer.loop for viewer in self.viewers}:
            with contextlib.suppress(RuntimeError):  # that loop is closing
                loop.call_soon_threadsafe(self._broadcast, message, loop)

    def _broadcast(self, message: dict[str, Any], loop: asyncio.AbstractEventLoop) -> None:
        viewers = [viewer for viewer in self.viewers if viewer.loop is loop]
        if viewers:
            text = json.dumps(message)
            for viewer in viewers:
                viewer.put(text)

"""A Ctrl-C between serve()'s start and uvicorn's own handlers (issue 22: one that landed inside
asyncio's loop construction printed a traceback of its half-built loop) is noted, then taken as
uvicorn's graceful shutdown, then ends serve() as KeyboardInterrupt, with the handlers of before."""

from __future__ import annotations

import signal
from typing import Any

import pytest

from cart2d.server import serving


def lifespan_app(events: list[str]) -> Any:
    async def app(scope: dict[str, Any], receive: Any, send: Any) -> None:
        assert scope["type"] == "lifespan"
        while True:
            message = await receive()
            kind = message["type"].split(".")[1]
            events.append(kind)
            await send({"type": f"lifespan.{kind}.complete"})
            if kind == "shutdown":
                return

    return app


def test_a_ctrl_c_before_uvicorns_handlers_is_a_graceful_stop(monkeypatch: pytest.MonkeyPatch) -> None:
    events: list[str] = []
    make_server = serving.server

    def interrupted_while_starting(app: Any, connections: int = serving.MAX_CONNECTIONS) -> serving.Server:
        signal.raise_signal(signal.SIGINT)  # handled at once: it must be noted, not raised here
        events.append("interrupted")
        return make_server(app, connections)

    monkeypatch.setattr(serving, "server", interrupted_while_starting)
    before = signal.getsignal(signal.SIGINT)
    sock = serving.listening_socket("127.0.0.1", 0)
    try:
        with pytest.raises(KeyboardInterrupt):
            serving.serve(lifespan_app(events), sock)
    finally:
        sock.close()
    assert events == ["interrupted", "startup", "shutdown"]
    assert signal.getsignal(signal.SIGINT) is before


def test_held_signals_raise_what_they_noted_when_released() -> None:
    seen: list[int] = []
    before = signal.signal(signal.SIGTERM, lambda sig, _frame: seen.append(sig))
    try:
        held = serving.HeldSignals()
        signal.raise_signal(signal.SIGTERM)
        assert seen == [] and held.pending == [signal.SIGTERM]
        held.release()
        assert seen == [signal.SIGTERM] and held.pending == []
    finally:
        signal.signal(signal.SIGTERM, before)

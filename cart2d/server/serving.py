"""Serving the API with uvicorn, bounded so that half-sent requests cannot use the gateway up
(SECURITY.md):

- a client has HEADER_TIMEOUT_S to send a request's headers from when the connection opens or
  its previous answer ends (uvicorn's own keep-alive timer stops at the first byte, and nothing
  times a fresh connection), then BODY_TIMEOUT_S for its body;
- at most MAX_CONNECTIONS HTTP connections (fewer if the descriptor limit is low) are open: one
  more evicts the one that has waited longest for a request or a body (one that sent part of a
  request or nothing for FRESH_S first), never one being answered; at most BACKLOG wait to be
  accepted;
- a WebSocket message is at most WS_MAX_BYTES;
- repeated log lines are rate-limited (RepeatFilter);
- a Ctrl-C before uvicorn has taken the signals waits until it has (HeldSignals): one that
  landed inside asyncio's loop construction printed a traceback of its half-built loop.

uvicorn (pinned with h11 in pyproject.toml) has no header timeout: the protocol below is its h11
protocol, subclassed with the few methods it needs."""

from __future__ import annotations

import asyncio
import contextlib
import logging
import resource
import signal
import socket
import threading
import time
from collections.abc import Iterator
from typing import Any, ClassVar

import h11
import uvicorn
from uvicorn.protocols.http.h11_impl import H11Protocol

from cart2d.server import guards

log = logging.getLogger(__name__)

HEADER_TIMEOUT_S = 10.0  # a browser sends its headers in one packet; 10 s is ample on any link
KEEP_ALIVE_S = 5  # an idle connection after an answer (uvicorn's default, stated)
MAX_CONNECTIONS = 200  # HTTP connections; a browser opens at most 6 per origin
BODY_TIMEOUT_S = guards.BODY_TIMEOUT_S + 1.0  # a backstop: the guard answers 408 at its own limit
MAX_HEADER_BYTES = 16 * 1024  # request line and headers (h11's default, stated)
WS_MAX_BYTES = 64 * 1024  # the panel sends nothing on /ws; uvicorn's default is 16 MiB per message
# The listen backlog, which is also how many connections asyncio accepts in one go before it reads
# any of them (uvicorn's default: 2048). Below MAX_CONNECTIONS, so that one batch of newcomers
# cannot evict a connection whose whole request is waiting to be read.
BACKLOG = 128
FRESH_S = 1.0  # a connection this young that sent nothing yet is evicted last
# The send buffer of every connection (socket(7) SO_SNDBUF; the kernel doubles it for its own
# bookkeeping): a few hundred /ws messages, plenty for a viewer that reads and for the panel's
# files. Linux grows it up to 4 MiB for a peer that does not read, which is what a stalled
# viewer held.
SEND_BUFFER_BYTES = 128 * 1024
FD_RESERVE = 128  # descriptors kept for the serial link, the simulator, logs and WebSocket viewers


class BoundedH11Protocol(H11Protocol):
    """uvicorn's h11 protocol with a header timeout and a cap on connections (this module's
    docstring). `waiting` holds, oldest first, the connections not inside a request: still to
    send a request's headers, or its body."""

    header_timeout_s: ClassVar[float] = HEADER_TIMEOUT_S
    body_timeout_s: ClassVar[float] = BODY_TIMEOUT_S
    max_connections: ClassVar[int] = MAX_CONNECTIONS
    open_connections: ClassVar[set[BoundedH11Protocol]] = set()
    waiting: ClassVar[dict[BoundedH11Protocol, float]] = {}  # insertion order: oldest first

    _deadline: asyncio.TimerHandle | None = None
    _body_timed: object = None  # the request cycle whose body is being timed
    _heard = False  # some bytes came on this connection

    def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
        super().connection_made(transport)
        no_delay(transport)
        cls = type(self)
        cls.open_connections.add(self)
        if len(cls.open_connections) > cls.max_connections and not self._evict_one():
            self._close(b"HTTP/1.1 503 Service Unavailable\r\nConnection: close\r\nContent-Length: 0\r\n\r\n")
            return
        self._start_waiting()

    def connection_lost(self, exc: Exception | None) -> None:
        self._stop_waiting()
        type(self).open_connections.discard(self)
        super().connection_lost(exc)

    def data_received(self, data: bytes) -> None:
        self._heard = True
        super().data_received(data)

    def handle_events(self) -> None:
        super().handle_events()
        if not self._in_request():
            return
        if not self._body_pending():
            self._stop_waiting()  # headers and body are in: the rest is the app's time
        elif self._body_timed is not self.cycle:
            # Headers in, body to come: it has its own time (the guard answers 408 just before).
            self._body_timed = self.cycle
            self._arm(self.body_timeout_s)

    def handle_websocket_upgrade(self, event: h11.Request) -> None:
        self._stop_waiting()
        type(self).open_connections.discard(self)  # a viewer now, counted by the WebSocket side
        super().handle_websocket_upgrade(event)

    def on_response_complete(self) -> None:
        super().on_response_complete()
        if not self.transport.is_closing() and not self._in_request():
            self._start_waiting()

    # -- waiting for a request --------------------------------------------------------------
    def _in_request(self) -> bool:
        return self.cycle is not None and not self.cycle.response_complete

    def _body_pending(self) -> bool:
        return self.conn.their_state is h11.SEND_BODY

    def _start_waiting(self) -> None:
        type(self).waiting.pop(self, None)
        type(self).waiting[self] = time.monotonic()
        self._arm(self.header_timeout_s)

    def _arm(self, seconds: float) -> None:
        if self._deadline is not None:
            self._deadline.cancel()
        self._deadline = self.loop.call_later(seconds, self._timed_out)

    def _stop_waiting(self) -> None:
        type(self).waiting.pop(self, None)
        if self._deadline is not None:
            self._deadline.cancel()
            self._deadline = None

    def _timed_out(self) -> None:
        self._deadline = None
        if self.transport.is_closing() or (self._in_request() and not self._body_pending()):
            return
        # Part of a request came and then nothing: RFC 9110's 408. Nothing at all: just close.
        partial = bool(self.conn.trailing_data[0]) and not self._in_request()
        self._close(
            b"HTTP/1.1 408 Request Timeout\r\nConnection: close\r\nContent-Length: 0\r\n\r\n"
            if partial
            else b""
        )

    def _evict_one(self) -> bool:
        """Closes the connection that has waited longest for a request or a body, preferring those
        proven slow (part of a request came, or nothing for FRESH_S): one just made may hold a
        whole request not read yet (a stop sent along with its connection)."""
        now = time.monotonic()
        waiting = type(self).waiting
        candidates = [c for c in waiting if c is not self and not c.transport.is_closing()]
        slow = [c for c in candidates if c._heard or now - waiting[c] >= FRESH_S]
        for victim in slow or candidates[:1]:
            victim._close(b"")
            return True
        return False

    def _close(self, answer: bytes) -> None:
        self._stop_waiting()
        type(self).open_connections.discard(self)  # counted out now, not at connection_lost
        if answer and not self.transport.is_closing():
            self.transport.write(answer)
        self.transport.close()
        if self.cycle is not None and not self.cycle.response_complete:
            self.cycle.disconnected = True
            self.cycle.message_event.set()


def bounded_protocol(header_timeout_s: float, max_connections: int) -> type[BoundedH11Protocol]:
    """A BoundedH11Protocol class with these limits and its own registry (one per server)."""
    return type(
        "BoundedH11Protocol",
        (BoundedH11Protocol,),
        {
            "header_timeout_s": header_timeout_s,
            "body_timeout_s": BODY_TIMEOUT_S,
            "max_connections": max_connections,
            "open_connections": set(),
            "waiting": {},
        },
    )


def descriptor_budget() -> tuple[int, int]:
    """(connections, backlog) this process can hold: from its file-descriptor limit (raised to the
    hard limit where allowed) less FD_RESERVE. The backlog is also how many connections asyncio
    accepts in one go, before any of them can be evicted: both must fit, or accept() fails with
    EMFILE and the listener pauses for a second (asyncio's ACCEPT_RETRY_DELAY)."""
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if soft != resource.RLIM_INFINITY and (hard == resource.RLIM_INFINITY or soft < hard):
        try:
            resource.setrlimit(resource.RLIMIT_NOFILE, (hard, hard))
            soft = hard
        except (ValueError, OSError):
            pass
    spare = 1 << 20 if soft == resource.RLIM_INFINITY else max(32, soft - FD_RESERVE)
    return min(MAX_CONNECTIONS, spare // 4), min(BACKLOG, spare // 2)


def no_delay(transport: asyncio.BaseTransport) -> None:
    """Sends every write at once (TCP_NODELAY). h11 writes an answer's headers and its body
    apart, and with Nagle's algorithm the body waited for the client's ACK of the headers, which
    Linux delays up to 40 ms while requests come often: POST /api/command at 62 a second took
    p50 52 ms instead of 9. asyncio sets the option itself only on sockets made with
    proto=IPPROTO_TCP, which socket.create_server's are not."""
    sock = transport.get_extra_info("socket")
    if sock is not None and sock.family in (socket.AF_INET, socket.AF_INET6):
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)


def listening_socket(host: str, port: int, backlog: int = BACKLOG) -> socket.socket:
    """The server's listening socket: connections accepted from it inherit its capped send
    buffer (on Linux, accepted sockets take the listener's SO_SNDBUF)."""
    family = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE)[0][0]
    sock = socket.create_server((host, port), family=family, backlog=backlog)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, SEND_BUFFER_BYTES)
    return sock


def server(app: Any, connections: int = MAX_CONNECTIONS) -> Server:
    """A uvicorn server for `app` with the bounds of this module's docstring; run it on
    listening_socket()."""
    config = uvicorn.Config(
        app,
        http=bounded_protocol(HEADER_TIMEOUT_S, connections),
        timeout_keep_alive=KEEP_ALIVE_S,
        h11_max_incomplete_event_size=MAX_HEADER_BYTES,
        ws_max_size=WS_MAX_BYTES,
        # Uncompressed: each viewer's permessage-deflate is a zlib stream of its own, compressing
        # the same frame again for every viewer, half of what a send cost (issue 22, profiled).
        ws_per_message_deflate=False,
        log_config=None,  # uvicorn's loggers go to the root handlers, and their RepeatFilter
        log_level="warning",
    )
    return Server(config)


HELD_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class HeldSignals:
    """Ctrl-C and SIGTERM noted, not acted on, from serve()'s start until uvicorn's handlers take
    them. A handler, not a blocked mask: Python runs a signal's handler at its next bytecode
    check, so one that arrived just before a mask was set still raised KeyboardInterrupt later,
    inside asyncio's loop construction, and printed a traceback of its half-built loop."""

    def __init__(self) -> None:
        self.pending: list[int] = []
        self._originals = {sig: signal.signal(sig, self._note) for sig in HELD_SIGNALS}

    def _note(self, sig: int, _frame: object) -> None:
        self.pending.append(sig)

    def take(self) -> list[int]:
        taken, self.pending = self.pending, []
        return taken

    def release(self) -> None:
        """The handlers of before serve(); a signal noted since (uvicorn re-raises the one that
        stopped it) is raised again for them: Ctrl-C ends as KeyboardInterrupt, as before."""
        for original, handler in self._originals.items():
            signal.signal(original, handler)
        for sig in self.take():
            signal.raise_signal(sig)


class Server(uvicorn.Server):
    """uvicorn's server, taking the signals serve() held once its own handlers are in place (a
    pending Ctrl-C is then uvicorn's graceful shutdown)."""

    held: HeldSignals | None = None

    @contextlib.contextmanager
    def capture_signals(self) -> Iterator[None]:
        with super().capture_signals():
            for sig in self.held.take() if self.held else ():
                self.handle_exit(sig, None)
            yield


def serve(app: Any, sock: socket.socket, connections: int = MAX_CONNECTIONS) -> None:
    """Runs `app` on the listening socket `sock` (listening_socket(), with the backlog of
    descriptor_budget()) until Ctrl-C or SIGTERM, which wait (HeldSignals) from here until
    uvicorn's handlers take them."""
    held = HeldSignals() if threading.current_thread() is threading.main_thread() else None
    try:
        running = server(app, connections)
        running.held = held
        running.run(sockets=[sock])
    finally:
        if held is not None:
            held.release()


class RepeatFilter(logging.Filter):
    """Lets at most `burst` records of one kind (logger, level, message template, exception type)
    through per `window_s`; the first of a kind after a quiet spell says how many were dropped.
    A flood (an accept() error per connection, a warning per bad request) stays a few lines."""

    def __init__(self, burst: int = 5, window_s: float = 10.0) -> None:
        super().__init__()
        self.burst = burst
        self.window_s = window_s
        self._lock = threading.Lock()
        self._kinds: dict[tuple[object, ...], list[float]] = {}  # kind -> [window start, passed, dropped]

    def filter(self, record: logging.LogRecord) -> bool:
        kind = (record.name, record.levelno, str(record.msg), record.exc_info[0] if record.exc_info else None)
        now = time.monotonic()
        with self._lock:
            if len(self._kinds) > 1000:
                self._kinds.clear()  # many kinds: forget old windows rather than grow
            state = self._kinds.setdefault(kind, [now, 0.0, 0.0])
            if now - state[0] >= self.window_s:
                dropped = int(state[2])
                state[:] = [now, 0.0, 0.0]
                if dropped:
                    record.msg = (
                        f"{record.msg} [{dropped} more like this in the last {self.window_s:g} s not shown]"
                    )
            if state[1] >= self.burst:
                state[2] += 1
                return False
            state[1] += 1
            return True


def install_log_filter(burst: int = 5, window_s: float = 10.0) -> None:
    """A RepeatFilter on every handler of the root logger (filters on a handler see records
    from every logger, a logger's own only those logged on it)."""
    repeat = RepeatFilter(burst, window_s)
    for handler in logging.getLogger().handlers:
        handler.addFilter(repeat)

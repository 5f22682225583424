"""What a request must be before the API acts on it (SECURITY.md says why):

- **Host** names this gateway (HostAllowlist): a page on a name its attacker controls, re-pointed
  at 127.0.0.1 after it loaded (DNS rebinding), has that name in Host; refused with 421, reads and
  the WebSocket too.
- A **change** (any method but GET, HEAD, OPTIONS) comes from the gateway's own origin: `Origin`,
  when a browser sends it, is the gateway's own (scheme, host, port), and `Sec-Fetch-Site`, when
  present, says same-origin or none; else 403. A browser sends both on every cross-origin POST,
  and neither a form nor a no-cors fetch can leave them out.
- A change carries the **content type** its operation documents (application/json unless the
  OpenAPI requestBody names another, as the firmware upload's application/octet-stream), bodiless
  or not; else 415. No HTML form, sendBeacon, ping or no-cors fetch can send these types without a
  CORS preflight, which this gateway never grants: the defence holds even in a browser that sent
  no Origin. The one type a form can send that an operation takes (multipart/form-data, a map
  upload) is taken only with proof that no page elsewhere sent it: the browser's own word (an
  `Origin` or `Sec-Fetch-Site: same-origin`, checked above) or an `X-Cart2d-Token` header, which
  no simple request can carry; else 403.
- The **body** is counted as it streams and cut at the limit (413: 256 KiB, or the operation's
  `x-max-body-bytes`, the map uploads' 8 MiB) before any handler or the token
  check has read it, and must arrive within a time limit (408). A response sent before the whole
  body was read closes the connection, so the rest is never read.
"""

from __future__ import annotations

import asyncio
import contextlib
import ipaddress
import json
import socket
import threading
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import psutil
from fastapi import FastAPI
from fastapi.routing import APIRoute
from starlette.datastructures import Headers
from starlette.routing import BaseRoute, Match
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from cart2d.server.models import ERRORS, MAX_BODY_BYTES

SAFE_METHODS = frozenset({"GET", "HEAD", "OPTIONS"})
# The types a page may send anywhere without a CORS preflight (the Fetch standard's safelisted ones)
SIMPLE_TYPES = frozenset({"application/x-www-form-urlencoded", "multipart/form-data", "text/plain"})
BODY_TIMEOUT_S = 20.0  # a 256 KiB body at 13 KiB/s; a settings file or a firmware over loopback takes ms
WILDCARD_BINDS = frozenset({"", "0.0.0.0", "::"})
LOOPBACK_NAMES = frozenset({"localhost", "127.0.0.1", "::1"})
ADDRESS_REFRESH_S = 2.0  # how often a wildcard gateway may enumerate its addresses again


def split_host(value: str) -> tuple[str, int | None] | None:
    """('127.0.0.1', 8080) from a Host header '127.0.0.1:8080', ('::1', None) from '[::1]'; the
    name lower-cased, without a final dot; None for anything else (user info, a path, spaces)."""
    value = value.strip().lower()
    port: int | None = None
    if value.startswith("["):
        name, bracket, rest = value[1:].partition("]")
        if not bracket:
            return None
        if rest:
            if not rest.startswith(":") or not rest[1:].isdigit():
                return None
            port = int(rest[1:])
        try:
            ipaddress.IPv6Address(name)
        except ValueError:
            return None
        return name, port
    name, colon, digits = value.partition(":")
    if colon:
        if not digits.isdigit() or ":" in digits:
            return None
        port = int(digits)
    name = name.removesuffix(".")
    if not name or any(not (c.isalnum() or c in "-.") for c in name):
        return None
    return name, port


def _address(text: str) -> str | None:
    """The canonical text of an IP address ('::1' for '0:0::1'), or None for a name."""
    try:
        return str(ipaddress.ip_address(text.split("%", 1)[0]))
    except ValueError:
        return None


def machine_names() -> set[str]:
    """This machine's host name, its first label and its mDNS name (NAME.local), lower-cased.
    Not getfqdn(): it asks DNS, which may hang without a network."""
    full = socket.gethostname().lower().removesuffix(".")
    short = full.split(".", 1)[0]
    return {n for n in (full, short, f"{short}.local") if n}


def machine_addresses() -> set[str]:
    """Every IPv4 and IPv6 address of every interface of this machine (loopback included)."""
    found: set[str] = set()
    for addresses in psutil.net_if_addrs().values():
        for a in addresses:
            if a.family in (socket.AF_INET, socket.AF_INET6) and (canonical := _address(a.address)):
                found.add(canonical)
    return found


class HostAllowlist:
    """The Host values that name this gateway (SECURITY.md, "Which Host names are accepted"):

    - bound to loopback: localhost, 127.0.0.1, ::1 and the bound address;
    - bound to all interfaces (0.0.0.0, ::): those, this machine's names (host name, its first
      label, NAME.local) and every address of its interfaces, enumerated again (at most every
      ADDRESS_REFRESH_S) when an address literal is not among them: a network may come up later;
    - bound to one address or name: it, the addresses it resolves to and this machine's names;
    - always: the names given with --allow-host (a reverse proxy's, a DNS name of the cart).
    Ports are not compared: a forwarded port (ssh -L) keeps working."""

    def __init__(self, bind_host: str, extra: Iterable[str] = ()) -> None:
        self.bind_host = bind_host.strip().lower().strip("[]")
        self.wildcard = self.bind_host in WILDCARD_BINDS
        self.extra = {h for h in (_normal(e) for e in extra) if h}
        self._lock = threading.Lock()
        self._refreshed = 0.0
        self.names = self._enumerate()

    def _enumerate(self) -> set[str]:
        names = set(self.extra)
        if self.wildcard:
            return names | LOOPBACK_NAMES | machine_names() | machine_addresses()
        names.add(_address(self.bind_host) or self.bind_host)
        if is_loopback(self.bind_host):
            return names | LOOPBACK_NAMES
        with contextlib.suppress(OSError):
            for *_, sockaddr in socket.getaddrinfo(self.bind_host, None):
                if canonical := _address(str(sockaddr[0])):
                    names.add(canonical)
        return names | machine_names()

    def allows(self, host_header: str | None) -> bool:
        parsed = split_host(host_header) if host_header is not None else None
        if parsed is None:
            return False
        name = _address(parsed[0]) or parsed[0]
        if name in self.names:
            return True
        if self.wildcard and _address(name) is not None:
            with self._lock:
                if time.monotonic() - self._refreshed >= ADDRESS_REFRESH_S:
                    self._refreshed = time.monotonic()
                    self.names = self._enumerate()
            return name in self.names
        return False


def _normal(host: str) -> str | None:
    parsed = split_host(host)
    return (_address(parsed[0]) or parsed[0]) if parsed else None


def is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def media_type(content_type: str | None) -> str | None:
    """'application/json' from 'Application/JSON; charset=utf-8'; None when absent."""
    if content_type is None:
        return None
    return content_type.split(";", 1)[0].strip().lower()


def same_origin(origin: str, scheme: str, host_header: str) -> bool:
    """Whether an Origin header is the origin of the URL the request was sent to."""
    scheme_of, sep, rest = origin.partition("://")
    request_host = split_host(host_header)
    origin_host = split_host(rest) if sep and "/" not in rest else None
    if request_host is None or origin_host is None or scheme_of.lower() != scheme:
        return False
    default = 443 if scheme in ("https", "wss") else 80
    return (origin_host[0], origin_host[1] or default) == (request_host[0], request_host[1] or default)


@dataclass(frozen=True)
class Refusal:
    status: int
    detail: str


def cross_origin_refusal(headers: Headers, scheme: str) -> Refusal | None:
    """403 unless a change or a WebSocket comes from the gateway's own origin (or from no browser)."""
    site = headers.get("sec-fetch-site")
    if site is not None and site not in ("same-origin", "none"):
        return Refusal(403, f"a request from another site ({site}) is refused: use the gateway's own page")
    origin = headers.get("origin")
    if origin is not None and not same_origin(origin, scheme, headers.get("host", "")):
        return Refusal(
            403, f"a request from another origin ({origin[:100]}) is refused: use the gateway's own page"
        )
    return None


def vouched(headers: Headers) -> bool:
    """Whether a change in a simple type shows that no page elsewhere sent it: the browser says
    where it comes from (cross_origin_refusal took only the gateway's own origin), or it carries
    X-Cart2d-Token, a header no simple request can have (a browser never adds it by itself, as it
    may add Authorization)."""
    return (
        headers.get("origin") is not None
        or headers.get("sec-fetch-site") == "same-origin"
        or "x-cart2d-token" in headers
    )


def body_limit(route: APIRoute | None, default: int) -> int:
    """The most bytes an operation's body may have: its OpenAPI `x-max-body-bytes` (a map upload,
    a settings file with its floor plan), else `default`."""
    extra = (route.openapi_extra or {}) if route is not None else {}
    limit = extra.get("x-max-body-bytes", default)
    return int(limit) if isinstance(limit, int) else default


def body_types(route: APIRoute) -> frozenset[str]:
    """The content types an operation takes: its documented requestBody's, else JSON."""
    body = (route.openapi_extra or {}).get("requestBody", {})
    documented = body.get("content", {}) if isinstance(body, dict) else {}
    return frozenset(documented) or frozenset({"application/json"})


class RequestGuard:
    """The ASGI middleware that applies the rules in this module's docstring to every request."""

    def __init__(
        self,
        app: ASGIApp,
        hosts: HostAllowlist,
        routes: Callable[[], Sequence[BaseRoute]],
        max_body_bytes: int = MAX_BODY_BYTES,
        body_timeout_s: float = BODY_TIMEOUT_S,
    ) -> None:
        self.app = app
        self.hosts = hosts
        self.routes = routes
        self.max_body_bytes = max_body_bytes
        self.body_timeout_s = body_timeout_s

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        headers = Headers(scope=scope)
        refusal = self.refusal(scope, headers)
        if refusal is not None:
            await _refuse(scope, send, refusal)
            return
        if scope["type"] == "websocket":
            await self.app(scope, receive, send)
            return
        limit = body_limit(self.route_of(scope), self.max_body_bytes)
        await BodyLimit(self.app, scope, receive, send, limit, self.body_timeout_s).run()

    def refusal(self, scope: Scope, headers: Headers) -> Refusal | None:
        host = headers.get("host")
        if not self.hosts.allows(host):
            shown = "no Host header" if host is None else f"Host {host[:100]!r}"
            return Refusal(421, f"this gateway does not answer to {shown}: open it by its own address")
        scheme = "http" if scope["scheme"] in ("http", "ws") else "https"
        if scope["type"] == "websocket":
            return cross_origin_refusal(headers, scheme)
        if scope["method"] in SAFE_METHODS:
            return None
        refused = cross_origin_refusal(headers, scheme)
        if refused is not None:
            return refused
        route = self.route_of(scope)
        if route is None:
            return None  # the app answers 404 or 405 with its Allow
        accepted = body_types(route)
        given = media_type(headers.get("content-type"))
        if given not in accepted:
            wanted = " or ".join(sorted(accepted))
            return Refusal(415, f"a change must be sent as {wanted} (this one: {given or 'no content type'})")
        if given in SIMPLE_TYPES and not vouched(headers):
            return Refusal(
                403,
                f"{given} is taken from the gateway's own page, or with an X-Cart2d-Token header (any value "
                "on loopback): a page elsewhere can send this type without either",
            )
        return None

    def route_of(self, scope: Scope) -> APIRoute | None:
        for route in self.routes():
            if isinstance(route, APIRoute) and route.matches(scope)[0] is Match.FULL:
                return route
        return None


async def _refuse(scope: Scope, send: Send, refusal: Refusal) -> None:
    body = json.dumps({"detail": refusal.detail}).encode()
    headers = [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode())]
    if scope["type"] == "http":
        # The body, if any, is not read: close the connection rather than read or skip it.
        await send(
            {
                "type": "http.response.start",
                "status": refusal.status,
                "headers": [*headers, (b"connection", b"close")],
            }
        )
        await send({"type": "http.response.body", "body": body})
    elif "websocket.http.response" in scope.get("extensions", {}):
        await send({"type": "websocket.http.response.start", "status": refusal.status, "headers": headers})
        await send({"type": "websocket.http.response.body", "body": body})
    else:
        await send({"type": "websocket.close", "code": 1008, "reason": refusal.detail[:120]})


class BodyLimit:
    """One request's body counted as it streams: 413 past the limit, 408 when it stops coming.
    The guard answers these itself (JSON, like every error) and the app sees a disconnect."""

    def __init__(
        self, app: ASGIApp, scope: Scope, receive: Receive, send: Send, limit: int, timeout_s: float
    ) -> None:
        self.app, self.scope, self._receive, self._send = app, scope, receive, send
        self.limit = limit
        self.deadline = time.monotonic() + timeout_s
        self.received = 0
        headers = Headers(scope=scope)
        # No body announced (GET, a bodiless POST): nothing to read, the connection stays open.
        self.body_done = "transfer-encoding" not in headers and headers.get("content-length", "0") == "0"
        self.started = False
        self.answered = False  # the guard's own 413/408 went out: the app's answer is dropped

    async def run(self) -> None:
        length = Headers(scope=self.scope).get("content-length")
        if length is not None and (not length.isdigit() or int(length) > self.limit):
            await self.answer(413, f"request body over {self.limit} bytes")
            return
        try:
            await self.app(self.scope, self.receive, self.send)
        except Exception:
            if not self.answered:
                raise  # after the guard's answer the app's troubles are its disconnect's

    async def receive(self) -> Message:
        if self.answered:
            return {"type": "http.disconnect"}
        if self.body_done:
            return await self._receive()  # waiting for the client to go: no deadline
        try:
            async with asyncio.timeout(max(0.0, self.deadline - time.monotonic())):
                message = await self._receive()
        except TimeoutError:
            await self.answer(408, "the request body did not arrive in time")
            return {"type": "http.disconnect"}
        if message["type"] == "http.request":
            self.received += len(message.get("body", b""))
            self.body_done = not message.get("more_body", False)
            if self.received > self.limit:
                await self.answer(413, f"request body over {self.limit} bytes")
                return {"type": "http.disconnect"}
        return message

    async def send(self, message: Message) -> None:
        if self.answered:
            return
        if message["type"] == "http.response.start":
            self.started = True
            if not self.body_done:
                # Answered before the whole body came (a refusal, a bodiless route): close rather
                # than read the rest, however long it is (RFC 9112, section 9.6).
                message = {**message, "headers": [*message.get("headers", []), (b"connection", b"close")]}
        await self._send(message)

    async def answer(self, status: int, detail: str) -> None:
        if self.started or self.answered:
            return
        self.answered = True
        await _refuse(self.scope, self._send, Refusal(status, detail))


def install(app: FastAPI, bind_host: str, allowed_hosts: Iterable[str] = ()) -> None:
    """Adds the guard to `app` (outside its routes, exception handlers and other middleware) and
    documents its answers in the OpenAPI schema."""
    app.add_middleware(
        RequestGuard, hosts=HostAllowlist(bind_host, allowed_hosts), routes=lambda: app.router.routes
    )
    generate = app.openapi

    def openapi() -> dict[str, Any]:
        if app.openapi_schema:
            return app.openapi_schema
        schema = generate()
        for item in schema.get("paths", {}).values():
            for method, operation in item.items():
                codes = (421,) if method.upper() in SAFE_METHODS else (403, 408, 415, 421)
                for code in codes:
                    operation.setdefault("responses", {}).setdefault(str(code), problem_response(code))
        return schema

    app.openapi = openapi  # type: ignore[method-assign]


def problem_response(code: int) -> dict[str, Any]:
    return {
        "description": ERRORS[code],
        "content": {"application/json": {"schema": {"$ref": "#/components/schemas/Problem"}}},
    }

"""The API's answers leave at once (issue 22: "the API round trip while driving at 62 requests/s
went from p50 9 ms to 52 ms"). h11 writes an answer's headers and its body in two writes; with
Nagle's algorithm on the server's socket the body waited for the client's ACK of the headers,
which Linux delays by up to 40 ms once requests come often (bench/system.py measured it; a GET
/api/mission took as long as a STATUS, and neither the link nor the firmware was the cause).
Checked on the connection itself, not on the clock."""

from __future__ import annotations

import socket
import threading
from typing import Any

from cart2d.server import serving
from tests.support.waiting import wait_for


async def answer_in_two_writes(scope: dict[str, Any], receive: Any, send: Any) -> None:
    if scope["type"] != "http":
        return
    await send({"type": "http.response.start", "status": 200, "headers": [(b"content-length", b"2")]})
    await send({"type": "http.response.body", "body": b"ok"})


def test_every_http_connection_sends_without_nagles_delay() -> None:
    sock = serving.listening_socket("127.0.0.1", 0)
    port = sock.getsockname()[1]
    server = serving.server(answer_in_two_writes)
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    try:
        wait_for(lambda: server.started, 20)
        with socket.create_connection(("127.0.0.1", port)) as client:
            client.sendall(f"GET / HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n".encode())
            answer = b""
            while not answer.endswith(b"ok"):
                answer += client.recv(4096)
            protocol = server.config.http  # the server's own class, with its own registry
            assert isinstance(protocol, type) and issubclass(protocol, serving.BoundedH11Protocol)
            sockets = [p.transport.get_extra_info("socket") for p in protocol.open_connections]
            served = [s for s in sockets if s is not None and s.getpeername() == client.getsockname()]
            assert len(served) == 1
            assert served[0].getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY) != 0
    finally:
        server.should_exit = True
        thread.join(10)

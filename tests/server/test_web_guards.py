"""Attacks on a real gateway (`cart2d sim` in its own process, on a free loopback port), as a web
page on another origin, a DNS-rebinding page, a memory-hungry or a slow client would make them
(issue 11; the same from a page in Chromium: web/tests/attack.spec.ts). Each asserts that the
gateway refuses them and that nothing changed: the map, settings.json, the firmware (the simulator
was not restarted), the cart's true pose."""

from __future__ import annotations

import base64
import http.client
import json
import logging
import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import psutil
import pytest
from starlette.testclient import WebSocketDenialResponse
from starlette.websockets import WebSocketDisconnect

from cart2d.link.built import default_firmware
from cart2d.server.guards import HostAllowlist, machine_addresses, same_origin, split_host
from cart2d.server.models import MAX_BODY_BYTES, MAX_MAP_BODY_BYTES
from cart2d.server.serving import HEADER_TIMEOUT_S, RepeatFilter
from tests.support.live import GatewayProcess
from tests.support.server import WS_BASE, Rig


class LiveGateway(GatewayProcess):
    """The gateway attacked: what an attack must not change."""

    def snapshot(self) -> dict[str, Any]:
        """What an attack must not change. A firmware update flashes the simulated Nano through
        avrdude and restarts its MCU (restarts noticed); a restart of the simulator is another
        process, its time from 0."""
        truth = self.side.request({"type": "truth"})["truth"]
        simulators = [p.pid for p in psutil.Process(self.process.pid).children() if "sim" in p.name()]
        status = self.get_json("/api/status")
        return {
            "map": self.get_json("/api/map"),
            "perception": self.get_json("/api/perception"),
            "settings.json": (self.home / "settings.json").read_bytes()
            if (self.home / "settings.json").exists()
            else None,
            "firmware update": self.get_json("/api/firmware/update")["state"],
            "firmware settings": self.get_json("/api/firmware/settings"),
            "simulator faults": self.side.request({"type": "faults"})["faults"],
            "simulated boxes": self.side.request({"type": "world_get"})["world"]["boxes"],
            "restarts noticed": status["reset"]["noticed"],
            "pose trusted": status["pose_trust"]["trusted"],
            "mission": status["mission"]["state"],
            "true pose": (round(truth["x"], 4), round(truth["y"], 4), round(truth["theta"], 4)),
            "sim time": truth["t"],
            "simulator process": simulators,
        }


@pytest.fixture(scope="module")
def live(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveGateway]:
    gateway = LiveGateway(tmp_path_factory.mktemp("live"))
    yield gateway
    gateway.stop()


def assert_unchanged(before: dict[str, Any], after: dict[str, Any]) -> None:
    changed = [key for key in before if after[key] != before[key] and key != "sim time"]
    if after["sim time"] < before["sim time"]:
        changed.append("sim time")
    assert changed == [], {key: (before[key], after[key]) for key in changed}


# What each state-changing operation would be sent by an attacker: a body that works when the
# gateway reads it (the real firmware, a settings file that wipes the map and opens the gateway to
# every interface, a goal, a drive). Every operation of the API must be here.
ATTACKS: dict[str, bytes] = {
    "POST /api/command": b'{"name": "GOTO", "args": [1.0, 0.0]}',
    "PUT /api/map/obstacle": b'{"x": 1.0, "y": 1.0}',
    "DELETE /api/map/obstacles": b"",  # every obstacle the user drew, gone
    "POST /api/goto": b'{"x": 1.0, "y": 0.0}',
    "POST /api/stop": b"",
    "POST /api/drive": b'{"v": 0.3, "omega": 0.0}',
    "PUT /api/firmware/settings": b'{"id": 6, "value": 0.3}',
    "POST /api/firmware/save": b"",
    "POST /api/firmware/load": b"",
    "POST /api/reset": b"",
    "POST /api/pose": b'{"x": 0.5, "y": 0.5, "theta": 1.0}',
    "POST /api/pose/accept": b"",
    "POST /api/pose/reset-routine": b"",
    "POST /api/firmware/update": default_firmware().read_bytes(),
    "PUT /api/settings/network": b'{"host": "0.0.0.0", "port": 8080}',
    "POST /api/settings/file": b'{"version": 1, "network": {"host": "0.0.0.0", "port": 8080}, '
    b'"map": {"cols": 10, "rows": 10, "step_m": 0.2, "obstacles": []}}',
    "PUT /api/sim/faults": b'{"uart_rx_drop": 1}',  # would cut the robot off
    # a box in the cart's way, or the boxes taken away
    "POST /api/sim/boxes": b'{"boxes": [{"x": 0.6, "y": 0.0, "sx": 0.2, "sy": 0.6}]}',
    "DELETE /api/sim/boxes/{box_id}": b"",
    "DELETE /api/sim/boxes": b"",
    # a wall of perceived cells across the arena, or perception off
    "PUT /api/perception": b'{"enabled": false, "cells": [[1.0, 0.0, 1.0], [1.0, 0.2, 1.0]]}',
    "POST /api/perception/clear": b"",
    "POST /api/map/save": b'{"name": "attack"}',  # a file written in the gateway's folder
    "POST /api/explore": b'{"save": "attack"}',  # the cart driven round the room, a map written
    "PUT /api/settings/camera": b'{"stream_url": "http://127.0.0.1:9/stream"}',  # a camera of theirs
    # a 4 x 4 m floor plan with a wall (a PGM of 40 x 40 cells at 0.1 m)
    "POST /api/map": b'{"resolution_m": 0.1, "image": "'
    + base64.b64encode(b"P5 40 40 255\n" + bytes([254] * 800 + [0] * 40 + [254] * 760))
    + b'"}',
}

# Simple requests (no CORS preflight) from another origin, as a browser sends them: a no-cors
# fetch, a form, sendBeacon, <a ping>. Chromium sends Origin and Sec-Fetch-Site with each.
SIMPLE_TYPES = [
    None,
    "text/plain;charset=UTF-8",
    "application/x-www-form-urlencoded",
    "multipart/form-data; boundary=----x",
    "text/ping",
]


def changing_operations(live: LiveGateway) -> list[str]:
    paths = live.get_json("/openapi.json")["paths"]
    return sorted(
        f"{method.upper()} {path}"
        for path, item in paths.items()
        for method in item
        if method.upper() not in ("GET", "HEAD", "OPTIONS")
    )


def test_every_changing_operation_is_attacked(live: LiveGateway) -> None:
    assert sorted(ATTACKS) == changing_operations(live)


def test_cross_origin_requests_change_nothing(live: LiveGateway) -> None:
    other_origin = f"http://127.0.0.1:{live.port + 1}"  # another port: another origin, the same site
    before = live.snapshot()
    refused: dict[int, int] = {}
    accepted: list[tuple[str, dict[str, str], int, bytes]] = []
    for operation, body in ATTACKS.items():
        method, path = operation.split()
        variants: list[dict[str, str]] = []
        for kind in SIMPLE_TYPES:
            typed = {"Content-Type": kind} if kind else {}
            # a page on another port, on another site, in a sandboxed frame; and, were a browser to
            # send no Origin, the type alone
            variants += [
                {**typed, "Origin": other_origin, "Sec-Fetch-Site": "same-site", "Sec-Fetch-Mode": "no-cors"},
                {**typed, "Origin": "http://evil.example", "Sec-Fetch-Site": "cross-site"},
                {**typed, "Origin": "null", "Sec-Fetch-Site": "cross-site"},
                typed,
            ]
        # even JSON, were it sent by another origin without a preflight
        variants.append({"Content-Type": "application/json", "Origin": other_origin})
        variants.append({"Content-Type": "application/json", "Sec-Fetch-Site": "same-site"})
        for headers in variants:
            status, _, answer = live.request(method, path, body, headers)
            refused[status] = refused.get(status, 0) + 1
            if status not in (403, 415):
                accepted.append((operation, headers, status, answer[:200]))
            else:
                assert json.loads(answer)["detail"]
    time.sleep(0.5)  # a drive or a goal would have moved the cart by now
    print(f"\ncross-origin: {sum(refused.values())} requests, answered {refused}")
    assert_unchanged(before, live.snapshot())
    assert accepted == []

    # The gateway's own page still changes things: same origin, JSON.
    own = {"Content-Type": "application/json", "Origin": live.origin, "Sec-Fetch-Site": "same-origin"}
    assert live.request("PUT", "/api/map/obstacle", ATTACKS["PUT /api/map/obstacle"], own)[0] == 200
    assert live.request("PUT", "/api/map/obstacle", b'{"x": 1.0, "y": 1.0, "present": false}', own)[0] == 200
    assert live.request("POST", "/api/stop", b"", own)[0] == 200
    # the same map again, two changes later (its version counts them)
    after = live.get_json("/api/map")
    assert after.pop("version") == before["map"]["version"] + 2
    assert after == {key: value for key, value in before["map"].items() if key != "version"}


def floor_plan_form() -> tuple[bytes, str]:
    """A floor plan as a cross-origin HTML form would post it (multipart/form-data): a 4 x 4 m
    PGM at 0.1 m with a wall across it."""
    boundary = "----cart2dform"
    image = b"P5 40 40 255\n" + bytes([254] * 800 + [0] * 40 + [254] * 760)
    head = f'--{boundary}\r\nContent-Disposition: form-data; name="image"; filename="p.pgm"\r\n\r\n'
    tail = (
        f'\r\n--{boundary}\r\nContent-Disposition: form-data; name="resolution_m"\r\n\r\n0.1'
        f'\r\n--{boundary}\r\nContent-Disposition: form-data; name="origin_m"\r\n\r\n[-2, -2]'
        f"\r\n--{boundary}--\r\n"
    )
    return head.encode() + image + tail.encode(), f"multipart/form-data; boundary={boundary}"


def test_a_floor_plan_form_is_taken_only_with_proof_that_no_page_elsewhere_sent_it(
    live: LiveGateway,
) -> None:
    """POST /api/map takes multipart/form-data, a type any page can post: from a browser that says
    nothing of where the form comes from, it is refused, as from another origin."""
    before = live.snapshot()
    body, kind = floor_plan_form()
    form = {"Content-Type": kind}
    for headers in [
        {},  # a browser that sends neither Origin nor Sec-Fetch-Site
        {"Sec-Fetch-Site": "none"},
        {"Authorization": "Basic dXNlcjpwYXNz"},  # a proxy's credentials, resent by the browser
        {"Origin": "http://evil.example", "Sec-Fetch-Site": "cross-site"},
        {"Origin": f"http://127.0.0.1:{live.port + 1}", "Sec-Fetch-Site": "same-site"},
        {"Origin": "null"},
    ]:
        status, _, answer = live.request("POST", "/api/map", body, {**form, **headers})
        assert status == 403 and json.loads(answer)["detail"], (headers, status, answer)
    assert_unchanged(before, live.snapshot())
    # the gateway's own page, or a program that says so with the token's header
    exported = live.request("GET", "/api/settings/file")[2]
    for proof in ({"Origin": live.origin, "Sec-Fetch-Site": "same-origin"}, {"X-Cart2d-Token": "curl"}):
        status, _, answer = live.request("POST", "/api/map", body, {**form, **proof})
        assert status == 200 and json.loads(answer)["floor_plan"]["width"] == 40, (proof, answer)
    own = {"Content-Type": "application/json", "Origin": live.origin}
    assert live.request("POST", "/api/settings/file", exported, own)[0] == 200  # the map as it was


def test_the_gateways_own_requests_keep_their_connection(live: LiveGateway) -> None:
    """Closing after refusals and cut bodies must not close every connection: the panel's requests
    (reads, bodiless and JSON changes) share one."""
    conn = http.client.HTTPConnection("127.0.0.1", live.port, timeout=30)
    json_type = {"Content-Type": "application/json", "Origin": live.origin}
    try:
        sock = None
        for method, path, body in [
            ("GET", "/api/status", None),
            ("POST", "/api/stop", None),
            ("PUT", "/api/map/obstacle", b'{"x": 0.4, "y": 1.2}'),
            ("PUT", "/api/map/obstacle", b'{"x": 0.4, "y": 1.2, "present": false}'),
            ("GET", "/api/map", None),
        ]:
            conn.request(method, path, body=body, headers=json_type if method != "GET" else {})
            answer = conn.getresponse()
            answer.read()
            assert answer.status == 200 and answer.getheader("connection") != "close", (method, path)
            assert sock is None or conn.sock is sock
            sock = conn.sock
    finally:
        conn.close()


REBOUND_HOSTS = ["evil.example", "127.0.0.1.evil.example", "localhost.evil.example", "cart2d", "10.0.0.1"]


def test_dns_rebinding_is_refused_for_reads_changes_and_the_websocket(live: LiveGateway) -> None:
    before = live.snapshot()
    for name in REBOUND_HOSTS:
        host = f"{name}:{live.port}"
        rebound = {"Host": host, "Origin": f"http://{host}", "Sec-Fetch-Site": "same-origin"}
        for path in ("/api/status", "/api/map", "/api/settings", "/api/settings/file", "/openapi.json", "/"):
            status, _, body = live.request("GET", path, headers=rebound)
            assert status == 421 and name in json.loads(body)["detail"], (path, status)
        for operation, body in ATTACKS.items():
            method, path = operation.split()
            kind = "application/octet-stream" if path == "/api/firmware/update" else "application/json"
            status, _, answer = live.request(method, path, body, {**rebound, "Content-Type": kind})
            assert status == 421, (operation, status, answer)
        assert websocket_handshake(live, rebound).startswith(b"HTTP/1.1 421")
    for malformed in ("", "127.0.0.1:80:80", "user@127.0.0.1", "127.0.0.1/x", "[::1"):
        assert live.request("GET", "/api/status", headers={"Host": malformed})[0] in (400, 421)
    assert_unchanged(before, live.snapshot())
    # The names of this gateway, bound to loopback, still work, ports included (a forwarded port).
    for host in (live.host, f"localhost:{live.port}", f"[::1]:{live.port}", "LOCALHOST.", "127.0.0.1:1"):
        assert live.request("GET", "/api/status", headers={"Host": host})[0] == 200, host
    assert websocket_handshake(live, {"Host": live.host, "Origin": live.origin}).startswith(b"HTTP/1.1 101")


def websocket_handshake(live: LiveGateway, headers: dict[str, str]) -> bytes:
    """The answer's first bytes to a WebSocket handshake on /ws with these headers."""
    lines = [
        "GET /ws HTTP/1.1",
        "Upgrade: websocket",
        "Connection: Upgrade",
        "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==",
        "Sec-WebSocket-Version: 13",
        *(f"{k}: {v}" for k, v in headers.items()),
    ]
    with socket.create_connection(("127.0.0.1", live.port), timeout=10) as s:
        s.sendall(("\r\n".join(lines) + "\r\n\r\n").encode())
        return s.recv(4096)


CHUNK = b":" * 2**20
UPLOAD_MIB = 128


def chunked_upload(live: LiveGateway, path: str, content_type: str, results: list[tuple[str, bytes]]) -> None:
    """Sends a UPLOAD_MIB MiB chunked body (no Content-Length) and keeps the answer."""
    with socket.create_connection(("127.0.0.1", live.port), timeout=60) as s:
        head = f"POST {path} HTTP/1.1\r\nHost: {live.host}\r\nContent-Type: {content_type}\r\n"
        s.sendall((head + "Transfer-Encoding: chunked\r\n\r\n").encode())
        try:
            for _ in range(UPLOAD_MIB):
                s.sendall(b"%x\r\n%b\r\n" % (len(CHUNK), CHUNK))
            s.sendall(b"0\r\n\r\n")
        except OSError:
            pass  # the gateway answered and closed: what we want
        answer = b""
        try:
            while chunk := s.recv(65536):
                answer += chunk
        except OSError:
            pass
        results.append((path, answer))


def test_a_chunked_body_is_cut_at_the_limit_before_it_is_kept(live: LiveGateway) -> None:
    before = live.snapshot()
    idle = live.rss_mib()
    peak = idle
    results: list[tuple[str, bytes]] = []
    cuts = {  # where each is cut: 256 KiB, a map or a settings file (it may carry a floor plan) 8 MiB
        "/api/firmware/update": ("application/octet-stream", MAX_BODY_BYTES),
        "/api/settings/file": ("application/json", MAX_MAP_BODY_BYTES),
        "/api/goto": ("application/json", MAX_BODY_BYTES),
        "/api/map": ("application/json", MAX_MAP_BODY_BYTES),
    }
    uploads = [
        threading.Thread(target=chunked_upload, args=(live, path, kind, results))
        for path, (kind, _) in cuts.items()
    ]
    for upload in uploads:
        upload.start()
    while any(u.is_alive() for u in uploads):
        peak = max(peak, live.rss_mib())
        time.sleep(0.01)
    print(f"\nchunked uploads: 4 x {UPLOAD_MIB} MiB; gateway RSS idle {idle:.0f} MiB, peak {peak:.0f} MiB")
    assert peak - idle < 48, f"the gateway grew from {idle:.0f} to {peak:.0f} MiB"
    assert sorted(path for path, _ in results) == sorted(cuts)
    for path, answer in results:
        limit = cuts[path][1]
        assert answer.startswith(b"HTTP/1.1 413") and b"over %d bytes" % limit in answer, answer[:200]
        assert b"connection: close" in answer.lower()  # the rest of the body is not read
    assert_unchanged(before, live.snapshot())


HALF_OPEN = 1100  # more than the gateway's connection limit and its descriptor limit of 1024


def test_half_sent_requests_do_not_starve_the_stop(tmp_path: Path) -> None:
    gateway = LiveGateway(tmp_path / "slow", max_open_files=1024)
    sockets: list[socket.socket] = []
    try:
        lines_before = gateway.log_lines()
        started = time.monotonic()
        for _ in range(HALF_OPEN):
            s = socket.create_connection(("127.0.0.1", gateway.port), timeout=10)
            s.sendall(f"GET /api/status HTTP/1.1\r\nHost: {gateway.host}\r\nX-Never: ".encode())
            sockets.append(s)
        stops = []
        for _ in range(3):
            t = time.monotonic()
            status, _, _ = gateway.request("POST", "/api/stop", headers={"Content-Type": "application/json"})
            stops.append(time.monotonic() - t)
            assert status == 200
        shown = ", ".join(f"{s * 1000:.0f}" for s in stops)
        print(f"\n{HALF_OPEN} half-sent requests: POST /api/stop answered in {shown} ms")
        # Every half-sent request is closed: evicted for a newer one, or at the header timeout.
        time.sleep(max(0.0, started + HEADER_TIMEOUT_S + 2 - time.monotonic()))
        closed = 0
        for s in sockets:
            s.settimeout(5)
            try:
                answer = s.recv(4096)
            except OSError:
                answer = b""
            closed += answer in (
                b"",
                b"HTTP/1.1 408 Request Timeout\r\nConnection: close\r\nContent-Length: 0\r\n\r\n",
            )
        assert closed == HALF_OPEN
        logged = gateway.log_lines() - lines_before
        print(f"log lines during the attack: {logged}")
        assert logged < 50, gateway.output()[-3000:]
        assert gateway.request("GET", "/api/status")[0] == 200
    finally:
        for s in sockets:
            s.close()
        gateway.stop()


def test_a_non_ascii_token_is_refused_not_a_crash(tmp_path: Path) -> None:
    rig = Rig(tmp_path, bind_host="0.0.0.0", token="s3cret-token-for-tests")

    def accept_with(header: str, value: str) -> Any:  # a change that needs the token (not the stop)
        request = rig.client.build_request("POST", "/api/pose/accept")
        request.headers[header] = value.encode().decode("latin-1")  # the UTF-8 bytes, as sent
        return rig.client.send(request)

    try:
        for token in ("é", "s3cret-token-for-testsé", "\u2603" * 20):
            answer = accept_with("X-Cart2d-Token", token)
            assert answer.status_code == 401 and "token" in answer.json()["detail"]
            assert accept_with("Authorization", f"Bearer {token}").status_code == 401
            with (
                pytest.raises(WebSocketDisconnect) as refused,
                rig.client.websocket_connect(f"{WS_BASE}/ws?token={token}") as ws,
            ):
                ws.receive_text()
            assert refused.value.code == 1008
        assert accept_with("X-Cart2d-Token", "s3cret-token-for-tests").status_code == 200
    finally:
        rig.close()


@pytest.mark.parametrize(
    "host",
    ["127.0.0.1\nAccess granted", "0.0.0.0 ", "evil host", "a/b", "-x", "fe80::1%eth0\n", "[::1]", "1.2.3"],
)
def test_a_network_host_must_be_an_address_or_a_name(rig: Rig, host: str) -> None:
    before = rig.client.get("/api/settings").json()
    answer = rig.client.put("/api/settings/network", json={"host": host, "port": 8080})
    assert answer.status_code == 422 and "host" in answer.json()["detail"]
    imported = {**before, "network": {"host": host, "port": 8080}}
    assert rig.client.post("/api/settings/file", json=imported).status_code == 422
    assert rig.client.get("/api/settings").json() == before
    assert rig.store.load().network.host == before["network"]["host"]


def test_the_websocket_refuses_a_foreign_host(rig: Rig) -> None:
    with (
        pytest.raises(WebSocketDenialResponse) as refused,
        rig.client.websocket_connect(
            "ws://evil.example:8080/ws", headers={"origin": "http://evil.example:8080"}
        ),
    ):
        pass
    assert refused.value.status_code == 421


# -- the rules on their own ------------------------------------------------------------------------


def test_host_headers_are_parsed_strictly() -> None:
    assert split_host("127.0.0.1:8080") == ("127.0.0.1", 8080)
    assert split_host("[::1]:8080") == ("::1", 8080)
    assert split_host("LocalHost.") == ("localhost", None)
    for bad in ("", "a b", "user@127.0.0.1", "127.0.0.1:x", "127.0.0.1:80:80", "[::1", "[nope]:1", "a/b"):
        assert split_host(bad) is None, bad


def test_the_host_allowlist_follows_the_bind_address() -> None:
    loopback = HostAllowlist("127.0.0.1")
    for good in ("127.0.0.1:8080", "localhost:1", "[::1]:8080", "[0:0::1]"):
        assert loopback.allows(good), good
    for bad in ("evil.example:8080", "127.0.0.2", "10.0.0.1", socket.gethostname(), None):
        assert not loopback.allows(bad), bad
    everywhere = HostAllowlist("0.0.0.0", extra=["cart.example"])
    addresses = machine_addresses()
    assert "127.0.0.1" in addresses and "::1" in addresses
    hosts = [f"[{a}]:8080" if ":" in a else f"{a}:8080" for a in addresses]  # IPv6 in brackets
    for good in [*hosts, socket.gethostname(), "localhost", "cart.example:443"]:
        assert everywhere.allows(good), good
    assert not everywhere.allows("evil.example") and not everywhere.allows("192.0.2.77")  # TEST-NET-1
    one = HostAllowlist("127.0.0.1", extra=["proxy.example"])
    assert one.allows("proxy.example") and not one.allows("other.example")


def test_an_origin_is_compared_by_scheme_host_and_port() -> None:
    assert same_origin("http://127.0.0.1:8080", "http", "127.0.0.1:8080")
    assert same_origin("http://127.0.0.1", "http", "127.0.0.1:80")
    assert same_origin("https://cart.example", "https", "cart.example")  # behind a TLS proxy
    assert not same_origin("http://127.0.0.1:8081", "http", "127.0.0.1:8080")
    assert not same_origin("https://127.0.0.1:8080", "http", "127.0.0.1:8080")
    assert not same_origin("http://localhost:8080", "http", "127.0.0.1:8080")
    assert not same_origin("null", "http", "127.0.0.1:8080")


def test_repeated_log_lines_are_rate_limited() -> None:
    repeat = RepeatFilter(burst=5, window_s=0.2)
    record = logging.LogRecord("asyncio", logging.ERROR, __file__, 1, "accept() failed", None, None)
    assert sum(repeat.filter(record) for _ in range(10_000)) == 5
    other = logging.LogRecord(
        "uvicorn.error", logging.WARNING, __file__, 1, "Invalid HTTP request", None, None
    )
    assert repeat.filter(other)  # another kind has its own budget
    time.sleep(0.25)
    assert repeat.filter(record) and "9995 more like this" in record.getMessage()

"""A gateway served as `cart2d sim` serves it: the real firmware in the simulator, the link, the
gateway and uvicorn on a free loopback port, driven over real HTTP connections from threads."""

from __future__ import annotations

import http.client
import json
import threading
import time
from pathlib import Path
from typing import Any

from cart2d.gateway import Gateway
from cart2d.link import Link
from cart2d.server import create_app, serving
from cart2d.simulator import Simulator
from cart2d.store import Store
from tests.conftest import start_sim, wait_for


class LiveGateway:
    def __init__(self, tmp_path: Path, **sim_options: Any) -> None:
        self.sim: Simulator = start_sim(tmp_path, pty_link=tmp_path / "robot-tty", **sim_options)
        self.link = Link(self.sim.pty, timeout_s=0.2).open()
        self.store = Store(tmp_path / "gateway")
        self.gateway = Gateway(self.link, self.store, self.store.load(), self.sim)
        self.gateway.wait_for_firmware(10.0, 0.1)
        self.gateway.start()
        sock = serving.listening_socket("127.0.0.1", 0)  # as cart2d.cli serves it
        self.port: int = sock.getsockname()[1]
        self.app = create_app(self.gateway)
        self.server = serving.server(self.app)
        self._thread = threading.Thread(target=self.server.run, kwargs={"sockets": [sock]}, daemon=True)
        self._thread.start()
        wait_for(lambda: self.server.started, 20)

    def http(self) -> Http:
        return Http(self.port)

    def close(self) -> None:
        self.server.should_exit = True
        self._thread.join(10)
        self.gateway.close()
        self.link.close()
        self.sim.stop()


class Http:
    """One keep-alive HTTP/1.1 connection; `sent` is set once a request's bytes are written."""

    def __init__(self, port: int, timeout_s: float = 30.0) -> None:
        self.port = port
        self.timeout_s = timeout_s
        self.conn = http.client.HTTPConnection("127.0.0.1", port, timeout=timeout_s)
        self.sent = threading.Event()

    def call(self, method: str, path: str, body: dict[str, Any] | None = None) -> tuple[int, Any]:
        data = json.dumps(body).encode() if body is not None else None
        headers = {"Content-Type": "application/json"} if data is not None else {}
        self.conn.request(method, path, body=data, headers=headers)
        self.sent.set()
        response = self.conn.getresponse()
        raw = response.read()
        return response.status, json.loads(raw) if raw else None

    def close(self) -> None:
        self.conn.close()


def wait_sim_time(sim: Simulator, seconds: float, wall_timeout_s: float = 30.0) -> float:
    """Waits until `seconds` of simulated time have passed; returns the simulated time then."""
    t_end = float(sim.truth()["t"]) + seconds
    deadline = time.monotonic() + wall_timeout_s
    while (t := float(sim.truth()["t"])) < t_end:
        if time.monotonic() > deadline:
            raise AssertionError("simulated time does not advance")
        time.sleep(0.002)
    return t

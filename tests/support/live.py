"""Real gateways on a free loopback port, driven over real HTTP connections: LiveGateway serves
one as `cart2d sim` does, in this process (the real firmware in the simulator, the link, the
gateway, uvicorn), GatewayProcess runs `cart2d sim` itself in a process of its own."""

from __future__ import annotations

import http.client
import json
import os
import re
import resource
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import psutil

from cart2d.link import Link
from cart2d.server import create_app, serving
from cart2d.simulation.side_channel import SideChannel
from cart2d.simulation.simulator import Simulator
from cart2d.simulation.wiring import simulated_gateway
from cart2d.store import Store
from tests.support.sim import start_sim
from tests.support.waiting import wait_for

Answer = tuple[int, dict[str, str], bytes]  # status, headers, body


class LiveGateway:
    def __init__(self, tmp_path: Path, **sim_options: Any) -> None:
        self.sim: Simulator = start_sim(tmp_path, pty_link=tmp_path / "robot-tty", **sim_options)
        self.link = Link(self.sim.pty, timeout_s=0.2).open()
        self.store = Store(tmp_path / "gateway")
        self.simulation = simulated_gateway(self.link, self.store, self.store.load(), self.sim)
        self.gateway = self.simulation.gateway
        self.gateway.wait_for_firmware(10.0, 0.1)
        self.gateway.start()
        sock = serving.listening_socket("127.0.0.1", 0)  # as cart2d.tools.cli serves it
        self.port: int = sock.getsockname()[1]
        self.app = create_app(self.gateway, simulation=self.simulation.add_routes)
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
        # A change carries its content type, bodiless or not (cart2d/server/guards.py).
        headers = {"Content-Type": "application/json"} if method not in ("GET", "HEAD") else {}
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


class GatewayProcess:
    """`cart2d sim` in a process of its own, on a free port of 127.0.0.1 with its own CART2D_HOME
    and `extra` options (without the simulated camera unless they give its port), its output in a
    file."""

    def __init__(self, home: Path, max_open_files: int | None = None, extra: Sequence[str] = ()) -> None:
        with socket.socket() as probe:
            probe.bind(("127.0.0.1", 0))
            self.port = probe.getsockname()[1]
        self.home = home
        self.log_path = home / "gateway.log"
        home.mkdir(parents=True, exist_ok=True)

        def limit_files() -> None:  # as on a desktop whose limit is 1024 (systemd's soft default)
            if max_open_files is not None:
                resource.setrlimit(resource.RLIMIT_NOFILE, (max_open_files, max_open_files))

        # the simulated camera only when asked for (its default port may be another run's)
        camera = [] if "--camera-port" in extra or "--no-camera" in extra else ["--no-camera"]
        with self.log_path.open("wb") as log:
            self.process = subprocess.Popen(
                [sys.executable, "-m", "cart2d.tools.cli", "sim", "--port", str(self.port), *camera, *extra],
                env={**os.environ, "CART2D_HOME": str(home)},
                stdout=log,
                stderr=subprocess.STDOUT,
                preexec_fn=limit_files,
            )
        wait_for(self._ready, 60, 0.2)
        found = re.search(r"side channel (\S+)", self.output())
        assert found, self.output()
        self.side = SideChannel(found.group(1))

    def _ready(self) -> bool:
        assert self.process.poll() is None, self.output()
        try:
            status, _, body = self.request("GET", "/api/status")
        except OSError:
            return False
        return status == 200 and json.loads(body).get("pose") is not None

    def output(self) -> str:
        return self.log_path.read_text(errors="replace")

    def log_lines(self) -> int:
        return self.output().count("\n")

    @property
    def host(self) -> str:
        return f"127.0.0.1:{self.port}"

    @property
    def origin(self) -> str:
        return f"http://{self.host}"

    def request(
        self, method: str, path: str, body: bytes = b"", headers: dict[str, str] | None = None
    ) -> Answer:
        """One request on a fresh connection; `headers` may replace Host."""
        conn = http.client.HTTPConnection("127.0.0.1", self.port, timeout=30)
        try:
            conn.putrequest(method, path, skip_host=True, skip_accept_encoding=True)
            sent = {"Host": self.host, **(headers or {})}
            if body or method not in ("GET", "HEAD"):
                sent.setdefault("Content-Length", str(len(body)))
            for name, value in sent.items():
                conn.putheader(name, value)
            conn.endheaders(body or None)
            answer = conn.getresponse()
            return answer.status, dict(answer.getheaders()), answer.read()
        finally:
            conn.close()

    def get_json(self, path: str) -> Any:
        status, _, body = self.request("GET", path)
        assert status == 200, body
        return json.loads(body)

    def rss_mib(self) -> float:
        return float(psutil.Process(self.process.pid).memory_info().rss) / 2**20

    def stop(self) -> None:
        self.side.close()
        self.process.send_signal(signal.SIGINT)
        try:
            self.process.wait(20)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()

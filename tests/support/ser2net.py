"""Debian's ser2net (4.x, YAML configuration) in front of a serial port, on 127.0.0.1 only: the
network link of docs/network-link.md, whose recipe is this module's config(). And a TCP relay
that delays every byte, for a network with latency (Wi-Fi: tens to hundreds of ms)."""

from __future__ import annotations

import shutil
import socket
import subprocess
import threading
import time
from pathlib import Path
from queue import Queue

import psutil

from tests.support.sockets import free_port

SER2NET = "/usr/sbin/ser2net"


def config(device: str, port: int, rfc2217: bool, host: str = "127.0.0.1") -> str:
    """ser2net's YAML for the cart's serial port `device` on host:port: RFC 2217 (Telnet COM
    port control, `rfc2217://`) or raw TCP (`socket://`). `nodelay` turns Nagle's algorithm off
    (without it each reply waits ~40 ms for the host's delayed ACK); `chardelay: false` sends
    what the serial port gave at once instead of waiting a few characters' time for more."""
    accepter = f"telnet(rfc2217),tcp(nodelay),{host},{port}" if rfc2217 else f"tcp(nodelay),{host},{port}"
    return (
        "%YAML 1.1\n"
        "---\n"
        "connection: &cart2d\n"
        f"  accepter: {accepter}\n"
        f"  connector: serialdev,{device},115200n81,local\n"
        "  options:\n"
        "    kickolduser: true\n"
        "    chardelay: false\n"
    )


class Ser2net:
    """ser2net in a process of its own, in the foreground (-n), without UUCP lock files (-u)."""

    def __init__(self, directory: Path, device: str, rfc2217: bool = True, port: int | None = None) -> None:
        if shutil.which(SER2NET) is None:
            raise RuntimeError(f"{SER2NET} is missing: apt-get install ser2net")
        self.port = port or free_port()
        self.rfc2217 = rfc2217
        self.config_path = directory / f"ser2net-{self.port}.yaml"
        self.config_path.write_text(config(device, self.port, rfc2217))
        self.log_path = directory / f"ser2net-{self.port}.log"
        self.process: subprocess.Popen[bytes] | None = None
        self.start()

    @property
    def url(self) -> str:
        return f"{'rfc2217' if self.rfc2217 else 'socket'}://127.0.0.1:{self.port}"

    def start(self) -> None:
        with self.log_path.open("ab") as log:
            self.process = subprocess.Popen(
                [
                    SER2NET,
                    "-n",
                    "-u",
                    "-c",
                    str(self.config_path),
                    "-P",
                    str(self.config_path.with_suffix(".pid")),
                ],
                stdout=log,
                stderr=subprocess.STDOUT,
            )
        deadline = time.monotonic() + 10
        while not self._listening():
            if self.process.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError(f"ser2net did not start: {self.log_path.read_text(errors='replace')}")
            time.sleep(0.02)

    def _listening(self) -> bool:
        # A probe connection would take the port: ser2net opens the device for it (a DTR reset).
        # The kernel's list of listening sockets says it without connecting.
        return any(
            c.status == psutil.CONN_LISTEN and c.laddr and c.laddr.port == self.port
            for c in psutil.net_connections(kind="tcp4")
        )

    def kill(self) -> None:
        """As a bridge that loses power: SIGKILL, its connections reset."""
        if self.process is not None and self.process.poll() is None:
            self.process.kill()
            self.process.wait()

    def stop(self) -> None:
        self.kill()


class DelayRelay:
    """Listens on 127.0.0.1 and relays each connection to `upstream_port`, every chunk held for
    `delay_s` in each direction (the order kept)."""

    def __init__(self, upstream_port: int, delay_s: float) -> None:
        self.upstream_port = upstream_port
        self.delay_s = delay_s
        self.server = socket.create_server(("127.0.0.1", 0))
        self.port: int = self.server.getsockname()[1]
        self._closing = threading.Event()
        self._sockets: list[socket.socket] = [self.server]
        threading.Thread(target=self._accept, daemon=True).start()

    def _accept(self) -> None:
        while not self._closing.is_set():
            try:
                client, _ = self.server.accept()
                upstream = socket.create_connection(("127.0.0.1", self.upstream_port))
            except OSError:
                return
            for sock in (client, upstream):
                sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            self._sockets += [client, upstream]
            for source, sink in ((client, upstream), (upstream, client)):
                queue: Queue[tuple[float, bytes]] = Queue()
                threading.Thread(target=self._receive, args=(source, queue), daemon=True).start()
                threading.Thread(target=self._send, args=(sink, queue), daemon=True).start()

    def _receive(self, source: socket.socket, queue: Queue[tuple[float, bytes]]) -> None:
        while True:
            try:
                data = source.recv(4096)
            except OSError:
                data = b""
            queue.put((time.monotonic() + self.delay_s, data))
            if not data:
                return

    def _send(self, sink: socket.socket, queue: Queue[tuple[float, bytes]]) -> None:
        while True:
            due, data = queue.get()
            time.sleep(max(0.0, due - time.monotonic()))
            try:
                if not data:
                    sink.shutdown(socket.SHUT_WR)
                    return
                sink.sendall(data)
            except OSError:
                return

    @property
    def url(self) -> str:
        return f"socket://127.0.0.1:{self.port}"

    def close(self) -> None:
        self._closing.set()
        for sock in self._sockets:
            sock.close()

"""Debian's mosquitto, started on loopback when the user names no broker (`cart2d fleet sim`
without --mqtt), and by the tests. Anonymous clients are allowed: it listens on 127.0.0.1
only, so that only this machine's processes reach it (SECURITY.md)."""

from __future__ import annotations

import shutil
import socket
import subprocess
import tempfile
import time
from pathlib import Path

from cart2d.fleet.mqtt import Broker

LOOPBACK = "127.0.0.1"


class BrokerError(Exception):
    pass


def free_port(host: str = LOOPBACK) -> int:
    with socket.socket() as sock:
        sock.bind((host, 0))
        port: int = sock.getsockname()[1]
        return port


def _program(name: str) -> str:
    """mosquitto's programs: Debian puts the broker in /usr/sbin (not on a user's PATH)."""
    for candidate in (shutil.which(name), f"/usr/sbin/{name}", f"/usr/bin/{name}"):
        if candidate and Path(candidate).exists():
            return candidate
    raise BrokerError(f"{name} is not installed (Debian: apt install mosquitto; tools/install-deps.sh)")


class Mosquitto:
    """A mosquitto process on LOOPBACK:port (a free one by default); start() waits until it
    accepts connections; stop() and start() again restart it on the same port."""

    def __init__(self, port: int | None = None, users: dict[str, str] | None = None) -> None:
        """`users`: name -> password, the only clients it lets in (default: anyone on loopback)."""
        self.port = port or free_port()
        self._dir = tempfile.TemporaryDirectory(prefix="cart2d-mosquitto-")
        folder = Path(self._dir.name)
        folder.chmod(0o755)  # started by root, mosquitto reads its files as the user mosquitto
        self.config = folder / "mosquitto.conf"
        self.log = folder / "mosquitto.log"
        access = "allow_anonymous true\n"
        if users:
            passwords = folder / "passwords"
            for k, (name, password) in enumerate(users.items()):
                create = ["-c"] if k == 0 else []
                subprocess.run(
                    [_program("mosquitto_passwd"), *create, "-b", str(passwords), name, password], check=True
                )
            passwords.chmod(0o644)  # hashed; the folder is this run's only
            access = f"allow_anonymous false\npassword_file {passwords}\n"
        self.config.write_text(
            f"listener {self.port} {LOOPBACK}\n{access}persistence false\nlog_dest stderr\n"
        )
        self._process: subprocess.Popen[bytes] | None = None

    @property
    def broker(self) -> Broker:
        return Broker(LOOPBACK, self.port)

    @property
    def pid(self) -> int | None:
        return self._process.pid if self._process is not None else None

    def start(self, wait_s: float = 10.0) -> Mosquitto:
        with self.log.open("ab") as log:  # its log, kept beside its configuration
            self._process = subprocess.Popen(
                [_program("mosquitto"), "-c", str(self.config)], stdout=subprocess.DEVNULL, stderr=log
            )
        deadline = time.monotonic() + wait_s
        while time.monotonic() < deadline:
            if self._process.poll() is not None:
                said = self.log.read_text(errors="replace").strip().splitlines()[-3:]
                raise BrokerError(
                    f"mosquitto exited with status {self._process.returncode}: {' '.join(said)}"
                )
            try:
                socket.create_connection((LOOPBACK, self.port), timeout=0.5).close()
                return self
            except OSError:
                time.sleep(0.05)
        self.stop()
        raise BrokerError(f"mosquitto did not listen on {LOOPBACK}:{self.port} within {wait_s:g} s")

    def stop(self) -> None:
        process, self._process = self._process, None
        if process is not None and process.poll() is None:
            process.terminate()
            try:
                process.wait(5)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()

    def close(self) -> None:
        self.stop()
        self._dir.cleanup()

    def __enter__(self) -> Mosquitto:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

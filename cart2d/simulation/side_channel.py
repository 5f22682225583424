"""The simulator's side channel (sim/README.md): JSON lines over TCP, requests acknowledged by id,
ground truth, events and camera frames kept as they come; and the error of a simulator that does
not answer."""

from __future__ import annotations

import itertools
import json
import socket
import threading
from collections.abc import Callable
from typing import Any


class SimulatorError(RuntimeError):
    pass


class SideChannel:
    """A JSON-lines client: requests get acks by id; truth and events are kept as they come."""

    def __init__(self, address: str) -> None:
        host, port = address.rsplit(":", 1)
        self._sock = socket.create_connection((host, int(port)), timeout=5.0)
        self._sock.settimeout(None)
        self._ids = itertools.count(1)
        self._cond = threading.Condition()
        self._acks: dict[int, dict[str, Any]] = {}
        self.truth: dict[str, Any] | None = None
        self.events: list[dict[str, Any]] = []
        self.frame: dict[str, Any] | None = None  # the camera's newest (cart2d/simulation/controls.py)
        self._listeners: list[Callable[[dict[str, Any]], None]] = []
        self._closed = False
        self._reader = threading.Thread(target=self._read, name="sim side channel", daemon=True)
        self._reader.start()

    def request(self, message: dict[str, Any], timeout_s: float = 10.0) -> dict[str, Any]:
        ident = next(self._ids)
        data = (json.dumps({**message, "id": ident}) + "\n").encode()
        with self._cond:
            try:
                self._sock.sendall(data)
            except OSError as exc:  # the simulator is gone
                raise SimulatorError(f"the side channel is closed: {exc}") from exc
            if not self._cond.wait_for(lambda: ident in self._acks or self._closed, timeout_s):
                raise SimulatorError(f"no ack to {message.get('type')}")
            if self._closed and ident not in self._acks:
                raise SimulatorError("side channel closed")
            ack = self._acks.pop(ident)
        if not ack.get("ok"):
            raise SimulatorError(f"{message.get('type')}: {ack.get('error')}")
        return ack

    def wait_truth(self, predicate: Any, timeout_s: float) -> dict[str, Any]:
        """Waits until a truth message satisfies predicate(truth); returns it."""
        with self._cond:
            if not self._cond.wait_for(lambda: self.truth is not None and predicate(self.truth), timeout_s):
                raise SimulatorError("condition not reached in time")
            assert self.truth is not None
            return self.truth

    def subscribe(self, listener: Callable[[dict[str, Any]], None]) -> None:
        """Calls listener(message) for every truth message, from the reader thread."""
        self._listeners.append(listener)

    @property
    def listeners(self) -> list[Callable[[dict[str, Any]], None]]:
        return list(self._listeners)

    @property
    def closed(self) -> bool:
        return self._closed

    def close(self) -> None:
        self._sock.close()

    def _read(self) -> None:
        buf = b""
        while True:
            try:
                chunk = self._sock.recv(65536)
            except OSError:
                chunk = b""
            if not chunk:
                with self._cond:
                    self._closed = True
                    self._cond.notify_all()
                return
            buf += chunk
            *lines, buf = buf.split(b"\n")
            messages = [json.loads(line) for line in lines]
            with self._cond:
                for message in messages:
                    self._dispatch(message)
                self._cond.notify_all()
            for message in messages:
                if message.get("type") == "truth":
                    for listener in self._listeners:
                        listener(message)

    def _dispatch(self, message: dict[str, Any]) -> None:
        kind = message.get("type")
        if kind == "ack":
            self._acks[message.get("id") or 0] = message
        elif kind == "truth":
            self.truth = message
        elif kind == "event":
            self.events.append(message)
        elif kind == "frame":
            self.frame = message

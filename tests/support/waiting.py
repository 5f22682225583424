"""Waiting, in wall time, for a condition or for a gateway to answer."""

from __future__ import annotations

import json
import time
import urllib.request
from collections.abc import Callable


def wait_serving(port: int, wall_timeout_s: float = 60.0) -> None:
    """Waits until a gateway on 127.0.0.1:`port` answers /api/status with its firmware."""

    def ready() -> bool:
        try:
            with urllib.request.urlopen(f"http://127.0.0.1:{port}/api/status", timeout=2) as answer:
                return bool(json.load(answer).get("firmware"))
        except OSError:
            return False

    wait_for(ready, wall_timeout_s, 0.2)


def wait_for(condition: Callable[[], bool], wall_timeout_s: float = 60.0, poll_s: float = 0.02) -> None:
    deadline = time.monotonic() + wall_timeout_s
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError("condition not reached in time")
        time.sleep(poll_s)

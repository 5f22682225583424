"""Fixtures for tests that run the real firmware in the simulator."""

from __future__ import annotations

import json
import socket
import time
import urllib.request
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from cart2d.link import Link
from cart2d.link.built import default_binary, default_firmware
from cart2d.simulation.simulator import SimOptions, Simulator


def _require_builds() -> None:
    for path, target in ((default_binary(), "make sim"), (default_firmware(), "make firmware")):
        if not path.exists():
            pytest.fail(f"{path} is missing: run `{target}` first (make test does)")


def start_sim(tmp_path: Path, **options: Any) -> Simulator:
    _require_builds()
    options.setdefault("eeprom", tmp_path / "eeprom.bin")
    options.setdefault("speed", "max")
    return Simulator(SimOptions(**options)).start()


@pytest.fixture
def sim(tmp_path: Path) -> Iterator[Simulator]:
    simulator = start_sim(tmp_path)
    yield simulator
    simulator.stop()


@pytest.fixture
def link(sim: Simulator) -> Iterator[Link]:
    with Link(sim.pty, timeout_s=0.2) as open_link:
        yield open_link


@pytest.fixture
def rig(tmp_path: Path) -> Iterator[Any]:
    """The gateway's app on a simulator (tests/test_server.py, Rig), closed after the test."""
    from tests.test_server import Rig  # imported here: test_server imports this module

    r = Rig(tmp_path)
    yield r
    r.close()


def events(sim: Simulator, kind: str, since: int = 0) -> list[dict[str, Any]]:
    """The simulator's side-channel events of one kind, from the `since`-th event on."""
    assert sim.side is not None
    return [e for e in sim.side.events[since:] if e.get("event") == kind]


def high_rate_truth(sim: Simulator, hz: float = 1000.0) -> list[dict[str, Any]]:
    """Every truth message from now on, at `hz` per simulated second."""
    samples: list[dict[str, Any]] = []
    assert sim.side is not None
    sim.side.subscribe(samples.append)
    sim.control("truth_rate", hz=hz)
    return samples


def free_port() -> int:
    """A TCP port nothing listens on now (another process may take it before it is used)."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port: int = probe.getsockname()[1]
        return port


def free_port_pair(avoid: int) -> int:
    """A port P with P + 1 free too (the camera's stream), neither of them `avoid`."""
    while True:
        with socket.socket() as first, socket.socket() as second:
            first.bind(("127.0.0.1", 0))
            port: int = first.getsockname()[1]
            if avoid in (port, port + 1):
                continue
            try:
                second.bind(("127.0.0.1", port + 1))
            except OSError:
                continue
            return port


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


def wait_idle(link: Link, wall_timeout_s: float = 60.0) -> tuple[float, ...]:
    """Waits until the firmware's mode is IDLE again; returns its STATUS."""
    status: tuple[float, ...] = ()

    def idle() -> bool:
        nonlocal status
        status = link.call("STATUS")
        return int(status[0]) == 0

    wait_for(idle, wall_timeout_s)
    return status


def run_for(sim: Simulator, seconds: float) -> None:
    """Lets `seconds` of simulated time pass."""
    t_end = sim.truth()["t"] + seconds
    wait_for(lambda: sim.truth()["t"] >= t_end)

"""Fixtures for tests that run the real firmware in the simulator."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from cart2d.link import Link
from cart2d.simulator import SimOptions, Simulator, default_binary, default_firmware


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

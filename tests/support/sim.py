"""The simulator for tests: started at full speed on a test's own EEPROM, its side-channel
events, its truth at a high rate, and simulated time let pass."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from cart2d.link import Link
from cart2d.link.built import default_binary, default_firmware
from cart2d.simulation.simulator import SimOptions, Simulator
from tests.support.waiting import wait_for


def require_builds() -> None:
    for path, target in ((default_binary(), "make sim"), (default_firmware(), "make firmware")):
        if not path.exists():
            pytest.fail(f"{path} is missing: run `{target}` first (make test does)")


def start_sim(tmp_path: Path, **options: Any) -> Simulator:
    require_builds()
    options.setdefault("eeprom", tmp_path / "eeprom.bin")
    options.setdefault("speed", "max")
    return Simulator(SimOptions(**options)).start()


def events(sim: Simulator, kind: str, since: int = 0) -> list[dict[str, Any]]:
    """The simulator's side-channel events of one kind, from the `since`-th event on."""
    assert sim.side is not None
    return [e for e in sim.side.events[since:] if e.get("event") == kind]


def high_rate_truth(sim: Simulator, hz: float = 1000.0) -> list[dict[str, Any]]:
    """Every truth message from now on, at `hz` per simulated second. The simulator skips truth
    lines for a reader more than 1 MiB behind: at full speed that is a tenth of a second of a
    busy machine's delay at 1000 Hz, so a test that needs every sample runs at real time."""
    samples: list[dict[str, Any]] = []
    assert sim.side is not None
    sim.side.subscribe(samples.append)
    sim.control("truth_rate", hz=hz)
    return samples


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

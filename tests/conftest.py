"""Fixtures for tests that run the real firmware in the simulator (the helpers behind them are in
tests/support/)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from cart2d.link import Link
from cart2d.simulation.simulator import Simulator
from tests.support.server import Rig
from tests.support.sim import start_sim


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
def rig(tmp_path: Path) -> Iterator[Rig]:
    """The gateway's app on a simulator (tests/support/server.py, Rig), closed after the test."""
    r = Rig(tmp_path)
    yield r
    r.close()

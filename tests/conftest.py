"""Fixtures for tests that run the real firmware in the simulator, and a Gateway on the fake
firmware (cart, gateway) for logic that needs no physics (the helpers behind them are in
tests/support/)."""

from __future__ import annotations

import logging
from collections.abc import Iterator
from pathlib import Path

import pytest

from cart2d.gateway import Gateway
from cart2d.link import Link
from cart2d.server.serving import RepeatFilter
from cart2d.simulation.simulator import Simulator
from cart2d.store import Store
from tests.support.fake_firmware import FakeFirmware
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


@pytest.fixture
def cart() -> FakeFirmware:
    firmware = FakeFirmware()
    firmware.pose = [0.2, 0.8, 0.0]
    return firmware


@pytest.fixture
def gateway(cart: FakeFirmware, tmp_path: Path) -> Iterator[Gateway]:
    store = Store(tmp_path)
    gateway = Gateway(cart, store, store.load())
    gateway.read_status()  # the baseline a restart is told from, as start() reads it
    yield gateway
    gateway.close()


@pytest.fixture(autouse=True)
def no_repeat_filter_left_behind() -> Iterator[None]:
    """A test running `cart2d` in-process (cli.main) installs the gateway's RepeatFilter on the root
    logger's handlers, pytest's capture among them: left there, it would drop a later test's
    expected log line as a repeat."""
    yield
    for handler in logging.getLogger().handlers:
        for f in [f for f in handler.filters if isinstance(f, RepeatFilter)]:
            handler.removeFilter(f)

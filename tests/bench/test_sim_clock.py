"""bench/sim_clock.py on a fake wall clock: a host's instant in simulated seconds, linear between
truth messages, NaN outside them; a span measured across a slowed simulator shrinks with it."""

from __future__ import annotations

import math

import pytest

from bench.sim_clock import SimClock
from tests.support.clock import FakeClock


def clock_with(pairs: list[tuple[float, float]]) -> SimClock:
    wall = FakeClock(1000.0)
    clock = SimClock(wall)
    for w, sim_t in pairs:
        wall.t = w
        clock.note({"type": "truth", "t": sim_t})
    return clock


def test_an_instant_is_told_in_simulated_seconds_between_truth_messages() -> None:
    clock = clock_with([(1000.0, 5.0), (1000.02, 5.02), (1000.06, 5.04)])  # then at half speed
    assert clock.at(1000.01) == pytest.approx(5.01)
    assert clock.at(1000.04) == pytest.approx(5.03)
    assert clock.span(1000.02, 1000.06) == pytest.approx(0.02)  # 40 ms of wall, 20 ms simulated


def test_outside_the_truth_messages_or_going_back_there_is_no_answer() -> None:
    clock = clock_with([(1000.0, 5.0), (1000.02, 5.02), (1000.03, 0.01)])  # a restart: ignored
    assert math.isnan(clock.at(999.0))
    assert math.isnan(clock.at(1000.03))

"""cmd_vel's gate and driver (cart2d/ros2/drive.py) on a fake clock and a fake drive: a stream
belongs to the stop generation of its first command, a stop cancels the rest of it, a silence of
the manual timeout starts a new one; speeds are clamped to the firmware's limits; NaN is dropped."""

from __future__ import annotations

import math

import pytest

from cart2d.link import MotionCancelled
from cart2d.ros2.drive import SILENCE_S, CmdVelGate, DriveCommand, Driver, speed_limits
from tests.support.clock import FakeClock
from tests.support.waiting import wait_for as wait_until


class Tokens:
    """The link's stop generations: a stop moves them on."""

    def __init__(self) -> None:
        self.generation = 0

    def __call__(self) -> int:
        return self.generation


def gate(clock: FakeClock, tokens: Tokens) -> CmdVelGate:
    return CmdVelGate(tokens, lambda: (0.5, 3.0), clock)


def test_the_manual_timeout_is_robot_tomls() -> None:
    assert SILENCE_S == 0.5


def test_a_stream_keeps_the_token_of_its_first_command() -> None:
    clock, tokens = FakeClock(), Tokens()
    g = gate(clock, tokens)
    first = g.admit(0.2, 0.0)
    tokens.generation = 1  # a stop
    clock.t += 0.1
    second = g.admit(0.2, 0.0)
    assert first is not None and second is not None
    assert second.token == first.token == 0  # cancelled by the stop: the stream is over


def test_a_silence_as_long_as_the_timeout_starts_a_new_stream() -> None:
    clock, tokens = FakeClock(), Tokens()
    g = gate(clock, tokens)
    g.admit(0.2, 0.0)
    tokens.generation = 1
    clock.t += SILENCE_S - 0.01
    held = g.admit(0.2, 0.0)
    clock.t += SILENCE_S
    fresh = g.admit(0.2, 0.0)
    assert held is not None and held.token == 0
    assert fresh is not None and fresh.token == 1


def test_speeds_are_clamped_to_the_limits() -> None:
    command = gate(FakeClock(), Tokens()).admit(2.0, -10.0)
    assert command == DriveCommand(0.5, -3.0, 0)


@pytest.mark.parametrize("v, omega", [(math.nan, 0.0), (0.1, math.inf), (-math.inf, 0.0)])
def test_a_speed_that_is_not_finite_is_dropped_with_a_line(
    v: float, omega: float, caplog: pytest.LogCaptureFixture
) -> None:
    assert gate(FakeClock(), Tokens()).admit(v, omega) is None
    assert "not finite" in caplog.text


def test_the_limits_are_the_firmwares_settings_else_the_defaults() -> None:
    assert speed_limits([{"name": "v_max_mps", "value": 0.3}]) == pytest.approx((0.3, math.pi))
    assert speed_limits([]) == pytest.approx((0.5, math.pi))


def test_the_driver_sends_nothing_more_of_a_cancelled_stream() -> None:
    sent: list[tuple[float, int]] = []

    def drive(v: float, omega: float, token: int) -> None:
        sent.append((v, token))
        if token == 0:
            raise MotionCancelled("a stop came after it")

    driver = Driver(drive).start()
    try:
        driver.offer(DriveCommand(0.1, 0.0, 0))
        wait_until(lambda: len(sent) == 1)
        driver.offer(DriveCommand(0.2, 0.0, 0))  # the same stream
        wait_until(lambda: driver.skipped == 1)
        driver.offer(DriveCommand(0.3, 0.0, 1))  # a new stream
        wait_until(lambda: len(sent) == 2)
    finally:
        driver.close()
    assert sent == [(0.1, 0), (0.3, 1)]

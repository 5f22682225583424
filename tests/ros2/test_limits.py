"""cmd_vel's speed limits (cart2d/ros2/limits.py) with a fake gateway and a fake node (no DDS,
no link): a command takes the limits last read without reading the firmware's settings on its
own path (that read cost the first command ~100 ms in the ros2 bench); they are read at start
and again after each command is sent, on a thread of their own."""

from __future__ import annotations

import threading
from typing import Any

import pytest

from cart2d.ros2.drive import DriveCommand, speed_limits
from cart2d.ros2.inbound import Inbound
from cart2d.ros2.limits import KnownLimits
from cart2d.ros2.names import Ros2Options
from tests.support.waiting import wait_for


class Settings:
    """The gateway's firmware_settings: v_max_mps as set; who read them, on which thread."""

    def __init__(self, v_max_mps: float = 0.3) -> None:
        self.v_max_mps = v_max_mps
        self.readers: list[threading.Thread] = []
        self.fail = False

    def __call__(self) -> list[dict[str, object]]:
        self.readers.append(threading.current_thread())
        if self.fail:
            raise TimeoutError("no reply to PARAM_GET")
        return [{"name": "v_max_mps", "value": self.v_max_mps}]


class FakeGateway:
    def __init__(self) -> None:
        self.firmware_settings = Settings()
        self.driven: list[tuple[float, float, int]] = []

    def drive(self, v_mps: float, omega_radps: float, token: int | None = None) -> None:
        self.driven.append((v_mps, omega_radps, token if token is not None else -1))

    def motion_token(self) -> int:
        return 7

    def go_to(self, x: float, y: float, token: int | None = None) -> Any:
        raise AssertionError("no goal here")

    def set_pose(self, x: float, y: float, theta: float) -> dict[str, float]:
        raise AssertionError("no pose here")


class FakeNode:
    """What Inbound asks of a RosNode before start(): its options and readers."""

    options = Ros2Options(60, "", "localhost")

    def reader(self, dds_name: str, kind: type[Any], profile: object) -> Any:
        return object()


def test_a_command_is_admitted_without_reading_the_settings_on_its_path() -> None:
    gateway = FakeGateway()
    inbound = Inbound(FakeNode(), gateway, lambda: 100.0)  # type: ignore[arg-type]
    command = inbound.gate.admit(2.0, 0.0)
    assert gateway.firmware_settings.readers == []  # not on the reading thread: not at all yet
    assert command == DriveCommand(speed_limits([])[0], 0.0, 7)  # the defaults, until read


def test_the_limits_are_read_at_start_and_after_each_command_sent() -> None:
    gateway = FakeGateway()
    inbound = Inbound(FakeNode(), gateway, lambda: 100.0)  # type: ignore[arg-type]
    inbound.limits.start()
    inbound.driver.start()
    try:
        wait_for(lambda: inbound.limits()[0] == pytest.approx(0.3))
        gateway.firmware_settings.v_max_mps = 0.2  # a setting changed on the firmware
        command = inbound.gate.admit(2.0, 0.0)
        assert command is not None and command.v_mps == pytest.approx(0.3)  # one command late
        inbound.driver.offer(command)
        wait_for(lambda: inbound.limits()[0] == pytest.approx(0.2))
        assert [(round(v, 6), w, token) for v, w, token in gateway.driven] == [(0.3, 0.0, 7)]
        assert threading.main_thread() not in gateway.firmware_settings.readers
    finally:
        inbound.driver.close()
        inbound.limits.close()


def test_limits_that_cannot_be_read_stay_as_last_read() -> None:
    settings = Settings(0.25)
    limits = KnownLimits(settings)
    assert limits() == speed_limits([])
    limits.refresh()
    assert limits()[0] == pytest.approx(0.25)
    settings.fail = True
    limits.refresh()
    assert limits()[0] == pytest.approx(0.25)

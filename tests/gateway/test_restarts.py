"""Restarts and the pose's trust (cart2d/gateway/restarts.py) on their own: a fake firmware, a
bus, and the mission's abort as a list of calls."""

from __future__ import annotations

import pytest

from cart2d.gateway.bus import Event, EventBus, PoseCorrected, Restarted, ViewerMessage
from cart2d.gateway.restarts import Restarts
from cart2d.gateway.status_cache import StatusCache
from tests.support.fake_firmware import FakeFirmware


class Rig:
    def __init__(self, driving: bool = False) -> None:
        self.cart = FakeFirmware()
        self.bus = EventBus()
        self.events: list[Event] = []
        self.bus.subscribe(Event, self.events.append)
        self.aborts: list[tuple[str, str, bool]] = []  # reason, routine's, trusted then
        self.driving = driving
        self.restarts = Restarts(
            self.cart, StatusCache(), self.bus, lambda: (0.1, 0.2, 0.0), self.abort, press_reset=None
        )
        self.restarts.read_status()  # the baseline

    def abort(self, reason: str, routine_reason: str) -> tuple[float, float] | None:
        self.aborts.append((reason, routine_reason, self.restarts.pose_trust.trusted))
        return (1.0, 2.0) if self.driving else None

    def messages(self, kind: str) -> list[dict[str, object]]:
        return [e.wire for e in self.events if isinstance(e, ViewerMessage) and e.message.type == kind]


def test_no_restart_no_event() -> None:
    rig = Rig()
    rig.restarts.read_status()
    assert rig.events == [] and rig.restarts.resets_noticed == 0 and rig.aborts == []


def test_an_unexpected_restart_untrusts_the_pose_before_it_ends_the_mission() -> None:
    rig = Rig(driving=True)
    rig.cart.restart()
    rig.restarts.read_status()
    (reason, routine_reason, trusted_then) = rig.aborts[0]
    assert reason.startswith("the controller restarted: ") and not trusted_then
    assert routine_reason == "the controller restarted before it squared up"
    report = rig.restarts.last_reset
    assert report is not None and report.mission_ended and not report.expected
    assert "The mission to (1.00, 2.00) failed." in report.message and "No goal is planned" in report.message
    assert rig.cart.requests[-1] == "STOP"  # the firmware is told again: idle
    (told,) = rig.messages("reset")
    assert told["pose_trust"] == {"trusted": False, "reason": rig.restarts.pose_trust.reason}
    assert rig.events[-1] == Restarted(expected=False, caused_by="", pose_trusted=False, mission_ended=True)


def test_a_soft_reset_that_kept_the_pose_keeps_it_trusted() -> None:
    rig = Rig()
    report = rig.restarts.soft_reset()
    assert report is not None and report.expected and report.pose_restored and not report.mission_ended
    assert report.caused_by == "a soft reset asked for through the gateway"
    assert rig.restarts.pose_trust.trusted and "REBOOT" in rig.cart.requests
    assert "STOP" not in rig.cart.requests  # no mission ended: nothing to stop


def test_an_expected_restart_that_untrusts_says_why() -> None:
    rig = Rig()
    with rig.restarts.resetting("a firmware update", certain=True, untrusts="the program was replaced"):
        rig.cart.restart(keep_pose=True)
    assert rig.restarts.resets_noticed == 1 and not rig.restarts.pose_trust.trusted
    report = rig.restarts.last_reset
    assert report is not None and "It is not trusted after a firmware update" in report.message


def test_a_certain_restart_is_reported_even_when_status_shows_none() -> None:
    """A fresh MCU whose uptime overtook the old one's with boot count 1 again looks like none."""
    rig = Rig()
    with rig.restarts.resetting(
        "restarting the simulator", certain=True, untrusts="a new simulator starts afresh"
    ):
        pass
    assert rig.restarts.resets_noticed == 1 and not rig.restarts.pose_trust.trusted


def test_trust_comes_back_with_words() -> None:
    rig = Rig()
    rig.cart.restart()
    rig.restarts.read_status()
    rig.restarts.trust("the pose was set")
    assert rig.restarts.pose_trust.trusted and rig.events[-1] == PoseCorrected("the pose was set")
    assert rig.messages("pose_trust") == [
        {"type": "pose_trust", "trusted": True, "reason": "", "how": "the pose was set"}
    ]


@pytest.mark.parametrize("driving", [False, True])
def test_the_restart_event_says_whether_a_mission_ended(driving: bool) -> None:
    rig = Rig(driving=driving)
    rig.cart.restart()
    rig.restarts.read_status()
    restarted = [e for e in rig.events if isinstance(e, Restarted)]
    assert [e.mission_ended for e in restarted] == [driving]

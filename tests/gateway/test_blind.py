"""The camera is never silently blind (cart2d/gateway/blind.py): the watch's rule against a fake
clock and a fake gateway, and in the simulator a mission whose camera dies halfway, which stops
the cart (ground truth) with the reason in the mission and its /ws message."""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import cast

import pytest

from cart2d.gateway import Gateway
from cart2d.gateway.blind import BlindWatch
from cart2d.gateway.camera import CameraFeed
from cart2d.simulation.camera import SimCameraServer
from cart2d.simulation.lockstep import Lockstep
from cart2d.tools.missions.camera import free_port_pair
from tests.support.gateway import WIDE, GatewayRig
from tests.support.sim import run_for
from tests.support.waiting import wait_for


@dataclass
class FakeSeeing:
    frames: int = 0  # frames perception put on its grid
    idle_skipped: int = 0  # and left out at rest


@dataclass
class FakeFeed:
    blind_s: float = 0.5
    in_hand: int | None = None  # the frame perception is working on

    def blindness(self) -> str:
        return "the camera's stream is not connected (the camera closed the stream)"


@dataclass
class FakeMission:
    state: str = "driving"


@dataclass
class FakeGateway:
    camera: FakeFeed | None = field(default_factory=FakeFeed)
    seeing: FakeSeeing | None = field(default_factory=FakeSeeing)
    enabled: bool = True
    mission: FakeMission = field(default_factory=FakeMission)
    stopped: list[str] = field(default_factory=list)

    def sees(self) -> bool:
        return self.seeing is not None and self.enabled

    def stop(self, reason: str) -> None:
        self.stopped.append(reason)
        self.mission.state = "failed"


class FakeClock:
    def __init__(self) -> None:
        self.t: float | None = 10.0

    def __call__(self) -> float | None:
        return self.t


def watching() -> tuple[BlindWatch, FakeGateway, FakeClock]:
    gateway, clock = FakeGateway(), FakeClock()
    return BlindWatch(cast(Gateway, gateway), clock), gateway, clock


def test_no_frame_for_the_limit_stops_the_mission_with_why() -> None:
    watch, gateway, clock = watching()
    assert watch.check() == ""  # the first look starts the count
    assert clock.t is not None
    clock.t += 0.49
    assert watch.check() == "" and gateway.stopped == []
    clock.t += 0.02
    reason = watch.check()
    assert reason == (
        "the camera went blind: no frame taken in for 0.5 s (the camera's stream is not connected "
        "(the camera closed the stream))"
    )
    assert gateway.stopped == [reason] and watch.stops == 1
    clock.t += 1.0
    assert watch.check() == ""  # the mission has ended: one stop


def test_a_frame_taken_in_starts_the_blind_time_again() -> None:
    watch, gateway, clock = watching()
    assert gateway.seeing is not None and clock.t is not None
    for k in range(20):  # a frame every 0.3 s, put on the grid or left out at rest: never blind
        watch.check()
        clock.t += 0.3
        if k % 2:
            gateway.seeing.frames += 1
        else:
            gateway.seeing.idle_skipped += 1
    assert gateway.stopped == [] and watch.longest_s == pytest.approx(0.0)
    watch.check()
    clock.t += 0.3
    watch.check()
    assert watch.longest_s == pytest.approx(0.3)


def test_the_blind_time_counts_only_while_perception_is_on_and_a_mission_drives() -> None:
    watch, gateway, clock = watching()
    assert clock.t is not None
    gateway.mission.state = "arrived"
    watch.check()
    clock.t += 5.0
    assert watch.check() == ""
    gateway.mission.state, gateway.enabled = "driving", False
    clock.t += 5.0
    assert watch.check() == ""
    gateway.enabled = True  # perception on again while the cart drives: its first frame is due
    assert watch.check() == ""
    clock.t += 0.3
    assert watch.check() == ""
    clock.t += 0.3
    assert watch.check().startswith("the camera went blind: no frame taken in for 0.6 s")


def test_a_frame_perception_is_still_working_on_counts_as_fresh_for_two_seconds() -> None:
    watch, gateway, clock = watching()
    assert gateway.camera is not None and clock.t is not None
    watch.check()
    gateway.camera.in_hand = 7  # a replan it caused, or the planner's lock held by another's
    for _ in range(8):  # steps of 0.25 s (exact in binary): seen in hand from the first, for 1.75 s
        clock.t += 0.25
        assert watch.check() == ""
    clock.t += 0.25
    assert watch.check() == ""  # 2 s on one frame: no longer fresh, blind since the look before
    clock.t += 0.25
    assert watch.check().startswith("the camera went blind: no frame taken in for 0.5 s")


def test_a_clock_that_went_back_or_another_camera_starts_the_count_again() -> None:
    watch, gateway, clock = watching()
    watch.check()
    clock.t = 0.2  # the simulator restarted: its time starts at 0 again
    assert watch.check() == ""
    clock.t = 0.6
    assert watch.check() == ""  # 0.4 s since the restart
    gateway.seeing = FakeSeeing()  # another camera (its own perception): counted from the first look
    clock.t = 0.8
    assert watch.check() == ""
    clock.t = 1.2
    assert watch.check() == "" and gateway.stopped == []
    clock.t = None  # no cart time yet (the simulator's first truth message)
    assert watch.check() == ""


@pytest.fixture
def seeing_rig(tmp_path: Path) -> Iterator[tuple[GatewayRig, SimCameraServer]]:
    """The WIDE grid in real time, with the simulated camera and perception on (as `cart2d sim`),
    in lockstep with perception as missions run (cart2d/simulation/lockstep.py): on a busy machine
    perception falling 0.5 s of wall time behind would otherwise be taken for a blind camera
    before the test kills it."""
    rig = GatewayRig(tmp_path, WIDE, speed="1")
    server = SimCameraServer(lambda: rig.sim.control_address, free_port_pair()).start()
    step: Lockstep | None = None
    try:
        feed = CameraFeed.of(server.url, None)
        assert feed is not None
        rig.gateway.use_camera(feed.start())
        step = Lockstep(rig.sim, feed).start()
        wait_for(lambda: feed.taken >= 3, 60.0)
        yield rig, server
    finally:
        if step is not None:
            step.close()
        rig.gateway.use_camera(None)
        server.stop()
        rig.close()


def test_the_camera_dying_mid_mission_stops_the_cart_with_the_reason(
    seeing_rig: tuple[GatewayRig, SimCameraServer],
) -> None:
    rig, camera = seeing_rig
    rig.sim.control("place", x=0.2, y=0.8, theta=0.0)
    rig.link.call("SET_POSE", 0.2, 0.8, 0.0)
    rig.gateway.go_to(3.6, 0.8)  # 3.4 m straight ahead: 7 s and more at 0.5 m/s
    wait_for(lambda: rig.sim.truth()["x"] > 0.8, 60.0)
    assert rig.gateway.mission_view()["state"] == "driving"
    # Where and when the camera dies, read before stopping it: the stop takes wall time (its
    # servers' threads end), and the simulator runs on meanwhile: on a busy machine, long enough
    # for the watch to have stopped the cart before a read after the stop.
    died = rig.sim.truth()
    camera.stop()  # the camera dies: its stream closes, and nothing listens on its port any more
    mission = rig.wait_end()
    assert mission["state"] == "failed"
    blind = re.match(r"the camera went blind: no frame taken in for (\d+\.\d) s \(.+\)$", mission["reason"])
    assert blind and float(blind[1]) >= 0.5, mission  # a look every 0.05 s: 0.5 or 0.6 s, later if busy
    told = [m for m in rig.messages if m["type"] == "mission" and m["state"] == "failed"]
    assert told and told[-1]["reason"] == mission["reason"]  # what /ws sends viewers
    run_for(rig.sim, 0.5)
    # ground truth: stopped soon after the camera died (simulated time: the limit, the braking and
    # a busy machine's lateness), far short of the goal it drove to at 0.5 m/s
    truth = rig.sim.truth()
    assert abs(truth["v"]) < 0.005, truth
    track = [m for m in rig.messages if m["type"] == "truth" and m["t"] >= died["t"]]
    moving = [m["t"] for m in track if abs(m["v"]) >= 0.005]
    assert moving and max(moving) - died["t"] < 2.5, (died["t"], max(moving))
    assert truth["x"] - died["x"] < 1.25 and truth["x"] < 3.6 - 1.0
    assert truth["collisions"] == 0

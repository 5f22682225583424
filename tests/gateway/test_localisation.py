"""The localisation service on the fake firmware (no simulator, a fake clock): a marker's fix
makes an untrusted pose trusted (a carried cart), corrects map -> odom, re-sends a driven route
in the corrected odometry's frame, and a fix far from the prediction changes nothing."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import cast

import numpy as np
import pytest

from cart2d.gateway import Gateway
from cart2d.gateway.bus import Event, PoseCorrected, ViewerMessage
from cart2d.gateway.camera import CameraFeed
from cart2d.gateway.localisation import Localisation, with_timing
from cart2d.gateway.messages import LocalisationMessage, TelemetryMessage
from cart2d.localisation.ekf import Pose2
from cart2d.localisation.markers import MarkerMap, arena_markers
from cart2d.localisation.tags import TagFix
from cart2d.perception.camera_model import Intrinsics, Mount
from tests.support.clock import FakeClock
from tests.support.fake_firmware import FakeFirmware

MOUNT = Mount.from_robot()
FIX_COVARIANCE = np.diag([0.01**2, 0.01**2, math.radians(1.0) ** 2])


def telemetry(pose: Pose2) -> ViewerMessage:
    zero = dict.fromkeys(
        (
            "v_left", "v_right", "v_left_target", "v_right_target", "pwm_left", "pwm_right", "v", "omega",
            "v_target", "omega_target", "distance_to_waypoint", "waypoint_index", "state",
        ),
        0,
    )  # fmt: skip
    return ViewerMessage(
        TelemetryMessage(x=pose[0], y=pose[1], theta=pose[2], tick=0, mode_name="IDLE", flag_names=[], **zero)
    )


@pytest.fixture
def clock() -> FakeClock:
    return FakeClock()


@pytest.fixture
def service(gateway: Gateway, clock: FakeClock) -> Localisation:
    markers: MarkerMap = arena_markers((-0.25, -0.25, 2.05, 2.05))
    return Localisation(
        gateway.bus, gateway.restarts, markers, Intrinsics.nominal(MOUNT), MOUNT, 0.06, gateway.frames, clock
    )


def drive(gateway: Gateway, clock: FakeClock, odom: Pose2) -> None:
    clock.t += 0.1
    gateway.bus.publish(telemetry(odom))


def fix_at(pose: Pose2) -> TagFix:
    return TagFix(3, pose, FIX_COVARIANCE, 0.5, 50.0)


def corrections(events: list[Event]) -> list[PoseCorrected]:
    return [e for e in events if isinstance(e, PoseCorrected) and e.map_to_odom is not None]


def test_a_carried_cart_is_found_at_its_first_marker(
    gateway: Gateway, cart: FakeFirmware, service: Localisation, clock: FakeClock
) -> None:
    events: list[Event] = []
    gateway.bus.subscribe(Event, events.append)
    cart.restart()
    gateway.read_status()
    assert not gateway.pose_trust.trusted
    drive(gateway, clock, (0.0, 0.0, 0.0))  # the firmware counts from (0, 0, 0) again
    assert service.fuse(fix_at((1.0, 0.8, 0.0)), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)) == "started"
    assert gateway.pose_trust.trusted
    (event,) = corrections(events)
    assert event.map_to_odom == pytest.approx((1.0, 0.8, 0.0))
    assert event.covariance is not None and len(event.covariance) == 9
    assert event.how == "marker 3 at 0.50 m: started"
    gateway.go_to(1.6, 0.8)  # planned in map, sent in odom
    assert cart.path[-1] == pytest.approx((0.6, 0.0))
    shown = [e.message for e in events if isinstance(e, ViewerMessage)]
    assert any(isinstance(m, LocalisationMessage) and m.trusted for m in shown)


def test_a_correction_during_a_mission_resends_its_route_in_odom(
    gateway: Gateway, cart: FakeFirmware, service: Localisation, clock: FakeClock
) -> None:
    drive(gateway, clock, (0.2, 0.8, 0.0))  # trusted at the start: map = odom
    gateway.go_to(1.6, 0.8)
    sent = cart.requests.count("WAIT_XY_ARRAY")
    cart.mode = "PATH"
    drive(gateway, clock, (0.2, 0.8, 0.0))
    # a marker says the cart is 4 cm further on than odometry counted
    assert service.fuse(fix_at((0.24, 0.8, 0.0)), (0.2, 0.8, 0.0), (0.2, 0.8, 0.0)) == "accepted"
    shift = gateway.frames.get()[0]
    assert 0.01 < shift < 0.04
    assert cart.requests.count("WAIT_XY_ARRAY") == sent + 1
    assert cart.path[-1] == pytest.approx((1.6 - shift, 0.8))
    assert gateway.mission_view()["replans"][-1]["reason"].startswith("the pose was corrected")


def test_a_correction_that_moves_the_route_by_a_centimetre_keeps_it(
    gateway: Gateway, cart: FakeFirmware, service: Localisation, clock: FakeClock
) -> None:
    """Near its goal: re-sent, the route would turn the cart on the spot to close a centimetre
    (cart2d/gateway/correction_resend.py)."""
    drive(gateway, clock, (1.5, 0.8, 0.0))
    gateway.go_to(1.6, 0.8)
    sent = cart.requests.count("WAIT_XY_ARRAY")
    cart.mode = "PATH"
    drive(gateway, clock, (1.58, 0.8, 0.0))
    # a marker says the cart is 2 cm further on than odometry counted: the goal lies behind it
    assert service.fuse(fix_at((1.6, 0.8, 0.0)), (1.58, 0.8, 0.0), (1.58, 0.8, 0.0)) == "accepted"
    assert 0.005 < gateway.frames.get()[0] < 0.03
    assert cart.requests.count("WAIT_XY_ARRAY") == sent and not gateway.mission_view()["replans"]


def test_a_fix_far_from_the_prediction_is_doubted_and_changes_nothing(
    gateway: Gateway, cart: FakeFirmware, service: Localisation, clock: FakeClock
) -> None:
    events: list[Event] = []
    drive(gateway, clock, (0.2, 0.8, 0.0))
    gateway.bus.subscribe(Event, events.append)
    assert service.fuse(fix_at((1.2, 0.8, 0.0)), (0.2, 0.8, 0.0), (0.2, 0.8, 0.0)) == "doubted"
    assert gateway.frames.get() == (0.0, 0.0, 0.0) and corrections(events) == []


def test_setting_the_pose_makes_map_and_odom_agree_again(
    gateway: Gateway, cart: FakeFirmware, service: Localisation, clock: FakeClock
) -> None:
    drive(gateway, clock, (0.2, 0.8, 0.0))
    service.fuse(fix_at((0.23, 0.8, 0.0)), (0.2, 0.8, 0.0), (0.2, 0.8, 0.0))
    assert gateway.frames.get() != (0.0, 0.0, 0.0)
    gateway.set_pose(0.5, 0.5, 0.0)
    assert gateway.frames.get() == (0.0, 0.0, 0.0)


class FakeFeed:
    """What the camera service asks of a camera feed."""

    def __init__(self) -> None:
        self.processors: list[object] = []

    def add_processor(self, processor: object) -> None:
        self.processors.append(processor)

    def subscribe(self, viewer: object) -> Callable[[], None]:
        return lambda: None

    def stop(self) -> None:
        pass


def test_what_the_camera_sees_is_placed_in_map_and_the_markers_processor_gets_every_feed(
    gateway: Gateway, service: Localisation
) -> None:
    gateway.frames.set((1.0, 0.5, math.pi / 2))
    gateway.camera_service.add_processor(service)
    feed = FakeFeed()
    gateway.camera_service.use_camera(cast(CameraFeed, feed))
    seeing = gateway.camera_service.seeing
    assert seeing is not None and feed.processors == [seeing, service]
    # perception's pose: odometry's (0.2, 0, 0) is map's (1.0, 0.7, pi/2)
    assert seeing.to_map((0.2, 0.0, 0.0)) == pytest.approx((1.0, 0.7, math.pi / 2))
    gateway.camera_service.use_camera(None)


def test_a_fix_from_a_turning_cart_counts_for_less_while_the_cameras_clock_is_unsure() -> None:
    # The heading of a frame taken while turning at 2.6 rad/s is only as good as its capture
    # time: with the camera's clock known to 2 ms the fix keeps its own heading variance; with
    # 40 ms (no stamps, or a clock still settling) it grows by (2.6 rad/s x 40 ms)^2.
    before, captured = (0.0, 0.0, 0.0), (0.0, 0.0, 0.26)  # RATE_WINDOW_S apart
    settled = with_timing(fix_at(captured), before, captured, 0.002).covariance[2, 2]
    unsure = with_timing(fix_at(captured), before, captured, 0.04).covariance[2, 2]
    own = FIX_COVARIANCE[2, 2]
    assert settled - own == pytest.approx((2.6 * 0.002) ** 2)
    assert unsure - own == pytest.approx((2.6 * 0.04) ** 2)
    assert unsure > 20 * own  # about 6 degrees of doubt: the filter takes such a heading lightly

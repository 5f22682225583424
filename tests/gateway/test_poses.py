"""The pose at a frame's capture (cart2d/gateway/poses.py) on fake clocks: a cart whose clocks
run 20 times faster than the gateway's (a simulator at full speed) is looked up by the camera's
stamp on the firmware's clock, where arrival less latency is far off; TICK's wrap and a restart;
a camera without stamps; a camera that restarts."""

from __future__ import annotations

import random

import pytest

from cart2d.gateway.poses import TICKS, CaptureClock, CapturePoses, FirmwareClock
from cart2d.perception.mjpeg import Frame
from tests.support.clock import FakeClock

TICK_S = 0.008
SPEED = 20.0  # the cart's seconds per second of the gateway's clock
LATENCY_S = 0.06  # the camera's, on its own clock
V = 0.5  # m/s along x, on the cart's clock
CAMERA_EPOCH = 1000.0  # the camera's clock reads this at the firmware's zero


def wall_at(device_s: float) -> float:
    return 5.0 + device_s / SPEED


def driven(first_tick: int = 65000) -> tuple[CapturePoses, FakeClock]:
    """Telemetry every 40 ms of the cart's clock for 3 s, the cart at V along x."""
    wall = FakeClock(5.0)
    poses = CapturePoses(LATENCY_S, wall)
    for k in range(76):
        t = 0.04 * k
        wall.t = wall_at(t)
        poses.add((V * t, 0.0, 0.0), (first_tick + 5 * k) % TICKS)
    return poses, wall


def frames(stamped: bool) -> list[tuple[float, Frame]]:
    """(capture time on the cart's clock, frame) at 15 fps from 1 s, each arriving LATENCY_S
    later by the cart's clock and up to 1 ms later by the gateway's (its reader's delay)."""
    jitter = random.Random(3)
    out = []
    for k in range(20):
        captured = 1.0 + k / 15.0
        received = wall_at(captured + LATENCY_S) + jitter.uniform(0.0, 0.001)
        out.append((captured, Frame(b"", k, CAMERA_EPOCH + captured if stamped else None, received)))
    return out


def test_a_fast_cart_is_looked_up_by_the_cameras_stamp_on_the_firmwares_clock() -> None:
    poses, _ = driven()
    errors = []
    for captured, frame in frames(stamped=True):
        pose = poses.at(frame)
        assert pose is not None
        errors.append(abs(pose[0] - V * captured))
    assert max(errors[5:]) < 0.01, errors  # once a few gaps are known: within a centimetre
    # arrival less latency, on the gateway's clock, puts the cart where it was 1.2 s before
    unstamped, _ = driven()
    for captured, frame in frames(stamped=False)[5:]:
        pose = unstamped.at(frame)
        assert pose is not None and V * captured - pose[0] > 0.5


def test_a_pose_back_from_the_capture_is_on_the_same_clock() -> None:
    poses, _ = driven()
    for _, frame in frames(stamped=True)[:10]:
        pose = poses.at(frame)
    earlier = poses.at(frame, back_s=0.2)
    assert pose is not None and earlier is not None
    assert pose[0] - earlier[0] == pytest.approx(V * 0.2, abs=0.01)


def test_without_stamps_the_arrival_less_the_latency_is_used() -> None:
    wall = FakeClock(5.0)
    poses = CapturePoses(LATENCY_S, wall)
    for k in range(50):  # a cart in real time: its clock and the gateway's alike
        wall.t = 5.0 + 0.04 * k
        poses.add((V * 0.04 * k, 0.0, 0.0), 5 * k)
    pose = poses.at(Frame(b"", 1, None, 5.0 + 1.06))
    assert pose is not None and pose[0] == pytest.approx(V * 1.0)


def test_ticks_wrap_and_a_restart_carries_the_firmwares_clock_on() -> None:
    clock = FirmwareClock(TICK_S)
    assert clock.add(0.0, TICKS - 5) == 0.0
    assert clock.add(0.1, 5) == pytest.approx(10 * TICK_S)  # through the wrap
    assert clock.add(0.2, 2) == pytest.approx(11 * TICK_S)  # back: a restart, one tick on
    assert clock.add(0.3, 7) == pytest.approx(16 * TICK_S)
    assert clock.first_after(0.15) == pytest.approx(11 * TICK_S)
    assert clock.first_after(0.3) is None  # nothing has arrived after it yet


def test_a_camera_that_restarts_forgets_the_gaps_of_its_old_clock() -> None:
    capture = CaptureClock(LATENCY_S)
    assert capture.firmware_time(1.0) is None
    capture.observe(100.0, 5.07)
    capture.observe(100.1, 5.16)
    assert capture.firmware_time(100.2) == pytest.approx(100.2 + (5.16 - 100.1) - LATENCY_S)
    capture.observe(0.5, 6.0)  # its clock back to zero
    assert capture.firmware_time(0.6) == pytest.approx(0.6 + 5.5 - LATENCY_S)


def test_one_gap_made_short_by_a_late_telemetry_frame_does_not_move_the_clock() -> None:
    capture = CaptureClock(LATENCY_S)
    for k in range(20):  # the camera's latency, and up to 40 ms of telemetry's period on top
        capture.observe(100.0 + k / 15.0, 5.0 + k / 15.0 + 0.06 + 0.002 * (k % 20))
    before = capture.firmware_time(102.0)
    capture.observe(101.4, 5.0 + 1.4 + 0.06 - 0.3)  # a telemetry frame handed on 0.3 s late
    assert capture.firmware_time(102.0) == before
    assert before is not None and before - (102.0 - 95.0) == pytest.approx(0.0, abs=0.01)

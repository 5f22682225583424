"""The pose at a frame's capture (cart2d/gateway/poses.py) on fake clocks: a cart whose clocks
run 20 times faster than the gateway's (a simulator at full speed) is looked up by the camera's
stamp on the firmware's clock, where arrival less latency is far off; a frame taken after the
newest telemetry waits for its own, never takes the newest pose; TICK's wrap and a restart; a
camera without stamps; a camera that restarts."""

from __future__ import annotations

import random
import threading
import time

import pytest

from cart2d.gateway.poses import (
    CAPTURE_SIGMA_S,
    MIN_GAPS,
    SETTLED_GAPS,
    TICKS,
    CaptureClock,
    CapturePoses,
    FirmwareClock,
)
from cart2d.perception.mjpeg import Frame
from tests.support.clock import FakeClock

TICK_S = 0.008
SPEED = 20.0  # the cart's seconds per second of the gateway's clock
LATENCY_S = 0.06  # the camera's, on its own clock
V = 0.5  # m/s along x, on the cart's clock
CAMERA_EPOCH = 1000.0  # the camera's clock reads this at the firmware's zero


def wall_at(device_s: float) -> float:
    return 5.0 + device_s / SPEED


def driven(first_tick: int = 65000, telemetry_wait_s: float = 0.0) -> tuple[CapturePoses, FakeClock]:
    """Telemetry every 40 ms of the cart's clock for 3 s, the cart at V along x."""
    wall = FakeClock(5.0)
    poses = CapturePoses(LATENCY_S, wall, telemetry_wait_s)
    for k in range(76):
        telemetry(poses, wall, k, first_tick)
    return poses, wall


def telemetry(poses: CapturePoses, wall: FakeClock, k: int, first_tick: int = 65000) -> None:
    """The k-th telemetry frame of the cart driving at V (every 40 ms of its clock)."""
    t = 0.04 * k
    wall.t = wall_at(t)
    poses.add((V * t, 0.0, 0.0), (first_tick + 5 * k) % TICKS)


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


def late_frame(captured: float) -> Frame:
    """A frame taken at `captured` (after the 3 s of telemetry driven() gives), arrived now."""
    return Frame(b"", 99, CAMERA_EPOCH + captured, wall_at(captured + LATENCY_S))


def test_a_frame_taken_after_the_newest_telemetry_has_no_pose_rather_than_the_newest() -> None:
    poses, _ = driven()  # no wait: telemetry held up behind a busy gateway never comes
    for _, frame in frames(stamped=True):
        poses.at(frame)  # the clocks' offset learned
    # the newest pose is 0.25 m short of where the cart was (a turning cart: a wrong heading)
    assert poses.at(late_frame(3.5)) is None
    assert poses.at(late_frame(3.5), back_s=1.0) is not None  # 2.5 s: telemetry has it


def test_a_frame_taken_after_the_newest_telemetry_waits_for_the_telemetry_of_its_capture() -> None:
    poses, wall = driven(telemetry_wait_s=60.0)  # the test's timeout ends a wait that never ends
    for _, frame in frames(stamped=True):
        poses.at(frame)
    frame = late_frame(3.5)

    def handed_on_late() -> None:  # telemetry to 3.6 s, a moment after the frame began to wait
        time.sleep(0.2)  # (were this thread first, the wait would be over at once: still right)
        for k in range(76, 91):
            telemetry(poses, wall, k)

    arriving = threading.Thread(target=handed_on_late)
    arriving.start()
    pose = poses.at(frame)
    arriving.join()
    assert pose is not None and pose[0] == pytest.approx(V * 3.5, abs=0.01)


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
    median_gap = ((5.07 - 100.0) + (5.16 - 100.1)) / 2
    assert capture.firmware_time(100.2) == pytest.approx(100.2 + median_gap - LATENCY_S)
    capture.observe(0.5, 6.0)  # its clock back to zero
    assert capture.firmware_time(0.6) == pytest.approx(0.6 + 5.5 - LATENCY_S)


def test_one_gap_made_short_by_a_late_telemetry_frame_does_not_move_the_clock() -> None:
    capture = CaptureClock(LATENCY_S)
    for k in range(20):  # the camera's latency, and up to 40 ms of telemetry's period on top
        capture.observe(100.0 + k / 15.0, 5.0 + k / 15.0 + 0.06 + 0.002 * (k % 20))
    before = capture.firmware_time(102.0, 0.04)
    capture.observe(101.4, 5.0 + 1.4 + 0.06 - 0.3)  # a telemetry frame handed on 0.3 s late
    after = capture.firmware_time(102.0, 0.04)
    assert before is not None and after is not None and abs(after - before) < 0.002
    assert before - (102.0 - 95.0) == pytest.approx(0.0, abs=0.005)


def test_gaps_made_short_by_telemetry_queued_at_the_start_do_not_put_the_captures_early() -> None:
    """Seen with both cores busy: the first frame's gap 2.7 s short, the next ones 0.3 s (telemetry
    queued since the gateway started), while the cart turned on the spot to look: the smallest
    gap, or a low quantile of the few known, put every capture that early for seconds."""
    capture = CaptureClock(LATENCY_S)
    short = [2.7, 0.3, 0.3]
    errors = []
    for k in range(30):
        stamp = 100.0 + k / 15.0
        waited = 0.04 * ((k * 7) % 10) / 10  # the next telemetry, within a 40 ms period
        capture.observe(stamp, stamp - 95.0 + LATENCY_S + waited - (short[k] if k < len(short) else 0.0))
        captured = capture.firmware_time(stamp, 0.04)
        assert captured is not None
        errors.append(abs(captured - (stamp - 95.0)))
    assert max(errors[6:]) < 0.02, errors


def test_the_stamp_clock_says_how_well_it_knows_the_offset_and_when_it_has_settled() -> None:
    """Gaps spread over a 40 ms telemetry period: the median's standard error, a few ms once 90
    are known; gaps that drift 10 ms a frame (telemetry queued at the start draining, seen under
    load): at least the drift of the recent ones from the median, so a turning cart's frames are
    taken as uncertain while it lasts. Settled from SETTLED_GAPS on, once known within 10 ms."""
    steady = CaptureClock(LATENCY_S)
    for k in range(MIN_GAPS - 1):
        steady.observe(100.0 + k / 15.0, 5.0 + k / 15.0 + 0.06)
    assert steady.sigma_s() is None
    for k in range(MIN_GAPS - 1, 90):
        if k < SETTLED_GAPS:
            assert not steady.settled()
        steady.observe(100.0 + k / 15.0, 5.0 + k / 15.0 + 0.06 + 0.04 * ((k * 7) % 10) / 10)
    sigma = steady.sigma_s()
    assert sigma is not None and 0.001 < sigma < 0.004
    assert steady.settled()
    drifting = CaptureClock(LATENCY_S)
    for k in range(12):
        drifting.observe(100.0 + k / 15.0, 5.0 + k / 15.0 + 0.06 + 0.01 * k)
    sigma = drifting.sigma_s()
    assert sigma is not None and sigma >= 0.03
    assert not drifting.settled()


def test_a_frames_timing_uncertainty_comes_from_its_camera_clock_or_the_default() -> None:
    poses, wall = driven()
    unstamped = Frame(b"", 1, None, wall())
    assert poses.settled()  # nothing to settle: no stamped frame seen
    assert poses.sigma_s(unstamped) == CAPTURE_SIGMA_S
    first = Frame(b"", 2, CAMERA_EPOCH + 2.5, wall_at(2.5 + LATENCY_S))
    poses.at(first)
    assert not poses.settled() and poses.sigma_s(first) == CAPTURE_SIGMA_S  # one gap: unknown


def test_frames_looked_up_before_telemetry_after_them_arrived_still_teach_the_clock() -> None:
    """Looked up as it arrives, a frame has no telemetry after it yet: its gap is taken at the
    next lookup, so the clock learns from every frame, not only those processed late."""
    wall = FakeClock(5.0)
    poses = CapturePoses(LATENCY_S, wall, telemetry_wait_s=0.0)
    k = 0
    for n in range(12):
        captured = 1.0 + n / 15.0
        while 0.04 * k <= captured + LATENCY_S:  # telemetry up to the frame's arrival, none after
            telemetry(poses, wall, k)
            k += 1
        poses.at(Frame(b"", n, CAMERA_EPOCH + captured, wall_at(captured + LATENCY_S) + 1e-6))
    assert poses.capture.sigma_s() is not None  # 11 gaps: all but the last frame's
    assert poses.capture.settled()

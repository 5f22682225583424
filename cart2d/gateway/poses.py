"""The odometry pose at a camera frame's capture.

A frame reaches the gateway some latency after it was taken, so its pose is looked up in the
poses telemetry brought. Counted on the gateway's clock (arrival less the camera's latency) that
is right only while the cart's clocks run as fast as the gateway's: behind a slow Wi-Fi hop, or a
simulator running faster than real time, the cart drives on during the wait by its own clock.
A camera that stamps its frames (X-Timestamp: the ESP32-CAM's, the simulator's) is looked up on
the firmware's clock (telemetry's TICK) instead: the offset between the two clocks is learned
from the frames themselves, from the gaps between a stamp and the firmware's time of the first
telemetry after the frame's arrival (the camera's latency and half a telemetry period, in the
median: telemetry queued behind a busy gateway makes a gap seconds short, a late frame long).
A frame taken after the newest telemetry (telemetry held up behind a busy gateway) waits for the
telemetry of its capture, up to TELEMETRY_WAIT_S, and has no pose if it does not come: the
newest pose would be that of a cart that has since turned. Nothing here asks whether the cart is simulated.
"""

from __future__ import annotations

import bisect
import itertools
import math
import statistics
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Any

from cart2d.params import robot
from cart2d.perception.mjpeg import Frame
from cart2d.perception.occupancy import Pose

TICKS = 65536  # telemetry's TICK is 16 bits
GAPS_KEPT = 90  # frames whose stamp-to-arrival gap the offset is learned from (6 s at 15 fps)
PERIODS_KEPT = 50  # telemetry frames whose spacing gives its period
FIRMWARE_KEEP_S = 30.0  # seconds of the firmware's clock kept: a faster clock than the gateway's
# How long a frame taken after the newest telemetry waits for it (wall seconds): a telemetry period
# of the slowest rate that keeps up with a turning cart (2 Hz), and the camera's blind limit
TELEMETRY_WAIT_S = 0.5
# How far off a frame's capture time may be when nothing better is known (a camera without
# stamps, or a stamp clock of fewer than MIN_GAPS gaps): a pose looked up for a frame is as
# uncertain as the cart's motion in that time, its speed taken over RATE_WINDOW_S
CAPTURE_SIGMA_S = 0.04
RATE_WINDOW_S = 0.1
# The stamp clock's offset is a median of gaps: its uncertainty is the median's standard error
# (1.25 x the gaps' robust spread / sqrt(n)), or how far the last RECENT_GAPS' median has moved from
# it (the gaps drift while telemetry queued at the start drains), whichever is more, from MIN_GAPS on.
# It is settled from SETTLED_GAPS on, once known within SETTLED_SIGMA_S: under load the offset moved
# 50 to 130 ms in the first 15 frames, when the cart turned on the spot to look, and the frames
# then put the floor beside a box over the box (the README's example world, 1 run in 5).
MIN_GAPS = 3
RECENT_GAPS = 5
SETTLED_GAPS = 8  # and the offset known within SETTLED_SIGMA_S: 0.026 rad at 2.6 rad/s
SETTLED_SIGMA_S = 0.01


def timing_sigmas(before: Pose, captured: Pose, sigma_s: float = CAPTURE_SIGMA_S) -> tuple[float, float]:
    """The pose's uncertainty from the capture time's, `sigma_s` (m, rad): the odometry's speed
    between `before` (RATE_WINDOW_S earlier) and `captured`, times sigma_s."""
    moved = math.dist(before[:2], captured[:2])
    turned = abs(math.remainder(captured[2] - before[2], math.tau))
    return moved / RATE_WINDOW_S * sigma_s, turned / RATE_WINDOW_S * sigma_s


class PoseHistory:
    """Poses by the time they belong to on one clock, kept `keep_s` back from the newest."""

    def __init__(self, keep_s: float = 3.0) -> None:
        self.keep_s = keep_s
        self._times: deque[float] = deque()
        self._poses: deque[Pose] = deque()
        self._lock = threading.Lock()
        self._added = threading.Condition(self._lock)

    def add(self, t: float, pose: Pose) -> None:
        with self._added:
            if self._times and t < self._times[-1]:  # a clock that went back: a new history
                self._times.clear()
                self._poses.clear()
            self._times.append(t)
            self._poses.append(pose)
            while self._times and self._times[0] < t - self.keep_s:
                self._times.popleft()
                self._poses.popleft()
            self._added.notify_all()

    def newest(self) -> Pose | None:
        with self._lock:
            return self._poses[-1] if self._poses else None

    def reaches(self, t: float, timeout_s: float) -> bool:
        """Whether a pose at or after `t` is here, waiting up to `timeout_s` for one."""
        with self._added:
            return self._added.wait_for(lambda: bool(self._times) and self._times[-1] >= t, timeout_s)

    def at(self, t: float) -> Pose | None:
        """The pose at `t`: interpolated between the two poses around it, the newest one if `t`
        is after it; None before the history starts (the pose then is not known)."""
        with self._lock:
            times, poses = list(self._times), list(self._poses)
        if not times or t < times[0]:
            return None
        k = bisect.bisect_right(times, t)
        if k >= len(times):
            return poses[-1]
        (t0, p0), (t1, p1) = (times[k - 1], poses[k - 1]), (times[k], poses[k])
        f = 0.0 if t1 <= t0 else (t - t0) / (t1 - t0)
        turn = math.remainder(p1[2] - p0[2], math.tau)
        return (p0[0] + f * (p1[0] - p0[0]), p0[1] + f * (p1[1] - p0[1]), p0[2] + f * turn)


class FirmwareClock:
    """Telemetry's TICK unwrapped into seconds of the firmware's clock, with when each arrived
    on the gateway's clock. A TICK that goes back (a restart) carries on from the last one."""

    def __init__(self, tick_s: float, keep: int = 1000) -> None:
        self.tick_s = tick_s
        self._last_tick: int | None = None
        self._ticks = 0  # unwrapped
        self._arrivals: deque[float] = deque(maxlen=keep)
        self._seconds: deque[float] = deque(maxlen=keep)
        self._lock = threading.Lock()

    def add(self, arrived_s: float, tick: int) -> float:
        """The firmware's time of a telemetry frame that arrived at `arrived_s`."""
        with self._lock:
            if self._last_tick is not None:
                step = (tick - self._last_tick) % TICKS
                self._ticks += step if step < TICKS // 2 else 1
            self._last_tick = tick
            seconds = self._ticks * self.tick_s
            self._arrivals.append(arrived_s)
            self._seconds.append(seconds)
            return seconds

    def first_after(self, arrived_s: float) -> float | None:
        """The firmware's time of the first telemetry to arrive after `arrived_s` (None if none
        has yet): the firmware's clock was at most that when something arrived then."""
        with self._lock:
            k = bisect.bisect_right(self._arrivals, arrived_s)
            return self._seconds[k] if k < len(self._seconds) else None

    def period_s(self) -> float:
        """Telemetry's period on the firmware's clock (the median spacing lately; 0 until known)."""
        with self._lock:
            recent = list(self._seconds)[-PERIODS_KEPT:]
        steps = [b - a for a, b in itertools.pairwise(recent) if b > a]
        return statistics.median(steps) if steps else 0.0


class CaptureClock:
    """A camera's stamps on the firmware's clock: stamp + the median gap lately between a stamp
    and the firmware's time of the first telemetry after its frame's arrival, less the camera's
    latency and the half telemetry period that telemetry came after the arrival on average."""

    def __init__(self, latency_s: float, kept: int = GAPS_KEPT) -> None:
        self.latency_s = latency_s
        self._gaps: deque[float] = deque(maxlen=kept)
        self._last_stamp = -math.inf

    def observe(self, stamp_s: float, firmware_at_arrival_s: float) -> None:
        if stamp_s < self._last_stamp:  # the camera restarted: its clock with it
            self._gaps.clear()
        self._last_stamp = stamp_s
        self._gaps.append(firmware_at_arrival_s - stamp_s)

    def firmware_time(self, stamp_s: float, telemetry_period_s: float = 0.0) -> float | None:
        if not self._gaps:
            return None
        return stamp_s + statistics.median(self._gaps) - telemetry_period_s / 2 - self.latency_s

    def sigma_s(self) -> float | None:
        """How far off the offset may be (s, see SETTLED_GAPS); None below MIN_GAPS gaps."""
        gaps = list(self._gaps)
        if len(gaps) < MIN_GAPS:
            return None
        middle = statistics.median(gaps)
        spread = 1.4826 * statistics.median(abs(g - middle) for g in gaps)
        drift = abs(statistics.median(gaps[-RECENT_GAPS:]) - middle)
        return max(1.25 * spread / math.sqrt(len(gaps)), drift)

    def settled(self) -> bool:
        sigma = self.sigma_s()
        return len(self._gaps) >= SETTLED_GAPS and sigma is not None and sigma <= SETTLED_SIGMA_S


class CapturePoses:
    """The pose at a frame's capture: by its stamp on the firmware's clock when the frame has a
    stamp and telemetry its TICK, else by its arrival less the camera's latency."""

    def __init__(
        self,
        latency_s: float,
        clock: Callable[[], float] = time.monotonic,
        telemetry_wait_s: float = TELEMETRY_WAIT_S,
    ) -> None:
        self.latency_s = latency_s
        self.clock = clock
        self.telemetry_wait_s = telemetry_wait_s
        self.by_arrival = PoseHistory()
        self.by_firmware = PoseHistory(keep_s=FIRMWARE_KEEP_S)
        self.firmware = FirmwareClock(1.0 / float(robot()["control"]["tick_hz"]))
        self.capture = CaptureClock(latency_s)
        # a frame looked up twice is one observation; None until a stamped frame is looked up
        self._observed_seq: int | None = None
        # stamped frames looked up before any telemetry arrived after them: their gaps are taken
        # at the next lookup, so every frame counts, not only those processed late
        self._pending: deque[tuple[float, float]] = deque(maxlen=GAPS_KEPT)

    def __call__(self, message: dict[str, Any]) -> None:
        """A gateway listener: its telemetry."""
        if message.get("type") == "telemetry":
            pose = (float(message["x"]), float(message["y"]), float(message["theta"]))
            self.add(pose, int(message["tick"]) if "tick" in message else None)

    def add(self, pose: Pose, tick: int | None) -> None:
        """A telemetry frame's pose, arrived now, with its TICK if it has one."""
        arrived = self.clock()
        self.by_arrival.add(arrived, pose)
        if tick is not None:
            self.by_firmware.add(self.firmware.add(arrived, tick), pose)

    def newest(self) -> Pose | None:
        return self.by_arrival.newest()

    def sigma_s(self, frame: Frame) -> float:
        """How far off `frame`'s capture time may be (after at(frame)): the stamp clock's
        uncertainty, CAPTURE_SIGMA_S without one."""
        sigma = self.capture.sigma_s() if frame.stamp_s is not None else None
        return CAPTURE_SIGMA_S if sigma is None else sigma

    def settled(self) -> bool:
        """Whether frames' capture times are known as well as they will be: no stamped frame
        seen (arrival less latency is all there is), or the stamp clock settled."""
        return self._observed_seq is None or self.capture.settled()

    def at(self, frame: Frame, back_s: float = 0.0) -> Pose | None:
        """The pose `back_s` before `frame` was taken; None if it is not known (before the
        history, or telemetry of the capture not here within `telemetry_wait_s`)."""
        captured = self._on_firmware_clock(frame)
        if captured is None:
            return self.by_arrival.at(frame.received_s - self.latency_s - back_s)
        if not self.by_firmware.reaches(captured - back_s, self.telemetry_wait_s):
            return None
        return self.by_firmware.at(captured - back_s)

    def _on_firmware_clock(self, frame: Frame) -> float | None:
        if frame.stamp_s is None:
            return None
        while self._pending:
            stamp, received = self._pending[0]
            later = self.firmware.first_after(received)
            if later is None:
                break
            self._pending.popleft()
            self.capture.observe(stamp, later)
        if frame.seq != self._observed_seq:
            self._observed_seq = frame.seq
            arrival = self.firmware.first_after(frame.received_s)
            if arrival is None:
                self._pending.append((frame.stamp_s, frame.received_s))
            else:
                self.capture.observe(frame.stamp_s, arrival)
        return self.capture.firmware_time(frame.stamp_s, self.firmware.period_s())

"""The pose in `map` (docs/localisation.md): the camera's frames searched for the markers of the
markers file, each fix fed to the pose filter (cart2d/localisation/ekf.py) with the odometry of
the telemetry as its motion, and the result kept as `map -> odom` (Frames) that the missions plan
with: a goal and the map are in `map`, the firmware's waypoints in its odometry's frame.

A correction publishes PoseCorrected with map -> odom, the pose and its covariance (the missions
re-send a driven route with it; a ROS 2 bridge publishes it); viewers get LocalisationMessage.
After a restart that left the pose untrusted the filter forgets where the cart is, and the first
marker it sees places it and makes the pose trusted again (a cart carried elsewhere). The user's
own SET_POSE (or accepting the firmware's) puts map -> odom back to the identity: the pose the
user gave is in `map`, and the firmware's odometry starts from it.

A fix is for the frame's capture, which the gateway learns of `latency_s` later: the fix is
carried to now by the odometry's step since the capture before it is fused.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import threading
import time
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from cart2d.gateway import messages
from cart2d.gateway.bus import EventBus, PoseCorrected, Restarted, ViewerMessage
from cart2d.gateway.camera import Overlay
from cart2d.gateway.poses import RATE_WINDOW_S, CapturePoses, timing_sigmas
from cart2d.gateway.restarts import Restarts
from cart2d.localisation.ekf import Pose2, PoseFilter, between, compose, to_map, to_odom
from cart2d.localisation.markers import MarkerMap
from cart2d.localisation.tags import Lens, Mounted, TagDetector, TagFix, TagLocaliser
from cart2d.perception.mjpeg import Frame

if TYPE_CHECKING:
    from cart2d.gateway.camera_service import CameraService

log = logging.getLogger(__name__)

IDENTITY: Pose2 = (0.0, 0.0, 0.0)
MESSAGE_EVERY_S = 0.25  # LocalisationMessage at most this often, but at every correction
# A correction that moves map -> odom by less than this is not worth re-sending a route for
REROUTE_SHIFT_M = 0.01
REROUTE_TURN_RAD = math.radians(1.0)
SET_POSE_SIGMA = (0.01, 0.01, math.radians(1.0))  # the user's SET_POSE, as good as a tape measure


class Frames:
    """map -> odom, read by the missions from any thread."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._map_to_odom = IDENTITY

    def get(self) -> Pose2:
        with self._lock:
            return self._map_to_odom

    def set(self, map_to_odom: Pose2) -> None:
        with self._lock:
            self._map_to_odom = map_to_odom

    def to_map(self, odom_pose: Pose2) -> Pose2:
        return to_map(self.get(), odom_pose)

    def to_odom_points(self, points: Sequence[tuple[float, float]]) -> list[tuple[float, float]]:
        m2o = self.get()
        return [to_odom(m2o, (x, y, 0.0))[:2] for x, y in points]


def _pose(p: Pose2) -> messages.Pose:
    return messages.Pose(x=p[0], y=p[1], theta=p[2])


class Localisation:
    def __init__(
        self,
        bus: EventBus,
        restarts: Restarts,
        markers: MarkerMap,
        lens: Lens,
        mount: Mounted,
        latency_s: float,
        frames: Frames | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.bus = bus
        self.restarts = restarts
        self.markers = markers
        self.frames = frames or Frames()
        self.filter = PoseFilter()
        self.latency_s = latency_s
        self._clock = clock
        self._detector = TagDetector()
        self._localiser = TagLocaliser(markers, lens, mount)
        self._poses = CapturePoses(latency_s, clock)
        self._lock = threading.Lock()
        self._last = "no marker seen yet"
        self._sent_s = -MESSAGE_EVERY_S
        self.detect_s: list[float] = []  # the detector's cost per frame (bench)
        bus.subscribe(ViewerMessage, self._on_message)
        bus.subscribe(PoseCorrected, self._on_corrected)
        bus.subscribe(Restarted, self._on_restart)

    # -- odometry, the user's pose, restarts -------------------------------------------------------
    def _on_message(self, event: ViewerMessage) -> None:
        m = event.message
        if not isinstance(m, messages.TelemetryMessage):
            return
        odom = (float(m.x), float(m.y), float(m.theta))
        self._poses.add(odom, int(m.tick))
        with self._lock:
            if not self.filter.trusted and self.filter.odom is None and self.restarts.pose_trust.trusted:
                # a trusted pose at the start: map and odom agree until a marker says otherwise
                self.filter.start_at(
                    to_map(self.frames.get(), odom), np.diag(np.square(SET_POSE_SIGMA)), odom
                )
            else:
                self.filter.predict(odom)
        self._tell(force=False)

    def _on_corrected(self, event: PoseCorrected) -> None:
        if event.map_to_odom is not None:
            return  # this service's own
        odom = self._poses.newest()
        with self._lock:
            self.frames.set(IDENTITY)
            if odom is not None:
                self.filter.start_at(odom, np.diag(np.square(SET_POSE_SIGMA)), odom)
            else:
                self.filter.forget()
            self._last = f"map and odometry agree: {event.how}"
        self._tell(force=True)

    def _on_restart(self, event: Restarted) -> None:
        if event.pose_trusted:
            return
        with self._lock:
            self.filter.forget()
            self._last = "the controller restarted: the pose is found again at the first marker seen"
        self._tell(force=True)

    # -- the camera's frames ---------------------------------------------------------------------
    def __call__(self, frame: Frame, bgr: np.ndarray) -> Overlay | None:
        """A camera processor (CameraFeed.add_processor): its markers, fused."""
        started = time.thread_time()  # CPU time: what the frame costs, whatever else runs
        sightings = self._detector.detect(np.asarray(bgr, dtype=np.uint8))
        fixes = self._localiser.fixes(sightings) if sightings else []
        self.detect_s.append(time.thread_time() - started)
        del self.detect_s[:-1000]
        if not fixes:
            return None
        captured = self._poses.at(frame)
        before = self._poses.at(frame, back_s=RATE_WINDOW_S)
        now = self._poses.newest()
        if captured is None or now is None:
            return None
        for fix in fixes:
            timed = with_timing(fix, before or captured, captured, self._poses.sigma_s(frame))
            self.fuse(timed, captured, now)
        return None

    def fuse(self, fix: TagFix, captured_odom: Pose2, now_odom: Pose2) -> str:
        """One fix taken at `captured_odom`, with the odometry at `now_odom` now."""
        z = compose(fix.pose, between(captured_odom, now_odom))
        with self._lock:
            was_trusted = self.restarts.pose_trust.trusted
            before = self.filter.map_to_odom()
            self.filter.predict(now_odom)
            outcome = self.filter.update(z, fix.covariance)
            after = self.filter.map_to_odom()
            words = f"marker {fix.tag_id} at {fix.range_m:.2f} m: {outcome}"
            self._last = words
            if outcome == "doubted" or after is None:
                return outcome
            self.frames.set(after)
            event = self._event(words)
        if not was_trusted:
            self.restarts.trust(f"found at marker {fix.tag_id}", event)
        elif outcome != "accepted" or before is None or _moved(before, after):
            self.bus.publish(event)
        self._tell(force=True)
        return outcome

    def _event(self, how: str) -> PoseCorrected:
        f = self.filter
        assert f.pose is not None
        return PoseCorrected(
            how,
            map_to_odom=self.frames.get(),
            pose=f.pose,
            covariance=tuple(float(v) for v in f.covariance.ravel()),
            stamp_s=self._clock(),
        )

    # -- viewers ---------------------------------------------------------------------------------
    def view(self) -> messages.LocalisationMessage:
        with self._lock:
            f = self.filter
            return messages.LocalisationMessage(
                trusted=f.trusted and self.restarts.pose_trust.trusted,
                pose=_pose(f.pose) if f.pose is not None else None,
                covariance=[float(v) for v in f.covariance.ravel()],
                map_to_odom=_pose(self.frames.get()),
                accepted=f.accepted,
                doubted=f.rejected,
                last=self._last,
                markers=[
                    messages.MarkerView(id=m.id, size_m=m.size_m, x=m.x, y=m.y, yaw_deg=m.yaw_deg, on=m.on)
                    for m in self.markers.markers
                ],
            )

    def _tell(self, force: bool) -> None:
        now = self._clock()
        if not force and now - self._sent_s < MESSAGE_EVERY_S:
            return
        self._sent_s = now
        self.bus.publish(ViewerMessage(self.view()))

    def summary(self) -> dict[str, Any]:
        costs = sorted(self.detect_s)
        return {
            "markers": len(self.markers.markers),
            "frames": len(costs),
            "detect_ms_median": 1000 * costs[len(costs) // 2] if costs else None,
            **self.view().model_dump(mode="json", exclude={"markers", "type"}),
        }


def with_timing(fix: TagFix, before: Pose2, captured: Pose2, sigma_s: float) -> TagFix:
    """The fix with the uncertainty of its capture time (`sigma_s`, the stamp clock's) added
    (poses.timing_sigmas), in x and y and in the heading."""
    along, turned = timing_sigmas(before, captured, sigma_s)
    extra = np.diag([along**2, along**2, turned**2])
    return dataclasses.replace(fix, covariance=fix.covariance + extra)


def _moved(a: Pose2, b: Pose2) -> bool:
    return (
        math.hypot(a[0] - b[0], a[1] - b[1]) > REROUTE_SHIFT_M
        or abs(math.remainder(a[2] - b[2], math.tau)) > REROUTE_TURN_RAD
    )


class Localisable(Protocol):
    """What localise() wires into: the Gateway (core.py)."""

    bus: EventBus
    restarts: Restarts
    frames: Frames
    camera_service: CameraService
    localisation: Localisation | None


def localise(
    gateway: Localisable, markers: MarkerMap, lens: Lens, mount: Mounted, latency_s: float
) -> Localisation:
    """The gateway finds its pose at these markers from now on, in the camera's frames."""
    service = Localisation(gateway.bus, gateway.restarts, markers, lens, mount, latency_s, gateway.frames)
    gateway.localisation = service
    gateway.camera_service.add_processor(service)
    service._tell(force=True)
    return service

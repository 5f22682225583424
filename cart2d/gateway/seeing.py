"""The gateway sees: each camera frame, with the odometry pose at its capture, goes through the
detector into the log-odds grid (cart2d/perception/pipeline.py). What the grid believes occupied
becomes the perceived layer of the live map (cart2d/gateway/perceived.py, so a blocked route is
replanned), the hits and the field of view go to viewers, and the detection is drawn on the
picture the panel shows. What it asks of the gateway is a `SeeingHost`: the camera service
(cart2d/gateway/camera_service.py).

The pose at capture: a frame reaches the gateway `latency_s` after it was taken (one frame plus
Wi-Fi on an ESP32-CAM; [sim.camera] latency_ms in the simulator); poses.py finds the odometry
pose of that moment, on the firmware's clock when the camera stamps its frames, and how far the
heading may be off when the capture time is (a turning cart's frames clear less floor).
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections import deque
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from cart2d.gateway.camera import Overlay
from cart2d.gateway.poses import RATE_WINDOW_S, CapturePoses, timing_sigmas
from cart2d.params import robot
from cart2d.perception.calibration import CameraCalibration, calibration_path, load_calibration
from cart2d.perception.mjpeg import Frame
from cart2d.perception.occupancy import LogOddsGrid, Pose
from cart2d.perception.pipeline import Perceived, Perception

if TYPE_CHECKING:
    from cart2d.gateway.live_map import Replan
    from cart2d.gateway.perceived import PerceivedLayer

log = logging.getLogger(__name__)

# The occupancy grid's cells. A hit marks its whole cell, so the blocked floor may begin up to a
# cell short of a face: 5 cm cells closed passages of the 4 m cluttered field that the known map
# leaves open by 5 cm (bench/perception_missions.py). Routes are planned as finely (live_map.layout_for).
GRID_RESOLUTION_M = 0.025
# An obstacle seen by its face is taken to be as deep as the face is wide, up to this, until views
# from elsewhere clear the floor behind it: a planned path round a face's end must not cut through
# the unseen rest (docs/perception.md, "How deep an obstacle is", for the rules measured).
OBSTACLE_DEPTH_M = 0.2
FRAME_LOG_LENGTH = 10_000  # about 11 minutes at 15 fps
# A cell goes on the map once its p(occupied) is above this: two hits more than misses (each hit
# adds 0.85 to the log-odds, each ray through it takes 0.4). One stray hit in the cell in front
# of a face (JPEG ringing, a pixel of noise) then never closes a passage beside it.
BELIEVED_P = 0.8
SEND_INTERVAL_S = 0.5  # the perceived layer is refreshed at least this often while its cells' p change
# Before a route starts, the map takes in this many frames captured after the request (a cell is
# believed after two hits): what stands in view of the cart at rest is on the map before it moves,
# not seen only once it drives (about 0.2 s at 15 fps with 60 ms of latency). A camera that sends
# nothing for LOOK_TIMEOUT_S does not hold the cart up for longer.
LOOK_FRAMES = 2
LOOK_TIMEOUT_S = 1.0
SETTLE_TIMEOUT_S = 2.0  # a camera whose stamps never settle holds one look up no longer, once
# Frames captured this near the cart's pose now show what new ones would (odometry at rest).
STILL_M = 0.003
STILL_RAD = math.radians(0.5)
# Standing still for IDLE_AFTER_S, perception takes in one frame in IDLE_EVERY (and the picture the
# panel shows keeps the last one's drawing): what stands in view does not move, a box put down is
# still seen within a fifth of a second, and a parked cart leaves the gateway's core to the rest
# (at 15 fps, every frame is 7 % of a core).
IDLE_AFTER_S = 1.0
IDLE_EVERY = 3


def _same_pose(a: Pose, b: Pose) -> bool:
    """Within STILL_M and STILL_RAD of each other."""
    turned = abs(math.remainder(a[2] - b[2], math.tau))
    return math.dist(a[:2], b[:2]) <= STILL_M and turned <= STILL_RAD


def default_latency_s() -> float:
    """Capture to arrival: the simulated camera's, which models the ESP32-CAM's frame plus Wi-Fi."""
    return float(robot()["sim"]["camera"]["latency_ms"]) / 1000.0


def _grid_for(arena: dict[str, float], resolution_m: float) -> LogOddsGrid:
    """A grid over the arena's walls and a cell beyond, so the walls' faces are in it."""
    x0, y0 = arena["x_min"] - resolution_m, arena["y_min"] - resolution_m
    width = math.ceil((arena["x_max"] - arena["x_min"]) / resolution_m) + 2
    height = math.ceil((arena["y_max"] - arena["y_min"]) / resolution_m) + 2
    return LogOddsGrid((x0, y0), resolution_m, width, height, hit_depth_m=OBSTACLE_DEPTH_M)


class SeeingHost(Protocol):
    """What perception asks of the gateway (the camera service, camera_service.py)."""

    @property
    def perceived(self) -> PerceivedLayer: ...

    def subscribe(self, listener: Callable[[dict[str, Any]], None]) -> Callable[[], None]: ...

    def arena(self) -> dict[str, float]: ...

    def replans(self) -> list[Replan]: ...

    def set_perceived(
        self, cells: list[tuple[float, float, float]], why: str, resolution_m: float | None = None
    ) -> object: ...

    def tell_camera(self, t: float | None, fov: Any, hits: Any) -> None: ...


class Seeing:
    """The camera feed's processor that turns frames into the live map's perceived layer."""

    def __init__(
        self,
        host: SeeingHost,
        calibration: CameraCalibration | None = None,
        latency_s: float | None = None,
        resolution_m: float = GRID_RESOLUTION_M,
        to_map: Callable[[Pose], Pose] | None = None,
    ) -> None:
        self.host = host
        # odometry -> map (localisation.py's Frames): the planner plans in map, so what is seen
        # is put there; the identity without markers
        self.to_map = to_map or (lambda pose: pose)
        self.calibration = calibration
        self.latency_s = default_latency_s() if latency_s is None else latency_s
        self.resolution_m = resolution_m
        self.poses = CapturePoses(self.latency_s)
        self._unsubscribe = host.subscribe(self.poses)
        self._arena: dict[str, float] | None = None
        self._perception: Perception | None = None
        self._sent: frozenset[tuple[int, int]] = frozenset()
        self._sent_at = 0.0
        self._layer: object = None  # the perceived layer this set last (another's means a clear)
        self.frames = 0
        self.skipped = 0  # frames without a pose (telemetry not yet there) or with perception off
        # For the frame-to-replan latency (bench/perception_missions.py): each processed frame's
        # capture stamp and the pose it was seen from, and per replan a frame caused (its map
        # change), that replan's record and the frame's stamp. Bounded: a long session forgets.
        self.frame_log: deque[tuple[float | None, Pose]] = deque(maxlen=FRAME_LOG_LENGTH)
        self.replan_causes: deque[tuple[Any, float | None]] = deque(maxlen=FRAME_LOG_LENGTH)
        self._taken = threading.Condition()
        # (capture time, pose at capture) of the frames last taken in
        self._captures: deque[tuple[float, Pose]] = deque(maxlen=LOOK_FRAMES)
        self.looks: deque[float] = deque(maxlen=FRAME_LOG_LENGTH)  # seconds each look() waited
        self._still: tuple[Pose, float, int] | None = None  # pose, since (capture time), frames since
        self._last_seen: Perceived | None = None
        self.idle_skipped = 0  # frames left out while the cart stood still
        self._unsettled = False  # the capture clock did not settle once: looks no longer wait for it

    def close(self) -> None:
        self._unsubscribe()

    @property
    def grid(self) -> LogOddsGrid | None:
        """What the camera has seen so far (None before its first frame): map_saving.py's."""
        return self._perception.grid if self._perception is not None else None

    def _perception_for_the_map(self) -> Perception:
        """A grid over the current map: a new map (its arena) starts a new belief."""
        arena = self.host.arena()
        if self._perception is None or arena != self._arena:
            self._arena = arena
            self._perception = Perception(_grid_for(arena, self.resolution_m), self.calibration)
            self._sent = frozenset()
        return self._perception

    def __call__(self, frame: Frame, bgr: np.ndarray) -> Overlay | None:
        host = self.host
        layer = host.perceived
        if not layer.enabled:
            self.skipped += 1
            return None
        pose = self.poses.at(frame)
        with self._taken:
            self._taken.notify_all()  # the capture clock may have settled (look() waits for it)
        if pose is None:
            self.skipped += 1
            return None
        perception = self._perception_for_the_map()
        cleared = self._layer is not None and layer is not self._layer and not layer.cells
        if cleared:
            perception.clear()  # cleared by the user: forget what was seen, not just what is shown
            self._sent = frozenset()
            # taken in once: the frames after it build the map again (once, a clear that left no
            # cell believed after one frame was taken for a new clear at every frame, for good)
            self._layer = layer
        # the last drawing fits a frame of its own size only (the camera's framesize may change)
        resized = self._last_seen is not None and self._last_seen.detection.floor_mask.shape != bgr.shape[:2]
        if (
            not (cleared or resized)
            and self._idle(pose, frame.received_s - self.latency_s)
            and self._last_seen
        ):
            self.idle_skipped += 1
            return Overlay(draw=self._last_seen.draw)
        earlier = self.poses.at(frame, back_s=RATE_WINDOW_S) or pose
        seen = perception.process(
            np.asarray(bgr, dtype=np.uint8),
            self.to_map(pose),
            timing_sigmas(earlier, pose, self.poses.sigma_s(frame))[1],
        )
        self._last_seen = seen
        self.frames += 1
        self.frame_log.append((frame.stamp_s, pose))
        host.tell_camera(frame.stamp_s, seen.fov.tolist(), seen.hits.tolist())
        replans = host.replans()
        before = len(replans)
        told = self._send(perception)  # a replan, if the route is blocked now, happens in here
        if told and host.replans() is replans:  # not one another thread made meanwhile
            self.replan_causes.extend((r, frame.stamp_s) for r in replans[before:] if told in r.reason)
        with self._taken:
            self._captures.append((frame.received_s - self.latency_s, pose))
            self._taken.notify_all()
        return Overlay(draw=seen.draw)

    def _idle(self, pose: Pose, captured_s: float) -> bool:
        """Whether this frame may be left out: the cart has stood at `pose` for IDLE_AFTER_S, and
        it is not the IDLE_EVERY-th frame since."""
        if self._still is None or not _same_pose(self._still[0], pose):
            self._still = (pose, captured_s, 0)
            return False
        start, since, count = self._still
        self._still = (start, since, count + 1)
        return captured_s - since >= IDLE_AFTER_S and (count + 1) % IDLE_EVERY != 0

    def observed(self, points: np.ndarray) -> np.ndarray:
        """Whether each point (N x 2, map m) is in a cell some frame has shown (hit or floor)."""
        perception = self._perception
        if perception is None:
            return np.zeros(len(points), dtype=np.bool_)
        return perception.grid.observed(points)

    def look(self, at: Pose | None = None, timeout_s: float = LOOK_TIMEOUT_S) -> bool:
        """Waits until LOOK_FRAMES frames captured after this call are on the map (at most
        `timeout_s`), unless the last ones taken in were captured within STILL of pose `at`, the
        cart's now (standing there, it has seen what it would see); and until the frames' capture
        times are known (poses.SETTLED_SIGMA_S, at most SETTLE_TIMEOUT_S once): a cart that turns to look
        before then places what it sees a few degrees off. Whether the frames came. Not with
        the camera service's lock held: taking a frame in needs it."""
        since = time.monotonic()
        with self._taken:
            if (
                at is not None
                and len(self._captures) == LOOK_FRAMES
                and all(_same_pose(pose, at) for _, pose in self._captures)
            ):
                came = True
            else:
                came = self._taken.wait_for(
                    lambda: sum(t >= since for t, _ in self._captures) >= LOOK_FRAMES, timeout_s
                )
            if came and not self._unsettled:
                left = since + SETTLE_TIMEOUT_S - time.monotonic()
                self._unsettled = not self._taken.wait_for(self.poses.settled, left)
        self.looks.append(time.monotonic() - since)
        return came

    def _send(self, perception: Perception) -> str:
        """The grid's occupied cells to the live map: at once when the set of cells changed (a
        replan may be due), else every SEND_INTERVAL_S while there are cells (their confidence).
        What it told the map ('' if nothing): a replan it caused has it in its reason."""
        cells = perception.cells(BELIEVED_P)
        r = self.resolution_m
        key = frozenset((math.floor(x / r), math.floor(y / r)) for x, y, _ in cells)
        now = time.monotonic()
        if key == self._sent and (not key or now - self._sent_at < SEND_INTERVAL_S):
            return ""
        what = f"the camera sees {len(key)} occupied cell{'s' if len(key) != 1 else ''}"
        self.host.set_perceived(cells, what, r)
        self._layer = self.host.perceived
        self._sent, self._sent_at = key, now
        return what


def seeing_for(host: SeeingHost, directory: Path, to_map: Callable[[Pose], Pose] | None = None) -> Seeing:
    """Perception with the calibration saved in `directory`, beside the gateway's settings (the
    nominal model, with a warning in the log, if there is none)."""
    path = calibration_path(directory)
    calibration = load_calibration(path)
    if not calibration.calibrated:
        log.warning(
            "the camera is not calibrated (cart2d camera calibrate): perception uses the nominal model"
        )
    return Seeing(host, calibration, to_map=to_map)

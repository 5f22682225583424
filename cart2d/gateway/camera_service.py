"""The camera, a service of the gateway: the feed it reads (cart2d/gateway/camera.py: the command
line's --camera for its run, or the saved settings' camera, which PUT /api/settings/camera and a
settings file change), the perception attached to it (seeing.py), the sinks that get every frame
shown whichever camera it is (a recording, the Foxglove view), perception on or off, the
perceived cells, and the firmware's reverse_allowed while it sees (forward_only.py).

The perceived layer is the live map's (map_service.py keeps it and plans with it); this service
is what edits it, and publishes `PerceivedChanged` when that changed the routes' planner (the
missions replan a driven route it blocks) and the viewers' "perceived" and "camera" messages.

Locks: its own for the feed, the sinks and the perceived layer's edits, taken before the live
map's and never while the bus is told (a handler takes the mission's lock); another for the
reverse guard, which the mission takes while it sends a route (so never the other way round)."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from cart2d.gateway import messages
from cart2d.gateway.bus import EventBus, PerceivedChanged, ViewerMessage
from cart2d.gateway.camera import CameraFeed, Processor, Shown
from cart2d.gateway.forward_only import ReverseGuard
from cart2d.gateway.live_map import Replan, arena
from cart2d.gateway.localisation import Frames
from cart2d.gateway.map_service import LiveMap
from cart2d.gateway.perceived import PerceivedLayer, check_resolution, parse_cells
from cart2d.gateway.seeing import Seeing, seeing_for
from cart2d.link import Link
from cart2d.shown import for_people
from cart2d.store import CameraSettings, GatewaySettings

PERCEIVED_MESSAGE_S = 0.5  # /ws "perceived" at most at 2 Hz
CAMERA_MESSAGE_S = 0.2  # /ws "camera" at most at 5 Hz
NO_CAMERA = "this gateway has no camera: start it with --camera http://HOST (or --camera-stream URL)"

Listener = Callable[[dict[str, Any]], None]


def _to_mm(points: Sequence[Sequence[float]]) -> list[list[float]]:
    """Points (map m) to the millimetre, for viewers: a hit is good to a centimetre, and 17-digit
    floats tripled the message every viewer gets."""
    return [[round(float(x), 3), round(float(y), 3)] for x, y in points]


class CameraService:
    """The feed, its perception and the perceived layer (see the module's docstring).
    `directory`: where the camera's calibration is saved; `replans`: the mission's replans now
    (the list itself: seeing.py tells the replans a frame caused)."""

    def __init__(
        self,
        link: Link,
        live_map: LiveMap,
        bus: EventBus,
        directory: Path,
        replans: Callable[[], list[Replan]] = list,
        clock: Callable[[], float] = time.monotonic,
        frames: Frames | None = None,
    ) -> None:
        self.link = link
        self.frames = frames or Frames()  # odometry -> map, for what is seen (localisation.py)
        self.live_map = live_map
        self.bus = bus
        self.directory = directory
        self._replans = replans
        self._clock = clock  # the messages' rate limits
        self.camera: CameraFeed | None = None
        self.seeing: Seeing | None = None  # the camera's frames into the perceived layer (seeing.py)
        self._sinks: dict[Callable[[Shown], None], Callable[[], None] | None] = {}  # sink: unsubscribe
        self._processors: list[Processor] = []  # besides seeing: the markers' (localisation.py)
        self._lock = threading.RLock()
        self._guard = ReverseGuard()  # forwards only while seeing (forward_only.py)
        self._guard_lock = threading.Lock()
        self._perceived_sent_s = -PERCEIVED_MESSAGE_S
        self._perceived_timer: threading.Timer | None = None
        self._camera_sent_s = -CAMERA_MESSAGE_S

    # -- what perception (seeing.py) asks of it ------------------------------------------------
    @property
    def perceived(self) -> PerceivedLayer:
        return self.live_map.perceived

    def subscribe(self, listener: Listener) -> Callable[[], None]:
        """listener(message) for every viewers' message (telemetry brings the poses)."""
        return self.bus.subscribe(ViewerMessage, lambda event: listener(event.wire))

    def arena(self) -> dict[str, float]:
        """Where the map's walls are, as the map's view shows them."""
        rounded: dict[str, float] = for_people(arena(self.live_map.settings.map))
        return rounded

    def replans(self) -> list[Replan]:
        return self._replans()

    # -- the feed -------------------------------------------------------------------------------
    def use_camera(self, feed: CameraFeed | None) -> None:
        """Reads `feed` (started) from now on, instead of the camera before it (stopped: the camera
        serves one stream client)."""
        with self._lock:
            old, self.camera = self.camera, feed
            replaced = old is not None and old is not feed
            old_seeing = self.seeing if replaced else None
            if replaced:
                self.seeing = None
        if replaced:  # stopped before the new one is attached, not under the lock: the old
            assert old is not None  # feed's last frame may be waiting for it
            old.stop()
            if old_seeing is not None:
                old_seeing.close()
        if feed is not None and feed is not old:
            with self._lock:
                if self.camera is not feed:
                    return  # replaced meanwhile by another call, which stopped it
                self.seeing = seeing_for(self, self.directory, self.frames.to_map)
                feed.add_processor(self.seeing)
                for processor in self._processors:
                    feed.add_processor(processor)
                for sink in self._sinks:
                    self._sinks[sink] = feed.subscribe(sink)
        self.forwards_only_while_seeing(certain=False)

    def sees(self) -> bool:
        """Whether the camera's frames keep the perceived layer (then the cart drives forwards only)."""
        return self.seeing is not None and self.perceived.enabled

    def forwards_only_while_seeing(self, certain: bool = True) -> None:
        """Before a route and after an MCU restart: reverse_allowed = 0 in the firmware while the
        gateway sees, the user's value back once it does not (forward_only.py). `certain`: LinkError
        / CommandRefused if the firmware does not take it (else it is tried only)."""
        with self._guard_lock:
            seeing = self.sees()
            if certain:
                self._guard.apply(self.link, seeing)
            else:
                self._guard.try_apply(self.link, seeing)

    def add_processor(self, processor: Processor) -> None:
        """processor(frame, image) on every frame of this camera and the next ones."""
        with self._lock:
            self._processors.append(processor)
            if self.camera is not None:
                self.camera.add_processor(processor)

    def add_camera_sink(self, sink: Callable[[Shown], None]) -> Callable[[], None]:
        """sink(shown) for every frame shown of whichever camera the gateway reads, now and after
        a change of camera (a recording, the Foxglove view); returns what stops it."""
        with self._lock:
            self._sinks[sink] = self.camera.subscribe(sink) if self.camera is not None else None

        def remove() -> None:
            with self._lock:
                unsubscribe = self._sinks.pop(sink, None)
                if unsubscribe is not None:
                    unsubscribe()

        return remove

    def set_camera(self, camera: CameraSettings) -> None:
        """Saves `camera` and reads it from now on (also when the saved one was the same but the
        command line gave another for this run); ValueError changes nothing."""
        with self._lock:
            settings = self.live_map.settings.model_copy(update={"camera": camera})
            self.live_map.update_settings(settings, "the camera changed", self.follow_settings)
            wanted = CameraFeed.of(camera.url, camera.stream_url)
            current = self.camera
            if wanted is None and current is None:
                return
            if wanted is not None and current is not None and wanted.same_camera(current):
                return
            self.use_camera(wanted.start() if wanted is not None else None)

    def follow_settings(self, new: GatewaySettings, old: GatewaySettings) -> Callable[[], None]:
        """What reads the camera of `new` settings (nothing if it is `old`'s); ValueError for a
        camera that cannot be read, before anything changes (map_service.SettingsFollower)."""
        if new.camera == old.camera:
            return lambda: None
        feed = CameraFeed.of(new.camera.url, new.camera.stream_url)
        return lambda: self.use_camera(feed.start() if feed is not None else None)

    # -- the perceived layer ---------------------------------------------------------------------
    def set_perceived(
        self, cells: Sequence[Sequence[float]], why: str, resolution_m: float | None = None
    ) -> dict[str, Any]:
        """Replaces the perceived cells (x_m, y_m, p_occupied); during a mission, replans if the
        rest of the path is blocked now, as a change of the user's obstacles does. Bad input
        (ValueError) changes nothing; while perception is off, cells are not taken."""
        parsed = parse_cells(cells)
        with self._lock:
            layer = self.perceived
            resolution = check_resolution(layer.resolution_m if resolution_m is None else resolution_m)
            if not layer.enabled:
                return self.perception_view()
            changed = self.live_map.take_perceived(PerceivedLayer(parsed, resolution, True, why))
        return self._taken(changed, why)

    def clear_perceived(self, why: str = "the perceived cells were cleared") -> dict[str, Any]:
        with self._lock:
            layer = self.perceived
            changed = self.live_map.take_perceived(PerceivedLayer((), layer.resolution_m, layer.enabled, why))
        return self._taken(changed, why)

    def set_perception_enabled(self, enabled: bool) -> dict[str, Any]:
        """Perception off clears its cells and takes no more until it is on again."""
        with self._lock:
            layer = self.perceived
            why = "perception was turned " + ("on" if enabled else "off")
            cells = layer.cells if enabled else ()
            changed = self.live_map.take_perceived(PerceivedLayer(cells, layer.resolution_m, enabled, why))
        return self._taken(changed, why)

    def perception_view(self) -> dict[str, Any]:
        s = self.live_map.state  # the layer and the planner it is in, read together
        blocked = int(s.perceived.mask(s.planner.grid).sum()) if s.perceived.cells else 0
        return {**s.perceived.view(), "blocked_cells": blocked}

    def _taken(self, changed: bool, why: str) -> dict[str, Any]:
        """After a new layer: the bus told if the routes' planner changed (without the lock: a
        driven route it blocks is replanned under the mission's), viewers; the view after."""
        if changed:
            self.bus.publish(PerceivedChanged(why))
        with self._lock:
            self._tell_perceived()
        return self.perception_view()

    def _tell_perceived(self) -> None:
        """/ws "perceived", at most every PERCEIVED_MESSAGE_S; the last state always goes out."""
        now = self._clock()
        wait_s = self._perceived_sent_s + PERCEIVED_MESSAGE_S - now
        if wait_s <= 0.0:
            self._perceived_sent_s = now
            view = self.perceived.view()
            self._publish(messages.PerceivedMessage(resolution=view["resolution"], cells=view["cells"]))
        elif self._perceived_timer is None or not self._perceived_timer.is_alive():
            self._perceived_timer = threading.Timer(wait_s, self._tell_later)
            self._perceived_timer.daemon = True
            self._perceived_timer.start()

    def _tell_later(self) -> None:
        with self._lock:
            self._perceived_timer = None
            self._tell_perceived()

    def tell_camera(
        self, t: float | None, fov: Sequence[Sequence[float]], hits: Sequence[Sequence[float]]
    ) -> None:
        """/ws "camera" for a processed frame (map coordinates, _to_mm), at most every
        CAMERA_MESSAGE_S."""
        now = self._clock()
        if now - self._camera_sent_s < CAMERA_MESSAGE_S:
            return
        self._camera_sent_s = now
        self._publish(messages.CameraMessage(t=t, fov=_to_mm(fov), hits=_to_mm(hits)))

    def _publish(self, message: messages.LiveMessage) -> None:
        self.bus.publish(ViewerMessage(message))

    def calibration_summary(self) -> dict[str, Any] | None:
        """The camera's calibration as /api/camera shows it; None without one."""
        seeing = self.seeing
        return seeing.calibration.summary() if seeing is not None and seeing.calibration else None

    def camera_view(self) -> dict[str, Any]:
        """The camera's stream and frames (CameraFeed.status), where it is and its calibration."""
        camera = self.camera
        if camera is None:
            return {"camera": False, "message": NO_CAMERA}
        return {
            **camera.status(),
            "camera": True,
            "url": camera.base_url,
            "stream_url": camera.reader.url,
            "calibration": self.calibration_summary(),
        }

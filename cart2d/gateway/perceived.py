"""The perceived layer of the live map: cells the camera believes occupied, kept apart from the
user's obstacles (never saved with them, cleared on their own), that the planner keeps the cart
off as it does the user's: they are blocked cells of its graph, inflated by the same footprint
stencils (cart2d/planning/graph.py), and a change runs the same route check and replan as a
change the user makes.

A perceived cell is a square of side `resolution_m` centred on (x, y); it blocks the planner
cells whose nodes it covers, or on a grid coarser than it every planner cell its square overlaps
(the planner's cells are the squares round its nodes), so no perceived obstacle slips between
two nodes (PerceivedLayer.mask). While there are perceived cells, routes are planned on the map
made finer (live_map.layout_for: a step of at most `resolution_m`, the user's obstacles blocking
the same floor as before): on the map's own grid (the seed's 0.2 m) a 2.5 cm cell would block a
whole 0.2 m cell and close passages the cart fits through. The map's own planner (the user's
obstacles as nodes) stays the Gateway's `map_planner`. Cells off the planner's grid are left out
(the camera sees past the arena's walls): they cannot block a path.

The camera's frames become perceived cells in cart2d/gateway/seeing.py, attached to every camera
feed the gateway reads. `PerceptionMixin` is the part of the Gateway (cart2d/gateway/core.py)
that holds the layer and the optional camera feed (cart2d/gateway/camera.py: the command line's
--camera for its run, or the saved settings' camera, which PUT /api/settings/camera and a
settings file change at once); core.py only builds its planner with `with_perceived` and lets
update_settings follow the camera.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from cart2d.gateway.bus import EventBus, PerceivedChanged
from cart2d.gateway.camera import CameraFeed, Shown
from cart2d.gateway.forward_only import ReverseGuard
from cart2d.gateway.live_map import Layout, layout_for
from cart2d.gateway.messages import CameraMessage, LiveMessage, PerceivedMessage
from cart2d.gateway.seeing import Seeing, seeing_for
from cart2d.planning import EPS, Grid, Planner

if TYPE_CHECKING:
    from cart2d.link import Link
    from cart2d.store import CameraSettings, GatewaySettings, MapSettings

MAX_PERCEIVED_CELLS = 100_000  # a 10 x 10 m room at 3 cm
OCCUPIED_P = 0.5  # a cell at or above this is believed occupied (the contract with vision)
PERCEIVED_MESSAGE_S = 0.5  # /ws "perceived" at most at 2 Hz
CAMERA_MESSAGE_S = 0.2  # /ws "camera" at most at 5 Hz
DEFAULT_RESOLUTION_M = 0.05

Cell = tuple[float, float, float]


def parse_cells(cells: Sequence[Sequence[float]]) -> tuple[Cell, ...]:
    """(x_m, y_m, p_occupied) triples, finite, p in [0.5, 1]; ValueError (in words) otherwise."""
    if len(cells) > MAX_PERCEIVED_CELLS:
        raise ValueError(f"{len(cells)} perceived cells: at most {MAX_PERCEIVED_CELLS}")
    out = []
    for k, cell in enumerate(cells):
        if len(cell) != 3:
            raise ValueError(f"perceived cell {k} must be [x_m, y_m, p_occupied], got {len(cell)} numbers")
        x, y, p = (float(v) for v in cell)
        if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(p)):
            raise ValueError(f"perceived cell {k} is not finite")
        if not OCCUPIED_P <= p <= 1.0:
            raise ValueError(
                f"perceived cell {k} has p_occupied {p:g}: cells believed occupied have {OCCUPIED_P:g} to 1"
            )
        out.append((x, y, p))
    return tuple(out)


def check_resolution(resolution_m: float) -> float:
    if not (math.isfinite(resolution_m) and 0.005 <= resolution_m <= 1.0):
        raise ValueError(f"the perceived cells' resolution must be 0.005 to 1 m, got {resolution_m:g}")
    return float(resolution_m)


def _nodes_within(low: float, high: float, count: int) -> range:
    """Nodes k in [low, high) (grid units): one at least when high - low >= 1."""
    return range(max(math.ceil(low - EPS), 0), min(math.ceil(high - EPS), count))


def _span(low: float, high: float, count: int) -> range:
    """Planner cells k (squares [k - 0.5, k + 0.5] in grid units) that [low, high] overlaps."""
    # k - 0.5 < high and k + 0.5 > low, by more than the planner's contact tolerance: squares
    # that only touch (up to rounding) do not overlap
    first = max(math.floor(low - 0.5 + EPS) + 1, 0)
    last = min(math.ceil(high + 0.5 - EPS) - 1, count - 1)
    return range(first, last + 1)


def _to_mm(points: Sequence[Sequence[float]]) -> list[list[float]]:
    """Points (map m) to the millimetre, for viewers: a hit is good to a centimetre, and 17-digit
    floats tripled the message every viewer gets."""
    return [[round(float(x), 3), round(float(y), 3)] for x, y in points]


@dataclass(frozen=True)
class PerceivedLayer:
    """What perception believes occupied (immutable: a change is a new layer)."""

    cells: tuple[Cell, ...] = ()
    resolution_m: float = DEFAULT_RESOLUTION_M
    enabled: bool = True
    why: str = ""

    def mask(self, grid: Grid) -> npt.NDArray[np.bool_]:
        """The planner cells that stand for the perceived cells, (rows, cols): on a grid as fine
        as they are, the cells whose centres (nodes) they cover, at least one each, so that what
        is blocked is within half a step of the perceived squares either way (overlap would add up
        to a whole step: a face seen 2 cm too near plus a step closed marginal passages); on a
        coarser grid every cell they overlap, so that none slips between two nodes."""
        out = np.zeros((grid.rows, grid.cols), dtype=np.bool_)
        half = self.resolution_m / 2.0 / grid.step_m
        span = _nodes_within if self.resolution_m >= grid.step_m - EPS else _span
        for x, y, _ in self.cells:
            u, v = grid.to_grid(x, y)
            columns, rows = span(u - half, u + half, grid.cols), span(v - half, v + half, grid.rows)
            if columns and rows:
                out[rows.start : rows.stop, columns.start : columns.stop] = True
        return out

    def view(self) -> dict[str, Any]:
        return {
            "enabled": self.enabled,
            "resolution": self.resolution_m,
            "cells": [list(cell) for cell in self.cells],
            "why": self.why,
        }


def route_layout(m: MapSettings, layer: PerceivedLayer) -> Layout | None:
    """The map on a grid as fine as the perceived cells; None while nothing is perceived (routes
    are then planned with the map's own planner)."""
    return layout_for(m, layer.resolution_m) if layer.cells else None


def with_perceived(m: MapSettings, layer: PerceivedLayer, map_planner: Planner) -> Planner:
    """The planner of routes: `map_planner` (built for `m` alone) while nothing is perceived, else
    the map on a grid as fine as the perceived cells, with them blocked too."""
    layout = route_layout(m, layer)
    return map_planner if layout is None else layout.planner(also_blocked=layer.mask(layout.grid))


class PerceptionMixin:
    """The Gateway's perceived layer and camera (see the module's docstring)."""

    camera: CameraFeed | None = None  # use_camera(): the command line, set_camera(), update_settings()
    seeing: Seeing | None = None  # the camera's frames into the perceived layer (seeing.py)
    _camera_sinks: dict[Callable[[Shown], None], Callable[[], None] | None] | None = None  # sink: unsubscribe
    perceived: PerceivedLayer = PerceivedLayer()
    _perceived_sent_s = 0.0
    _perceived_timer: threading.Timer | None = None
    _camera_sent_s = 0.0
    _reverse_guard: ReverseGuard | None = None  # forwards only while seeing (forward_only.py)

    # what the Gateway has (core.py)
    _lock: threading.RLock
    link: Link
    planner: Planner  # the routes' (with_perceived)
    map_planner: Planner  # the map's alone
    settings: GatewaySettings
    bus: EventBus

    def update_settings(self, settings: GatewaySettings, why: str = "") -> None:
        raise NotImplementedError

    def _publish(self, message: LiveMessage) -> None:
        raise NotImplementedError

    def use_camera(self, feed: CameraFeed | None) -> None:
        """Reads `feed` (started) from now on, instead of the camera before it (stopped: the camera
        serves one stream client)."""
        old, self.camera = self.camera, feed
        if old is not None and old is not feed:
            old.stop()
            if self.seeing is not None:
                self.seeing.close()
                self.seeing = None
        if feed is not None and feed is not old:
            self.seeing = seeing_for(self)  # type: ignore[arg-type]  # self is the Gateway
            feed.add_processor(self.seeing)
            sinks = self._sinks()
            for sink in sinks:
                sinks[sink] = feed.subscribe(sink)
        self.forwards_only_while_seeing(certain=False)

    def sees(self) -> bool:
        """Whether the camera's frames keep the perceived layer (then the cart drives forwards only)."""
        return self.seeing is not None and self.perceived.enabled

    def _guard(self) -> ReverseGuard:
        if self._reverse_guard is None:
            self._reverse_guard = ReverseGuard()  # this gateway's own
        return self._reverse_guard

    def forwards_only_while_seeing(self, certain: bool = True) -> None:
        """Before a route and after an MCU restart: reverse_allowed = 0 in the firmware while the
        gateway sees, the user's value back once it does not (forward_only.py). `certain`: LinkError
        / CommandRefused if the firmware does not take it (else it is tried only)."""
        with self._lock:
            guard, seeing = self._guard(), self.sees()
            if certain:
                guard.apply(self.link, seeing)
            else:
                guard.try_apply(self.link, seeing)

    def _sinks(self) -> dict[Callable[[Shown], None], Callable[[], None] | None]:
        if self._camera_sinks is None:
            self._camera_sinks = {}  # this gateway's own
        return self._camera_sinks

    def add_camera_sink(self, sink: Callable[[Shown], None]) -> Callable[[], None]:
        """sink(shown) for every frame shown of whichever camera the gateway reads, now and after
        a change of camera (a recording, the Foxglove view); returns what stops it."""
        with self._lock:
            self._sinks()[sink] = self.camera.subscribe(sink) if self.camera is not None else None

        def remove() -> None:
            with self._lock:
                unsubscribe = self._sinks().pop(sink, None)
                if unsubscribe is not None:
                    unsubscribe()

        return remove

    def set_camera(self, camera: CameraSettings) -> None:
        """Saves `camera` and reads it from now on (also when the saved one was the same but the
        command line gave another for this run); ValueError changes nothing."""
        with self._lock:
            self.update_settings(self.settings.model_copy(update={"camera": camera}), "the camera changed")
            wanted = CameraFeed.of(camera.url, camera.stream_url)
            current = self.camera
            if wanted is None and current is None:
                return
            if wanted is not None and current is not None and wanted.same_camera(current):
                return
            self.use_camera(wanted.start() if wanted is not None else None)

    def _camera_change(self, settings: GatewaySettings) -> tuple[bool, CameraFeed | None]:
        """Whether `settings` change the camera, and the new feed (not started; None: no camera);
        ValueError for a camera that cannot be read (before anything changes)."""
        if settings.camera == self.settings.camera:
            return False, None
        return True, CameraFeed.of(settings.camera.url, settings.camera.stream_url)

    def _apply_camera(self, change: tuple[bool, CameraFeed | None]) -> None:
        changed, feed = change
        if changed:
            self.use_camera(feed.start() if feed is not None else None)

    def set_perceived(
        self, cells: Sequence[Sequence[float]], why: str, resolution_m: float | None = None
    ) -> dict[str, Any]:
        """Replaces the perceived cells (x_m, y_m, p_occupied); during a mission, replans if the
        rest of the path is blocked now, as a change of the user's obstacles does. Bad input
        (ValueError) changes nothing; while perception is off, cells are not taken."""
        parsed = parse_cells(cells)
        with self._lock:
            resolution = check_resolution(
                self.perceived.resolution_m if resolution_m is None else resolution_m
            )
            if not self.perceived.enabled:
                return self.perception_view()
            self._take(PerceivedLayer(parsed, resolution, True, why), why)
            return self.perception_view()

    def clear_perceived(self, why: str = "the perceived cells were cleared") -> dict[str, Any]:
        with self._lock:
            layer = self.perceived
            self._take(PerceivedLayer((), layer.resolution_m, layer.enabled, why), why)
            return self.perception_view()

    def set_perception_enabled(self, enabled: bool) -> dict[str, Any]:
        """Perception off clears its cells and takes no more until it is on again."""
        with self._lock:
            layer = self.perceived
            why = "perception was turned " + ("on" if enabled else "off")
            cells = layer.cells if enabled else ()
            self._take(PerceivedLayer(cells, layer.resolution_m, enabled, why), why)
            return self.perception_view()

    def perception_view(self) -> dict[str, Any]:
        with self._lock:
            blocked = int(self.perceived.mask(self.planner.grid).sum()) if self.perceived.cells else 0
            return {**self.perceived.view(), "blocked_cells": blocked}

    def _take(self, layer: PerceivedLayer, why: str) -> None:
        """Makes `layer` the perceived one (lock held): the planner, the route check, viewers."""
        old, self.perceived = self.perceived, layer
        layout = route_layout(self.settings.map, layer)  # once: it is rebuilt at every camera update
        grid = self.map_planner.grid if layout is None else layout.grid
        mask = layer.mask(grid)
        if grid != self.planner.grid or not np.array_equal(old.mask(grid), mask):
            self.planner = self.map_planner if layout is None else layout.planner(also_blocked=mask)
            self.bus.publish(PerceivedChanged(why))  # a driven route it blocks is replanned
        self._tell_perceived()

    def _tell_perceived(self) -> None:
        """/ws "perceived", at most every PERCEIVED_MESSAGE_S; the last state always goes out."""
        wait_s = self._perceived_sent_s + PERCEIVED_MESSAGE_S - time.monotonic()
        if wait_s <= 0.0:
            self._perceived_sent_s = time.monotonic()
            view = self.perceived.view()
            self._publish(PerceivedMessage(resolution=view["resolution"], cells=view["cells"]))
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
        now = time.monotonic()
        if now - self._camera_sent_s < CAMERA_MESSAGE_S:
            return
        self._camera_sent_s = now
        self._publish(CameraMessage(t=t, fov=_to_mm(fov), hits=_to_mm(hits)))

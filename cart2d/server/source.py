"""What the reading routes answer from: the live Gateway, or a replay's recorded state at its
position (cart2d/recording/replay_app.py). A route that depends on nothing but a Source answers in
a replay too, through the same route module; every other route is the live gateway's alone."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol

from cart2d.gateway.camera import Shown


class Camera(Protocol):
    """The part of a CameraFeed (cart2d/gateway/camera.py) the re-stream and the newest frame use."""

    def subscribe(self, viewer: Callable[[Shown], None]) -> Callable[[], None]: ...

    def shown(self) -> Shown | None: ...


class Source(Protocol):
    def status_view(self) -> dict[str, Any]: ...

    def status_view_unless_busy(self) -> dict[str, Any] | None:
        """status_view() if it can be had without waiting; else None (then asked in a thread)."""
        ...

    def mission_view(self) -> dict[str, Any]: ...

    def map_view(self) -> dict[str, Any]: ...

    def floor_plan_png(self, version: int | None) -> bytes | None:
        """The floor plan of the map's `version` (None: the map shown now) as a PNG; None when
        the map is a grid of nodes."""
        ...

    def perception_view(self) -> dict[str, Any]: ...

    def firmware_settings(self) -> list[dict[str, object]]: ...

    def camera_view(self) -> dict[str, Any]:
        """/api/camera's answer but its `viewers`: `camera` false and a `message` without one."""
        ...

    def camera_feed(self) -> Camera | None: ...

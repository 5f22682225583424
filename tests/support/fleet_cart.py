"""A fake cart for a fleet vehicle's executor (cart2d/fleet/order.py's Cart): it records what it
is asked (each mission's points and last point, the nodes passed, the stops, the poses set) and
drives nowhere; the test says when a mission ends. A goal at a negative x is refused."""

from __future__ import annotations

import threading
from collections.abc import Sequence

from cart2d.fleet.order import Refused


class RecordingCart:
    def __init__(self) -> None:
        self.pose = (0.25, 0.25, 0.0, 0.0, 0.0)
        self.goals: list[tuple[float, float]] = []  # each mission's last point
        self.routes: list[list[tuple[float, float]]] = []  # each mission's points
        self.passed_points: list[tuple[float, float]] = []
        self.stops: list[str] = []
        self.poses_set: list[tuple[float, float, float]] = []
        self.asked = threading.Event()

    def go_to(self, x: float, y: float) -> None:
        if x < 0:
            raise Refused("outside the arena")
        self.goals.append((x, y))
        self.asked.set()

    def go_through(self, points: Sequence[tuple[float, float]]) -> None:
        self.go_to(*points[-1])
        self.routes.append(list(points))

    def passed(self, x: float, y: float) -> None:
        self.passed_points.append((x, y))

    def stop(self, reason: str) -> None:
        self.stops.append(reason)

    def set_pose(self, x: float, y: float, theta: float) -> None:
        self.poses_set.append((x, y, theta))
        self.pose = (x, y, theta, 0.0, 0.0)

"""What a mission keeps of the gateway's stream while it drives (cart2d/tools/missions/run.py): the ground
truth, the firmware's modes by tick and the routes sent, for the report's times and paths."""

from __future__ import annotations

import threading
from typing import Any

from cart2d.planning import Point


class Recorder:
    """Keeps the ground truth (t, x, y) and the firmware's (tick, mode) from the gateway's stream."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.t0 = 0.0  # the simulated time the mission started at
        self.truth: list[tuple[float, float, float]] = []
        self.modes: list[tuple[int, str]] = []
        self.routes: list[list[Point]] = []  # every route the gateway sent (a replan sends one more)

    def __call__(self, message: dict[str, Any]) -> None:
        with self._lock:
            if message.get("type") == "truth":
                self.truth.append((message["t"], message["x"], message["y"]))
            elif message.get("type") == "telemetry":
                self.modes.append((message["tick"], message["mode_name"]))
            elif message.get("type") == "mission" and message.get("plan"):
                plan = message["plan"]
                route = [tuple(plan["start"]), *map(tuple, plan["waypoints"])]
                if not self.routes or self.routes[-1] != route:
                    self.routes.append(route)

    def routes_since(self, mark: int) -> list[list[Point]]:
        with self._lock:
            return self.routes[mark:]

    def mark(self) -> tuple[int, int]:
        with self._lock:
            return len(self.truth), len(self.modes)

    def driving_ticks(self, since: int) -> tuple[int, int] | None:
        """The ticks of the first telemetry frame in PATH mode after `since` and of the first
        frame out of it after the last PATH frame; None until both have arrived."""
        with self._lock:
            frames = self.modes[since:]
        path = [k for k, (_, mode) in enumerate(frames) if mode == "PATH"]
        if not path or path[-1] + 1 >= len(frames):
            return None
        return frames[path[0]][0], frames[path[-1] + 1][0]

    def _until_path(self, since: int) -> tuple[list[tuple[int, str]], int | None]:
        """The telemetry frames (tick, mode) after `since`, and the index of the first in PATH mode."""
        with self._lock:
            frames = self.modes[since:]
        return frames, next((k for k, (_, mode) in enumerate(frames) if mode == "PATH"), None)

    def starting_ticks(self, since: int) -> int | None:
        """The ticks from the first telemetry frame after `since` to the first in PATH mode: from a
        goal's request to driving (planning, the look while the gateway sees, the upload)."""
        frames, first_path = self._until_path(since)
        return None if first_path is None else frames[first_path][0] - frames[0][0]

    def looking_ticks(self, since: int) -> int:
        """The ticks from the first telemetry frame in MANUAL mode after `since` to the first in PATH
        mode: the gateway's look before driving off while it sees (cart2d/gateway/look.py)."""
        frames, first_path = self._until_path(since)
        if first_path is None:
            return 0
        first_manual = next((k for k, (_, mode) in enumerate(frames[:first_path]) if mode == "MANUAL"), None)
        return 0 if first_manual is None else frames[first_path][0] - frames[first_manual][0]

    def samples(self, since: int) -> list[tuple[float, float, float]]:
        with self._lock:
            return self.truth[since:]

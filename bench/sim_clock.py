"""The simulator's clock read from the host: the wall time each truth message (its simulated `t`)
arrived, so that a host's wall-clock instant can be told in simulated seconds. Good to about the
truth messages' period (20 ms at 50 Hz) at an instant, and to the jitter of their delivery (~1 ms
on loopback) for a span between two instants inside the same run, which is how benches use it."""

from __future__ import annotations

import bisect
import threading
import time
from collections.abc import Callable
from typing import Any


class SimClock:
    """sim.subscribe_truth(clock.note); clock.at(wall) in simulated seconds."""

    def __init__(self, wall: Callable[[], float] = time.time) -> None:
        self._wall = wall  # the clock of the instants asked about
        self._walls: list[float] = []
        self._sims: list[float] = []
        self._lock = threading.Lock()

    def note(self, truth: dict[str, Any]) -> None:
        wall = self._wall()
        with self._lock:
            if not self._sims or truth["t"] > self._sims[-1]:  # a restart's time going back: ignored
                self._walls.append(wall)
                self._sims.append(float(truth["t"]))

    def at(self, wall: float) -> float:
        """The simulated time at `wall`, linear between the truth messages around it (NaN
        outside them: before the first or after the last)."""
        with self._lock:
            i = bisect.bisect_left(self._walls, wall)
            if i < len(self._walls) and self._walls[i] == wall:
                return self._sims[i]
            if i == 0 or i == len(self._walls):
                return float("nan")
            w0, w1, s0, s1 = self._walls[i - 1], self._walls[i], self._sims[i - 1], self._sims[i]
        return s0 + (s1 - s0) * (wall - w0) / (w1 - w0) if w1 > w0 else s0

    def span(self, began: float, ended: float) -> float:
        """The simulated seconds between two wall instants."""
        return self.at(ended) - self.at(began)

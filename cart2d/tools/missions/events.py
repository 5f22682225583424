"""A mission's timed map changes (`"events"`), and the pacing of the simulator around the
gateway's work.

An event adds and removes obstacles at a simulated time after the mission's start (its first
goal's: cart2d/tools/missions/run.py). Twice: in the simulator, scheduled in advance at that exact time, as
physical obstacles (boxes of their cells: the cart cannot pass them, touching one counts as a
collision); and in the gateway's map once the simulator has reached that time, as a user's click
would, so the gateway checks the rest of the path and replans if the change blocks it.

The simulator runs faster than real time, the gateway at its own pace: while the gateway plans
and uploads, the simulator is paced to the wall clock (as a real cart would go on driving),
else a busy machine would cost the simulated cart seconds for a path half sent.
"""

from __future__ import annotations

import contextlib
import math
import threading
from collections.abc import Iterator
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, field_validator

from cart2d.gateway import Gateway
from cart2d.planning import Grid, PlanError, Point
from cart2d.simulation.side_channel import SimulatorError
from cart2d.simulation.simulator import Simulator

Coordinate = float
# Real time from this long before an event: the simulator is paced to the wall clock when the
# gateway hears of the change.
EVENT_LEAD_S = 0.25


class MapEvent(BaseModel):
    model_config = ConfigDict(extra="forbid")
    at_s: float = Field(
        ge=0.0, le=1e5, allow_inf_nan=False, description="simulated seconds after the first goal's start"
    )
    add: list[tuple[Coordinate, Coordinate]] = Field(default_factory=list, max_length=10_000)
    remove: list[tuple[Coordinate, Coordinate]] = Field(default_factory=list, max_length=10_000)

    @field_validator("add", "remove")
    @classmethod
    def finite_points(cls, points: list[tuple[float, float]]) -> list[tuple[float, float]]:
        if not all(math.isfinite(x) and math.isfinite(y) for x, y in points):
            raise ValueError("event obstacles must be finite points")
        return points


class Pacer:
    """The simulator at real time while anyone holds it, at its own speed otherwise."""

    def __init__(self, sim: Simulator) -> None:
        self.sim = sim
        self._lock = threading.Lock()
        self._holders = 0

    def _set(self, real_time: bool) -> None:
        speed = self.sim.options.speed
        factor: float | str = 1 if real_time else ("max" if speed == "max" else float(speed))
        with contextlib.suppress(SimulatorError):
            self.sim.control("speed", factor=factor)

    @contextlib.contextmanager
    def real_time(self) -> Iterator[None]:
        with self._lock:
            self._holders += 1
            if self._holders == 1:
                self._set(True)
        try:
            yield
        finally:
            with self._lock:
                self._holders -= 1
                if self._holders == 0:
                    self._set(False)


def snapped(grid: Grid, points: list[tuple[float, float]]) -> list[Point]:
    """The nodes nearest the points (the cells the gateway's map will hold), in metres."""
    return [grid.node_xy(*grid.nearest_node(x, y)) for x, y in points]


class EventPlayer:
    """Schedules the events in the simulator and tells the gateway of each when its time comes
    (a thread of its own); `applied` reports each: when, what, and how long until the gateway's
    map and, if the change blocked the path, the firmware had the new path."""

    def __init__(
        self, gateway: Gateway, sim: Simulator, pacer: Pacer, events: list[MapEvent], t0: float
    ) -> None:
        self.gateway, self.sim, self.pacer, self.t0 = gateway, sim, pacer, t0
        self.events = sorted(events, key=lambda e: e.at_s)
        self.applied: list[dict[str, Any]] = []
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._run, name="map events", daemon=True)
        grid = gateway.map_planner.grid
        self._cells = [(snapped(grid, e.add), snapped(grid, e.remove)) for e in self.events]
        for event, (add, remove) in zip(self.events, self._cells, strict=True):
            sim.change_obstacles(add, remove, step=grid.step_m, physical=True, at_s=t0 + event.at_s)

    def __enter__(self) -> EventPlayer:
        if self.events:
            self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._done.set()
        if self._thread.is_alive():
            self._thread.join()

    def _wait_until(self, t: float) -> bool:
        """Waits for simulated time t; False if the mission ended first."""
        side = self.sim.side
        while not self._done.is_set() and side is not None:
            try:
                side.wait_truth(lambda truth: truth["t"] >= t, 0.2)
                return True
            except SimulatorError:
                continue
        return False

    def _run(self) -> None:
        for event, (add, remove) in zip(self.events, self._cells, strict=True):
            at = self.t0 + event.at_s
            if not self._wait_until(at - EVENT_LEAD_S):
                return
            with self.pacer.real_time():
                if not self._wait_until(at):
                    return
                replans = len(self.gateway.mission.replans)
                seen_t = self.sim.truth()["t"]
                why = f"mission event at {event.at_s:g} s ({len(add)} obstacles added, {len(remove)} removed)"
                record: dict[str, Any] = {"at_s": event.at_s, "add": add, "remove": remove}
                try:
                    self.gateway.change_obstacles(add, remove, why)
                except PlanError as exc:
                    record["error"] = str(exc)
                done_t = self.sim.truth()["t"]
                replanned = self.gateway.mission.replans[replans:]
                record.update(
                    seen_s=seen_t - self.t0,
                    handled_s=done_t - self.t0,
                    replanned=bool(replanned),
                    # the change's time to the new path in the firmware (its first frame answered)
                    new_path_after_s=done_t - at
                    if replanned and replanned[0].outcome == "replanned"
                    else None,
                )
                self.applied.append(record)

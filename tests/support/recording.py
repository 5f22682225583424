"""Recordings read back with the `mcap` package, and a stand-in for the gateway the Foxglove
publisher and the recorder can hook into (no simulator)."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

from mcap.reader import make_reader

from cart2d.maps import OccupancyMap
from cart2d.recording import channels as c


class Read:
    """A recording's channels and messages, in the order they are in the file."""

    def __init__(self, path: Path) -> None:
        with path.open("rb") as stream:
            reader = make_reader(stream)
            summary = reader.get_summary()
            assert summary is not None and summary.statistics is not None
            self.statistics = summary.statistics
            self.channels = {ch.topic: ch for ch in summary.channels.values()}
            self.schemas = {ch.topic: summary.schemas[ch.schema_id] for ch in summary.channels.values()}
            self.messages = [(channel.topic, message) for _, channel, message in reader.iter_messages()]

    def on(self, topic: str) -> list[Any]:
        return [message for t, message in self.messages if t == topic]

    def ws(self, kind: str) -> list[dict[str, Any]]:
        return [m for m in (json.loads(x.data) for x in self.on(c.TOPIC_WS)) if m["type"] == kind]


class StandIn:
    """What the publisher uses of a Gateway: subscribe, map_view, floor_plan."""

    def __init__(self, plan: OccupancyMap | None = None) -> None:
        self.listeners: list[Callable[[dict[str, Any]], None]] = []
        self.sim = None
        self.plan = plan

    def subscribe(self, listener: Callable[[dict[str, Any]], None]) -> Callable[[], None]:
        self.listeners.append(listener)
        return lambda: self.listeners.remove(listener)

    def map_view(self) -> dict[str, Any]:
        return {
            "version": 1,
            "cols": 5,
            "rows": 4,
            "step_m": 0.2,
            "origin_m": [0.0, 0.0],
            "obstacles": [[0.4, 0.2]],
        }

    def floor_plan(self) -> OccupancyMap | None:
        return self.plan

    def publish(self, message: dict[str, Any]) -> None:
        for listener in self.listeners:
            listener(message)

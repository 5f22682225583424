"""Reading a recording back (the `mcap` package) and playing it at its recorded pace.

Replay needs only the JSON channels (channels.py): /cart2d/ws, each /ws message as the panel got
it, and /cart2d/map_view, the map it fetched. The built-in-schema channels are for Foxglove."""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mcap.exceptions import McapError
from mcap.reader import make_reader

from cart2d.recording.channels import TOPIC_MAP_VIEW, TOPIC_WS

Listener = Callable[[dict[str, Any]], None]


class RecordingError(ValueError):
    """A file that is not a cart2d recording, in a sentence for a person."""


@dataclass(frozen=True)
class Entry:
    log_time_ns: int
    topic: str
    message: dict[str, Any]


@dataclass
class Recorded:
    path: Path
    entries: list[Entry] = field(default_factory=list)  # in log time order

    @property
    def start_ns(self) -> int:
        return self.entries[0].log_time_ns if self.entries else 0

    @property
    def duration_s(self) -> float:
        return (self.entries[-1].log_time_ns - self.start_ns) / 1e9 if self.entries else 0.0

    def ws_messages(self) -> list[dict[str, Any]]:
        return [e.message for e in self.entries if e.topic == TOPIC_WS]

    def first_map_view(self) -> dict[str, Any] | None:
        return next((e.message for e in self.entries if e.topic == TOPIC_MAP_VIEW), None)


def read_recording(path: Path) -> Recorded:
    """The replayable messages of an MCAP file written by cart2d; RecordingError if it has none."""
    recorded = Recorded(path)
    try:
        with path.open("rb") as stream:
            reader = make_reader(stream)
            for _schema, channel, message in reader.iter_messages(
                topics=[TOPIC_WS, TOPIC_MAP_VIEW], log_time_order=True
            ):
                recorded.entries.append(Entry(message.log_time, channel.topic, json.loads(message.data)))
    except (McapError, json.JSONDecodeError, UnicodeDecodeError, EOFError) as exc:
        raise RecordingError(f"{path} is not a readable MCAP recording ({exc})") from exc
    if not recorded.entries:
        raise RecordingError(f"{path} holds no cart2d messages ({TOPIC_WS}): was it recorded by cart2d?")
    return recorded


class Player:
    """Plays a recording to its listeners at `speed` times its pace, in a thread; keeps what the
    panel asks for over HTTP (the map at the current position, the mission, the position)."""

    def __init__(self, recorded: Recorded, speed: float = 1.0, loop: bool = False) -> None:
        self.recorded = recorded
        self.speed = speed
        self.loop = loop
        self.state = "waiting"  # for its first viewer, then playing, then ended
        self.position_s = 0.0
        self.sent = 0  # /ws messages handed to the listeners
        self.map = recorded.first_map_view() or {}
        self.mission: dict[str, Any] = {"state": "idle", "goal": None, "reason": "", "elapsed_s": 0.0}
        self.mission.update(plan=None, replans=[])
        self.truth_seen = False
        self._listeners: tuple[Listener, ...] = ()
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._play, name="replay", daemon=True)

    # the part of Gateway's interface the /ws fan-out (cart2d/server/live.py, Viewers) uses
    def subscribe(self, listener: Listener) -> Callable[[], None]:
        with self._lock:
            self._listeners = (*self._listeners, listener)
            if self.state == "waiting":  # the first viewer sees the recording from its start
                self.state = "playing"
                self._thread.start()

        def unsubscribe() -> None:
            with self._lock:
                self._listeners = tuple(known for known in self._listeners if known is not listener)

        return unsubscribe

    def mission_view(self) -> dict[str, Any]:
        return dict(self.mission)

    def view(self) -> dict[str, Any]:
        """The replay's state, as /api/status `replay`."""
        return {
            "file": self.recorded.path.name,
            "state": self.state,
            "position_s": round(self.position_s, 3),
            "duration_s": round(self.recorded.duration_s, 3),
            "speed": self.speed,
            "sent": self.sent,
        }

    def close(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=2.0)

    def _play(self) -> None:
        while not self._stop.is_set():
            self._play_once()
            if not self.loop:
                self.state = "ended"
                return

    def _play_once(self) -> None:
        start_ns = self.recorded.start_ns
        began = time.monotonic()
        for entry in self.recorded.entries:
            at_s = (entry.log_time_ns - start_ns) / 1e9
            if self._stop.wait(max(0.0, began + at_s / self.speed - time.monotonic())):
                return
            self.position_s = at_s
            if entry.topic == TOPIC_MAP_VIEW:
                self.map = entry.message
                continue
            message = entry.message
            kind = message.get("type")
            if kind == "mission":
                self.mission = {k: v for k, v in message.items() if k != "type"}
            elif kind == "truth":
                self.truth_seen = True
            self.sent += 1
            for listener in self._listeners:
                listener(message)

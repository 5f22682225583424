"""Playing a recording (recorded.py) back at its recorded pace, with play, pause, seek and restart.

The player hands each /ws message to its listeners (the /ws fan-out, cart2d/server/live.py) and
each camera frame to its frame sinks (the MJPEG re-stream) when its time comes, and keeps the
state a panel would have at its position (replay_state.py). A seek, a restart or a loop tells the
listeners with a "replay" message (the position, the cart's trails up to it) followed by the
messages of the state there: the panel then draws the world as it was at that moment.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any, TypeVar

from cart2d.gateway.messages import ReplayMessage, wire
from cart2d.recording.channels import TOPIC_WS
from cart2d.recording.recorded import Frame, Recorded, RecordingError, read_recording
from cart2d.recording.replay_state import ReplayState

__all__ = ["Player", "RecordingError", "read_recording"]

Listener = Callable[[dict[str, Any]], None]
FrameSink = Callable[[Frame, int], None]  # the frame and its number
# A paused replay (or one between two distant frames) shows its camera frame again this often:
# the panel's MJPEG re-stream ends when it has had no frame for a few seconds (server/camera.py).
KEEPALIVE_S = 1.0
T = TypeVar("T")


class Player:
    """Plays a recording to its listeners at `speed` times its pace, in a thread of its own, from
    its first viewer on (or a play); keeps what the panel asks for over HTTP (the map, the world,
    the mission, the camera frame at the current position)."""

    def __init__(self, recorded: Recorded, speed: float = 1.0, loop: bool = False) -> None:
        self.recorded = recorded
        self.speed = speed
        self.loop = loop
        self.state = "waiting"  # for its first viewer; then playing, paused or ended
        self.sent = 0  # /ws messages handed to the listeners
        self.seeks = 0  # seeks, restarts and loops: the panel's trails are from before
        self.version = 0  # counts the changes of state (a panel keeps the newest it was told)
        self.now = ReplayState(recorded)
        self._index = 0  # the next entry to play
        self._position_s = 0.0  # while not playing; playing: _anchor's
        self._anchor = (0.0, 0.0)  # (monotonic time, position) the pace is counted from
        self._frame_told = 0.0  # monotonic time the frame sinks last had a frame
        self._listeners: tuple[Listener, ...] = ()
        self._frame_sinks: tuple[FrameSink, ...] = ()
        self._cond = threading.Condition()
        self._closed = False
        self._thread = threading.Thread(target=self._run, name="replay", daemon=True)

    # -- the part of Gateway's interface the /ws fan-out (cart2d/server/live.py, Viewers) uses --
    def subscribe(self, listener: Listener) -> Callable[[], None]:
        with self._cond:
            self._listeners = (*self._listeners, listener)
            if self.state == "waiting":  # the first viewer sees the recording from its start
                self._play()

        def unsubscribe() -> None:
            with self._cond:
                self._listeners = tuple(known for known in self._listeners if known is not listener)

        return unsubscribe

    def mission_view(self) -> dict[str, Any]:
        with self._cond:
            return self.now.mission()

    # -- the camera's frames, for the re-stream ----------------------------------------------
    def subscribe_frames(self, sink: FrameSink) -> Callable[[], None]:
        with self._cond:
            self._frame_sinks = (*self._frame_sinks, sink)

        def unsubscribe() -> None:
            with self._cond:
                self._frame_sinks = tuple(known for known in self._frame_sinks if known is not sink)

        return unsubscribe

    # -- reading -------------------------------------------------------------------------------
    @property
    def position_s(self) -> float:
        """Where the replay is, s from the recording's start."""
        with self._cond:
            return self._position()

    def view(self) -> dict[str, Any]:
        """The replay's state, as GET /api/replay and /api/status `replay`."""
        with self._cond:
            return {
                "file": self.recorded.path.name,
                "state": self.state,
                "position_s": round(self._position(), 3),
                "duration_s": round(self.recorded.duration_s, 3),
                "speed": self.speed,
                "loop": self.loop,
                "sent": self.sent,
                "seeks": self.seeks,
                "version": self.version,
            }

    def read(self, what: Callable[[ReplayState], T]) -> T:
        """what(state) of the state at the position, read under the player's lock."""
        with self._cond:
            return what(self.now)

    def snapshot(self) -> list[dict[str, Any]]:
        """The messages that bring a panel opened now to the state at the position."""
        with self._cond:
            return self._snapshot()

    # -- controls --------------------------------------------------------------------------------
    def play(self) -> None:
        """Plays on from the position (from the start once ended)."""
        with self._cond:
            if self.state == "ended":
                self._seek(0.0)
            self._play()

    def pause(self) -> None:
        with self._cond:
            if self.state == "playing":
                self._position_s = self._position()
                self.state = "paused"
                self.version += 1
                self._tell_state()

    def seek(self, position_s: float) -> None:
        """Goes to position_s (within the recording): the listeners get the state there; a replay
        that played plays on from there, one that did not waits there (paused)."""
        with self._cond:
            if self.state != "playing":
                self.state = "paused"
            self._seek(min(max(position_s, 0.0), self.recorded.duration_s))

    def restart(self) -> None:
        """From the start, playing."""
        with self._cond:
            self._seek(0.0)
            self._play()

    def close(self) -> None:
        with self._cond:
            self._closed = True
            self._cond.notify_all()
        if self._thread.is_alive():
            self._thread.join(timeout=2.0)

    # -- inside (the lock held) --------------------------------------------------------------------
    def _position(self) -> float:
        if self.state != "playing":
            return self._position_s
        at_wall, at_position = self._anchor
        entries = self.recorded.entries
        upcoming = entries[self._index].at_s if self._index < len(entries) else self.recorded.duration_s
        return min(at_position + (time.monotonic() - at_wall) * self.speed, upcoming)

    def _play(self) -> None:
        if self.state == "playing" or self._closed:
            return
        self.state = "playing"
        self.version += 1
        self._anchor = (time.monotonic(), self._position_s)
        if not self._thread.is_alive():
            self._thread.start()
        self._cond.notify_all()
        self._tell_state()

    def _seek(self, position_s: float) -> None:
        self._index = self.recorded.index_after(position_s)
        self.now = ReplayState.at(self.recorded, self._index)
        self._position_s = position_s
        self._anchor = (time.monotonic(), position_s)
        self.seeks += 1
        self.version += 1
        self._cond.notify_all()
        for message in self._snapshot():
            self._tell(message)
        self._tell_frame()

    def _replay_message(self) -> dict[str, Any]:
        state = ReplayMessage(
            state=self.state,
            position_s=round(self._position(), 3),
            duration_s=round(self.recorded.duration_s, 3),
            seeks=self.seeks,
            version=self.version,
        )
        return wire(state)

    def _snapshot(self) -> list[dict[str, Any]]:
        return [{**self._replay_message(), **self.now.trails()}, *self.now.messages()]

    def _tell(self, message: dict[str, Any]) -> None:
        for listener in self._listeners:  # they do not block (one hop into an event loop)
            listener(message)

    def _tell_state(self) -> None:
        self._tell(self._replay_message())

    def _tell_frame(self) -> None:
        self._frame_told = time.monotonic()
        if self.now.frame is not None:
            for sink in self._frame_sinks:
                sink(self.now.frame, self.now.frames)

    def _run(self) -> None:
        with self._cond:
            while not self._closed:
                if time.monotonic() - self._frame_told >= KEEPALIVE_S:
                    self._tell_frame()
                if self.state != "playing":
                    self._cond.wait(KEEPALIVE_S)
                    continue
                entries = self.recorded.entries
                if self._index >= len(entries):
                    self._at_end()
                    continue
                entry = entries[self._index]
                at_wall, at_position = self._anchor
                wait_s = at_wall + (entry.at_s - at_position) / self.speed - time.monotonic()
                if wait_s > 0:
                    self._cond.wait(min(wait_s, KEEPALIVE_S))  # a control may change what comes next
                    continue
                self._index += 1
                self.now.apply(entry)
                if isinstance(entry.message, Frame):
                    self._tell_frame()
                elif entry.topic == TOPIC_WS:
                    self.sent += 1
                    self._tell(entry.message)

    def _at_end(self) -> None:
        if self.loop:
            self._seek(0.0)
            return
        self._position_s = self.recorded.duration_s
        self.state = "ended"
        self.version += 1
        self._tell_state()

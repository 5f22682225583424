"""The gateway's event bus: what happened, as typed events, from the part that knows to the
parts that act on it (the mission, the pose's trust, viewers, a later ROS 2 bridge).

Synchronous: publish() calls every handler of the event's type, in the order they subscribed,
on the publisher's thread, and returns when they have returned; a handler must not block (the
server's hop into its event loop, a list's append). Publishing takes no lock: telemetry and a
stop publish while anything else may hold the gateway's locks, so the subscriptions are a
tuple replaced, never changed in place, under their own lock. An exception in a handler goes
to the publisher, as the gateway's message listeners' always did."""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property
from typing import Any, TypeVar

from cart2d.gateway.messages import LiveMessage, wire


@dataclass(frozen=True)
class Event:
    """What every event is."""


@dataclass(frozen=True)
class ViewerMessage(Event):
    """A message for viewers (/ws, the recording, a mission's trace): one of messages.py's."""

    message: LiveMessage

    @cached_property
    def wire(self) -> dict[str, Any]:
        """The message as /ws sends it and recordings keep it, dumped once for all its viewers."""
        return wire(self.message)


@dataclass(frozen=True)
class Restarted(Event):
    """The MCU restarted (docs/protocol.md, Reset causes); `expected`: the gateway caused it."""

    expected: bool
    caused_by: str
    pose_trusted: bool  # after the restart
    mission_ended: bool


@dataclass(frozen=True)
class PoseCorrected(Event):
    """The pose is trusted again: the user set it, accepted it, or the reset routine squared the
    cart up (`how`, in words); or the pose filter corrected it from fiducial markers
    (cart2d/gateway/localisation.py), which fills the rest: `map_to_odom` (x, y, yaw: where the
    odometry's origin lies in `map`), the cart's `pose` in `map`, its 3 x 3 `covariance` of
    (x, y, yaw) row by row, and `stamp_s` the gateway's monotonic time of the fix. What a ROS 2
    bridge publishes as map -> odom and a PoseWithCovarianceStamped."""

    how: str
    map_to_odom: tuple[float, float, float] | None = None
    pose: tuple[float, float, float] | None = None
    covariance: tuple[float, ...] | None = None
    stamp_s: float | None = None


@dataclass(frozen=True)
class MapChanged(Event):
    """The map the routes are planned on changed (its version counts the changes)."""

    version: int
    why: str
    walls: bool = False  # its walls too (a new floor plan or grid): the simulated world's follow


@dataclass(frozen=True)
class PerceivedChanged(Event):
    """What the camera sees changed the routes' planner (camera_service.py)."""

    why: str


@dataclass(frozen=True)
class MissionStarted(Event):
    goal: tuple[float, float]


@dataclass(frozen=True)
class MissionEnded(Event):
    goal: tuple[float, float] | None
    outcome: str  # arrived | failed
    reason: str


@dataclass(frozen=True)
class StopAsked(Event):
    """A stop was asked for (Missions.stop), published before the STOP goes: what runs goal
    after goal (exploration) sends none after it."""

    reason: str


@dataclass(frozen=True)
class RoutineStarted(Event):
    """The firmware took RESET_ROUTINE through the gateway: a mission driving ends (replaced)."""


@dataclass(frozen=True)
class Closing(Event):
    """The gateway closes (Gateway.close, its one shutdown path): each service stops what it runs."""


@dataclass(frozen=True)
class SimulatorExited(Event):
    """The simulator's process ended without being asked to (`how`: 'exited with status 1')."""

    how: str


@dataclass(frozen=True)
class SimulatorRestarted(Event):
    """The simulator's supervisor's attempt to start it again; `error` is "" if it runs."""

    restarts: int
    error: str
    answered: bool  # its firmware answers


E = TypeVar("E", bound=Event)
_Subscription = tuple[type[Event], Callable[[Any], None]]


class EventBus:
    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._subscriptions: tuple[_Subscription, ...] = ()

    def subscribe(self, kind: type[E], handler: Callable[[E], None]) -> Callable[[], None]:
        """Calls handler(event) for every event of `kind` (or of a subclass) published from
        now on; returns the function that unsubscribes it."""
        subscription: _Subscription = (kind, handler)
        with self._lock:
            self._subscriptions = (*self._subscriptions, subscription)

        def unsubscribe() -> None:
            with self._lock:
                self._subscriptions = tuple(s for s in self._subscriptions if s is not subscription)

        return unsubscribe

    def publish(self, event: Event) -> None:
        for kind, handler in self._subscriptions:  # a tuple read once: no lock (module docstring)
            if isinstance(event, kind):
                handler(event)

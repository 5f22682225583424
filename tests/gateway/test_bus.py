"""The gateway's event bus (cart2d/gateway/bus.py): typed, synchronous, in subscription order."""

from __future__ import annotations

import threading
from collections.abc import Callable

import pytest

from cart2d.gateway.bus import Event, EventBus, MapChanged, MissionEnded, PoseCorrected, ViewerMessage
from cart2d.gateway.messages import MapMessage


def test_a_handler_gets_the_events_of_its_type_only() -> None:
    bus = EventBus()
    maps: list[MapChanged] = []
    poses: list[PoseCorrected] = []
    bus.subscribe(MapChanged, maps.append)
    bus.subscribe(PoseCorrected, poses.append)
    bus.publish(MapChanged(2, "an obstacle was added"))
    bus.publish(MissionEnded((1.0, 1.0), "arrived", ""))
    assert maps == [MapChanged(2, "an obstacle was added")] and poses == []


def test_handlers_run_in_order_on_the_publishers_thread_and_a_base_type_gets_all() -> None:
    bus = EventBus()
    calls: list[tuple[str, object, threading.Thread]] = []
    bus.subscribe(Event, lambda e: calls.append(("any", e, threading.current_thread())))
    bus.subscribe(PoseCorrected, lambda e: calls.append(("pose", e, threading.current_thread())))
    event = PoseCorrected("the pose was set")
    bus.publish(event)
    assert [(who, e) for who, e, _ in calls] == [("any", event), ("pose", event)]
    assert all(thread is threading.current_thread() for _, _, thread in calls)


def test_unsubscribe_stops_only_that_handler() -> None:
    bus = EventBus()
    first: list[ViewerMessage] = []
    second: list[ViewerMessage] = []
    unsubscribe = bus.subscribe(ViewerMessage, first.append)
    bus.subscribe(ViewerMessage, second.append)
    unsubscribe()
    unsubscribe()  # twice changes nothing
    bus.publish(ViewerMessage(MapMessage(version=1, why="a test")))
    assert first == [] and len(second) == 1


def test_a_handler_may_unsubscribe_while_an_event_is_delivered() -> None:
    """Delivery reads the subscriptions once: a change during it applies from the next event."""
    bus = EventBus()
    seen: list[str] = []
    unsubscribes: list[Callable[[], None]] = []

    def once(event: PoseCorrected) -> None:
        seen.append("once")
        unsubscribes[0]()

    unsubscribes.append(bus.subscribe(PoseCorrected, once))
    bus.subscribe(PoseCorrected, lambda e: seen.append("always"))
    bus.publish(PoseCorrected("a"))
    bus.publish(PoseCorrected("b"))
    assert seen == ["once", "always", "always"]


def test_events_are_frozen() -> None:
    with pytest.raises(AttributeError):
        MapChanged(1, "x").version = 2  # type: ignore[misc]


def test_an_error_in_a_handler_reaches_the_publisher() -> None:
    bus = EventBus()

    def broken(event: MapChanged) -> None:
        raise ValueError("broken viewer")

    bus.subscribe(MapChanged, broken)
    with pytest.raises(ValueError, match="broken viewer"):
        bus.publish(MapChanged(1, ""))

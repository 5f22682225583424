"""The camera service (cart2d/gateway/camera_service.py) with a fake feed, a fake clock and a fake
firmware (fake_firmware.py): no camera, no simulator. The perceived cells it takes, what it tells
the bus and viewers and how often, the feed and sinks it swaps, and (with the Gateway) the replan
a perceived change causes through the bus."""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, cast

import pytest

from cart2d.gateway import Gateway
from cart2d.gateway.bus import Event, EventBus, PerceivedChanged, ViewerMessage
from cart2d.gateway.camera import CameraFeed, Processor, Shown
from cart2d.gateway.camera_service import CameraService
from cart2d.gateway.map_service import LiveMap
from cart2d.gateway.seeing import Seeing
from cart2d.store import Store
from tests.support.clock import FakeClock
from tests.support.fake_firmware import FakeFirmware
from tests.support.waiting import wait_for

ACROSS = [(1.0, 0.6 + 0.05 * k, 0.9) for k in range(9)]  # a wall of 5 cm cells across y = 0.8


class FakeFeed:
    """What the service does to a camera feed: processors added, viewers subscribed, stopped."""

    def __init__(self) -> None:
        self.processors: list[Processor] = []
        self.viewers: list[Callable[[Shown], None]] = []
        self.stopped = False

    def add_processor(self, processor: Processor) -> None:
        self.processors.append(processor)

    def subscribe(self, viewer: Callable[[Shown], None]) -> Callable[[], None]:
        self.viewers.append(viewer)
        return lambda: self.viewers.remove(viewer)

    def stop(self) -> None:
        self.stopped = True


@pytest.fixture
def cart() -> FakeFirmware:
    return FakeFirmware()


@pytest.fixture
def clock() -> FakeClock:
    return FakeClock()


@pytest.fixture
def service(tmp_path: Path, cart: FakeFirmware, clock: FakeClock) -> CameraService:
    bus = EventBus()
    return CameraService(
        cart, LiveMap(Store(tmp_path), Store(tmp_path).load(), bus), bus, tmp_path, clock=clock
    )


def told(service: CameraService) -> tuple[list[Event], list[dict[str, Any]]]:
    """The events published from now on, and among them the viewers' messages."""
    events: list[Event] = []
    service.bus.subscribe(Event, events.append)
    messages: list[dict[str, Any]] = []
    service.bus.subscribe(ViewerMessage, lambda e: messages.append(e.wire))
    return events, messages


def test_cells_that_change_the_routes_are_told_once_and_a_refresh_of_them_is_not(
    service: CameraService,
) -> None:
    events, _ = told(service)
    routes = service.live_map.planner
    view = service.set_perceived(ACROSS, "the camera sees 9 cells")
    assert [e for e in events if isinstance(e, PerceivedChanged)] == [
        PerceivedChanged("the camera sees 9 cells")
    ]
    assert view["blocked_cells"] > 0 and service.live_map.planner is not routes
    events.clear()
    service.set_perceived([(x, y, 0.95) for x, y, _ in ACROSS], "the same cells, more sure")
    assert not [e for e in events if isinstance(e, PerceivedChanged)]


def test_bad_cells_change_nothing(service: CameraService) -> None:
    service.set_perceived(ACROSS, "a wall")
    events, _ = told(service)
    before = service.live_map.state
    with pytest.raises(ValueError, match=r"p_occupied 1\.5"):
        service.set_perceived([(1.0, 0.8, 0.9), (1.0, 1.0, 1.5)], "one bad cell")
    with pytest.raises(ValueError, match="resolution"):
        service.set_perceived([(1.0, 0.8, 0.9)], "a bad resolution", resolution_m=0.0)
    assert service.live_map.state is before and events == []


def test_perception_off_clears_the_cells_and_takes_none_until_it_is_on(service: CameraService) -> None:
    service.set_perceived(ACROSS, "a wall")
    events, _ = told(service)
    assert service.set_perception_enabled(False)["cells"] == []
    assert events.count(PerceivedChanged("perception was turned off")) == 1
    assert service.set_perceived(ACROSS, "the wall again")["cells"] == []  # not taken while off
    assert service.live_map.planner is service.live_map.map_planner
    service.set_perception_enabled(True)
    assert len(service.set_perceived(ACROSS, "on again")["cells"]) == len(ACROSS)


def test_messages_keep_their_rates_by_the_clock(service: CameraService, clock: FakeClock) -> None:
    _, messages = told(service)
    for k in range(3):
        service.tell_camera(float(k), [(0.1, 0.0), (1.5, 0.8)], [(1.0, 0.0)])
    clock.t += 0.19
    service.tell_camera(3.0, [], [])
    assert [m["t"] for m in messages if m["type"] == "camera"] == [0.0]
    clock.t += 0.01
    service.tell_camera(4.0, [], [])
    assert [m["t"] for m in messages if m["type"] == "camera"] == [0.0, 4.0]
    for k in range(3):  # a burst: the first at once, the last state once half a second has passed
        service.set_perceived([(1.0, 0.1 * k, 0.9)], "a burst")
    assert [m["cells"] for m in messages if m["type"] == "perceived"] == [[[1.0, 0.0, 0.9]]]
    clock.t += 0.5
    wait_for(lambda: len([m for m in messages if m["type"] == "perceived"]) == 2, 10.0)
    assert [m for m in messages if m["type"] == "perceived"][-1]["cells"] == [[1.0, 0.2, 0.9]]


def test_the_bus_is_told_with_the_services_lock_free(service: CameraService) -> None:
    free: list[bool] = []

    def try_the_lock() -> None:
        got = service._lock.acquire(blocking=False)
        free.append(got)
        if got:
            service._lock.release()

    def handler(event: PerceivedChanged) -> None:
        thread = threading.Thread(target=try_the_lock)
        thread.start()
        thread.join()

    service.bus.subscribe(PerceivedChanged, handler)
    service.set_perceived(ACROSS, "a wall")
    service.clear_perceived()
    service.set_perception_enabled(False)
    assert free == [True, True]  # turning off an empty layer changes no route


def test_a_new_feed_gets_perception_and_the_sinks_and_the_old_one_stops(service: CameraService) -> None:
    first, second = FakeFeed(), FakeFeed()
    shown: list[Shown] = []
    remove = service.add_camera_sink(shown.append)
    service.use_camera(cast(CameraFeed, first))
    seeing = service.seeing
    assert isinstance(seeing, Seeing) and first.processors == [seeing] and first.viewers == [shown.append]
    assert service.sees()
    service.use_camera(cast(CameraFeed, second))
    assert first.stopped and service.seeing is not seeing and second.viewers == [shown.append]
    remove()
    assert second.viewers == []
    service.set_perception_enabled(False)
    assert not service.sees()
    service.use_camera(None)
    assert second.stopped and service.seeing is None and service.camera is None


@pytest.fixture
def gateway(cart: FakeFirmware, tmp_path: Path) -> Iterator[Gateway]:
    cart.pose = [0.2, 0.8, 0.0]
    store = Store(tmp_path)
    gateway = Gateway(cart, store, store.load())
    gateway.read_status()
    yield gateway
    gateway.close()


def test_cells_across_the_driven_route_replan_it_through_the_bus(
    gateway: Gateway, cart: FakeFirmware
) -> None:
    gateway.go_to(1.6, 0.8)
    straight = list(cart.path)
    gateway.set_perceived(ACROSS, "the camera sees 9 cells")
    (replan,) = gateway.mission.replans
    assert replan.reason == "the map changed: the camera sees 9 cells" and replan.outcome == "replanned"
    assert cart.path != straight and gateway.mission_view()["state"] == "driving"
    assert gateway.perceived is gateway.live_map.perceived and gateway.planner is gateway.live_map.planner

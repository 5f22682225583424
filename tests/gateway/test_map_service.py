"""The live map service (cart2d/gateway/map_service.py) on its own: no link, no simulator, no
mission. A change is told once on the bus, a planner handed out is never changed by later edits,
and bad input changes nothing."""

from __future__ import annotations

import threading
from pathlib import Path

import numpy as np
import pytest

from cart2d.gateway.bus import Event, EventBus, MapChanged, ViewerMessage
from cart2d.gateway.map_service import LiveMap
from cart2d.gateway.perceived import PerceivedLayer
from cart2d.maps import OCCUPIED, OccupancyMap
from cart2d.planning import OffMap, PlanError, Point
from cart2d.store import GatewaySettings, MapSettings, Store

ACROSS = [(1.0, 0.6), (1.0, 0.8), (1.0, 1.0)]  # three nodes across the straight line at y = 0.8


def live_map(tmp_path: Path, position: Point | None = None) -> tuple[LiveMap, list[Event], Store]:
    store, bus = Store(tmp_path), EventBus()
    events: list[Event] = []
    bus.subscribe(Event, events.append)
    return LiveMap(store, store.load(), bus, lambda: position), events, store


def test_an_obstacle_change_is_told_once_with_the_new_version_and_saved(tmp_path: Path) -> None:
    m, events, store = live_map(tmp_path)
    m.change_obstacles(ACROSS, [], "a box was put down")
    assert [e for e in events if isinstance(e, MapChanged)] == [MapChanged(2, "a box was put down")]
    assert [e.wire for e in events if isinstance(e, ViewerMessage)] == [
        {"type": "map", "version": 2, "why": "a box was put down"}
    ]
    assert len(store.load().map.obstacles) == 3 and m.map_view()["version"] == 2
    events.clear()
    m.change_obstacles(ACROSS[:1], [], "the same box again")  # no change: nothing told, no new version
    assert events == [] and m.version == 2


def test_a_planner_handed_out_is_not_changed_by_later_edits(tmp_path: Path) -> None:
    m, _, _ = live_map(tmp_path)
    routes, own = m.planner, m.map_planner
    straight = routes.plan((0.2, 0.8), (1.6, 0.8))
    m.change_obstacles(ACROSS, [], "a box was put down")
    assert own.obstacles == frozenset() and routes.plan((0.2, 0.8), (1.6, 0.8)) == straight
    assert m.planner is not routes and len(m.map_planner.obstacles) == 3
    assert m.planner.plan((0.2, 0.8), (1.6, 0.8)).length_m > straight.length_m  # round the box
    m.take_perceived(PerceivedLayer(((1.0, 0.8, 0.9),), 0.05))
    assert own.obstacles == frozenset() and routes.plan((0.2, 0.8), (1.6, 0.8)) == straight


def test_a_point_off_the_map_changes_nothing(tmp_path: Path) -> None:
    m, events, store = live_map(tmp_path)
    before, saved = m.state, store.path.read_bytes() if store.path.exists() else None
    with pytest.raises(OffMap):
        m.change_obstacles([(1.0, 0.8), (50.0, 0.8)], [], "one on the map, one far off it")
    assert m.state is before and events == []
    assert (store.path.read_bytes() if store.path.exists() else None) == saved


def test_settings_the_rest_refuses_change_nothing(tmp_path: Path) -> None:
    m, events, store = live_map(tmp_path)
    m.change_obstacles(ACROSS, [], "a box was put down")
    before, saved, events[:] = m.state, store.path.read_bytes(), []
    wider = m.settings.model_copy(update={"map": MapSettings(cols=20, rows=10)})

    def refuse(new: GatewaySettings, old: GatewaySettings) -> None:
        raise ValueError("the camera's URL must be http://HOST[:PORT]")

    with pytest.raises(ValueError, match="camera's URL"):
        m.update_settings(wider, "a wider map", refuse)  # type: ignore[arg-type]
    assert m.state is before and events == [] and store.path.read_bytes() == saved
    with pytest.raises(ValueError):
        m.update_settings(m.settings.model_copy(update={"map": MapSettings.model_construct(cols=0)}))
    assert m.state is before and events == [] and store.path.read_bytes() == saved


def test_new_walls_are_told_as_such_and_the_rest_follows_after_the_map(tmp_path: Path) -> None:
    m, events, _ = live_map(tmp_path)
    order: list[str] = []
    wider = m.settings.model_copy(update={"map": MapSettings(cols=20, rows=10)})
    m.update_settings(wider, "a wider map", lambda new, old: lambda: order.append(f"camera at v{m.version}"))
    assert order == ["camera at v2"]
    assert [e for e in events if isinstance(e, MapChanged)] == [MapChanged(2, "a wider map", walls=True)]
    assert m.map_view()["cols"] == 20
    events.clear()
    m.update_settings(m.settings.model_copy(update={"token": "a" * 16}), "a token")  # not the map
    assert events == [] and m.version == 2


def test_the_bus_is_told_with_the_maps_lock_free(tmp_path: Path) -> None:
    m, _, _ = live_map(tmp_path)
    free: list[bool] = []

    def try_the_lock() -> None:  # another thread: a handler's own lock order must not matter
        got = m._lock.acquire(blocking=False)
        free.append(got)
        if got:
            m._lock.release()

    def handler(event: MapChanged) -> None:
        thread = threading.Thread(target=try_the_lock)
        thread.start()
        thread.join()

    m.bus.subscribe(MapChanged, handler)
    m.change_obstacles(ACROSS, [], "a box")
    m.clear_obstacles()
    assert free == [True, True]


def test_perceived_cells_plan_routes_finer_and_the_same_mask_again_is_no_change(tmp_path: Path) -> None:
    m, events, _ = live_map(tmp_path)
    own = m.map_planner
    layer = PerceivedLayer(tuple((1.0, 0.6 + 0.05 * k, 0.9) for k in range(9)), 0.05)
    assert m.take_perceived(layer)
    assert m.planner.grid.step_m < own.grid.step_m and m.map_planner is own and m.perceived is layer
    assert not m.take_perceived(PerceivedLayer(layer.cells, 0.05, why="the same cells, later"))
    assert m.take_perceived(PerceivedLayer())
    assert m.planner is own and events == []  # the camera service tells the bus (PerceivedChanged)


def test_a_floor_plan_warns_when_the_cart_stands_in_a_wall(tmp_path: Path) -> None:
    cells = np.zeros((40, 60), dtype=np.int8)
    cells[0, :] = cells[-1, :] = cells[:, 0] = cells[:, -1] = OCCUPIED
    room = OccupancyMap((-0.5, -0.5), 0.05, cells)
    inside, _, _ = live_map(tmp_path / "in", position=(0.5, 0.5))
    assert inside.load_floor_plan(room, "room")["pose_warning"] is None
    in_wall, events, _ = live_map(tmp_path / "wall", position=(-0.5, 0.0))
    view = in_wall.load_floor_plan(room, "room")
    assert "the cart's position (-0.500, 0.000) is off the map" in view["pose_warning"]
    assert MapChanged(2, "the floor plan 'room' was loaded", walls=True) in events
    with pytest.raises(PlanError):
        in_wall.planner.plan((0.0, 0.0), (5.0, 5.0))  # off the plan

"""The live map, a service of the gateway: the saved settings (the map, its user's obstacles, a
floor plan), the perceived layer the camera feeds it (cart2d/gateway/camera_service.py), and the
planners built from them: the map's own (the user's obstacles as nodes) and the routes' (with what
the camera sees, on a grid as fine as its cells). A change publishes the viewers' "map" message
and `MapChanged` on the bus (cart2d/gateway/bus.py): the missions replan a driven route it
blocks, the simulated world's walls follow new walls.

What it hands out is a snapshot (`MapState`): replaced whole, never changed, so a planner read
once plans on one map however the map changes meanwhile, and readers take no lock. The lock
only orders the writers; events are published once it is released, so a handler may take the
mission's lock without ever waiting for the map's (and a stop never waits for a planner being
built: that happens before the lock, seconds for a 2000 x 2000 floor plan)."""

from __future__ import annotations

import copy
import logging
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from cart2d.gateway import messages
from cart2d.gateway.bus import EventBus, MapChanged, ViewerMessage
from cart2d.gateway.live_map import Layout, arena, layout_for, planner_for
from cart2d.gateway.perceived import PerceivedLayer
from cart2d.maps import OccupancyMap
from cart2d.maps.ros import image_bytes
from cart2d.params import footprint_radius_m
from cart2d.planning import Planner, Point
from cart2d.shown import for_people
from cart2d.store import FloorPlan, GatewaySettings, MapSettings, Store

log = logging.getLogger(__name__)

# The rest of new settings (the camera's, camera_service.py): checked before anything is written
# (a ValueError changes nothing), given (new, old); what it returns applies them once the map did.
SettingsFollower = Callable[[GatewaySettings, GatewaySettings], Callable[[], None]]


def route_layout(m: MapSettings, layer: PerceivedLayer) -> Layout | None:
    """The map on a grid as fine as the perceived cells; None while nothing is perceived (routes
    are then planned with the map's own planner)."""
    return layout_for(m, layer.resolution_m) if layer.cells else None


def with_perceived(m: MapSettings, layer: PerceivedLayer, map_planner: Planner) -> Planner:
    """The planner of routes: `map_planner` (built for `m` alone) while nothing is perceived, else
    the map on a grid as fine as the perceived cells, with them blocked too."""
    layout = route_layout(m, layer)
    return map_planner if layout is None else layout.planner(also_blocked=layer.mask(layout.grid))


def walls_of(m: MapSettings) -> tuple[object, ...]:
    """What of a map decides the simulated world's walls (live_map.world_for): not its obstacles."""
    return (m.floor_plan, m.cols, m.rows, m.step_m, m.origin_m)


@dataclass(frozen=True)
class MapState:
    """The live map at one moment (never changed: a change is a new state)."""

    settings: GatewaySettings
    map_planner: Planner  # the map's alone: the user's obstacles are its nodes
    planner: Planner  # the routes': with what the camera sees (with_perceived)
    version: int  # counts the map's changes (the panel fetches the map again)
    perceived: PerceivedLayer


class LiveMap:
    """The map, its planners and its changes (see the module's docstring). `position`: where the
    cart stands, (x, y), or None when it cannot be read (a floor plan's warning asks it)."""

    def __init__(
        self,
        store: Store,
        settings: GatewaySettings,
        bus: EventBus,
        position: Callable[[], Point | None] = lambda: None,
    ) -> None:
        self.store = store
        self.bus = bus
        self._position = position
        self._lock = threading.RLock()  # orders the writers (readers read one state)
        map_planner = planner_for(settings.map)
        self._state = MapState(settings, map_planner, map_planner, 1, PerceivedLayer())

    # -- what readers read (no lock: one state read once) ---------------------------------------
    @property
    def state(self) -> MapState:
        return self._state

    @property
    def settings(self) -> GatewaySettings:
        return self._state.settings

    @property
    def planner(self) -> Planner:
        """The routes' planner now: plan on it as long as you like, a change makes another."""
        return self._state.planner

    @property
    def map_planner(self) -> Planner:
        return self._state.map_planner

    @property
    def version(self) -> int:
        return self._state.version

    @property
    def perceived(self) -> PerceivedLayer:
        return self._state.perceived

    def map_view(self) -> dict[str, Any]:
        s = self._state
        m = s.settings.map
        g = s.map_planner.grid
        view: dict[str, Any] = {
            "version": s.version,
            "cols": g.cols,
            "rows": g.rows,
            "step_m": g.step_m,
            "origin_m": list(g.origin),
            "arena": arena(m),
            "footprint_radius_m": footprint_radius_m(),
            "planning_radius_m": s.planner.footprint_radius_m,
            "obstacles": [list(g.node_xy(i, j)) for i, j in sorted(s.map_planner.obstacles)],
            "floor_plan": None,
            "unknown_is_free": m.unknown_is_free,
        }
        if m.floor_plan is not None:
            plan = m.floor_plan
            view["floor_plan"] = {
                "name": plan.name,
                "origin_m": list(plan.origin_m),
                "resolution_m": plan.resolution_m,
                "width": plan.width,
                "height": plan.height,
                "cells": plan.occupancy().counts(),
                "image": f"/api/map/image?version={s.version}",
            }
        rounded: dict[str, Any] = for_people(view)  # 0.3, not 0.30000000000000004
        return rounded

    def floor_plan(self) -> OccupancyMap | None:
        plan = self._state.settings.map.floor_plan
        return plan.occupancy() if plan is not None else None

    def floor_plan_png(self) -> bytes | None:
        """The floor plan as a PNG (map_server's grey levels), None without one."""
        plan = self.floor_plan()
        return None if plan is None else image_bytes(plan, ".png")

    # -- the user's obstacles --------------------------------------------------------------------
    def set_obstacle(self, x: float, y: float, present: bool) -> dict[str, Any]:
        """Adds or removes the obstacle at the node nearest (x, y), and saves the map."""
        added, removed = ([(x, y)], []) if present else ([], [(x, y)])
        return self.change_obstacles(added, removed, "an obstacle was " + ("added" if present else "removed"))

    def clear_obstacles(self) -> tuple[list[Point], int]:
        """Removes every obstacle of the user's; the ones removed (their nodes) and the map's
        version after."""
        with self._lock:
            grid = self.map_planner.grid
            removed = [grid.node_xy(i, j) for i, j in sorted(self.map_planner.obstacles)]
            state, changed = self._with_obstacles([], removed)
        if changed:
            self._tell(state.version, "the obstacles were cleared", walls=False)
        return removed, state.version

    def change_obstacles(self, add: Sequence[Point], remove: Sequence[Point], why: str) -> dict[str, Any]:
        """Adds and removes obstacles at the nodes nearest the points (all or nothing: OffMap for
        a point off the map changes nothing), saves the map and tells the bus (a driven route
        the change blocks is replanned before this returns)."""
        with self._lock:
            state, changed = self._with_obstacles(add, remove)
        if changed:
            self._tell(state.version, why, walls=False)
        return self.map_view()

    def _with_obstacles(self, add: Sequence[Point], remove: Sequence[Point]) -> tuple[MapState, bool]:
        """The state with these obstacles added and removed, saved (lock held); whether it changed."""
        s = self._state
        grid = s.map_planner.grid
        added = {grid.nearest_node(x, y) for x, y in add}
        removed = {grid.nearest_node(x, y) for x, y in remove} - added
        before = s.map_planner.obstacles
        nodes = sorted((before - removed) | added)
        if set(nodes) == before:
            return s, False
        map_planner = copy.copy(s.map_planner)  # the snapshots handed out keep theirs
        map_planner.set_obstacles(nodes)
        m = s.settings.map.model_copy(update={"obstacles": nodes})
        settings = s.settings.model_copy(update={"map": m})
        planner = with_perceived(m, s.perceived, map_planner)
        self.store.save(settings)
        self._state = MapState(settings, map_planner, planner, s.version + 1, s.perceived)
        return self._state, True

    # -- floor plans and settings ------------------------------------------------------------------
    def load_floor_plan(
        self,
        occupancy: OccupancyMap,
        name: str = "",
        planning_step_m: float | None = None,
        unknown_is_free: bool = False,
    ) -> dict[str, Any]:
        """Plans on this floor plan from now on (the user's obstacles are cleared) and saves it;
        the map's view with a warning if the cart's position is not a start on it."""
        floor = FloorPlan.of(occupancy, name)
        m = MapSettings.model_validate(
            {"floor_plan": floor, "planning_step_m": planning_step_m, "unknown_is_free": unknown_is_free}
        )
        self.update_settings(
            self.settings.model_copy(update={"map": m}), f"the floor plan {name!r} was loaded"
        )
        return {**self.map_view(), "pose_warning": self._pose_problem()}

    def _pose_problem(self) -> str | None:
        """Why no plan can start where the cart's pose says it stands on the map, with what to do;
        None if one can, or the pose cannot be read (a goal's refusal will say why then)."""
        position = self._position()
        return None if position is None else self.map_planner.start_problem(position)

    def update_settings(
        self,
        settings: GatewaySettings,
        why: str = "new settings were loaded",
        follow: SettingsFollower | None = None,
    ) -> None:
        """Replaces the settings (a new map takes effect now) and saves them; `follow` checks and
        applies the rest (the camera). The new map's planners are built before the lock is taken
        (seconds for a 2000 x 2000 plan): nothing waits for them."""
        layer = self.perceived
        map_planner = planner_for(settings.map)  # validates the map first
        planner = with_perceived(settings.map, layer, map_planner)
        saved = self.store.encode(settings)
        with self._lock:
            s = self._state
            if s.perceived is not layer:  # the camera saw more meanwhile
                planner = with_perceived(settings.map, s.perceived, map_planner)
            apply = follow(settings, s.settings) if follow is not None else None  # ValueError: unchanged
            self.store.write(saved)
            new_map = settings.map != s.settings.map
            # Only new walls replace the simulated world: an obstacle drawn on the map must not
            # sweep away the boxes standing in it (a mission's world, its events).
            new_walls = new_map and walls_of(settings.map) != walls_of(s.settings.map)
            version = s.version + 1 if new_map else s.version
            self._state = MapState(settings, map_planner, planner, version, s.perceived)
        if apply is not None:
            apply()
        if new_map:
            self._tell(version, why, walls=new_walls)

    # -- the perceived layer ---------------------------------------------------------------------
    def take_perceived(self, layer: PerceivedLayer) -> bool:
        """Makes `layer` the perceived one; whether that changed the routes' planner (then its
        owner publishes PerceivedChanged: a driven route it blocks is replanned)."""
        with self._lock:
            s = self._state
            layout = route_layout(s.settings.map, layer)  # once: it is rebuilt at every camera update
            grid = s.map_planner.grid if layout is None else layout.grid
            mask = layer.mask(grid)
            changed = grid != s.planner.grid or not np.array_equal(s.perceived.mask(grid), mask)
            planner = s.planner
            if changed:
                planner = s.map_planner if layout is None else layout.planner(also_blocked=mask)
            self._state = replace(s, planner=planner, perceived=layer)
            return changed

    def _tell(self, version: int, why: str, walls: bool) -> None:
        """Viewers and the bus, once the lock is released (see the module's docstring)."""
        self.bus.publish(ViewerMessage(messages.MapMessage(version=version, why=why)))
        self.bus.publish(MapChanged(version, why, walls))

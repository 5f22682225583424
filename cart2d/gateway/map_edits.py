"""The Gateway's map (cart2d/gateway/core.py): its view for the panel, the user's obstacles, floor
plans and new settings, and what follows a change of them: the planners (the map's own, and the
routes' with what the camera sees, perceived.py), the simulated world's walls, viewers told, and
a replan of a driven path the change blocks. Every method takes the Gateway's lock."""

from __future__ import annotations

import threading
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from cart2d.gateway.bus import EventBus, MapChanged
from cart2d.gateway.collaborators import SimulatedWorld
from cart2d.gateway.live_map import arena, planner_for, world_for
from cart2d.gateway.perceived import PerceivedLayer, with_perceived
from cart2d.link import CommandRefused, Link, LinkError
from cart2d.maps import OccupancyMap
from cart2d.params import footprint_radius_m
from cart2d.planning import Planner, Point
from cart2d.shown import for_people
from cart2d.store import FloorPlan, GatewaySettings, MapSettings, Store

if TYPE_CHECKING:
    from cart2d.gateway.camera import CameraFeed


def _walls_of(m: MapSettings) -> tuple[object, ...]:
    """What of a map decides the simulated world's walls (world_for): not its obstacles."""
    return (m.floor_plan, m.cols, m.rows, m.step_m, m.origin_m)


class MapMixin:
    """The Gateway's map (see the module's docstring)."""

    # what the Gateway has (core.py, perceived.py)
    _lock: threading.RLock
    link: Link
    settings: GatewaySettings
    store: Store
    world: SimulatedWorld | None
    map_version: int
    bus: EventBus
    map_planner: Planner
    planner: Planner
    perceived: PerceivedLayer

    def _publish(self, message: dict[str, Any]) -> None:
        raise NotImplementedError

    if TYPE_CHECKING:  # PerceptionMixin's, which comes after this class in the Gateway's bases

        def _camera_change(self, settings: GatewaySettings) -> tuple[bool, CameraFeed | None]: ...

        def _apply_camera(self, change: tuple[bool, CameraFeed | None]) -> None: ...

    def map_view(self) -> dict[str, Any]:
        with self._lock:
            m = self.settings.map
            g = self.map_planner.grid
            view: dict[str, Any] = {
                "version": self.map_version,
                "cols": g.cols,
                "rows": g.rows,
                "step_m": g.step_m,
                "origin_m": list(g.origin),
                "arena": arena(m),
                "footprint_radius_m": footprint_radius_m(),
                "planning_radius_m": self.planner.footprint_radius_m,
                "obstacles": [list(g.node_xy(i, j)) for i, j in sorted(self.map_planner.obstacles)],
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
                    "image": f"/api/map/image?version={self.map_version}",
                }
            rounded: dict[str, Any] = for_people(view)  # 0.3, not 0.30000000000000004
            return rounded

    def floor_plan(self) -> OccupancyMap | None:
        with self._lock:
            plan = self.settings.map.floor_plan
            return plan.occupancy() if plan is not None else None

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
            self.change_obstacles([], removed, "the obstacles were cleared")
            return removed, self.map_version

    def change_obstacles(self, add: Sequence[Point], remove: Sequence[Point], why: str) -> dict[str, Any]:
        """Adds and removes obstacles at the nodes nearest the points (all or nothing: OffMap for
        a point off the map changes nothing), saves the map and, during a mission, replans if
        the rest of the path is blocked now."""
        with self._lock:
            grid = self.map_planner.grid
            added = {grid.nearest_node(x, y) for x, y in add}
            removed = {grid.nearest_node(x, y) for x, y in remove} - added
            before = self.map_planner.obstacles
            nodes = sorted((before - removed) | added)
            if set(nodes) != before:
                self.map_planner.set_obstacles(nodes)
                self.settings = self.settings.model_copy(
                    update={"map": self.settings.map.model_copy(update={"obstacles": nodes})}
                )
                self.planner = with_perceived(self.settings.map, self.perceived, self.map_planner)
                self.store.save(self.settings)
                self._map_changed(why)
            return self.map_view()

    def load_floor_plan(
        self,
        occupancy: OccupancyMap,
        name: str = "",
        planning_step_m: float | None = None,
        unknown_is_free: bool = False,
    ) -> dict[str, Any]:
        """Plans on this floor plan from now on (the user's obstacles are cleared), saves it and,
        in simulation, makes its walls the simulated world's."""
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
        if not self.link.connected.is_set():
            return None
        try:
            x, y, _ = self.link.call("POSE")
        except (LinkError, CommandRefused):
            return None
        with self._lock:
            return self.map_planner.start_problem((x, y))

    def update_settings(self, settings: GatewaySettings, why: str = "new settings were loaded") -> None:
        """Replaces the gateway's settings (a new map takes effect now) and saves them. The new
        map's planners are built before the lock is taken, the simulator's new walls sent after it
        is released (seconds, and half a second, for a 2000 x 2000 plan): a stop, a mission's end,
        a view wait for none of that."""
        layer = self.perceived
        map_planner = planner_for(settings.map)  # validates the map first
        planner = with_perceived(settings.map, layer, map_planner)
        saved = self.store.encode(settings)
        with self._lock:
            if self.perceived is not layer:  # the camera saw more meanwhile
                planner = with_perceived(settings.map, self.perceived, map_planner)
            camera = self._camera_change(settings)  # and the camera (perceived.py)
            self.store.write(saved)
            new_map = settings.map != self.settings.map
            # Only new walls replace the simulated world: an obstacle drawn on the map must not
            # sweep away the boxes standing in it (a mission's world, its events).
            new_walls = new_map and _walls_of(settings.map) != _walls_of(self.settings.map)
            self.settings = settings
            self.map_planner, self.planner = map_planner, planner
            self._apply_camera(camera)
            if new_map:
                self._map_changed(why)
        if new_walls:
            self._sync_world()

    def _sync_world(self) -> None:
        """The simulated world's walls follow the map (and do so again after a restart); it
        reads the map when it sends them: the latest, whoever sends last (collaborators.py)."""
        if self.world is not None:
            self.world.follow_walls(lambda: world_for(self.settings.map))

    def _map_changed(self, why: str) -> None:
        """Tells viewers, and replans a driven path the change blocks (lock held)."""
        self.map_version += 1
        self._publish({"type": "map", "version": self.map_version, "why": why})
        self.bus.publish(MapChanged(self.map_version, why))  # a driven route it blocks is replanned

"""The gateway: what the seed's ESP32 did, as one object the HTTP API (server.py) and the
command line use. It owns the link to the firmware, the map and its planner, the mission
(idle / driving / arrived / failed) and the fan-out of live data to viewers."""

from __future__ import annotations

import dataclasses
import logging
import threading
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any

from cart2d import firmware
from cart2d.flashing import Flasher
from cart2d.link import CommandRefused, Link, LinkError
from cart2d.params import footprint_radius_m, planning_radius_m, robot
from cart2d.planner import Grid, Plan, PlanError, Planner, polyline_length
from cart2d.protocol import Telemetry
from cart2d.simulator import Simulator
from cart2d.smoothing import round_corners
from cart2d.store import GatewaySettings, MapSettings, Store

log = logging.getLogger(__name__)

Listener = Callable[[dict[str, Any]], None]


class PathTooLong(PlanError):
    """More waypoints than the firmware's buffer holds."""


@dataclass
class Mission:
    state: str = "idle"  # idle | driving | arrived | failed
    goal: tuple[float, float] | None = None
    reason: str = ""
    started_s: float = 0.0
    ended_s: float = 0.0
    plan: dict[str, Any] | None = field(default=None, repr=False)


class Gateway:
    def __init__(
        self, link: Link, store: Store, settings: GatewaySettings, sim: Simulator | None = None
    ) -> None:
        self.link = link
        self.store = store
        self.settings = settings
        self.sim = sim
        self.planner = self._planner_for(settings.map)
        self.mission = Mission()
        self._lock = threading.RLock()  # guards settings, planner and mission
        # The listeners have their own lock: the link's reader thread publishes telemetry while
        # another thread may hold _lock waiting for a reply that only that reader can deliver.
        self._listeners_lock = threading.Lock()
        self._listeners: list[Listener] = []
        self._stop = threading.Event()
        self._monitor = threading.Thread(target=self._watch_mission, name="mission monitor", daemon=True)
        self.version: firmware.Version | None = None
        self.flasher = Flasher(link, store.directory, sim, after=self._check_after_update)
        link.subscribe(self._on_telemetry)
        if sim is not None and sim.side is not None:
            sim.side.subscribe(self._on_truth)

    # -- lifecycle -------------------------------------------------------------------------
    def start(self) -> None:
        self._monitor.start()

    def close(self) -> None:
        self._stop.set()
        self._monitor.join(timeout=2.0)

    def _check_after_update(self) -> None:
        self.wait_for_firmware(10.0, 0.2)

    def wait_for_firmware(self, wait_s: float, poll_s: float) -> firmware.Version:
        """check_firmware(), retried every poll_s while the MCU may still be starting
        (bootloader, simulator start-up, a Nano's reset on opening its port); raises its
        LinkError once wait_s have passed."""
        deadline = time.monotonic() + wait_s
        while True:
            try:
                return self.check_firmware()
            except LinkError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(poll_s)

    def check_firmware(self) -> firmware.Version:
        """Reads the firmware's version and refuses an incompatible one."""
        version = firmware.read_version(self.link)
        firmware.check_compatible(version)
        self.version = version
        return version

    # -- live data ---------------------------------------------------------------------------
    def subscribe(self, listener: Listener) -> Callable[[], None]:
        """Calls listener(message) for telemetry, truth and mission events; returns unsubscribe."""
        with self._listeners_lock:
            self._listeners.append(listener)

        def unsubscribe() -> None:
            with self._listeners_lock:
                if listener in self._listeners:
                    self._listeners.remove(listener)

        return unsubscribe

    def _publish(self, message: dict[str, Any]) -> None:
        with self._listeners_lock:
            listeners = list(self._listeners)
        for listener in listeners:
            listener(message)

    def _on_telemetry(self, t: Telemetry) -> None:
        data = asdict(t)
        data["mode_name"] = firmware.mode_name(t.mode)
        data["flag_names"] = firmware.flag_names(t.flags)
        self._publish({"type": "telemetry", **data})

    def _on_truth(self, truth: dict[str, Any]) -> None:
        self._publish(truth)  # already {"type": "truth", ...}

    # -- map ---------------------------------------------------------------------------------
    def _planner_for(self, m: MapSettings) -> Planner:
        grid = Grid(cols=m.cols, rows=m.rows, step_m=m.step_m)
        return Planner(grid, planning_radius_m(), obstacles=m.obstacles)

    def map_view(self) -> dict[str, Any]:
        with self._lock:
            g = self.planner.grid
            margin = float(robot()["sim"]["arena_margin_m"])  # walls outside the grid (the brief)
            width, height = g.size_m
            return {
                "cols": g.cols,
                "rows": g.rows,
                "step_m": g.step_m,
                "arena": {
                    "x_min": -margin,
                    "y_min": -margin,
                    "x_max": width + margin,
                    "y_max": height + margin,
                },
                "footprint_radius_m": footprint_radius_m(),
                "planning_radius_m": self.planner.footprint_radius_m,
                "obstacles": [list(g.node_xy(i, j)) for i, j in sorted(self.planner.obstacles)],
            }

    def set_obstacle(self, x: float, y: float, present: bool) -> dict[str, Any]:
        """Adds or removes the obstacle at the node nearest (x, y), and saves the map."""
        with self._lock:
            if present:
                self.planner.add_obstacle(x, y)
            else:
                self.planner.remove_obstacle(x, y)
            nodes = sorted(self.planner.obstacles)
            self.settings = self.settings.model_copy(
                update={"map": self.settings.map.model_copy(update={"obstacles": nodes})}
            )
            self.store.save(self.settings)
            return self.map_view()

    def update_settings(self, settings: GatewaySettings) -> None:
        """Replaces the gateway's settings (a new map takes effect now) and saves them."""
        with self._lock:
            planner = self._planner_for(settings.map)  # validates the map before anything changes
            self.store.save(settings)
            self.settings = settings
            self.planner = planner

    # -- motion ------------------------------------------------------------------------------
    def go_to(self, x: float, y: float) -> Plan:
        """Plans from the measured pose to (x, y) and sends the path; PlanError sends nothing."""
        pose = self.link.call("POSE")
        with self._lock:
            plan = self.planner.plan((pose[0], pose[1]), (x, y))
            capacity = self.waypoint_capacity
            if len(plan.waypoints) > capacity:
                raise PathTooLong(
                    f"the path needs {len(plan.waypoints)} waypoints and the firmware holds {capacity}: "
                    "remove obstacles or pick a nearer goal"
                )
            plan = self._rounded(plan, capacity)
            firmware.upload_path(self.link, plan.waypoints)
            self.mission = Mission(
                state="driving", goal=(x, y), started_s=time.monotonic(), plan=self.plan_view(plan)
            )
        self._publish({"type": "mission", **self.mission_view()})
        return plan

    @property
    def waypoint_capacity(self) -> int:
        """Points the firmware's path buffer holds (32 until its version has been read)."""
        return self.version.waypoint_capacity if self.version else 32

    def _rounded(self, plan: Plan, capacity: int) -> Plan:
        """The plan with its corners rounded where there is room (cart2d/smoothing.py)."""
        graph = self.planner.graph
        waypoints = round_corners(plan.start, plan.waypoints, graph.segment_free, capacity)
        length = polyline_length([plan.start, *waypoints])
        return dataclasses.replace(plan, waypoints=tuple(waypoints), length_m=length)

    @staticmethod
    def plan_view(plan: Plan) -> dict[str, Any]:
        return {
            "waypoints": [list(p) for p in plan.waypoints],
            "grid_path": [list(p) for p in plan.path],
            "length_m": plan.length_m,
            "grid_length_m": plan.grid_length_m,
        }

    def stop(self) -> None:
        """Emergency stop: motors off now; a mission in progress fails."""
        self.link.call("STOP")
        with self._lock:
            if self.mission.state == "driving":
                self._end_mission("failed", "stopped by the user")

    def drive(self, v_mps: float, omega_radps: float) -> None:
        """Manual driving; the firmware stops by itself without a refresh within its timeout."""
        self.link.call("VELOCITY", v_mps, omega_radps)
        with self._lock:
            if self.mission.state == "driving":
                self._end_mission("failed", "taken over by manual driving")

    def mission_view(self) -> dict[str, Any]:
        with self._lock:
            m = self.mission
            elapsed = (m.ended_s or time.monotonic()) - m.started_s if m.started_s else 0.0
            return {
                "state": m.state,
                "goal": list(m.goal) if m.goal else None,
                "reason": m.reason,
                "elapsed_s": round(elapsed, 3),
                "plan": m.plan,
            }

    def _end_mission(self, state: str, reason: str) -> None:
        self.mission.state = state
        self.mission.reason = reason
        self.mission.ended_s = time.monotonic()
        self._publish({"type": "mission", **self.mission_view()})

    def _watch_mission(self) -> None:
        """Follows a driving mission through the firmware's STATUS until it ends."""
        while not self._stop.wait(0.1):
            with self._lock:
                driving = self.mission.state == "driving"
            if not driving:
                continue
            try:
                status = firmware.read_status(self.link)
            except (LinkError, CommandRefused):
                continue  # the link is reconnecting: the firmware keeps driving on its own
            outcome = status.path_outcome()
            if outcome is None:
                continue
            with self._lock:
                if self.mission.state == "driving":
                    self._end_mission("failed" if outcome else "arrived", outcome)

    def status_view(self) -> dict[str, Any]:
        link_state = "connected" if self.link.connected.is_set() else "reconnecting"
        view: dict[str, Any] = {
            "link": {"state": link_state, "port": self.link.port, "simulated": self.sim is not None},
            "firmware": asdict(self.version) if self.version else None,
            "mission": self.mission_view(),
        }
        if link_state == "connected":
            try:
                view["status"] = asdict(firmware.read_status(self.link))
                view["pose"] = dict(zip(("x", "y", "theta"), self.link.call("POSE"), strict=True))
            except (LinkError, CommandRefused) as exc:
                view["link"]["error"] = str(exc)
        return view

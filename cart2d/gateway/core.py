"""The gateway: what the seed's ESP32 did, as one object the HTTP API (cart2d/server/) and the
command line use: a thin front over services that each own their state, wired in __init__ and
joined by the event bus (bus.py): the mission (missions.py: go-to, stop, drive, replan, resume,
and abort(), the one way every fault ends a mission and the reset routine), the reset routine
(routine.py), the STATUS monitor (monitor.py), restarts and the pose's trust (restarts.py).
close() is the one shutdown path: the services subscribed to its Closing event.

Over ~500 lines for a reason: it has no logic of its own but one short delegation for each thing
the server, the tools and the tests ask of the services (a stable API over services that move).

The live map (map_service.py) and the camera (camera_service.py) own their state and locks.
Besides its link the gateway may be given a source of ground truth, a simulated world, a reset
button and a bootloader port (collaborators.py): the simulation package wires them in, and its
supervisor restarts a simulator that exits on its own (cart2d/simulation/supervisor.py). While
the robot's program is replaced (a firmware update, replacing_program()), a stop waits for the
program that answers and stops it."""

from __future__ import annotations

import contextlib
import logging
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import asdict
from typing import Any

from cart2d.gateway import messages
from cart2d.gateway.blind import BlindWatch
from cart2d.gateway.bus import (
    Closing,
    EventBus,
    MapChanged,
    ViewerMessage,
)
from cart2d.gateway.camera import CameraFeed, Shown
from cart2d.gateway.camera_service import CameraService
from cart2d.gateway.collaborators import GroundTruth, ResetButton, SimulatedWorld
from cart2d.gateway.commands import Commands
from cart2d.gateway.exploration_service import Exploration, ExplorationDrive, seen_if_seeing
from cart2d.gateway.live_map import world_for
from cart2d.gateway.localisation import Frames, Localisation
from cart2d.gateway.look import look_before_driving
from cart2d.gateway.map_saving import save_seen_map
from cart2d.gateway.map_service import LiveMap
from cart2d.gateway.missions import Missions, plan_view
from cart2d.gateway.monitor import Monitor
from cart2d.gateway.perceived import PerceivedLayer
from cart2d.gateway.restarts import Restarts
from cart2d.gateway.routine import ResetRoutine
from cart2d.gateway.seeing import Seeing
from cart2d.gateway.state import (
    Mission,
    PoseTrust,
    ResetReport,
    Routine,
)
from cart2d.gateway.status_cache import StatusCache
from cart2d.link import CommandRefused, Link, LinkError, firmware, path_stream
from cart2d.link.bootloader import BootloaderPort
from cart2d.link.flashing import HURRIED_CHECK_S, Flasher
from cart2d.link.protocol import Reply, Telemetry
from cart2d.maps import OccupancyMap
from cart2d.planning import Plan, Planner, Point
from cart2d.spec import load_spec
from cart2d.store import CameraSettings, GatewaySettings, Store

log = logging.getLogger(__name__)

UPDATE_WAIT_S = 150.0  # a stop during a firmware update waits this long at most for the firmware back
PROGRAM_WAIT_S = 20.0  # and while the program is replaced otherwise (a restart of the simulator)
# Why a pose the firmware kept through a firmware update is not trusted (README, "Restarts").
FLASHED_POSE = "the program that kept it was replaced, and the cart may have been moved while it was flashed"

Listener = Callable[[dict[str, Any]], None]


class Gateway:
    def __init__(
        self,
        link: Link,
        store: Store,
        settings: GatewaySettings,
        *,
        truth: GroundTruth | None = None,
        world: SimulatedWorld | None = None,
        reset_button: ResetButton | None = None,
        bootloader: BootloaderPort | None = None,
    ) -> None:
        """Wires the services (each owns its state; they meet on the bus or through what they
        are given here), in the order they depend on each other."""
        self.link = link
        self.store = store
        self.truth = truth  # collaborators.py: all optional, given by the simulation package
        self.world = world
        self.bus = EventBus()  # what happened, typed; viewers' messages too (bus.py)
        self.live_map = LiveMap(store, settings, self.bus, self._position)  # map_service.py
        self.frames = Frames()  # map -> odom: the identity until markers correct it (localisation.py)
        self.camera_service = CameraService(  # camera_service.py: the feed, perception
            link, self.live_map, self.bus, store.directory, lambda: self.mission.replans, frames=self.frames
        )
        self.localisation: Localisation | None = None  # with a markers file (localisation.localise)
        self.version: firmware.Version | None = None
        self.status_cache = StatusCache()  # what /api/status answers (status_cache.py)
        self.restarts = Restarts(  # restarts.py: every STATUS read, the pose's trust
            link,
            self.status_cache,
            self.bus,
            self._pose,
            # what a restart ends (missions.py, wired below: no STATUS is read before that)
            lambda reason, routine_reason: self.missions.restart_ended(reason, routine_reason),
            press_reset=reset_button,
        )
        self.monitor = Monitor(  # monitor.py: STATUS a few times a second, to what it follows
            link, self.bus, self.read_status, self._pose, self.status_cache.telemetry_age_s
        )
        # one lock for the mission and the routine: a path replaces the routine, the routine the
        # mission, and a path is sent and its mission recorded together
        self._lock = threading.RLock()
        self.reset_routine = ResetRoutine(self._lock, self.bus, self._pose, self.restarts.trust)  # routine.py
        self.missions = Missions(  # missions.py: go-to, stop, drive, replan, resume, abort
            link,
            self.bus,
            self.restarts,
            self.reset_routine,
            self._lock,
            planner=lambda: self.planner,
            read_pose=self._pose,
            look=self._look,
            forwards_only=self.forwards_only_while_seeing,
            wait_for_the_program=self._wait_for_the_program,
            sim_time=lambda: truth.time_s() if truth is not None else None,
            wake=self.monitor.wake,
            frames=self.frames,
        )
        self.monitor.follow(self.missions)
        self.monitor.follow(self.reset_routine)
        self.commands = Commands(  # commands.py: the generic command form
            link, self.restarts, self.missions, self.reset_routine, self._pose, self.monitor.wake
        )
        self.exploration = Exploration(  # exploration_service.py: frontier after frontier
            self.bus,
            ExplorationDrive(
                go_to=self.go_to,
                mission=lambda: self.mission,
                motion_token=link.motion_token,
                planner=lambda: self.planner,
                pose=lambda: self.frames.to_map(self._pose()),
                seen=lambda: seen_if_seeing(self.seeing if self.sees() else None),
                save=lambda name: save_seen_map(self.seeing, store.directory, name),
                arena=lambda: self.map_view()["arena"],
                sim_time=lambda: truth.time_s() if truth is not None else None,
            ),
        )
        self.settings_cache = firmware.SettingsCache(link)
        self.flasher = Flasher(
            link,
            store.directory,
            bootloader,
            check=self._check_after_update,
            resetting=lambda: self.restarts.resetting(
                "a firmware update", certain=True, untrusts=FLASHED_POSE
            ),
        )
        self._program_back = threading.Event()  # cleared while replacing_program() is held
        self._program_back.set()
        self._status_parts: dict[str, Callable[[], Any]] = {}  # add_status_part()
        self.blind_watch = BlindWatch(self, self.cart_time)  # stops a mission the camera went blind in
        self.bus.subscribe(Closing, lambda _: self.blind_watch.close())
        link.subscribe(self._on_telemetry)
        self.bus.subscribe(MapChanged, lambda e: self._sync_world() if e.walls else None)
        if truth is not None:
            truth.subscribe(lambda message: self._publish(messages.TruthMessage.model_validate(message)))
        if world is not None:
            self._sync_world()

    # -- lifecycle -------------------------------------------------------------------------
    def start(self) -> None:
        """Starts the monitor, with the first STATUS as the baseline restarts are told from."""
        if self.link.connected.is_set():
            with contextlib.suppress(LinkError, CommandRefused):
                self.read_status()
                self._pose()
        self.monitor.start()
        self.blind_watch.start()

    def close(self) -> None:
        """The one shutdown path: every service closes what it runs (they subscribed to Closing)."""
        self.bus.publish(Closing())

    def cart_time(self) -> float | None:
        """The cart's clock, s: the ground truth's when there is one (simulated time; None before
        its first message), else the monotonic clock."""
        return self.truth.time_s() if self.truth is not None else time.monotonic()

    def _check_after_update(self, wait_s: float, hurried: Callable[[], bool]) -> None:
        self.wait_for_firmware(wait_s, 0.1, hurried)

    def wait_for_firmware(
        self, wait_s: float, poll_s: float, hurried: Callable[[], bool] = lambda: False
    ) -> firmware.Version:
        """check_firmware(), retried every poll_s while the MCU may still be starting
        (bootloader, simulator start-up, a Nano's reset on opening its port); raises its
        LinkError once wait_s have passed, or HURRIED_CHECK_S after hurried() turned true."""
        deadline = time.monotonic() + wait_s
        while True:
            try:
                return self.check_firmware()
            except LinkError:
                now = time.monotonic()
                if hurried():
                    deadline = min(deadline, now + HURRIED_CHECK_S)
                if now > deadline:
                    raise
                time.sleep(poll_s)

    def check_firmware(self) -> firmware.Version:
        """Reads the firmware's version and refuses an incompatible one; a compatible one is
        the firmware a failed update returns to."""
        version = firmware.read_version(self.link)
        firmware.check_compatible(version)
        self.version = version
        self.flasher.answered()
        return version

    # -- live data ---------------------------------------------------------------------------
    def subscribe(self, listener: Listener) -> Callable[[], None]:
        """Calls listener(message) for telemetry, truth and mission events; returns unsubscribe."""
        return self.bus.subscribe(ViewerMessage, lambda event: listener(event.wire))

    def _publish(self, message: messages.LiveMessage) -> None:
        """Hands `message` to every listener; they must not block (the server's hop into its
        event loop, a list's append)."""
        self.bus.publish(ViewerMessage(message))

    def _on_telemetry(self, t: Telemetry) -> None:
        self.monitor.on_tick(t.tick)  # a TICK that went backwards: the MCU may have restarted
        self.status_cache.pose_of_telemetry((t.x, t.y, t.theta))
        data = asdict(t)
        data["mode_name"] = firmware.mode_name(t.mode)
        data["flag_names"] = firmware.flag_names(t.flags)
        self._publish(messages.TelemetryMessage(**data))

    # -- the live map (map_service.py) -------------------------------------------------------
    @property
    def settings(self) -> GatewaySettings:
        return self.live_map.settings

    @property
    def planner(self) -> Planner:
        """The routes' planner now (a snapshot no later change of the map alters)."""
        return self.live_map.planner

    @property
    def map_planner(self) -> Planner:
        return self.live_map.map_planner

    @property
    def map_version(self) -> int:
        return self.live_map.version

    def map_view(self) -> dict[str, Any]:
        return self.live_map.map_view()

    def floor_plan(self) -> OccupancyMap | None:
        return self.live_map.floor_plan()

    def set_obstacle(self, x: float, y: float, present: bool) -> dict[str, Any]:
        return self.live_map.set_obstacle(x, y, present)

    def clear_obstacles(self) -> tuple[list[Point], int]:
        return self.live_map.clear_obstacles()

    def change_obstacles(self, add: Sequence[Point], remove: Sequence[Point], why: str) -> dict[str, Any]:
        return self.live_map.change_obstacles(add, remove, why)

    def load_floor_plan(
        self,
        occupancy: OccupancyMap,
        name: str = "",
        planning_step_m: float | None = None,
        unknown_is_free: bool = False,
    ) -> dict[str, Any]:
        return self.live_map.load_floor_plan(occupancy, name, planning_step_m, unknown_is_free)

    def update_settings(self, settings: GatewaySettings, why: str = "new settings were loaded") -> None:
        """Replaces the settings (a new map, a new camera take effect now) and saves them;
        ValueError changes nothing."""
        self.live_map.update_settings(settings, why, self.camera_service.follow_settings)

    def _position(self) -> Point | None:
        """Where the cart's pose says it stands, None if it cannot be read now."""
        if not self.link.connected.is_set():
            return None
        try:
            x, y, _ = self.link.call("POSE")
        except (LinkError, CommandRefused):
            return None
        return (x, y)

    def _sync_world(self) -> None:
        """The simulated world's walls follow the map (and do so again after a restart); it
        reads the map when it sends them: the latest, whoever sends last (collaborators.py)."""
        if self.world is not None:
            self.world.follow_walls(lambda: world_for(self.settings.map))

    # -- the camera and perception (camera_service.py) ---------------------------------------
    @property
    def camera(self) -> CameraFeed | None:
        return self.camera_service.camera

    @camera.setter
    def camera(self, feed: CameraFeed | None) -> None:
        """A feed read without perception (tests, benchmarks); use_camera() attaches it."""
        self.camera_service.camera = feed

    @property
    def seeing(self) -> Seeing | None:
        return self.camera_service.seeing

    @property
    def perceived(self) -> PerceivedLayer:
        return self.live_map.perceived

    def use_camera(self, feed: CameraFeed | None) -> None:
        self.camera_service.use_camera(feed)

    def sees(self) -> bool:
        return self.camera_service.sees()

    def forwards_only_while_seeing(self, certain: bool = True) -> None:
        self.camera_service.forwards_only_while_seeing(certain)

    def add_camera_sink(self, sink: Callable[[Shown], None]) -> Callable[[], None]:
        return self.camera_service.add_camera_sink(sink)

    def set_camera(self, camera: CameraSettings) -> None:
        self.camera_service.set_camera(camera)

    def set_perceived(
        self, cells: Sequence[Sequence[float]], why: str, resolution_m: float | None = None
    ) -> dict[str, Any]:
        return self.camera_service.set_perceived(cells, why, resolution_m)

    def clear_perceived(self, why: str = "the perceived cells were cleared") -> dict[str, Any]:
        return self.camera_service.clear_perceived(why)

    def set_perception_enabled(self, enabled: bool) -> dict[str, Any]:
        return self.camera_service.set_perception_enabled(enabled)

    def perception_view(self) -> dict[str, Any]:
        return self.camera_service.perception_view()

    # -- the mission (missions.py) -------------------------------------------------------------
    def go_to(self, x: float, y: float, token: int | None = None) -> Plan:
        """Missions.go_to: plans from the measured pose to (x, y) and sends the path."""
        return self.missions.go_to(x, y, token)

    def _look(self, goal: Point, token: int | None, driving: bool) -> int:
        """What the camera sees is on the map before a route to `goal` is planned: from rest the
        cart turns to look beside its first stretch (look.py); the turns it took."""
        seeing = self.seeing
        if seeing is None or not self.sees():
            return 0
        if driving:
            seeing.look()
            return 0
        return look_before_driving(self.link, lambda: self.planner, seeing, goal, token)

    def stop(self, reason: str = "stopped by the user") -> Reply:
        """Missions.stop: the emergency stop, answered without waiting for the lock."""
        return self.missions.stop(reason)

    def _wait_for_the_program(self) -> None:
        if self.flasher.running():
            self.flasher.hurry()
            self.flasher.wait(UPDATE_WAIT_S)
        self._program_back.wait(PROGRAM_WAIT_S)

    @contextlib.contextmanager
    def replacing_program(self) -> Iterator[None]:
        """Held while the robot's program is replaced from outside the gateway (a restart of the
        simulator; a firmware update is the flasher's, above): a stop meanwhile waits for the
        program that answers, PROGRAM_WAIT_S at most, and stops that."""
        self._program_back.clear()
        try:
            yield
        finally:
            self._program_back.set()

    def drive(self, v_mps: float, omega_radps: float, token: int | None = None) -> None:
        self.missions.drive(v_mps, omega_radps, token)

    def abort(
        self,
        reason: str,
        routine_reason: str = "",
        mission: Mission | None = None,
        routine: Routine | None = None,
    ) -> tuple[float, float] | None:
        """Missions.abort: the one way every fault ends the mission and the reset routine."""
        return self.missions.abort(reason, routine_reason, mission, routine)

    @property
    def mission(self) -> Mission:
        return self.missions.mission

    @property
    def routine(self) -> Routine:
        """The reset routine as started through the gateway (routine.py)."""
        return self.reset_routine.routine

    @property
    def path_stream(self) -> path_stream.PathStream | None:
        """The stream of the last path go_to sent (it may still be sending)."""
        return self.missions.path_stream

    @property
    def looks_turned(self) -> int:
        return self.missions.looks_turned

    @property
    def stop_reason(self) -> str:
        return self.missions.stop_reason

    @property
    def waypoint_capacity(self) -> int:
        """Points the firmware's waypoint window holds (32 until its version has been read)."""
        return self.version.waypoint_capacity if self.version else 32

    def mission_view(self) -> dict[str, Any]:
        return self.missions.mission_view()

    @staticmethod
    def plan_view(plan: Plan) -> dict[str, Any]:
        return plan_view(plan)

    def routine_view(self) -> dict[str, Any]:
        return self.reset_routine.view()

    # -- firmware settings -----------------------------------------------------------------------
    def firmware_settings(self) -> list[dict[str, object]]:
        """Every firmware setting with its value, read once and again only when it may have
        changed (firmware.SettingsCache)."""
        return self.settings_cache.read()

    def save_settings(self) -> None:
        """SAVE: the firmware writes its settings to EEPROM in the background (~280 ms)."""
        self.link.call("SAVE")
        self.commands.status_after_save()

    def load_settings(self) -> None:
        """LOAD: the firmware reads its settings back from EEPROM."""
        self.link.call("LOAD")

    def write_setting(self, ident: int, value: float) -> float:
        return firmware.write_setting(self.link, ident, value)

    # -- the pose after a restart (restarts.py) --------------------------------------------------
    def set_pose(self, x: float, y: float, theta: float) -> dict[str, float]:
        """SET_POSE from the user, within the arena's walls: the pose is trusted again."""
        return self.restarts.set_pose(x, y, theta, self.map_view()["arena"])

    def accept_pose(self) -> tuple[dict[str, float], str]:
        """Trusts the pose the firmware has; returns it and what it is, in words."""
        return self.restarts.accept_pose()

    def start_reset_routine(self, token: int | None = None) -> None:
        """RESET_ROUTINE: the cart squares up against the wall in front; the pose is trusted
        again once the routine ends squared up (not with ROUTINE_FAILED, not interrupted)."""
        reply = self.command(load_spec().code("RESET_ROUTINE"), (), token)
        if not reply.ok:
            raise CommandRefused(reply)

    def command(self, code: int, args: Sequence[float], token: int | None = None) -> Reply:
        """Any protocol request, with what the gateway must know of it (commands.py)."""
        return self.commands.command(code, args, token)

    def _pose(self) -> tuple[float, float, float]:
        x, y, theta = self.link.call("POSE")
        self.status_cache.pose_read((x, y, theta))
        return x, y, theta

    # -- restarts ----------------------------------------------------------------------------
    def read_status(self, restarted_for_sure: bool = False) -> firmware.Status:
        """STATUS, shown to the restart watch (restarts.py) in the order read."""
        return self.restarts.read_status(restarted_for_sure)

    @property
    def pose_trust(self) -> PoseTrust:
        return self.restarts.pose_trust

    @property
    def resets_noticed(self) -> int:
        return self.restarts.resets_noticed

    @property
    def last_reset(self) -> ResetReport | None:
        return self.restarts.last_reset

    def soft_reset(self) -> ResetReport | None:
        """Restarts the MCU (REBOOT; the reset button in the simulator) and waits until the
        restart is noticed; returns its report (None if it was not noticed within 5 s)."""
        return self.restarts.soft_reset()

    def status_view_unless_busy(self) -> dict[str, Any] | None:
        """status_view() if the gateway's lock is free now, without waiting for it; else None."""
        if not self._lock.acquire(blocking=False):
            return None
        try:
            return self.status_view()
        finally:
            self._lock.release()

    def status_view(self) -> dict[str, Any]:
        """The link, firmware, mission, restarts and pose trust; STATUS and the pose as the gateway
        last read them (the monitor does a few times a second): no request on the link."""
        link_state = "connected" if self.link.connected.is_set() else "reconnecting"
        view: dict[str, Any] = {
            "link": {"state": link_state, "port": self.link.port, "simulated": self.simulated},
            "firmware": asdict(self.version) if self.version else None,
            "mission": self.mission_view(),
        }
        view.update((name, part()) for name, part in self._status_parts.items())
        if link_state == "connected":
            seen = self.status_cache.view()
            if error := seen.pop("error", None):
                view["link"]["error"] = error
            view.update(seen)
        else:
            view["link"]["error"] = self.link.down_reason()
        with self._lock:
            view["reset"] = {
                "last": asdict(self.last_reset) if self.last_reset else None,
                "noticed": self.resets_noticed,
            }
            view["pose_trust"] = asdict(self.pose_trust)
        view["routine"] = self.routine_view()
        return view

    def add_status_part(self, name: str, part: Callable[[], Any]) -> None:
        """status_view()[name] is part() from now on (the simulator's supervisor's state)."""
        self._status_parts[name] = part

    @property
    def simulated(self) -> bool:
        """Whether the cart is a simulated one (it has a simulated world): for what is shown."""
        return self.world is not None

    # -- for the API: what its routes ask without reaching past the front ---------------------
    def motion_token(self) -> int:
        """The stop generation of a motion request arriving now (Link.motion_token)."""
        return self.link.motion_token()

    def start_update(self, hex_file: bytes) -> dict[str, object]:
        """Flashes `hex_file` (Flasher.start: ValueError for a bad file, RuntimeError when nothing
        can flash); the update's view."""
        return self.flasher.start(hex_file).view()

    def update_view(self) -> dict[str, object]:
        return self.flasher.job.view()

    def floor_plan_png(self, version: int | None = None) -> bytes | None:
        """A live map has its current plan only, whatever `version` is asked (the panel's cache
        key: a replay's matters)."""
        return self.live_map.floor_plan_png()

    def calibration_summary(self) -> dict[str, Any] | None:
        return self.camera_service.calibration_summary()

    def camera_view(self) -> dict[str, Any]:
        return self.camera_service.camera_view()

    def camera_feed(self) -> CameraFeed | None:
        return self.camera

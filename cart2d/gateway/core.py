"""The gateway: what the seed's ESP32 did, as one object the HTTP API (cart2d/server/) and the
command line use. It owns the link to the firmware, the map and its planner, the mission
(idle / driving / arrived / failed) and the fan-out of live data to viewers (the event bus,
bus.py). Restarts of the MCU and the pose's trust are restarts.py's: a restart ends the mission
through abort(), the one way every fault, stop or takeover ends a mission and the reset routine.

A stop is the last word the motors hear: it cancels every motion request asked for before it
(the link's stop generations, cart2d/link/transport.py), also between the POSE a goal is
planned from and the path's last frame; while a firmware update or a restart of the simulator
replaces the robot's program, it waits for the program that answers and stops that. When the
simulator it started exits on its own (a crash, a kill -9), the gateway ends the mission with
the reason, says so (/ws message `simulator`, /api/status `simulator`) and starts it again.

Still one class over ~500 lines (issue 23 splits it on): one lock guards the settings, the
planner, the mission and the reset routine, and the methods here keep an invariant across them
(a path is sent and its mission recorded together). What it keeps is in state.py; the map's
edits (map_edits.py), perception (perceived.py) and the simulator's boxes (sim_world.py) are
mixins under the same lock."""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import math
import subprocess
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict
from typing import Any

from cart2d.gateway.blind import BlindWatch
from cart2d.gateway.bus import (
    EventBus,
    MapChanged,
    MissionEnded,
    MissionStarted,
    PerceivedChanged,
    SimulatorExited,
    SimulatorRestarted,
    ViewerMessage,
)
from cart2d.gateway.camera import CameraFeed
from cart2d.gateway.live_map import Replan, RouteAhead, planner_for
from cart2d.gateway.look import look_before_driving
from cart2d.gateway.map_edits import MapMixin
from cart2d.gateway.perceived import PerceptionMixin
from cart2d.gateway.restarts import Restarts
from cart2d.gateway.sim_world import NotSimulated, SimWorldMixin
from cart2d.gateway.state import (
    BUSY_POLL_S,
    RESET_POSE_SETTINGS,
    ROUTINE_HEADING_TOLERANCE_RAD,
    ROUTINE_POSE_TOLERANCE_M,
    STATUS_POLL_S,
    Mission,
    MissionEnd,
    PathTooLong,
    PoseOutsideArena,
    PoseTrust,
    PoseUntrusted,
    ResetReport,
    Routine,
    RoutineEnd,
    SimulatorRun,
    SimulatorState,
    exit_words,
    pose_text,
)
from cart2d.gateway.status_cache import StatusCache
from cart2d.link import CommandRefused, Link, LinkError, MotionCancelled, firmware, path_stream
from cart2d.link.flashing import HURRIED_CHECK_S, Flasher
from cart2d.link.protocol import Reply, Telemetry
from cart2d.maps.ros import image_bytes
from cart2d.params import robot, setting_id
from cart2d.planning import Plan, PlanError, Point, StartBlocked, polyline_length
from cart2d.planning.smoothing import round_corners
from cart2d.shown import for_people
from cart2d.simulator import Simulator, SimulatorError
from cart2d.spec import load_spec
from cart2d.store import GatewaySettings, Store

log = logging.getLogger(__name__)

UPDATE_WAIT_S = 150.0  # a stop during a firmware update waits this long at most for the firmware back
SIM_RESTART_WAIT_S = 20.0  # and during a restart of the simulator
SIM_START_TRIES = 3
# Why a pose the firmware kept through a firmware update is not trusted (README, "Restarts").
NO_CAMERA = "this gateway has no camera: start it with --camera http://HOST (or --camera-stream URL)"
FLASHED_POSE = "the program that kept it was replaced, and the cart may have been moved while it was flashed"

Listener = Callable[[dict[str, Any]], None]


class Gateway(MapMixin, PerceptionMixin, SimWorldMixin):  # map_edits.py, perceived.py, sim_world.py
    def __init__(
        self, link: Link, store: Store, settings: GatewaySettings, sim: Simulator | None = None
    ) -> None:
        self.link = link
        self.store = store
        self.settings = settings
        self.sim = sim
        self.map_planner = planner_for(settings.map)  # the map's: the user's obstacles are its nodes
        self.planner = self.map_planner  # the routes': with what the camera sees (perceived.py)
        self.map_version = 1  # counts the map's changes (the panel fetches the map again)
        self._last_truth_t: float | None = None  # the simulator's time in its latest truth message
        self.mission = Mission()
        self._stream: path_stream.PathStream | None = None  # the mission's path, streamed to the firmware
        self._frames_at_route = 0  # telemetry frames received when the last route was sent
        self.looks_turned = 0  # turns on the spot to look before a route left (look.py)
        self._lock = threading.RLock()  # guards settings, planner and mission
        self.bus = EventBus()  # what happened, typed; viewers' messages too (bus.py)
        self.bus.subscribe(MapChanged, lambda e: self._routes_changed(e.why))
        self.bus.subscribe(PerceivedChanged, lambda e: self._routes_changed(e.why))
        self._stop = threading.Event()
        self._wake = threading.Event()  # look at STATUS now (telemetry's TICK went backwards)
        # (mission, routine) of each stop answered, to record as ended under the lock (stop())
        self._stops_to_record: list[tuple[Mission, Routine, str]] = []
        self._monitor = threading.Thread(target=self._watch, name="gateway monitor", daemon=True)
        self.version: firmware.Version | None = None
        self.status_cache = StatusCache()  # what /api/status answers (status_cache.py)
        self._last_tick: int | None = None
        self.routine = Routine()
        self.restarts = Restarts(  # restarts.py: every STATUS read, the pose's trust
            link,
            self.status_cache,
            self.bus,
            self._pose,
            self._restart_ended_motion,
            press_reset=self._press_sim_reset if sim is not None else None,
        )
        self.settings_cache = firmware.SettingsCache(link)
        self.flasher = Flasher(
            link,
            store.directory,
            sim,
            check=self._check_after_update,
            resetting=lambda: self.restarts.resetting(
                "a firmware update", certain=True, untrusts=FLASHED_POSE
            ),
        )
        self.simulator = SimulatorState()
        self._simulator_back = threading.Event()  # set while the simulator runs (or cannot be started)
        self._simulator_back.set()
        self.blind_watch = BlindWatch(self, self.cart_time)  # stops a mission the camera went blind in
        self.stop_reason = "stopped by the user"  # the last stop's: a mission it cut short ends with it
        link.subscribe(self._on_telemetry)
        if sim is not None:
            sim.subscribe_truth(self._on_truth)
            sim.on_exit = self._simulator_exited
            self._sync_world()

    # -- lifecycle -------------------------------------------------------------------------
    def start(self) -> None:
        """Starts the monitor, with the first STATUS as the baseline restarts are told from."""
        if self.link.connected.is_set():
            with contextlib.suppress(LinkError, CommandRefused):
                self.read_status()
                self._pose()
        self._monitor.start()
        self.blind_watch.start()

    def close(self) -> None:
        self._cancel_stream()
        self._stop.set()
        if self._monitor.ident is not None:  # started: a Ctrl-C may come before start()
            self._monitor.join(timeout=2.0)
        self.blind_watch.close()

    def cart_time(self) -> float | None:
        """The cart's clock, s: simulated time when the gateway runs the simulator (its latest
        truth message; None before the first), else the monotonic clock."""
        return self._last_truth_t if self.sim is not None else time.monotonic()

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
        return self.bus.subscribe(ViewerMessage, lambda event: listener(event.message))

    def _publish(self, message: dict[str, Any]) -> None:
        """Hands `message` to every listener; they must not block (the server's hop into its
        event loop, a list's append)."""
        self.bus.publish(ViewerMessage(message))

    def _on_telemetry(self, t: Telemetry) -> None:
        last, self._last_tick = self._last_tick, t.tick
        if last is not None and (t.tick - last) % 65536 > 32768:
            self._wake.set()  # TICK went backwards (not a wrap): the MCU may have restarted
        self.status_cache.pose_of_telemetry((t.x, t.y, t.theta))
        data = asdict(t)
        data["mode_name"] = firmware.mode_name(t.mode)
        data["flag_names"] = firmware.flag_names(t.flags)
        self._publish({"type": "telemetry", **data})

    def _on_truth(self, truth: dict[str, Any]) -> None:
        self._last_truth_t = truth.get("t")
        self._publish(truth)  # already {"type": "truth", ...}

    # -- motion ------------------------------------------------------------------------------
    def go_to(self, x: float, y: float, token: int | None = None) -> Plan:
        """Plans from the measured pose to (x, y) and sends the path; PlanError, or
        PoseUntrusted after an MCU restart, sends nothing. `token`: the stop generation the
        request belongs to (Link.motion_token() when it arrived; default now): a stop after it,
        before the last frame of the path, leaves the path unsent (MotionCancelled); one that
        comes as the last frame goes stops it, and the mission is recorded as stopped."""
        token = self.link.motion_token() if token is None else token
        self.read_status()  # a restart since the last look is noticed before planning
        seeing = self.seeing
        if seeing is not None and self.sees():
            if self.mission.state == "driving":
                seeing.look()  # what stands in view now is on the map before the route is planned
            else:
                self.looks_turned += look_before_driving(self, seeing, (x, y), token)
        with self._lock:
            if not self.pose_trust.trusted:
                raise PoseUntrusted(self.pose_trust.refusal())
        pose = self.link.call("POSE")
        with self._lock:
            if not self.pose_trust.trusted:  # a restart noticed meanwhile
                raise PoseUntrusted(self.pose_trust.refusal())
            plan = self.planner.plan((pose[0], pose[1]), (x, y))
            if len(plan.waypoints) > path_stream.MAX_PATH_POINTS:
                raise PathTooLong(
                    f"the path needs {len(plan.waypoints)} waypoints and a firmware path holds at most "
                    f"{path_stream.MAX_PATH_POINTS}: remove obstacles or pick a nearer goal"
                )
            plan = self._rounded(plan, path_stream.MAX_PATH_POINTS)
            self._send_route(plan, token)
            if self.routine.state == "running":
                self._end_routine("failed", "a path replaced it before it squared up")
            self.mission = Mission(
                state="driving",
                goal=(x, y),
                started_s=time.monotonic(),
                plan=plan,
                token=token,
                route_start=plan.start,
                route=plan.waypoints,
            )
            self.bus.publish(MissionStarted((x, y)))
            if self.link.stopped_since(token):  # the stop went right after the last frame
                self.abort(self.stop_reason)
                raise MotionCancelled("the path was sent as a stop came: the stop ended it")
        self._publish({"type": "mission", **self.mission_view()})
        return plan

    def _send_route(self, plan: Plan, token: int | None) -> None:
        """Sends the plan's waypoints as the firmware's path (lock held). The old path's stream
        stops before the new path replaces it: an append of the old path must never reach the
        new one (docs/protocol.md, Paths and the waypoint window)."""
        self._cancel_stream()
        self.forwards_only_while_seeing()
        self._stream = path_stream.upload_path(self.link, plan.waypoints, token)
        self._frames_at_route = self.link.telemetry_count

    # -- replanning ---------------------------------------------------------------------------
    def _routes_changed(self, why: str) -> None:
        """The map or the perceived layer changed (lock held): a driven route it blocks is replanned."""
        if self.mission.state == "driving" and self.mission.route:
            self._check_route(f"the map changed: {why}")

    def _check_route(self, why: str) -> None:
        """Checks the rest of the driven route against the map now (the planner's own check:
        footprint plus clearance); replans from the measured pose if it is blocked (lock held)."""
        mission = self.mission
        try:
            status = self.read_status()
            pose = self._pose()
        except (LinkError, CommandRefused) as exc:
            log.warning("the path could not be checked against the changed map: %s", exc)
            return
        if self.mission is not mission or mission.state != "driving" or status.mode != "PATH":
            return  # ended meanwhile, or about to be ended by the monitor
        here = (pose[0], pose[1])
        ahead = RouteAhead.of(mission.route_start, mission.route, status.waypoint_index, here)
        if ahead.blocked(self.planner.graph):
            self._replan(why, here, ahead.entry)

    def _check_off_path(self) -> None:
        """Replans when telemetry shows the cart off its route by more than robot.toml's
        [planning] off_path_replan_m (at most once per off_path_replan_interval_s)."""
        limits = robot()["planning"]
        frame = self.link.telemetry
        with self._lock:
            mission = self.mission
            if mission.state != "driving" or not mission.route or frame is None:
                return
            # a frame sent before the route was: its waypoint index is another path's
            if (
                self.link.telemetry_count <= self._frames_at_route + 1
                or firmware.mode_name(frame.mode) != "PATH"
            ):
                return
            if time.monotonic() - max(mission.started_s, mission.last_replan_s) < float(
                limits["off_path_replan_interval_s"]
            ):
                return
            here = (frame.x, frame.y)
            ahead = RouteAhead.of(mission.route_start, mission.route, int(frame.waypoint_index), here)
            off_m = ahead.distance(here)
            if off_m > float(limits["off_path_replan_m"]):
                self._replan(f"the cart was {off_m:.2f} m off its path", here, ahead.entry)

    def _replan(self, reason: str, pose: Point, entry: Point) -> None:
        """Plans again from the measured pose to the mission's goal and replaces the firmware's
        path with it (WAIT_XY_ARRAY: atomic, the speed carried on through the acceleration
        limits); with no path left, stops the cart and fails the mission with the reason (lock
        held). A cart within its clearance of an obstacle (it follows its path within that) is
        planned from the nearest point of its route."""
        mission = self.mission
        goal = mission.goal
        assert goal is not None
        started = time.perf_counter()
        try:
            try:
                plan = self.planner.plan(pose, goal)
            except StartBlocked:
                plan = self.planner.plan(entry, goal)
            plan = self._rounded(plan, path_stream.MAX_PATH_POINTS)
        except PlanError as exc:
            self._record_replan(mission, reason, time.perf_counter() - started, None, str(exc))
            with contextlib.suppress(LinkError, CommandRefused):
                self.link.stop()
            self._cancel_stream()
            log.warning("%s, and no path remains: %s", reason, exc)
            self.abort(f"{reason}, and no path remains: {exc}")
            return
        plan_time_s = time.perf_counter() - started
        try:
            self._send_route(plan, mission.token)
        except MotionCancelled:
            self.abort(self.stop_reason)
            return
        except (LinkError, CommandRefused) as exc:
            with contextlib.suppress(LinkError, CommandRefused):
                self.link.stop()
            self.abort(f"{reason}; the new path could not be sent: {exc}")
            return
        mission.generation += 1
        mission.route_start, mission.route = plan.start, plan.waypoints
        mission.plan = plan
        self._record_replan(mission, reason, plan_time_s, plan, "replanned")
        log.info("%s: replanned in %.3f s, %.2f m to go", reason, plan_time_s, plan.length_m)
        self._publish({"type": "mission", **self.mission_view()})

    def _record_replan(
        self, mission: Mission, reason: str, plan_time_s: float, plan: Plan | None, outcome: str
    ) -> None:
        now = time.monotonic()
        replan = Replan(
            reason=reason,
            at_s=now - mission.started_s,
            sim_t=self._last_truth_t if self.sim is not None else None,
            plan_time_s=plan_time_s,
            length_m=plan.length_m if plan is not None else 0.0,
            waypoints=len(plan.waypoints) if plan is not None else 0,
            outcome=outcome,
        )
        mission.replans.append(replan)
        mission.last_replan_s = now
        self._publish({"type": "replan", **asdict(replan)})

    @property
    def waypoint_capacity(self) -> int:
        """Points the firmware's waypoint window holds (32 until its version has been read)."""
        return self.version.waypoint_capacity if self.version else 32

    @property
    def path_stream(self) -> path_stream.PathStream | None:
        """The stream of the last path go_to sent (it may still be sending)."""
        with self._lock:
            return self._stream

    def _cancel_stream(self) -> None:
        with self._lock:
            stream = self._stream
        if stream is not None:
            stream.cancel()

    def _rounded(self, plan: Plan, capacity: int) -> Plan:
        """The plan with its corners rounded where there is room (cart2d/smoothing.py)."""
        graph = self.planner.graph
        waypoints = round_corners(plan.start, plan.waypoints, graph.segment_free, capacity)
        length = polyline_length([plan.start, *waypoints])
        return dataclasses.replace(plan, waypoints=tuple(waypoints), length_m=length)

    @staticmethod
    def plan_view(plan: Plan) -> dict[str, Any]:
        view: dict[str, Any] = for_people(
            {
                "start": plan.start,
                "waypoints": plan.waypoints,
                "grid_path": plan.path,
                "length_m": plan.length_m,
                "grid_length_m": plan.grid_length_m,
            }
        )
        return view

    def stop(self, reason: str = "stopped by the user") -> Reply:
        """Emergency stop: motors off now; a mission in progress fails (with `reason`: the
        user's, or the gateway's own, a camera gone blind). Every motion request asked for
        before it is refused, however long it waited. While the robot's program is being
        replaced (a firmware update, a restart of the simulator) the stop waits for the program
        that answers (an update not yet answered is rolled back at once) and stops it.

        It returns once the firmware has the STOP, without waiting for the gateway's lock (a goal
        being planned or sent, an obstacle's check of the route, each reading the link while
        they hold it, held stops 0.1-0.5 s with 20 clients): the mission and the routine it ends
        are recorded at once if the lock is free, else by a thread as soon as it is."""
        self.stop_reason = reason
        try:
            with self.link.stopping():
                self._wait_for_the_program()
                mission, routine = self.mission, self.routine  # what the STOP ends (no lock needed)
                reply = self.link.stop()
        finally:
            stream = self._stream  # after the STOP: its appends are refused from then on anyway
            if stream is not None:
                stream.cancel()
        if not reply.ok:
            raise CommandRefused(reply)
        self._stops_to_record.append((mission, routine, reason))  # list.append: atomic, no lock
        if self._lock.acquire(blocking=False):
            try:
                self._record_stops()
            finally:
                self._lock.release()
        else:
            threading.Thread(target=self._record_stops_once_free, name="after a stop", daemon=True).start()
        return reply

    def _record_stops_once_free(self) -> None:
        with self._lock:
            self._record_stops()

    def _record_stops(self) -> None:
        """Ends the missions and routines the stops ended (lock held), unless they were replaced
        since: what started after a stop is not its to end (what was asked for before it is
        refused unsent). Whatever reads the mission to act on it (a START's resume) calls this
        first."""
        while self._stops_to_record:
            mission, routine, reason = self._stops_to_record.pop(0)
            if self.abort(reason, mission=mission, routine=routine) is not None:
                mission.resumable = True  # the firmware keeps the path: START resumes it

    def _wait_for_the_program(self) -> None:
        if self.flasher.running():
            self.flasher.hurry()
            self.flasher.wait(UPDATE_WAIT_S)
        self._simulator_back.wait(SIM_RESTART_WAIT_S)

    def drive(self, v_mps: float, omega_radps: float, token: int | None = None) -> None:
        """Manual driving; the firmware stops by itself without a refresh within its timeout.
        MotionCancelled if a stop came after `token` (the request's arrival)."""
        self._cancel_stream()
        self.link.call("VELOCITY", v_mps, omega_radps, token=token)
        with self._lock:
            self.mission.resumable = False
            self.abort("taken over by manual driving")

    def mission_view(self) -> dict[str, Any]:
        with self._lock:
            m = self.mission
            elapsed = (m.ended_s or time.monotonic()) - m.started_s if m.started_s else 0.0
            view: dict[str, Any] = for_people(
                {
                    "state": m.state,
                    "goal": m.goal,
                    "reason": m.reason,
                    "elapsed_s": round(elapsed, 3),
                    "plan": self.plan_view(m.plan) if m.plan is not None else None,
                    "replans": [asdict(r) for r in m.replans],
                }
            )
            return view

    def abort(
        self,
        reason: str,
        routine_reason: str = "",
        mission: Mission | None = None,
        routine: Routine | None = None,
    ) -> tuple[float, float] | None:
        """Ends, as failed, the mission driving now with `reason` and the reset routine running
        now with `routine_reason` (default: `reason` and "before it squared up"): the one way
        every fault, stop or takeover ends them. `mission`, `routine`: only if they are still
        these (what started since is not this fault's to end). Returns the goal of the mission
        it ended, None if it ended none. Sends nothing to the firmware: the caller has stopped
        the cart, or the firmware stopped it itself."""
        with self._lock:
            ended = None
            if (mission is None or self.mission is mission) and self.mission.state == "driving":
                ended = self.mission.goal or (0.0, 0.0)
                self._end_mission("failed", reason)
            if (routine is None or self.routine is routine) and self.routine.state == "running":
                self._end_routine("failed", routine_reason or f"{reason} before it squared up")
            return ended

    def _end_mission(self, state: MissionEnd, reason: str) -> None:
        self.mission.state = state
        self.mission.reason = reason
        self.mission.ended_s = time.monotonic()
        self._publish({"type": "mission", **self.mission_view()})
        self.bus.publish(MissionEnded(self.mission.goal, state, reason))

    # -- firmware settings -----------------------------------------------------------------------
    def firmware_settings(self) -> list[dict[str, object]]:
        """Every firmware setting with its value, read once and again only when it may have
        changed (firmware.SettingsCache)."""
        return self.settings_cache.read()

    def save_settings(self) -> None:
        """SAVE: the firmware writes its settings to EEPROM in the background (~280 ms)."""
        self.link.call("SAVE")
        self._status_after_save()

    def load_settings(self) -> None:
        """LOAD: the firmware reads its settings back from EEPROM."""
        self.link.call("LOAD")

    def _status_after_save(self) -> None:
        # /api/status answers from the last STATUS read (status_cache.py): read one now, so that
        # from this answer on it shows the EEPROM busy, not the STATUS from before the SAVE.
        with contextlib.suppress(LinkError, CommandRefused):
            self.read_status()

    def write_setting(self, ident: int, value: float) -> float:
        return firmware.write_setting(self.link, ident, value)

    # -- the pose after a restart --------------------------------------------------------------
    def set_pose(self, x: float, y: float, theta: float) -> dict[str, float]:
        """SET_POSE from the user, who knows where the cart is: the pose is trusted again."""
        arena = self.map_view()["arena"]
        if not (arena["x_min"] <= x <= arena["x_max"] and arena["y_min"] <= y <= arena["y_max"]):
            raise PoseOutsideArena(
                f"the pose ({x:.3f}, {y:.3f}) lies beyond the arena's walls (x from {arena['x_min']:g} "
                f"to {arena['x_max']:g} m, y from {arena['y_min']:g} to {arena['y_max']:g} m)"
            )
        self.link.call("SET_POSE", x, y, theta)
        pose = self._pose()
        self._trust(f"the pose was set to {pose_text(*pose)}")
        return dict(zip(("x", "y", "theta"), pose, strict=True))

    def accept_pose(self) -> tuple[dict[str, float], str]:
        """Trusts the pose the firmware has; returns it and what it is, in words."""
        status = self.read_status()
        pose = self._pose()
        where = pose_text(*pose)
        with self._lock:
            trusted = self.pose_trust.trusted
        if trusted:
            words = f"the pose was trusted already: {where}"
        elif status.has("POSE_RESTORED"):
            words = (
                f"accepted the pose the firmware restored from RAM, {where}: the pose at the reset, "
                "blind to any motion during it"
            )
        else:
            words = (
                f"accepted the pose the firmware has, {where}: it restarted at (0, 0, 0) and has "
                "counted the motion since"
            )
        self._trust(words)
        return dict(zip(("x", "y", "theta"), pose, strict=True)), words

    def start_reset_routine(self, token: int | None = None) -> None:
        """RESET_ROUTINE: the cart squares up against the wall in front; the pose is trusted
        again once the routine ends squared up (not with ROUTINE_FAILED, not interrupted)."""
        reply = self.command(load_spec().code("RESET_ROUTINE"), (), token)
        if not reply.ok:
            raise CommandRefused(reply)

    def command(self, code: int, args: Sequence[float], token: int | None = None) -> Reply:
        """Any protocol request (the generic command form), with what the gateway must know of
        it: STOP is the emergency stop, a REBOOT restarts the MCU on purpose, SET_POSE and RESET
        give the pose, and the reset routine is followed to its end. A motion command belongs
        to `token` (see go_to)."""
        name = load_spec().name_of(code).removeprefix("COMMAND_")
        if name == "STOP" and not args:
            return self.stop()
        if name == "REBOOT":
            self.read_status()  # the baseline the restart is noticed against
            noticed = self.resets_noticed
            with self.restarts.resetting("a REBOOT sent through the gateway", certain=False):
                reply = self.link.request(code, args)
                if reply.ok:
                    self.restarts.wait_for_restart(noticed, 5.0)
            return reply
        if name == "RESET_ROUTINE":
            x, y, theta = (firmware.read_setting(self.link, setting_id(n)) for n in RESET_POSE_SETTINGS)
        if name in ("WAIT_XY_ARRAY", "XY_APPEND", "GOTO"):
            self._cancel_stream()  # a path of the user's: the mission's stream must not add to it
        if name in ("WAIT_XY_ARRAY", "XY_APPEND", "GOTO", "VELOCITY", "RESET_ROUTINE"):
            with self._lock:
                self.mission.resumable = False  # the firmware's path is no longer the mission's
        reply = self.link.request(code, args, token=token)
        if not reply.ok:
            return reply
        if name == "START":
            self._resume_mission(token)
        elif name == "SAVE":
            self._status_after_save()
        elif name in ("SET_POSE", "RESET"):
            self._trust(f"the pose was set to {pose_text(*self._pose())} with {name}")
        elif name == "RESET_ROUTINE":
            with self._lock:
                if self.mission.state == "driving":
                    self._end_mission("failed", "replaced by the reset routine")
                self.routine = Routine("running", "driving slowly to the wall in front", (x, y, theta))
                self._publish({"type": "routine", **self.routine_view()})
            self._wake.set()
        return reply

    def _resume_mission(self, token: int | None) -> None:
        """After a START: the mission a stop ended drives again if its path is still the
        firmware's (its points, nothing sent since but START); the rest of a long path streams
        again from where the firmware stands."""
        with self._lock:
            self._record_stops()  # a stop answered while the lock was busy: recorded before this
            mission, stream = self.mission, self._stream
            if not (mission.state == "failed" and mission.resumable and mission.plan):
                return
        status = self.read_status()
        if status.waypoint_count != len(mission.plan.waypoints):
            return
        outcome = status.path_outcome()
        with self._lock:
            if self.mission is not mission or not mission.resumable:
                return  # replaced meanwhile
            mission.resumable = False
            if outcome is None and stream is not None and stream.sent < stream.count:
                self._stream = stream.resumed(status.waypoint_index, status.waypoints_received, token)
            if outcome is None or outcome == "":
                mission.state, mission.reason = ("driving", "") if outcome is None else ("arrived", "")
                mission.ended_s = 0.0 if outcome is None else time.monotonic()
            else:
                return
        log.info("the mission to %s resumed after a stop", mission.goal)
        self._publish({"type": "mission", **self.mission_view()})
        self._wake.set()

    def routine_view(self) -> dict[str, Any]:
        with self._lock:
            return {"state": self.routine.state, "words": self.routine.words}

    def _end_routine(self, state: RoutineEnd, words: str) -> None:
        self.routine = Routine(state, words)
        self._publish({"type": "routine", **self.routine_view()})

    def _pose(self) -> tuple[float, float, float]:
        x, y, theta = self.link.call("POSE")
        self.status_cache.pose_read((x, y, theta))
        return x, y, theta

    def _trust(self, how: str) -> None:
        self.restarts.trust(how)

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

    def _restart_ended_motion(self, reason: str, routine_reason: str) -> tuple[float, float] | None:
        """What a restart of the MCU ends (restarts.py): the path it lost, the mission and the
        routine; the saved reverse_allowed is back (forward_only.py)."""
        self.forwards_only_while_seeing(certain=False)
        with self._lock:
            self.mission.resumable = False  # a restart loses the path
            if self._stream is not None:
                self._stream.cancel()
            return self.abort(reason, routine_reason)

    def _press_sim_reset(self) -> None:
        assert self.sim is not None
        try:
            self.sim.control("reset")
        except SimulatorError as exc:
            raise LinkError(f"the simulator did not reset the MCU: {exc}") from exc

    def soft_reset(self) -> ResetReport | None:
        """Restarts the MCU (REBOOT; the reset button in the simulator) and waits until the
        restart is noticed; returns its report (None if it was not noticed within 5 s)."""
        return self.restarts.soft_reset()

    # -- the monitor -------------------------------------------------------------------------
    def _watch(self) -> None:
        """Reads STATUS a few times a second, also when nothing runs (that notices restarts),
        and follows a mission and the reset routine to their ends."""
        while not self._stop.is_set():
            with self._lock:
                busy = self.mission.state == "driving" or self.routine.state == "running"
            self._wake.wait(BUSY_POLL_S if busy else STATUS_POLL_S)
            self._wake.clear()
            if self._stop.is_set() or not self.link.connected.is_set():
                continue
            with self._lock:  # a STATUS asked for before a new path or routine says nothing about it
                mission, routine, generation = self.mission, self.routine, self.mission.generation
            try:
                status = self.read_status()
                self._follow(status, mission, routine, generation)
                self._check_off_path()
                if self.status_cache.telemetry_age_s() > 2 * BUSY_POLL_S:  # telemetry is off
                    self._pose()  # for /api/status, which reads none itself (status_cache.py)
            except (LinkError, CommandRefused):
                continue  # the link is reconnecting: the firmware keeps driving on its own

    def _follow(
        self, status: firmware.Status, mission: Mission, routine: Routine, generation: int = 0
    ) -> None:
        """Ends `mission` or `routine` (those running when `status` was asked for) when `status`
        shows their end. A path or routine started while the STATUS was on its way is a new
        object, and a replan a new generation of the mission: the stale IDLE of before it must
        not end it."""
        outcome = status.path_outcome()
        with self._lock:
            current = self.mission is mission and mission.generation == generation
            stream = self._stream if current and mission.state == "driving" else None
        if outcome is None and stream is not None and stream.failure:
            outcome = f"the path could not be streamed to the firmware: {stream.failure}"
            with contextlib.suppress(LinkError, CommandRefused):
                self.link.call("STOP")  # the cart waits at the end of the points it has: stop it
        with self._lock:
            current = self.mission is mission and mission.generation == generation
            if outcome is not None and current and mission.state == "driving":
                self._end_mission("failed" if outcome else "arrived", outcome)
        if routine.state != "running" or status.mode == "RESET_ROUTINE":
            return
        pose = self._pose()
        with self._lock:
            if self.routine is not routine:
                return  # ended meanwhile (a stop, a restart)
            if status.has("ROUTINE_FAILED"):
                self._end_routine("failed", "it found no wall in time: the pose is unchanged")
                return
            expected = routine.expected_pose or pose
            off_m = math.hypot(pose[0] - expected[0], pose[1] - expected[1])
            off_rad = abs(math.remainder(pose[2] - expected[2], 2 * math.pi))
            if off_m > ROUTINE_POSE_TOLERANCE_M or off_rad > ROUTINE_HEADING_TOLERANCE_RAD:
                self._end_routine("failed", "it was interrupted before it squared up")
                return
            self._end_routine("done", f"squared up against the wall: pose {pose_text(*pose)}")
        self._trust(f"the reset routine squared the cart up against the wall: pose {pose_text(*pose)}")

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
            "link": {"state": link_state, "port": self.link.port, "simulated": self.sim is not None},
            "firmware": asdict(self.version) if self.version else None,
            "mission": self.mission_view(),
        }
        if self.sim is not None:
            view["simulator"] = asdict(self.simulator)
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

    # -- the simulator, when it exits on its own ----------------------------------------------
    def _simulator_exited(self, process: subprocess.Popen[str], returncode: int) -> None:
        """The simulator's process ended without being asked to (its exit watcher's thread):
        the mission ends with the reason, the user is told, and the simulator starts again."""
        how = exit_words(returncode)
        when = time.strftime("%H:%M:%S")
        self._simulator_back.clear()
        with self._lock:
            sentences = [f"The simulator {how} at {when}."]
            goal = self.abort(
                f"the simulator {how}: the simulated cart stopped with it",
                f"the simulator {how} before it squared up",
            )
            if goal is not None:
                sentences.append(f"The mission to ({goal[0]:.2f}, {goal[1]:.2f}) failed.")
            sentences.append("The gateway is starting it again.")
            self.simulator = SimulatorState("restarting", self.simulator.restarts, " ".join(sentences))
        log.warning("%s", self.simulator.message)
        self._publish({"type": "simulator", **asdict(self.simulator)})
        self.bus.publish(SimulatorExited(how))
        try:
            self._restart_simulator(process, how)
        finally:
            self._simulator_back.set()

    def _restart_simulator(self, exited: subprocess.Popen[str], how: str) -> None:
        sim = self.sim
        assert sim is not None
        self.flasher.wait(UPDATE_WAIT_S)  # an update under way ends first (its avrdude lost the port)
        error, answered = "", False
        with sim.lifecycle:
            if sim.process is exited or not sim.running():  # else restarted meanwhile
                error, answered = self._start_simulator_again(sim, how)
        with self._lock:
            restarts = self.simulator.restarts + (0 if error else 1)
            state: SimulatorRun = "failed" if error else "running"
            if error:
                words = f"It could not be started again: {error}."
            elif answered:
                words = f"It runs again (restart {restarts}) and the firmware answers."
            else:
                words = f"It runs again (restart {restarts}), but the firmware does not answer yet."
            self.simulator = SimulatorState(state, restarts, f"{self.simulator.message} {words}")
        (log.error if error else log.warning)("%s", self.simulator.message)
        self._publish({"type": "simulator", **asdict(self.simulator)})
        self.bus.publish(SimulatorRestarted(restarts, error, answered))

    def _start_simulator_again(self, sim: Simulator, how: str) -> tuple[str, bool]:
        """Starts the simulator on the firmware it ran (then on the last one that answered);
        returns why it could not ("" if it runs) and whether its firmware answered."""
        error = ""
        with self.restarts.resetting(
            f"restarting the simulator, which {how}", certain=True, untrusts="a new simulator starts afresh"
        ):
            for attempt in range(SIM_START_TRIES):
                firmware_file = sim.options.firmware if attempt == 0 else self.flasher.good_firmware()
                try:
                    sim.restart(firmware_file)
                    error = ""
                    break
                except (SimulatorError, OSError) as exc:
                    error = str(exc)
                    time.sleep(0.5)
            if error:
                return error, False
            try:
                self.link.connected.wait(10.0)
                self.wait_for_firmware(5.0, 0.1)
                return "", True
            except (LinkError, CommandRefused):
                return "", False

    # -- for the API: what its routes ask without reaching past the front ---------------------
    def motion_token(self) -> int:
        """The stop generation of a motion request arriving now (Link.motion_token)."""
        return self.link.motion_token()

    def start_update(self, hex_file: bytes) -> dict[str, object]:
        """Flashes `hex_file` (Flasher.start: ValueError for a bad file, RuntimeError when nothing
        can flash); the update's view."""
        return self.flasher.start(hex_file).view()

    def update_view(self) -> dict[str, object]:
        """The firmware update's state and log."""
        return self.flasher.job.view()

    def calibration_summary(self) -> dict[str, Any] | None:
        """The camera's calibration as /api/camera shows it; None without one."""
        seeing = self.seeing
        return seeing.calibration.summary() if seeing is not None and seeing.calibration else None

    def sim_faults(self, chosen: dict[str, float] | None = None) -> dict[str, float]:
        """The simulator's faults now, set to `chosen` first if given; NotSimulated on a real cart."""
        if self.sim is None:
            raise NotSimulated("there is no simulator")
        return self.sim.faults() if chosen is None else self.sim.set_faults(chosen)

    def floor_plan_png(self, version: int | None = None) -> bytes | None:
        """The floor plan as a PNG (map_server's grey levels), None without one. A live map has its
        current plan only, whatever `version` is asked (the panel's cache key: a replay's matters)."""
        plan = self.floor_plan()
        return None if plan is None else image_bytes(plan, ".png")

    def camera_view(self) -> dict[str, Any]:
        """The camera's stream and frames (CameraFeed.status), where it is and its calibration."""
        camera = self.camera
        if camera is None:
            return {"camera": False, "message": NO_CAMERA}
        return {
            **camera.status(),
            "camera": True,
            "url": camera.base_url,
            "stream_url": camera.reader.url,
            "calibration": self.calibration_summary(),
        }

    def camera_feed(self) -> CameraFeed | None:
        return self.camera

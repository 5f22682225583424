"""The mission: a goal planned from the measured pose and sent as the firmware's path (streamed
when it is longer than the firmware's waypoint window), followed to its end, replanned when the
map blocks the rest of its route or the cart strays off it, and resumed by a START after a stop.

abort(reason) is the one way every fault, stop or takeover ends the mission and the reset
routine (routine.py) together. A stop is the last word the motors hear: it cancels every motion
request asked for before it (the link's stop generations, cart2d/link/transport.py), also
between the POSE a goal is planned from and the path's last frame, and it is answered without
waiting for the lock: the mission it ended is recorded at once if the lock is free, else as soon
as it is (tests/server/test_stop_lock.py).

The lock guards the mission and the path's stream, and a path is sent and its mission recorded
together under it. The live map hands out planner snapshots no later edit changes; its changes
(MapChanged / PerceivedChanged, published with its locks free) check the route here under it.
Over ~500 lines for a reason: the lock's invariants (a path sent and its mission recorded
together; a stop that never waits for it) hold only if everything that takes it lives here.

Goals, routes and the map are in `map`; the firmware's pose and waypoints in its odometry's frame
(`odom`): `frames` (cart2d/gateway/localisation.py) converts between them, the identity until a
marker corrects the pose. A correction (PoseCorrected with map -> odom) re-sends the driven
route: the same goal, its waypoints in the corrected odometry's frame."""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import threading
import time
from collections.abc import Callable
from dataclasses import asdict
from typing import Any

from cart2d.gateway import messages
from cart2d.gateway.bus import (
    Closing,
    EventBus,
    MapChanged,
    MissionEnded,
    MissionStarted,
    PerceivedChanged,
    PoseCorrected,
    RoutineStarted,
    StopAsked,
    ViewerMessage,
)
from cart2d.gateway.correction_resend import worth_resending
from cart2d.gateway.live_map import Replan, RouteAhead
from cart2d.gateway.localisation import Frames
from cart2d.gateway.restarts import Restarts
from cart2d.gateway.routine import ResetRoutine
from cart2d.gateway.state import Mission, MissionEnd, PathTooLong, PoseUntrusted, Routine
from cart2d.gateway.through import plan_onward
from cart2d.gateway.way_out import clearance_m, plan_from
from cart2d.link import CommandRefused, Link, LinkError, MotionCancelled, firmware, path_stream
from cart2d.link.protocol import Reply
from cart2d.params import robot
from cart2d.planning import Plan, PlanError, Planner, Point, StartBlocked, polyline_length
from cart2d.planning.smoothing import round_corners
from cart2d.shown import for_people

log = logging.getLogger(__name__)

Pose = tuple[float, float, float]
# look(goal, token, driving): what the camera sees is on the map before a route is planned (the
# cart turns on the spot to look beside its first stretch when it starts from rest: look.py);
# how many turns it took
Look = Callable[[Point, int | None, bool], int]


class Missions:
    def __init__(
        self,
        link: Link,
        bus: EventBus,
        restarts: Restarts,
        routine: ResetRoutine,
        lock: threading.RLock,
        planner: Callable[[], Planner],
        read_pose: Callable[[], Pose],
        look: Look,
        forwards_only: Callable[[bool], None],
        wait_for_the_program: Callable[[], None],
        sim_time: Callable[[], float | None],
        wake: Callable[[], None],
        clock: Callable[[], float] = time.monotonic,
        frames: Frames | None = None,
    ) -> None:
        """`restarts`: the restart watch (STATUS reads, the pose's trust); `lock`: the one the
        map's edits hold too (module docstring), the routine's; `planner()`: the routes' now;
        `read_pose`: POSE; `forwards_only(certain)`: reverse_allowed as the camera wants it
        (forward_only.py); `wait_for_the_program`: what a stop waits for while the robot's
        program is replaced; `sim_time`: the simulator's time, None on a real cart; `wake`: the
        monitor looks at STATUS now; `clock`: monotonic seconds."""
        self.link = link
        self.bus = bus
        self.restarts = restarts
        self.routine = routine
        self.lock = lock
        self._planner = planner
        self._read_pose = read_pose
        self._look = look
        self._forwards_only = forwards_only
        self._wait_for_the_program = wait_for_the_program
        self._sim_time = sim_time
        self._wake = wake
        self._clock = clock
        self.frames = frames or Frames()  # map <-> odom (module docstring)
        self.mission = Mission()
        self._stream: path_stream.PathStream | None = None  # the mission's path, streamed to the firmware
        self._frames_at_route = 0  # telemetry frames received when the last route was sent
        self._route_sent_with = self.frames.get()  # the map -> odom the last route was sent with
        self.looks_turned = 0  # turns on the spot to look before a route left (look.py)
        # (mission, routine) of each stop answered, to record as ended under the lock (stop())
        self._stops_to_record: list[tuple[Mission, Routine, str]] = []
        self.stop_reason = "stopped by the user"  # the last stop's: a mission it cut short ends with it
        bus.subscribe(MapChanged, lambda e: self._routes_changed(e.why))
        bus.subscribe(PerceivedChanged, lambda e: self._routes_changed(e.why))
        bus.subscribe(RoutineStarted, lambda _: self._replaced_by_routine())
        bus.subscribe(PoseCorrected, self._pose_corrected)
        bus.subscribe(Closing, lambda _: self.cancel_stream())

    def _publish(self, message: messages.LiveMessage) -> None:
        self.bus.publish(ViewerMessage(message))

    # -- motion ------------------------------------------------------------------------------
    def go_to(self, x: float, y: float, token: int | None = None, via: tuple[Point, ...] = ()) -> Plan:
        """Plans from the measured pose to (x, y) and sends the path; PlanError, or
        PoseUntrusted after an MCU restart, sends nothing. `token`: the stop generation the
        request belongs to (Link.motion_token() when it arrived; default now): a stop after it,
        before the last frame of the path, leaves the path unsent (MotionCancelled); one that
        comes as the last frame goes stops it, and the mission is recorded as stopped. `via`:
        stops the route passes through first, in order, without stopping (through.py); sent
        while a mission drives, the new path replaces its path at speed."""
        token = self.link.motion_token() if token is None else token
        self.restarts.read_status()  # a restart since the last look is noticed before planning
        first = via[0] if via else (x, y)
        self.looks_turned += self._look(first, token, self.mission.state == "driving")
        with self.lock:
            if not self.restarts.pose_trust.trusted:
                raise PoseUntrusted(self.restarts.pose_trust.refusal())
        odom_x, odom_y, odom_theta = self.link.call("POSE")
        pose = self.frames.to_map((odom_x, odom_y, odom_theta))
        with self.lock:
            if not self.restarts.pose_trust.trusted:  # a restart noticed meanwhile
                raise PoseUntrusted(self.restarts.pose_trust.refusal())
            # a cart that stopped within its clearance of what the camera marked since plans
            # from the nearest place it may stand (way_out.py), not refused for good
            planner = self._planner()
            onward = [*via[1:], (x, y)] if via else []
            plan = plan_onward(planner, plan_from(planner, (pose[0], pose[1]), first, clearance_m()), onward)
            if len(plan.waypoints) > path_stream.MAX_PATH_POINTS:
                raise PathTooLong(
                    f"the path needs {len(plan.waypoints)} waypoints and a firmware path holds at most "
                    f"{path_stream.MAX_PATH_POINTS}: remove obstacles or pick a nearer goal"
                )
            plan = self._rounded(plan, path_stream.MAX_PATH_POINTS)
            self._send_route(plan, token)
            self.routine.fail("a path replaced it before it squared up")
            self.mission = Mission(
                state="driving",
                goal=(x, y),
                started_s=self._clock(),
                plan=plan,
                token=token,
                route_start=plan.start,
                route=plan.waypoints,
                via=via,
            )
            self.bus.publish(MissionStarted((x, y)))
            if self.link.stopped_since(token):  # the stop went right after the last frame
                self.abort(self.stop_reason)
                raise MotionCancelled("the path was sent as a stop came: the stop ended it")
        self._publish(messages.MissionMessage(**self.mission_view()))
        return plan

    def _send_route(self, plan: Plan, token: int | None) -> None:
        """Sends the plan's waypoints as the firmware's path (lock held). The old path's stream
        stops before the new path replaces it: an append of the old path must never reach the
        new one (docs/protocol.md, Paths and the waypoint window)."""
        self.cancel_stream()
        self._forwards_only(True)
        self._route_sent_with = self.frames.get()
        waypoints = self.frames.to_odom_points(plan.waypoints)
        self._stream = path_stream.upload_path(self.link, waypoints, token)
        self._frames_at_route = self.link.telemetry_count

    def drive(self, v_mps: float, omega_radps: float, token: int | None = None) -> None:
        """Manual driving; the firmware stops by itself without a refresh within its timeout.
        MotionCancelled if a stop came after `token` (the request's arrival)."""
        self.cancel_stream()
        self.link.call("VELOCITY", v_mps, omega_radps, token=token)
        with self.lock:
            self.mission.resumable = False
            self.abort("taken over by manual driving")

    def path_replaced(self) -> None:
        """A motion command of the user's reached the firmware: its path is no longer the
        mission's, and a START does not resume it."""
        with self.lock:
            self.mission.resumable = False

    @property
    def path_stream(self) -> path_stream.PathStream | None:
        """The stream of the last path go_to sent (it may still be sending)."""
        with self.lock:
            return self._stream

    def cancel_stream(self) -> None:
        with self.lock:
            stream = self._stream
        if stream is not None:
            stream.cancel()

    def _rounded(self, plan: Plan, capacity: int) -> Plan:
        """The plan with its corners rounded where there is room (cart2d/smoothing.py)."""
        graph = self._planner().graph
        waypoints = round_corners(plan.start, plan.waypoints, graph.segment_free, capacity)
        length = polyline_length([plan.start, *waypoints])
        return dataclasses.replace(plan, waypoints=tuple(waypoints), length_m=length)

    def passed(self, stop: Point) -> None:
        """The cart passed `stop`, one of the driven mission's `via`: a replan leaves it out."""
        with self.lock:
            via = self.mission.via
            if stop in via:
                self.mission.via = via[via.index(stop) + 1 :]

    # -- the stop ----------------------------------------------------------------------------
    def stop(self, reason: str = "stopped by the user") -> Reply:
        """Emergency stop: motors off now; a mission in progress fails (with `reason`: the
        user's, or the gateway's own, a camera gone blind). Every motion request asked for
        before it is refused, however long it waited. While the robot's program is being
        replaced (a firmware update, a restart of the simulator) the stop waits for the program
        that answers (an update not yet answered is rolled back at once) and stops it.

        It returns once the firmware has the STOP, without waiting for the lock (a goal being
        planned or sent, an obstacle's check of the route, each reading the link while they hold
        it, held stops 0.1-0.5 s with 20 clients): the mission and the routine it ends are
        recorded at once if the lock is free, else by a thread as soon as it is."""
        self.stop_reason = reason
        self.bus.publish(StopAsked(reason))  # its handlers set a flag: the STOP is not held
        try:
            with self.link.stopping():
                self._wait_for_the_program()
                mission, routine = self.mission, self.routine.routine  # what the STOP ends (no lock needed)
                reply = self.link.stop()
        finally:
            stream = self._stream  # after the STOP: its appends are refused from then on anyway
            if stream is not None:
                stream.cancel()
        if not reply.ok:
            raise CommandRefused(reply)
        self._stops_to_record.append((mission, routine, reason))  # list.append: atomic, no lock
        if self.lock.acquire(blocking=False):
            try:
                self._record_stops()
            finally:
                self.lock.release()
        else:
            threading.Thread(target=self._record_stops_once_free, name="after a stop", daemon=True).start()
        return reply

    def stops_pending(self) -> int:
        """Stops answered whose mission is not recorded as ended yet (the lock was busy)."""
        return len(self._stops_to_record)

    def _record_stops_once_free(self) -> None:
        with self.lock:
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

    # -- the end of a mission ------------------------------------------------------------------
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
        with self.lock:
            ended = None
            if (mission is None or self.mission is mission) and self.mission.state == "driving":
                ended = self.mission.goal or (0.0, 0.0)
                self._end_mission("failed", reason)
            self.routine.fail(routine_reason or f"{reason} before it squared up", routine)
            return ended

    def restart_ended(self, reason: str, routine_reason: str) -> tuple[float, float] | None:
        """What a restart of the MCU ends (restarts.py): the path it lost, the mission and the
        routine; the saved reverse_allowed is back (forward_only.py)."""
        self._forwards_only(False)
        with self.lock:
            self.mission.resumable = False  # a restart loses the path
            if self._stream is not None:
                self._stream.cancel()
            return self.abort(reason, routine_reason)

    def _replaced_by_routine(self) -> None:
        with self.lock:
            if self.mission.state == "driving":
                self._end_mission("failed", "replaced by the reset routine")

    def _end_mission(self, state: MissionEnd, reason: str) -> None:
        self.mission.state = state
        self.mission.reason = reason
        self.mission.ended_s = self._clock()
        self._publish(messages.MissionMessage(**self.mission_view()))
        self.bus.publish(MissionEnded(self.mission.goal, state, reason))

    # -- followed by the monitor (monitor.py) ---------------------------------------------------
    def busy(self) -> bool:
        with self.lock:
            return self.mission.state == "driving"

    def before_status(self) -> tuple[Mission, int]:
        """The mission now and its generation: a STATUS asked for before a new path or a replan
        says nothing about it."""
        with self.lock:
            return self.mission, self.mission.generation

    def after_status(self, status: firmware.Status, running: tuple[Mission, int]) -> None:
        """Ends the mission running when `status` was asked for if `status` shows its end (a
        path that could not be streamed stops the cart), then replans if the cart is off its
        route (replanning)."""
        mission, generation = running
        outcome = status.path_outcome()
        with self.lock:
            current = self.mission is mission and mission.generation == generation
            stream = self._stream if current and mission.state == "driving" else None
        if outcome is None and stream is not None and stream.failure:
            outcome = f"the path could not be streamed to the firmware: {stream.failure}"
            with contextlib.suppress(LinkError, CommandRefused):
                self.link.call("STOP")  # the cart waits at the end of the points it has: stop it
        with self.lock:
            current = self.mission is mission and mission.generation == generation
            if outcome is not None and current and mission.state == "driving":
                if outcome:  # the firmware stopped it (its words), or its stream failed
                    self.abort(outcome, mission=mission)  # no routine runs beside a driven path
                else:
                    self._end_mission("arrived", "")
        self._check_off_path()

    # -- replanning ---------------------------------------------------------------------------
    def _routes_changed(self, why: str) -> None:
        """The map or the perceived layer changed (published with their locks free): a driven
        route it blocks is replanned, under the mission's lock."""
        with self.lock:
            if self.mission.state == "driving" and self.mission.route:
                self._check_route(f"the map changed: {why}")

    def _pose_corrected(self, event: PoseCorrected) -> None:
        """The pose filter moved map -> odom: the driven route's waypoints, in odom, are where
        they were no longer; sent again from the corrected pose (lock held)."""
        if event.map_to_odom is None:
            return  # the user's SET_POSE: odometry is map's again, the route's odom points too
        with self.lock:
            mission = self.mission
            if mission.state == "driving" and mission.route:
                # a route the correction hardly moved is only checked (correction_resend.py)
                cart = event.pose[:2] if event.pose is not None else None
                moved = worth_resending(mission.route, self._route_sent_with, event.map_to_odom, cart)
                self._check_route(f"the pose was corrected ({event.how})", always=moved)

    def _check_route(self, why: str, always: bool = False) -> None:
        """Checks the rest of the driven route against the map now (the planner's own check:
        footprint plus clearance); replans from the measured pose if it is blocked, or `always`
        (lock held)."""
        mission = self.mission
        try:
            status = self.restarts.read_status()
            pose = self.frames.to_map(self._read_pose())
        except (LinkError, CommandRefused) as exc:
            log.warning("the path could not be checked against the changed map: %s", exc)
            return
        if self.mission is not mission or mission.state != "driving" or status.mode != "PATH":
            return  # ended meanwhile, or about to be ended by the monitor
        here = (pose[0], pose[1])
        ahead = RouteAhead.of(mission.route_start, mission.route, status.waypoint_index, here)
        if always or ahead.blocked(self._planner().graph):
            self._replan(why, here, ahead.entry)

    def _check_off_path(self) -> None:
        """Replans when telemetry shows the cart off its route by more than robot.toml's
        [planning] off_path_replan_m (at most once per off_path_replan_interval_s)."""
        limits = robot()["planning"]
        frame = self.link.telemetry
        with self.lock:
            mission = self.mission
            if mission.state != "driving" or not mission.route or frame is None:
                return
            # a frame sent before the route was: its waypoint index is another path's
            if (
                self.link.telemetry_count <= self._frames_at_route + 1
                or firmware.mode_name(frame.mode) != "PATH"
            ):
                return
            if self._clock() - max(mission.started_s, mission.last_replan_s) < float(
                limits["off_path_replan_interval_s"]
            ):
                return
            x, y, _ = self.frames.to_map((frame.x, frame.y, frame.theta))
            here = (x, y)
            ahead = RouteAhead.of(mission.route_start, mission.route, int(frame.waypoint_index), here)
            off_m = ahead.distance(here)
            if off_m > float(limits["off_path_replan_m"]):
                self._replan(f"the cart was {off_m:.2f} m off its path", here, ahead.entry)

    def _replan(self, reason: str, pose: Point, entry: Point) -> None:
        """Plans again from the measured pose to the mission's goal (through its stops not passed
        yet) and replaces the firmware's
        path with it (WAIT_XY_ARRAY: atomic, the speed carried on through the acceleration
        limits); with no path left, stops the cart and fails the mission with the reason (lock
        held). A cart within its clearance of an obstacle (it follows its path within that) is
        planned from the nearest point of its route, or else from the nearest place it may stand."""
        mission = self.mission
        assert mission.goal is not None
        # through the stops not passed yet: a fleet cart's route must keep to its released nodes
        goal, *onward = [*mission.via, mission.goal]
        started = time.perf_counter()  # the planner's latency, a figure for benches
        try:
            planner = self._planner()
            try:
                plan = planner.plan(pose, goal)
            except StartBlocked:
                try:
                    plan = planner.plan(entry, goal)
                except StartBlocked:  # the entry too: from the nearest place the cart may stand
                    plan = plan_from(planner, pose, goal, clearance_m())
            plan = plan_onward(planner, plan, onward)
            plan = self._rounded(plan, path_stream.MAX_PATH_POINTS)
        except PlanError as exc:
            self._record_replan(mission, reason, time.perf_counter() - started, None, str(exc))
            with contextlib.suppress(LinkError, CommandRefused):
                self.link.stop()
            self.cancel_stream()
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
        self._publish(messages.MissionMessage(**self.mission_view()))

    def _record_replan(
        self, mission: Mission, reason: str, plan_time_s: float, plan: Plan | None, outcome: str
    ) -> None:
        now = self._clock()
        replan = Replan(
            reason=reason,
            at_s=now - mission.started_s,
            sim_t=self._sim_time(),
            plan_time_s=plan_time_s,
            length_m=plan.length_m if plan is not None else 0.0,
            waypoints=len(plan.waypoints) if plan is not None else 0,
            outcome=outcome,
        )
        mission.replans.append(replan)
        mission.last_replan_s = now
        self._publish(messages.ReplanMessage(**asdict(replan)))

    # -- resuming after a stop -------------------------------------------------------------------
    def resume(self, token: int | None) -> None:
        """After a START: the mission a stop ended drives again if its path is still the
        firmware's (its points, nothing sent since but START); the rest of a long path streams
        again from where the firmware stands."""
        with self.lock:
            self._record_stops()  # a stop answered while the lock was busy: recorded before this
            mission, stream = self.mission, self._stream
            if not (mission.state == "failed" and mission.resumable and mission.plan):
                return
        status = self.restarts.read_status()
        if status.waypoint_count != len(mission.plan.waypoints):
            return
        outcome = status.path_outcome()
        with self.lock:
            if self.mission is not mission or not mission.resumable:
                return  # replaced meanwhile
            mission.resumable = False
            if outcome is None and stream is not None and stream.sent < stream.count:
                self._stream = stream.resumed(status.waypoint_index, status.waypoints_received, token)
            if outcome is None or outcome == "":
                mission.state, mission.reason = ("driving", "") if outcome is None else ("arrived", "")
                mission.ended_s = 0.0 if outcome is None else self._clock()
            else:
                return
        log.info("the mission to %s resumed after a stop", mission.goal)
        self._publish(messages.MissionMessage(**self.mission_view()))
        self._wake()

    # -- views -----------------------------------------------------------------------------------
    def mission_view(self) -> dict[str, Any]:
        with self.lock:
            m = self.mission
            elapsed = (m.ended_s or self._clock()) - m.started_s if m.started_s else 0.0
            view: dict[str, Any] = for_people(
                {
                    "state": m.state,
                    "goal": m.goal,
                    "reason": m.reason,
                    "elapsed_s": round(elapsed, 3),
                    "plan": plan_view(m.plan) if m.plan is not None else None,
                    "replans": [asdict(r) for r in m.replans],
                }
            )
            return view


def plan_view(plan: Plan) -> dict[str, Any]:
    """A plan as the API and viewers show it."""
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

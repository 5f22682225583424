"""Exploration as a gateway service (issue 26): POST /api/explore and `cart2d explore` start
exploration.py's loop on its own thread, driving goal after goal through the mission (go_to),
until no reachable frontier is left, a STOP (the bus's StopAsked, published before the STOP
goes), or the gateway closes; the map is saved at the end. Its progress is published on the bus
as an `exploration` viewer message and answered by GET /api/explore.

Everything it drives with is given as callables (wired in core.py), so it is tested with fakes."""

from __future__ import annotations

import itertools
import logging
import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import ndimage

from cart2d.gateway import messages
from cart2d.gateway.bus import Closing, EventBus, MissionEnded, StopAsked, ViewerMessage
from cart2d.gateway.exploration import Explorer, Progress
from cart2d.gateway.map_saving import NothingSeen, checked_name, seen_map
from cart2d.gateway.seeing import Seeing
from cart2d.gateway.state import Mission, PathTooLong, PoseUntrusted, Refused
from cart2d.gateway.way_out import clearance_m, plan_from, rings
from cart2d.link import CommandRefused, LinkError, MotionCancelled
from cart2d.maps.frontiers import Point, frontiers
from cart2d.maps.occupancy import FREE, OCCUPIED, UNKNOWN, OccupancyMap
from cart2d.params import robot
from cart2d.planning import Plan, PlanError, Planner, StartBlocked

log = logging.getLogger(__name__)

DEFAULT_NAME = "explored"
GOAL_WAIT_S = 600.0  # wall seconds a goal may take before exploration gives it up (a stuck mission)
STOPPED_BY_USER = "exploration stopped by the user"
# A frontier's cell is often too near a wall or a box for the cart's centre: it drives to the
# nearest place it may stand within VIEW_M of it (the camera sees 0.3 to ~1.2 m ahead).
VIEW_M = 0.6
RING_STEP_M = 0.05
# and with this much room round it: a goal at the very edge of the free space is blocked by the
# next few cells perception marks on the way there, and the cart, stopped, cannot plan from it
ROOM_M = 0.06
SUSPECT_M = 0.05  # unknown floor this near an occupied cell may be the same obstacle
# How the firmware's stops for a contact begin (cart2d/link/firmware.py, Status.path_outcome)
NEAR_M = 0.2  # a frontier this near one driven to is the same (frontiers.choose's near_m)
RAN_INTO = ("the cart touched something", "a wheel stalled")


def _stopped_because(reason: str) -> str:
    return STOPPED_BY_USER if reason == "stopped by the user" else f"exploration stopped: {reason}"


def seen_if_seeing(seeing: Seeing | None) -> OccupancyMap | None:
    """What perception has seen, None without perception or before its first frame."""
    try:
        return seen_map(seeing)
    except NothingSeen:
        return None


class ExplorationRefused(Refused):
    """Exploration cannot start now (the sentence says why): a 409."""


@dataclass
class ExplorationDrive:
    """What exploration drives with: the gateway's, wired in core.py."""

    go_to: Callable[[float, float, int | None], object]  # plans and sends; raises if it cannot
    mission: Callable[[], Mission]  # the mission now
    motion_token: Callable[[], int]  # the link's stop generation now
    planner: Callable[[], Planner]  # the routes' planner now
    pose: Callable[[], tuple[float, float, float]]  # the cart's pose in map
    seen: Callable[[], OccupancyMap | None]  # what the camera has seen; None: no camera or nothing yet
    save: Callable[[str], dict[str, Any]]  # writes the seen map as NAME (map_saving.save_seen_map)
    arena: Callable[[], dict[str, float]]  # the walls round the map
    sim_time: Callable[[], float | None]  # simulated s, None on a real cart


class Exploration:
    def __init__(self, bus: EventBus, drive: ExplorationDrive) -> None:
        self.bus = bus
        self.drive = drive
        self._lock = threading.Lock()
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()  # a STOP or the gateway's close since the start
        self._stopped_why = ""
        self._mission_ended = threading.Event()
        self._view = self._message("idle", Progress(), None, None, None)
        self._deferred = 0  # frontiers left out of the last choice: their way passes unseen sides
        self._last_seen: OccupancyMap | None = None  # _seen()'s, and what it makes
        self._suspect_m = np.zeros((0, 0))
        self._wary: tuple[Planner, Planner] | None = None  # (the planner, it with suspect cells)
        self._legs: dict[Point, tuple[Point, ...]] = {}  # a frontier's way round unseen sides
        self._round_m: dict[Point, float] = {}  # and its length
        body = robot()["body"]
        self.footprint_m = float(body["footprint_radius_m"]) + float(body["clearance_m"])
        bus.subscribe(StopAsked, lambda e: self._stopping(_stopped_because(e.reason)))
        bus.subscribe(Closing, lambda _: self._stopping("exploration stopped: the gateway closed"))
        bus.subscribe(MissionEnded, lambda _: self._mission_ended.set())

    # -- the API's -----------------------------------------------------------------------------
    def start(self, name: str = DEFAULT_NAME) -> dict[str, Any]:
        """Starts exploring; the map is saved as `name` at the end. ValueError for a bad name,
        ExplorationRefused when it cannot start now; nothing is changed then."""
        checked_name(name)
        with self._lock:
            if self._thread is not None and self._thread.is_alive():
                raise ExplorationRefused("the cart is exploring already: stop it first")
            if self.drive.mission().state == "driving":
                raise ExplorationRefused("a mission is running: stop it or wait for its end, then explore")
            if self.drive.seen() is None:
                raise ExplorationRefused(
                    "exploring needs the camera and perception: attach a camera (--camera) with "
                    "perception on, and let it see a frame"
                )
            self._stop.clear()
            self._stopped_why = ""
            started = (time.monotonic(), self.drive.sim_time())
            self._publish(self._message("exploring", Progress(), started, None, None))
            self._thread = threading.Thread(
                target=self._run, args=(name, started), name="exploration", daemon=True
            )
            self._thread.start()
        return self.view()

    def view(self) -> dict[str, Any]:
        return messages.wire(self._view)

    def wait(self, timeout_s: float | None = None) -> bool:
        """Until the exploration running ends (tests, benches); whether it has."""
        thread = self._thread
        if thread is not None:
            thread.join(timeout_s)
            return not thread.is_alive()
        return True

    # -- the loop ------------------------------------------------------------------------------
    def _stopping(self, why: str) -> None:
        if not self._stop.is_set():
            self._stopped_why = why
        self._stop.set()

    def _run(self, name: str, started: tuple[float, float | None]) -> None:
        saved: list[str] = []

        def save() -> str:
            try:
                answer = self.drive.save(name)
            except (NothingSeen, OSError) as exc:
                return f"the map could not be saved: {exc}"
            saved.append(str(answer["yaml"]))
            return f"map saved as {answer['yaml']}"

        def tell(progress: Progress) -> None:
            self._publish(self._message("exploring", progress, started, None, None))

        explorer = Explorer(
            seen=self._seen,
            path_length=self._path_length,
            last_resort=self._round_length,
            go_to=self._go_to,
            stopped=self._stop.is_set,
            save=save,
            tell=tell,
        )
        try:
            progress = explorer.run()
        except Exception as exc:  # a fault must not leave the state "exploring" for ever
            log.exception("exploration failed")
            progress = Progress(sentence=f"exploration failed: {exc}; {save()}")
        state = "failed"
        if progress.sentence.startswith(STOPPED_BY_USER):
            state = "stopped"
            progress.sentence = progress.sentence.replace(STOPPED_BY_USER, self._stopped_why, 1)
        elif progress.sentence.startswith("exploration finished"):
            state = "finished"
            if self._deferred:
                unsafe = f"{self._deferred} whose way passes unseen floor beside an obstacle"
                progress.sentence = progress.sentence.replace(
                    "no reachable frontier left", f"no reachable frontier left but {unsafe}", 1
                )
        log.info("%s", progress.sentence)
        self._publish(self._message(state, progress, started, progress.sentence, saved[0] if saved else None))

    def _seen(self) -> OccupancyMap:
        """What the camera has seen, the far side of the arena's walls taken as wall: never
        seen, it is no floor to explore."""
        seen = self.drive.seen()
        if seen is None:
            raise NothingSeen("the camera was taken away while the cart explored")
        a = self.drive.arena()
        r = seen.resolution_m
        xs = seen.origin_m[0] + (np.arange(seen.width) + 0.5) * r
        ys = seen.origin_m[1] + (np.arange(seen.height) + 0.5) * r
        outside_x = (xs < a["x_min"]) | (xs > a["x_max"])
        outside_y = (ys < a["y_min"]) | (ys > a["y_max"])
        cells = seen.cells.copy()
        cells[outside_y[:, None] | outside_x[None, :]] = OCCUPIED
        self._last_seen = OccupancyMap(seen.origin_m, r, cells)
        self._deferred = 0  # a new look, a new choice
        self._wary = None
        self._legs = {}
        self._round_m = {}
        # unknown floor beside what is seen occupied is likely more of it (a box's unseen side)
        suspect = (cells == UNKNOWN) & ndimage.binary_dilation(
            cells == OCCUPIED, iterations=max(1, round(SUSPECT_M / r))
        )
        self._suspect_m = ndimage.distance_transform_edt(~suspect) * r
        return self._last_seen

    def _passes_unseen_sides(self, plan: Plan) -> bool:
        """Whether the plan's way comes within the cart's footprint and clearance of floor unseen
        beside an obstacle: a box's side the camera has not seen may be there."""
        seen = self._last_seen
        if seen is None:
            return False
        keep = self.footprint_m
        points = [plan.start, *plan.waypoints]
        for a, b in itertools.pairwise(points):
            n = max(1, math.ceil(math.dist(a, b) / seen.resolution_m))
            for k in range(n + 1):
                x = a[0] + (b[0] - a[0]) * k / n
                y = a[1] + (b[1] - a[1]) * k / n
                i = math.floor((x - seen.origin_m[0]) / seen.resolution_m)
                j = math.floor((y - seen.origin_m[1]) / seen.resolution_m)
                if 0 <= i < seen.width and 0 <= j < seen.height and self._suspect_m[j, i] < keep:
                    return True
        return False

    def _still_a_frontier(self, frontier: Point) -> bool:
        return any(math.dist(f.centre, frontier) < NEAR_M for f in frontiers(self._seen()))

    def _goal_for(self, frontier: Point, planner: Planner, here: Point) -> Point | None:
        """Where the cart may stand nearest the frontier (within VIEW_M), the nearer to it of
        equally near places; None if there is none. Only on floor the camera saw free: the
        planner takes unknown floor as free, and a goal there may be inside a box not yet seen."""
        graph = planner.graph
        seen = self._last_seen or self._seen()

        def seen_free(p: Point) -> bool:
            i = math.floor((p[0] - seen.origin_m[0]) / seen.resolution_m)
            j = math.floor((p[1] - seen.origin_m[1]) / seen.resolution_m)
            return 0 <= i < seen.width and 0 <= j < seen.height and seen.cells[j, i] == FREE

        def roomy(p: Point) -> bool:
            return (
                seen_free(p)
                and graph.point_free(*p)
                and all(
                    graph.point_free(p[0] + ROOM_M * math.cos(a), p[1] + ROOM_M * math.sin(a))
                    for a in (math.tau * n / 8 for n in range(8))
                )
            )

        if roomy(frontier):
            return frontier
        for ring in rings(frontier, (k * RING_STEP_M for k in range(1, round(VIEW_M / RING_STEP_M) + 1))):
            free = [p for p in ring if roomy(p)]
            if free:
                return min(free, key=lambda p: math.dist(p, here))
        return None

    def _path_length(self, frontier: Point) -> float | None:
        try:
            x, y, _ = self.drive.pose()
            planner = self.drive.planner()
            goal = self._goal_for(frontier, planner, (x, y))
            if goal is None:
                return None
            plan = plan_from(planner, (x, y), goal, clearance_m())
        except StartBlocked as exc:  # the cart's fault, not the frontier's: every plan fails
            self._stopping(f"exploration stopped: {exc}")
            return math.inf
        except (PlanError, LinkError, CommandRefused):
            return None
        if self._passes_unseen_sides(plan):
            self._deferred += 1
            wary = self._wary_plan(planner, plan.start, goal)
            if wary is not None:  # for _round_length, when nothing else is left
                self._legs[frontier] = tuple(wary.waypoints[:-1])
                self._round_m[frontier] = wary.length_m
            return math.inf  # not now: a later view may show the side (frontiers.choose)
        return plan.length_m

    def _round_length(self, frontier: Point) -> float:
        """The last resort's path length (Explorer.last_resort): the way round the unseen sides
        _path_length found for a frontier it left out, infinite for the rest (not chosen, not
        set aside)."""
        return self._round_m.get(frontier, math.inf)

    def _wary_plan(self, planner: Planner, start: Point, goal: Point) -> Plan | None:
        """A way that keeps the cart's footprint and clearance off the unseen floor beside
        obstacles too (a box's unseen side may be there), None if there is none: the shortest
        way hugs every obstacle, so without it a frontier behind a box waited for a view that
        never came, and exploration ended with the floor behind unseen."""
        if self._wary is None or self._wary[0] is not planner:
            wary = Planner(
                planner.grid,
                planner.footprint_radius_m,
                planner.obstacles,
                planner.blocked,
                planner.outside_blocked,
                planner.start_slack_m,
                planner.kinds,
            )
            seen = self._last_seen
            nodes = set(wary.obstacles)
            if seen is not None:
                r = seen.resolution_m
                for j, i in zip(*np.nonzero(self._suspect_m == 0), strict=True):
                    x, y = seen.origin_m[0] + (i + 0.5) * r, seen.origin_m[1] + (j + 0.5) * r
                    if wary.grid.on_map(x, y):
                        nodes.add(wary.grid.nearest_node(x, y))
            wary.set_obstacles(nodes)
            self._wary = (planner, wary)
        try:
            return self._wary[1].plan(start, goal)
        except PlanError:
            return None

    def _go_to(self, frontier: Point) -> str:
        """Drives to the frontier (the nearest place to it the cart may stand): "" once there
        (or stopped: the loop ends then, nothing set aside), else why not."""
        token = self.drive.motion_token()  # before the flag: a STOP after it cancels the path
        if self._stop.is_set():
            return ""
        self._mission_ended.clear()
        try:
            x, y, _ = self.drive.pose()
            goal = self._goal_for(frontier, self.drive.planner(), (x, y))
            if goal is None:
                return f"no place the cart may stand within {VIEW_M} m of it"
        except (LinkError, CommandRefused) as exc:
            self._stopping(f"exploration stopped: the cart did not take its goal ({exc})")
            return ""
        for leg in self._legs.get(frontier, ()):  # round the unseen sides, a corner at a time
            why_not = self._drive_to(leg, token)
            if why_not or self._stop.is_set():
                return why_not
        why_not = self._drive_to(goal, token)
        if why_not or self._stop.is_set():
            return why_not
        if self._still_a_frontier(frontier):  # explore_lite's goal sent again and again
            return f"looked at from ({goal[0]:.2f}, {goal[1]:.2f}), and still unseen beyond"
        return ""

    def _drive_to(self, goal: Point, token: int) -> str:
        """One mission to `goal`: "" once there (or stopped), else why not."""
        self._mission_ended.clear()
        try:
            self.drive.go_to(goal[0], goal[1], token)
        except MotionCancelled:
            return ""
        except StartBlocked as exc:  # no frontier's fault: every goal would fail from here
            self._stopping(f"exploration stopped: {exc}")
            return ""
        except (PlanError, PathTooLong) as exc:
            return f"no way there: {exc}"
        except PoseUntrusted as exc:
            self._stopping(f"exploration stopped: {exc}")
            return ""
        except (LinkError, CommandRefused) as exc:
            self._stopping(f"exploration stopped: the cart did not take its goal ({exc})")
            return ""
        mission = self.drive.mission()
        deadline = time.monotonic() + GOAL_WAIT_S
        while mission.state == "driving" and time.monotonic() < deadline:
            self._mission_ended.wait(0.2)
        if self._stop.is_set():
            return ""
        if mission.state == "driving":
            return f"not reached in {GOAL_WAIT_S:.0f} s"
        if mission.reason.startswith(RAN_INTO):  # perception missed something: no more goals
            self._stopping(f"exploration stopped: {mission.reason}")
            return ""
        if mission.state != "arrived":
            return mission.reason or "the mission failed"
        return ""

    # -- progress ------------------------------------------------------------------------------
    def _message(
        self,
        state: str,
        progress: Progress,
        started: tuple[float, float | None] | None,
        sentence: str | None,
        saved: str | None,
    ) -> messages.ExplorationMessage:
        wall_s, sim_s = 0.0, None
        if started is not None:
            wall_s = time.monotonic() - started[0]
            now_sim = self.drive.sim_time()
            if started[1] is not None and now_sim is not None:
                sim_s = round(now_sim - started[1], 2)
        a = self.drive.arena()
        area = max((a["x_max"] - a["x_min"]) * (a["y_max"] - a["y_min"]), 1e-9)
        return messages.ExplorationMessage(
            state=state,
            seen_m2=round(progress.seen_free_m2, 2),
            seen_percent=round(min(100.0, 100.0 * progress.seen_free_m2 / area), 1),
            frontiers=progress.frontiers,
            goals=progress.goals,
            set_aside=[messages.SetAside(x=p[0], y=p[1], reason=r) for p, r in progress.set_aside.items()],
            elapsed_s=round(wall_s, 2),
            elapsed_sim_s=sim_s,
            sentence=sentence or "",
            saved=saved,
        )

    def _publish(self, message: messages.ExplorationMessage) -> None:
        self._view = message
        self.bus.publish(ViewerMessage(message))

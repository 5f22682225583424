"""Headless missions in the simulator: `cart2d mission MISSION.json [--report REPORT.json]`.

A mission is a map, a start pose and goals; the runner drives to each goal in turn through the
same gateway code as the web API (plan from the measured pose, upload, follow STATUS) and
reports, per goal, whether it was reached, the simulated time, the errors (ground truth against
goal and against odometry) and the path length driven and planned. The mission file is checked
whole before anything runs (spec.py); once it runs, the report is written however it
ends, and a goal off the map or unreachable is reported with its reason and nothing is sent.
`resets_at_s` presses the simulated reset button: the goal in progress fails with the reset's
words, and the goals after it are not driven (the gateway no longer trusts the pose).

`"map": "path/to/map.yaml"` (a ROS map_server map, relative to the mission file) takes the place
of `"grid"`: the gateway plans on it and its occupied cells are the simulated world's walls.
`"events"` change the map at simulated times (cart2d/tools/missions/events.py): the report lists
them and every replan of the gateway (time, reason, plan time, new length)."""

from __future__ import annotations

import contextlib
import math
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from tqdm import tqdm

from cart2d.gateway import Gateway, PoseUntrusted
from cart2d.gateway.live_map import planner_for, world_for
from cart2d.gateway.messages import GoalMessage, wire
from cart2d.link import CommandRefused, Link, LinkError, firmware, path_stream
from cart2d.maps import MapError, load_ros_map
from cart2d.params import robot, setting_id
from cart2d.planning import Grid, PlanError, Point, point_polyline_distance, polyline_length
from cart2d.planning.baseline import SEED_SETTINGS, seed_path
from cart2d.recording import open_recording
from cart2d.recording.session import DEFAULT_CAMERA_FPS
from cart2d.simulation import world_file
from cart2d.simulation.lockstep import Lockstep
from cart2d.simulation.side_channel import SimulatorError
from cart2d.simulation.simulator import SimOptions, Simulator
from cart2d.simulation.wiring import simulated_gateway
from cart2d.store import FloorPlan, GatewaySettings, MapSettings, Store
from cart2d.tools.missions import spec as mission_file
from cart2d.tools.missions.camera import mission_camera, perception_report
from cart2d.tools.missions.events import EventPlayer, Pacer, snapped
from cart2d.tools.missions.spec import MissionSpec
from cart2d.tools.missions.trace import Recorder

Tell = Callable[[dict[str, Any]], None]  # a message of the mission's own for its recording


# Faults that make the link retry: its waits are wall-clock time, so a mission with them runs
# in real time (at full speed a 20 ms retry would let the cart drive on for half a second).
LINE_FAULTS = ("uart_rx_drop", "uart_rx_corrupt", "uart_tx_drop", "uart_tx_corrupt", "uart_burst_hz")


def _apply_settings(link: Link, settings: dict[str, float]) -> None:
    for name, value in settings.items():
        firmware.write_setting(link, setting_id(name), value)


def _wait_for_path_end(link: Link, sim: Simulator, deadline_t: float, watch: firmware.ResetWatch) -> str:
    """Polls STATUS until the firmware leaves PATH mode: '' when it arrived, else why not (a
    restart of the MCU since the watch's last look included)."""
    try:
        status = firmware.wait_path_end(link, lambda: sim.truth()["t"] > deadline_t, 0.005, watch)
    except firmware.ControllerRestarted as exc:
        return str(exc)
    if status is None:
        link.call("STOP")
        return "timeout: the mission's time ran out"
    return status.path_outcome() or ""


def _resets_at(sim: Simulator, times_s: list[float]) -> None:
    """Presses the simulated reset button at these simulated times: scheduled in the simulator,
    which presses it at that cycle whatever the speed (a thread watching the time pressed it as
    late as a busy machine let it, by then seconds of simulated time at full speed)."""
    for t in times_s:
        sim.control("reset", at=t)


def _drive_like_the_seed(
    gateway: Gateway, sim: Simulator, pacer: Pacer, goal: Point, deadline_t: float, sent: Callable[[], None]
) -> tuple[list[Point], str]:
    """The seed's way: a waypoint at every node, sent as many buffers-full as it takes."""
    watch = firmware.ResetWatch(gateway.read_status())  # the gateway notices a restart before this too
    if not gateway.pose_trust.trusted:
        raise PoseUntrusted(gateway.pose_trust.refusal())
    x, y, _ = gateway.link.call("POSE")
    m = gateway.settings.map
    waypoints = seed_path(gateway.map_planner.grid, m.obstacles, (x, y), goal)
    capacity = gateway.waypoint_capacity
    for first in range(0, len(waypoints), capacity):
        with pacer.real_time():
            path_stream.upload_path(gateway.link, waypoints[first : first + capacity])
        sent()
        reason = _wait_for_path_end(gateway.link, sim, deadline_t, watch)
        if reason:
            break
    return [(x, y), *waypoints], reason


def _drive_with_cart2d(
    gateway: Gateway, sim: Simulator, pacer: Pacer, goal: Point, deadline_t: float, sent: Callable[[], None]
) -> tuple[list[Point], str]:
    with pacer.real_time():
        try:
            plan = gateway.go_to(*goal)
        finally:
            sent()
    # A path longer than the firmware's window streams while the cart drives, and a replan sends
    # a new one: in real time, as on a cart, or the uploader's latency would cost it a multiple
    # in simulated time.
    paced, holding = contextlib.ExitStack(), False
    with paced:
        while gateway.mission_view()["state"] == "driving":
            if sim.truth()["t"] > deadline_t:
                gateway.stop()
                return [plan.start, *plan.waypoints], "timeout: the mission's time ran out"
            stream = gateway.path_stream
            sending = stream is not None and stream.sending
            if sending and not holding:
                paced.enter_context(pacer.real_time())
            elif holding and not sending:
                paced.close()
            holding = sending
            time.sleep(0.005)
    mission = gateway.mission_view()
    first = [plan.start, *plan.waypoints]
    return first, "" if mission["state"] == "arrived" else mission["reason"]


@dataclass(frozen=True)
class _Run:
    """What driving the goals needs: the rig, the deadline (simulated s), where goals are told."""

    gateway: Gateway
    sim: Simulator
    pacer: Pacer
    recorder: Recorder
    spec: MissionSpec
    deadline: float
    tell: Tell
    # held in real time from the mission's start until its first goal's path is sent (a mission
    # with events or resets): at full speed their clock would run ahead of a busy gateway's start
    starting: contextlib.ExitStack


def _drive_to(run: _Run, goal: Point) -> dict[str, Any]:
    gateway, sim, pacer, recorder = run.gateway, run.sim, run.pacer, run.recorder
    seed, deadline_t = run.spec.behaviour == "seed", run.deadline
    result: dict[str, Any] = {"goal": list(goal), "reached": False}
    # Real time from the mark until the path is sent: at full speed the simulator ran on while a
    # busy machine's mission runner got to the request, and start_s counted it (up to 1.7 s).
    start = contextlib.ExitStack()
    start.enter_context(pacer.real_time())

    def sent() -> None:
        start.close()
        run.starting.close()

    truth_mark, modes_mark = recorder.mark()
    routes_mark = len(recorder.routes)
    t_goal = sim.truth()["t"]
    result["started_s"] = t_goal - recorder.t0
    drive = _drive_like_the_seed if seed else _drive_with_cart2d
    try:
        with start:
            planned, reason = drive(gateway, sim, pacer, goal, deadline_t, sent)
    except PlanError as exc:
        return {**result, "reason": str(exc), "time_s": 0.0, "path_length_m": 0.0}
    except PoseUntrusted:
        reason = f"not driven: the pose is not trusted since {gateway.pose_trust.reason}"
        return {**result, "reason": reason, "time_s": 0.0, "path_length_m": 0.0}
    result["planned_path"] = [list(p) for p in planned]
    result["planned_length_m"] = polyline_length(planned)
    if not seed:
        result["replans"] = _replans(gateway, sim, recorder.t0)
        if result["replans"]:
            final = gateway.mission_view()["plan"] or {}
            result["final_plan"] = [list(p) for p in final.get("waypoints", [])]
    if reason:
        result["reason"] = reason
    else:
        result["reached"] = True
    # The time to goal counts firmware ticks, from the first telemetry frame in PATH mode to the
    # first one after it (25 Hz: each end within 40 ms); a wall-clock poll would add latency.
    # start_s: from the request to that first PATH frame; look_s: of which the turns to look
    # (MANUAL mode) while the gateway sees.
    wait_until = time.monotonic() + 2.0
    ticks = recorder.driving_ticks(modes_mark)
    while ticks is None and time.monotonic() < wait_until:
        time.sleep(0.005)
        ticks = recorder.driving_ticks(modes_mark)
    if ticks is not None:
        tick_hz = robot()["control"]["tick_hz"]
        result["time_s"] = (ticks[1] - ticks[0]) / tick_hz
        result["start_s"] = (recorder.starting_ticks(modes_mark) or 0) / tick_hz
        result["look_s"] = recorder.looking_ticks(modes_mark) / tick_hz
    else:
        result["time_s"] = sim.truth()["t"] - t_goal
    trace = recorder.samples(truth_mark)
    points = [(x, y) for _, x, y in trace]
    result["path_length_m"] = polyline_length(points)
    # from the plan, or from the nearest of the plans when the gateway replanned
    routes = [planned, *recorder.routes_since(routes_mark)]
    result["max_deviation_m"] = max(
        (min(point_polyline_distance(p, route) for route in routes) for p in points), default=0.0
    )
    result["trace"] = [[round(t, 3), round(x, 4), round(y, 4)] for t, x, y in trace]
    return result


def _replans(gateway: Gateway, sim: Simulator, t0: float) -> list[dict[str, Any]]:
    """The mission's replans, their times in simulated seconds from the mission's start."""
    return [
        {
            "time_s": None if r["sim_t"] is None else r["sim_t"] - t0,
            "reason": r["reason"],
            "plan_time_s": r["plan_time_s"],
            "new_length_m": r["length_m"],
            "waypoints": r["waypoints"],
            "outcome": r["outcome"],
        }
        for r in gateway.mission_view()["replans"]
    ]


def mission_map(spec: MissionSpec, base_dir: Path | None = None) -> MapSettings:
    """The map the mission's gateway plans on (the floor plan read, the obstacles on its nodes)."""
    if spec.map is not None:
        path = Path(spec.map)
        if not path.is_absolute() and base_dir is not None:
            path = base_dir / path
        occupancy = load_ros_map(path)
        m = MapSettings.model_validate(
            {
                "floor_plan": FloorPlan.of(occupancy, path.name),
                "planning_step_m": spec.planning_step,
                "unknown_is_free": spec.unknown_is_free,
            }
        )
    else:
        g = spec.grid
        m = MapSettings(cols=g.cols, rows=g.rows, step_m=g.step)
    grid = planner_for(m).grid
    nodes = sorted({grid.nearest_node(x, y) for x, y in spec.obstacles})
    return m.model_copy(update={"obstacles": nodes})


def run_mission(
    spec: MissionSpec,
    speed: str = "max",
    seed: int = 1,
    progress: bool = False,
    report: dict[str, Any] | None = None,
    base_dir: Path | None = None,
    mcap_path: Path | None = None,
    camera_calibration: Path | None = None,
    camera_fps: float = DEFAULT_CAMERA_FPS,
) -> dict[str, Any]:
    """Runs the mission in a fresh simulator (blank EEPROM); returns the report. `report`, if
    given, is filled as the mission goes (each goal as it ends): what it holds is the report so
    far if the run stops on an error. `base_dir`: where a relative "map" path starts (the
    mission file's folder). `mcap_path`: where to record the run (cart2d/recording/).
    `camera_calibration`: the saved camera calibration perception sees with (None: the nominal
    model), when the mission sees (its "perception", on by default with a "world")."""
    report = {} if report is None else report
    report.update(behaviour=spec.behaviour, goals=[], resets=[])
    map_settings = mission_map(spec, base_dir)
    with tempfile.TemporaryDirectory() as tmp:
        options = SimOptions(
            speed=speed,
            seed=seed,
            eeprom=Path(tmp) / "eeprom.bin",
            start=spec.start,
            world=world_for(map_settings),  # the walls around the grid, or the floor plan's
            quiet=True,
            faults=dict(spec.faults),
        )
        store = Store(Path(tmp) / "gateway")
        settings = GatewaySettings(map=map_settings)
        wall_start = time.monotonic()
        with Simulator(options) as sim, Link(sim.pty) as link, contextlib.ExitStack() as recording:
            simulation = simulated_gateway(link, store, settings, sim)
            gateway = simulation.gateway
            tell: Tell = lambda message: None  # noqa: E731
            if mcap_path is not None:  # closed after gateway.close(): the file holds the whole run
                session = recording.enter_context(
                    open_recording(gateway, mcap_path, overwrite=True, camera_fps=camera_fps)
                )
                tell = session.publish_event if session is not None else tell
            if spec.world is not None and spec.world.look is not None:
                sim.set_look(spec.world.look.message())
            if spec.world is not None:  # after the gateway has made the simulator's walls follow its map
                simulation.world.add_boxes(
                    [b.box() for b in spec.world.boxes]
                )  # viewers (the recording) told
            grid = gateway.map_planner.grid
            points = snapped(grid, [grid.node_xy(i, j) for i, j in map_settings.obstacles])
            sim.change_obstacles(add=points, step=grid.step_m)  # virtual: counted, not felt
            recorder = Recorder()
            gateway.subscribe(recorder)
            gateway.wait_for_firmware(10.0, 0.1)  # the open reset the Nano into Optiboot
            if spec.behaviour == "seed":
                _apply_settings(link, SEED_SETTINGS)
            _apply_settings(link, spec.settings)
            link.call("SET_POSE", *spec.start)
            gateway.start()
            resets: list[dict[str, Any]] = report["resets"]
            keys = ("time", "cause", "cause_words", "boot_count", "message")
            gateway.subscribe(
                lambda m: resets.append({key: m[key] for key in keys}) if m.get("type") == "reset" else None
            )
            pacer = Pacer(sim)
            t0 = sim.truth()["t"]
            events: EventPlayer | None = None
            step: Lockstep | None = None
            try:
                with contextlib.ExitStack() as seeing:
                    sees = mission_file.perception_on(spec.perception, spec.world is not None)
                    if sees and spec.behaviour != "seed":
                        step = seeing.enter_context(
                            mission_camera(gateway, sim, camera_calibration, spec.lockstep)
                        )
                        seeing.enter_context(pacer.real_time())  # perception runs in wall-clock time
                    elif any(spec.faults.get(key, 0.0) for key in LINE_FAULTS):
                        seeing.enter_context(pacer.real_time())  # the link's retries wait on the wall clock
                    # The mission's time starts with its first goal, once the camera sees: the
                    # events, the resets and the timeout count from here.
                    starting = contextlib.ExitStack()
                    if spec.events or spec.resets_at_s:
                        starting.enter_context(pacer.real_time())
                    t0 = recorder.t0 = sim.truth()["t"]
                    events = EventPlayer(gateway, sim, pacer, spec.events, t0)
                    _resets_at(sim, [t0 + t for t in spec.resets_at_s])
                    with starting, events:
                        run = _Run(gateway, sim, pacer, recorder, spec, t0 + spec.timeout_s, tell, starting)
                        _drive_goals(run, progress, report["goals"])
                        if gateway.seeing is not None:
                            report["perception"] = perception_report(gateway, step)
            finally:
                gateway.close()
                if spec.events:
                    report["events"] = events.applied if events is not None else []
                if spec.behaviour != "seed":
                    report["replans"] = [r for g in report["goals"] for r in g.get("replans", [])]
                with contextlib.suppress(SimulatorError):  # the simulator may be what failed
                    truth = sim.truth()
                    sim_time = truth["t"] - t0
                    report.update(
                        collisions=truth["collisions"],
                        wall_contacts=truth["wall_contacts"],
                        box_contacts=truth["box_contacts"],
                        sim_time_s=sim_time,
                        real_time_factor=sim_time / max(time.monotonic() - wall_start, 1e-9),
                    )
        return report


def _drive_goals(run: _Run, progress: bool, goals: list[dict[str, Any]]) -> None:
    """Each goal in turn, each in the report and told to the recording (its start and its end),
    even one refused at once."""
    spec = run.spec
    for index, goal in enumerate(tqdm(spec.goals, desc="goals", unit="goal", disable=not progress), 1):
        started = GoalMessage(index=index, of=len(spec.goals), goal=tuple(goal), state="started")
        run.tell(wire(started))
        result = _drive_to(run, goal)
        truth = run.sim.truth()
        x, y, _ = run.gateway.link.call("POSE")
        result.update(
            final_error_m=math.dist((truth["x"], truth["y"]), goal),
            odometry_error_m=math.dist((truth["x"], truth["y"]), (x, y)),
        )
        goals.append(result)
        ended = "reached" if result["reached"] else "failed"
        run.tell(wire(started.model_copy(update={"state": ended, "reason": result.get("reason", "")})))


def check_mission(mission_path: Path, report_path: Path) -> tuple[MissionSpec | None, list[str]]:
    """The mission, or every problem found before it runs (spec.py), one sentence each."""
    data, problems = mission_file.read_problems(mission_path)
    spec = None
    if data is not None:
        spec, problems = world_file.parse(data, MissionSpec, str(mission_path))
    if spec is not None:
        problems += mission_file.settings_problems(spec.settings)
        problems += mission_file.faults_problems(spec.faults)
        problems += world_file.world_problems(spec.start, spec.world)
        if spec.map is None:
            g = spec.grid
            grid = Grid(cols=g.cols, rows=g.rows, step_m=g.step)
            problems += mission_file.map_problems(grid, spec.start, spec.obstacles)
        else:
            try:
                planner = planner_for(mission_map(spec, mission_path.parent))
                start = planner.start_problem(spec.start[:2], advice=False)
                if start is not None:  # else the simulator starts with the cart in a wall
                    problems.append(f"start: {start}: choose a start on the map's free floor")
            except (MapError, PlanError, OSError) as exc:
                problems.append(f"map: {exc}")
    problems += mission_file.report_problems(report_path, mission_path)
    return (spec if not problems else None), problems


def main_mission(
    mission_path: Path,
    report_path: Path | None,
    speed: str,
    seed: int,
    mcap_path: Path | None = None,
    camera_fps: float = DEFAULT_CAMERA_FPS,
) -> int:
    """The `cart2d mission` command. Everything is checked first: each problem is a line on
    stderr and the exit status is 2, with nothing run and no report. Once the mission runs, the
    report is written however it ends (an error stops it: exit status 1, the error in the
    report); 0 only if every goal was reached."""
    report_path = report_path or mission_file.default_report_path(mission_path)
    spec, problems = check_mission(mission_path, report_path)
    for problem in problems:
        print(f"cart2d mission: {problem}", file=sys.stderr)
    if spec is None:
        return 2
    report: dict[str, Any] = {}
    try:
        run_mission(
            spec,
            speed,
            seed,
            progress=sys.stderr.isatty(),
            report=report,
            base_dir=mission_path.parent,
            mcap_path=mcap_path,
            camera_fps=camera_fps,
        )
    except (LinkError, CommandRefused, SimulatorError, PlanError, MapError, OSError) as exc:
        report["error"] = str(exc)
    except KeyboardInterrupt:
        report["error"] = "interrupted (Ctrl-C)"
    mission_file.write_report(report_path, report)
    goals = report.get("goals", [])
    reached = sum(g["reached"] for g in goals)
    if "error" in report:
        print(f"cart2d mission: stopped: {report['error']}", file=sys.stderr)
    if mcap_path is not None and mcap_path.exists():
        print(f"recording in {mcap_path} (cart2d replay plays it back)", file=sys.stderr)
    print(f"{reached} of {len(spec.goals)} goals reached; report in {report_path}", file=sys.stderr)
    return 0 if "error" not in report and reached == len(spec.goals) else 1

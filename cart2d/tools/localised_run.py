"""Goals driven in the simulator with fiducial markers on its walls and odometry errors switched
on, the gateway's pose against the simulator's truth at each goal: the test of a mission with
wheel slip, a kidnapped start, and the bench's "localisation and mapping" (bench/localisation.py).

The camera and the localisation run in wall-clock time, so the simulator runs in real time while
they see (as `cart2d mission` with perception does), in lockstep with the camera's processing.
Not at full speed, as exploration does: a fix's capture is the frame's arrival on the gateway's
clock minus the camera's latency (gateway/localisation.py), so at full speed its odometry pose is
off by up to the lockstep's two frames of motion (tried: fixes doubted, the pose 33 mm off)."""

from __future__ import annotations

import math
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from cart2d.gateway.live_map import world_for
from cart2d.gateway.state import PoseTrust, PoseUntrusted
from cart2d.link import Link, firmware
from cart2d.localisation.markers import MarkerMap
from cart2d.maps.world import arena_world
from cart2d.params import setting_id
from cart2d.planning import PlanError
from cart2d.simulation.simulator import SimOptions, Simulator
from cart2d.simulation.wiring import simulated_gateway
from cart2d.store import GatewaySettings, MapSettings, Store
from cart2d.tools.localisation import start_localisation
from cart2d.tools.missions.camera import mission_camera
from cart2d.tools.missions.events import Pacer

Pose = tuple[float, float, float]
TRACE_EVERY_S = 0.25  # simulated


@dataclass
class Run:
    goals: list[tuple[float, float]]
    start: Pose
    markers: MarkerMap | None  # None: odometry alone
    faults: dict[str, float] = field(default_factory=dict)
    grid: tuple[int, int, float] = (10, 10, 0.2)  # cols, rows, step: the arena's walls around it
    start_believed: Pose | None = None  # the firmware's pose at the start if not the truth (carried)
    goal_timeout_s: float = 60.0  # simulated


def _angle(a: float) -> float:
    return math.remainder(a, math.tau)


def _errors(estimate: Pose, truth: dict[str, Any], goal: tuple[float, float]) -> dict[str, float]:
    return {
        "pose_error_m": math.hypot(estimate[0] - truth["x"], estimate[1] - truth["y"]),
        "heading_error_deg": abs(math.degrees(_angle(estimate[2] - truth["theta"]))),
        "goal_error_m": math.hypot(goal[0] - truth["x"], goal[1] - truth["y"]),
    }


def run_goals(run: Run, speed: str = "max", seed: int = 1) -> dict[str, Any]:
    """Drives the goals in turn; returns each goal's outcome and errors, the collisions, the
    detector's cost and how the localisation ended."""
    cols, rows, step = run.grid
    settings = GatewaySettings(map=MapSettings(cols=cols, rows=rows, step_m=step))
    report: dict[str, Any] = {"goals": []}
    trace: list[list[float]] = report.setdefault("trace", [])
    with tempfile.TemporaryDirectory() as tmp:
        options = SimOptions(
            speed=speed,
            seed=seed,
            eeprom=Path(tmp) / "eeprom.bin",
            start=run.start,
            world=world_for(settings.map),
            quiet=True,
            faults=dict(run.faults),
        )
        store = Store(Path(tmp) / "gateway")
        with Simulator(options) as sim, Link(sim.pty) as link:
            gateway = simulated_gateway(link, store, settings, sim).gateway
            try:
                gateway.wait_for_firmware(10.0, 0.1)
                link.call("SET_POSE", *(run.start_believed or run.start))
                gateway.start()
                if run.start_believed is not None:  # carried: the firmware's pose is not to be trusted
                    gateway.restarts.pose_trust = PoseTrust(False, "the cart was carried")
                pacer = Pacer(sim)
                with mission_camera(gateway, sim, None), pacer.real_time():
                    gateway.camera_service.set_perception_enabled(False)  # the markers only
                    gateway.camera_service.forwards_only_while_seeing()  # the guard lets go now
                    # forwards, as while seeing: backing away, the camera would see no marker
                    firmware.write_setting(link, setting_id("reverse_allowed"), 0.0)
                    service = (
                        start_localisation(gateway, run.markers, store.directory, sim)
                        if run.markers
                        else None
                    )
                    for goal in run.goals:
                        report["goals"].append(_drive(gateway, sim, goal, run.goal_timeout_s, service, trace))
                    report["localisation"] = service.summary() if service is not None else None
            finally:
                gateway.close()
            truth = sim.truth()
            report.update(
                collisions=truth["collisions"], box_contacts=truth["box_contacts"], sim_t=truth["t"]
            )
    return report


def _sample(gateway: Any, service: Any, truth: dict[str, Any], trace: list[list[float]]) -> None:
    """[t, x, y (truth), error of the gateway's pose, of the odometry's] every TRACE_EVERY_S."""
    frame = gateway.link.telemetry
    if frame is None or (trace and truth["t"] - trace[-1][0] < TRACE_EVERY_S):
        return
    odom = (frame.x, frame.y, frame.theta)
    estimate = _gateway_pose(service, odom)
    error = math.hypot(estimate[0] - truth["x"], estimate[1] - truth["y"])
    odom_error = math.hypot(odom[0] - truth["x"], odom[1] - truth["y"])
    trace.append([truth["t"], truth["x"], truth["y"], error, odom_error])


def _gateway_pose(service: Any, odom: tuple[float, ...]) -> Pose:
    """The pose the gateway plans from and shows now: the odometry's through map -> odom (not
    the filter's state, which stays where the last fix left it while the cart drives on)."""
    x, y, theta = odom
    return service.frames.to_map((x, y, theta)) if service is not None else (x, y, theta)


def _drive(
    gateway: Any,
    sim: Simulator,
    goal: tuple[float, float],
    timeout_s: float,
    service: Any,
    trace: list[list[float]],
) -> dict[str, Any]:
    out: dict[str, Any] = {"goal": list(goal)}
    deadline = sim.truth()["t"] + timeout_s
    wait_until_trusted = time.monotonic() + 10.0
    while not gateway.pose_trust.trusted and time.monotonic() < wait_until_trusted:
        time.sleep(0.05)  # a carried cart waits for its first marker
    try:
        gateway.go_to(*goal)
    except (PlanError, PoseUntrusted) as exc:
        return {**out, "reached": False, "reason": str(exc)}
    while gateway.mission_view()["state"] == "driving":
        truth = sim.truth()
        if truth["t"] > deadline:
            gateway.stop()
            break
        _sample(gateway, service, truth, trace)
        time.sleep(0.05)
    time.sleep(0.3)  # the last frames of the cart at rest: a fix at the goal
    view = gateway.mission_view()
    truth = sim.truth()
    odom = tuple(gateway.link.call("POSE"))
    estimate = _gateway_pose(service, odom)
    out.update(
        reached=view["state"] == "arrived", reason=view.get("reason") or "", replans=len(view["replans"])
    )
    out.update(_errors(estimate, truth, goal))
    out["odometry_error_m"] = math.hypot(odom[0] - truth["x"], odom[1] - truth["y"])
    return out


def arena_bounds(grid: tuple[int, int, float]) -> tuple[float, float, float, float]:
    cols, rows, step = grid
    boundary = arena_world(cols, rows, step).boundary
    assert isinstance(boundary, tuple)
    return boundary

"""Headless missions in the simulator: `cart2d mission MISSION.json --report REPORT.json`.

A mission is a map, a start pose and goals; the runner drives to each goal in turn through the
same gateway code as the web API (plan from the measured pose, upload, follow STATUS) and
reports, per goal, whether it was reached, the simulated time, the errors (ground truth against
goal and against odometry) and the path length driven and planned. The report is written in
every case; an invalid or unreachable goal is reported with its reason and nothing is sent."""

from __future__ import annotations

import json
import math
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError
from tqdm import tqdm

from cart2d.gateway import Gateway
from cart2d.link import Link, LinkError
from cart2d.params import settings_table
from cart2d.planner import Grid, PlanError
from cart2d.simulator import SimOptions, Simulator
from cart2d.store import GatewaySettings, MapSettings, Store

Coordinate = float


class GridSpec(BaseModel):
    model_config = ConfigDict(extra="forbid")
    cols: int = Field(10, ge=2, le=1000)
    rows: int = Field(10, ge=2, le=1000)
    step: float = Field(0.2, ge=0.01, le=10.0, allow_inf_nan=False)


class MissionSpec(BaseModel):
    model_config = ConfigDict(extra="forbid")
    grid: GridSpec = Field(default_factory=GridSpec)
    obstacles: list[tuple[Coordinate, Coordinate]] = Field(default_factory=list)
    start: tuple[Coordinate, Coordinate, Coordinate] = (0.0, 0.0, 0.0)
    goals: list[tuple[Coordinate, Coordinate]] = Field(min_length=1, max_length=1000)
    settings: dict[str, float] = Field(default_factory=dict, description="firmware settings by name")
    faults: dict[str, float] = Field(default_factory=dict, description="simulator faults (sim/README.md)")
    timeout_s: float = Field(120.0, gt=0.0, le=1e5, allow_inf_nan=False, description="simulated seconds")


class Odometer:
    """Integrates the true path length from the simulator's truth stream."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._last: tuple[float, float] | None = None
        self.length_m = 0.0

    def __call__(self, truth: dict[str, Any]) -> None:
        with self._lock:
            here = (truth["x"], truth["y"])
            if self._last is not None:
                self.length_m += math.dist(self._last, here)
            self._last = here

    def read(self) -> float:
        with self._lock:
            return self.length_m


def _apply_settings(link: Link, settings: dict[str, float]) -> None:
    ids = {s["name"]: s["id"] for s in settings_table()}
    for name, value in settings.items():
        if name not in ids:
            raise ValueError(f"unknown firmware setting {name!r} (config/robot.toml lists them)")
        link.call("PARAM_SET", ids[name], value)


def _drive_to(
    gateway: Gateway, sim: Simulator, goal: tuple[float, float], deadline_t: float
) -> dict[str, Any]:
    result: dict[str, Any] = {"goal": list(goal), "reached": False}
    try:
        plan = gateway.go_to(*goal)
    except PlanError as exc:
        return {**result, "reason": str(exc)}
    result["planned_length_m"] = plan.length_m
    while gateway.mission_view()["state"] == "driving":
        if sim.truth()["t"] > deadline_t:
            gateway.stop()
            return {**result, "reason": "timeout: the mission's time ran out"}
        time.sleep(0.01)
    mission = gateway.mission_view()
    if mission["state"] != "arrived":
        return {**result, "reason": mission["reason"]}
    return {**result, "reached": True}


def run_mission(
    spec: MissionSpec, speed: str = "max", seed: int = 1, progress: bool = False
) -> dict[str, Any]:
    """Runs the mission in a fresh simulator (blank EEPROM); returns the report."""
    g = spec.grid
    grid = Grid(cols=g.cols, rows=g.rows, step_m=g.step)
    with tempfile.TemporaryDirectory() as tmp:
        options = SimOptions(
            speed=speed,
            seed=seed,
            eeprom=Path(tmp) / "eeprom.bin",
            start=spec.start,
            grid=(max(g.cols, g.rows), g.step),
            quiet=True,
        )
        store = Store(Path(tmp) / "gateway")
        nodes = sorted({grid.nearest_node(x, y) for x, y in spec.obstacles})
        settings = GatewaySettings(map=MapSettings(cols=g.cols, rows=g.rows, step_m=g.step, obstacles=nodes))
        wall_start = time.monotonic()
        with Simulator(options) as sim, Link(sim.pty) as link:
            odometer = Odometer()
            assert sim.side is not None
            sim.side.subscribe(odometer)
            sim.control("obstacles", step=g.step, size=max(g.cols, g.rows), cells=[list(n) for n in nodes])
            if spec.faults:
                sim.control("faults", **spec.faults)
            gateway = Gateway(link, store, settings, sim)
            gateway.check_firmware()
            _apply_settings(link, spec.settings)
            link.call("SET_POSE", *spec.start)
            gateway.start()
            t0 = sim.truth()["t"]
            deadline = t0 + spec.timeout_s
            goals: list[dict[str, Any]] = []
            try:
                for goal in tqdm(spec.goals, desc="goals", unit="goal", disable=not progress):
                    t_goal, length_before = sim.truth()["t"], odometer.read()
                    result = _drive_to(gateway, sim, goal, deadline)
                    truth = sim.truth()
                    x, y, _ = link.call("POSE")
                    result.update(
                        time_s=truth["t"] - t_goal,
                        final_error_m=math.dist((truth["x"], truth["y"]), goal),
                        odometry_error_m=math.dist((truth["x"], truth["y"]), (x, y)),
                        path_length_m=odometer.read() - length_before,
                    )
                    goals.append(result)
            finally:
                gateway.close()
            truth = sim.truth()
        sim_time = truth["t"] - t0
        return {
            "goals": goals,
            "collisions": truth["collisions"],
            "wall_contacts": truth["wall_contacts"],
            "sim_time_s": sim_time,
            "real_time_factor": sim_time / max(time.monotonic() - wall_start, 1e-9),
        }


def main_mission(mission_path: Path, report_path: Path, speed: str, seed: int) -> int:
    """The `cart2d mission` command: always writes the report; 0 only if every goal was reached."""
    report: dict[str, Any]
    try:
        spec = MissionSpec.model_validate_json(mission_path.read_bytes())
        report = run_mission(spec, speed, seed, progress=sys.stderr.isatty())
    except (OSError, ValidationError, ValueError, LinkError) as exc:
        report = {"error": f"{type(exc).__name__}: {exc}", "goals": []}
    report_path.write_text(json.dumps(report, indent=2) + "\n")
    ok = "error" not in report and all(g["reached"] for g in report["goals"])
    reached = sum(g["reached"] for g in report.get("goals", []))
    print(
        f"{reached} of {len(report.get('goals', []))} goals reached; report in {report_path}", file=sys.stderr
    )
    if "error" in report:
        print(f"cart2d mission: {report['error']}", file=sys.stderr)
    return 0 if ok else 1

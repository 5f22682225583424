"""Exploration in the simulator (issue 26): an arena with boxes the map does not show, the
simulated camera and perception in lockstep with the simulator (cart2d/tools/missions/camera.py),
the gateway's exploration (POST /api/explore's) started and followed to its end. What the test
(tests/tools/test_exploration_sim.py) and the bench (bench/localisation.py) measure: how it
ended, the simulated time, collisions and box contacts, the share of the reachable floor seen
over simulated time, and the saved map against the true world (exploration_metrics.py)."""

from __future__ import annotations

import dataclasses
import shutil
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from cart2d.gateway.exploration_service import seen_if_seeing
from cart2d.gateway.live_map import world_for
from cart2d.link import Link
from cart2d.maps.ros import load_ros_map
from cart2d.maps.world import Box
from cart2d.simulation.simulator import SimOptions, Simulator
from cart2d.simulation.wiring import simulated_gateway
from cart2d.store import GatewaySettings, MapSettings, Store
from cart2d.tools.exploration_metrics import compare, reachable_floor, seen_share
from cart2d.tools.localised_run import arena_bounds
from cart2d.tools.missions.camera import mission_camera

Pose = tuple[float, float, float]
SAMPLE_EVERY_S = 0.5  # wall seconds between looks at the share of the floor seen


@dataclass
class Exploring:
    grid: tuple[int, int, float]  # cols, rows, step: the arena's walls around it
    boxes: tuple[Box, ...]  # in the simulated world, not on the map
    start: Pose
    timeout_s: float = 300.0  # simulated: a STOP then
    speed: str = "max"
    seed: int = 1
    calibration: Path | None = None  # a saved camera calibration to see with; None: the nominal model


def explore_in_simulator(run: Exploring, name: str = "explored", keep: Path | None = None) -> dict[str, Any]:
    """Explores; the report. `keep`: a folder the saved map is copied to."""
    settings = GatewaySettings(map=MapSettings(cols=run.grid[0], rows=run.grid[1], step_m=run.grid[2]))
    bounds = arena_bounds(run.grid)
    report: dict[str, Any] = {"seen_share": [], "contacts_at": []}
    with tempfile.TemporaryDirectory() as tmp:
        options = SimOptions(
            speed=run.speed,
            seed=run.seed,
            eeprom=Path(tmp) / "eeprom.bin",
            start=run.start,
            world=dataclasses.replace(world_for(settings.map), boxes=run.boxes),
            quiet=True,
        )
        store = Store(Path(tmp) / "gateway")
        with Simulator(options) as sim, Link(sim.pty) as link:
            gateway = simulated_gateway(link, store, settings, sim).gateway
            try:
                gateway.wait_for_firmware(10.0, 0.1)
                link.call("SET_POSE", *run.start)
                gateway.start()
                with mission_camera(gateway, sim, run.calibration) as step:
                    t0 = sim.truth()["t"]
                    gateway.exploration.start(name)
                    _follow(gateway, sim, run, bounds, t0, report)
                    report["exploration"] = gateway.exploration.view()
                    report["lockstep"] = step.report() if step is not None else None
            finally:
                gateway.close()
            truth = sim.truth()
            report.update(
                collisions=truth["collisions"], box_contacts=truth["box_contacts"], sim_s=truth["t"] - t0
            )
        saved = report["exploration"]["saved"]
        if saved:
            if keep is not None:
                keep.mkdir(parents=True, exist_ok=True)
                for part in (Path(saved), Path(saved).with_suffix(".pgm")):
                    shutil.copy(part, keep / part.name)
            occupancy = load_ros_map(Path(saved))
            floor = reachable_floor(occupancy, bounds, run.boxes, run.start[:2])
            report["saved"] = {
                "cells": list(occupancy.cells.shape),
                "seen_share": round(seen_share(occupancy, floor), 3),
                "with_walls": compare(occupancy, bounds, run.boxes),
                "boxes": compare(occupancy, bounds, run.boxes, walls=False),
            }
    return report


def _follow(
    gateway: Any,
    sim: Simulator,
    run: Exploring,
    bounds: tuple[float, float, float, float],
    t0: float,
    report: dict[str, Any],
) -> None:
    """Until exploration ends (a STOP after run.timeout_s simulated): [simulated s, share of the
    reachable floor seen] every SAMPLE_EVERY_S of wall time in report["seen_share"], and where
    the cart was when the simulator counted a contact in report["contacts_at"]."""
    floor = None
    stopped = threading.Event()
    shares: list[list[float]] = report["seen_share"]
    contacts = 0
    while not gateway.exploration.wait(SAMPLE_EVERY_S):
        truth = sim.truth()
        t = truth["t"] - t0
        if truth["box_contacts"] + truth["collisions"] > contacts:
            contacts = truth["box_contacts"] + truth["collisions"]
            where = [round(truth[k], 3) for k in ("x", "y", "theta")]
            report["contacts_at"].append([round(t, 2), *where, gateway.mission_view()["reason"]])
        seen = seen_if_seeing(gateway.seeing)
        if seen is not None:
            if floor is None:
                floor = reachable_floor(seen, bounds, run.boxes, run.start[:2])
            shares.append([round(t, 2), round(seen_share(seen, floor), 3)])
        if t > run.timeout_s and not stopped.is_set():
            stopped.set()
            gateway.stop("exploration took too long")
            time.sleep(0.1)


def time_to_share(shares: list[list[float]], share: float) -> float | None:
    """The simulated time the share of the reachable floor seen first reached `share`."""
    return next((t for t, s in shares if s >= share), None)

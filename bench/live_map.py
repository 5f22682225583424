"""## Live map: replans while the cart drives, and floor plans of 2000 x 2000 cells

**Missions with map changes.** `cart2d mission` with `"events"`: obstacles added (and removed) at
simulated times while the cart drives, physical in the simulator from that moment (the cart
cannot pass them; touching one counts as a collision). The gateway hears of each change as it
would of a user's click, checks the rest of its path (footprint plus clearance) and, when the
change blocks it, replans from the measured pose and replaces the firmware's path while the cart
drives. Measured: every goal reached, collisions, the time to goal against the lower bound of
the *final* map (L/v_max + v_max/a_max, L the length the planner finds on the map as it ends,
known from the start), the time from a change to the new path in the firmware (simulated time:
the simulator is paced to the wall clock while the gateway works, as a cart would go on
driving), and the replans' plan times (wall clock, this machine).

**Planning on large floor plans.** Synthetic houses of 2000 x 2000 cells at 5 cm (100 m x 100 m:
rooms 5 m wide, 10 cm walls, 1 m doors, some doors shut, a few pieces of furniture), planned
from one corner room to the opposite one, on blocks of 2 x 2 cells (the gateway's default
planning step: half the planning radius, 0.1 m). Times: the planner for a new map (coarsening,
the graph), the first plan (it builds the search structure), a later plan, and a replan after
an obstacle appears (the graph and search structure rebuilt, then the plan); median and range
over repeats, wall clock, one thread.

`python -m bench.live_map [--quick]`.
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np

from bench.common import Section, missed, percentile, section_main, spread, table
from cart2d.gateway.live_map import planner_for
from cart2d.maps import OCCUPIED, OccupancyMap, save_ros_map
from cart2d.params import settings_table
from cart2d.store import FloorPlan, MapSettings
from cart2d.tools.missions.run import mission_map, run_mission
from cart2d.tools.missions.spec import MissionSpec

NAME = "live_map"
_DEFAULTS = {s["name"]: float(s["default"]) for s in settings_table()}
V_MAX, A_MAX = _DEFAULTS["v_max_mps"], _DEFAULTS["a_max_mps2"]
TIME_RATIO_TARGET = 1.5  # time to goal against the final map's bound
LATENCY_TARGET_S = 0.5  # a change to the new path in the firmware, p99, simulated
PLAN_TARGET_S = 1.0  # a plan or replan on a 2000 x 2000 floor plan, worst of the repeats


def house(cells: int = 2000, resolution: float = 0.05, seed: int = 1) -> OccupancyMap:
    """Rooms of 5 m in a grid, 10 cm walls with a 1 m door in each, a fifth of the doors shut,
    furniture (0.5 to 1.5 m boxes) in some rooms; the outline walled."""
    rng = np.random.default_rng(seed)
    grid = np.zeros((cells, cells), dtype=np.int8)
    room, wall, door = round(5.0 / resolution), round(0.1 / resolution), round(1.0 / resolution)
    for k in range(0, cells, room):
        grid[k : k + wall, :] = OCCUPIED
        grid[:, k : k + wall] = OCCUPIED
    grid[-wall:, :] = grid[:, -wall:] = OCCUPIED
    for k in range(0, cells - room + 1, room):  # rooms: rows from k, columns from m
        for m in range(0, cells - room + 1, room):
            if k > 0 and rng.random() >= 0.2:  # a door in its bottom wall, unless shut
                at = m + int(rng.integers(wall + 2, room - door - 2))
                grid[k : k + wall, at : at + door] = 0
            if m > 0 and rng.random() >= 0.2:  # and in its left wall
                at = k + int(rng.integers(wall + 2, room - door - 2))
                grid[at : at + door, m : m + wall] = 0
            if rng.random() < 0.5:
                w, h = (int(rng.integers(10, 30)) for _ in range(2))
                x, y = (
                    m + int(rng.integers(wall + 25, room - 55)),
                    k + int(rng.integers(wall + 25, room - 55)),
                )
                grid[y : y + h, x : x + w] = OCCUPIED
    return OccupancyMap((0.0, 0.0), resolution, grid)


def plan_times(repeats: int) -> dict[str, Any]:
    """Times of the planner on a 2000 x 2000 house (see the module's docstring)."""
    build, first, later, replan = [], [], [], []
    length = 0.0
    start, goal = (0.8, 0.8), (99.2, 99.2)  # corners of the corner rooms, clear of furniture
    for seed in range(1, repeats + 1):
        floor = FloorPlan.of(house(seed=seed), "house")
        settings = MapSettings.model_validate({"floor_plan": floor})
        t0 = time.perf_counter()
        planner = planner_for(settings)
        t1 = time.perf_counter()
        plan = planner.plan(start, goal)
        t2 = time.perf_counter()
        planner.plan(start, goal)
        t3 = time.perf_counter()
        # an obstacle on the path: a new graph and search structure, then the plan
        x, y = plan.waypoints[len(plan.waypoints) // 2]
        planner.add_obstacle(x, y)
        t4 = time.perf_counter()
        planner.plan(start, goal)
        t5 = time.perf_counter()
        build.append(t1 - t0)
        first.append(t2 - t1)
        later.append(t3 - t2)
        replan.append(t5 - t4)
        length = plan.length_m
    return {
        "cells": "2000 x 2000",
        "nodes": f"{settings.cols} x {settings.rows}",
        "step_m": settings.step_m,
        "path_length_m": length,
        "build_s": spread(build).as_dict(),
        "first_plan_s": spread(first).as_dict(),
        "later_plan_s": spread(later).as_dict(),
        "replan_s": spread(replan).as_dict(),
    }


def room_map(directory: Path) -> Path:
    """A 6 x 4 m floor plan at 5 cm: outline walls and a partition with a door."""
    cells = np.zeros((80, 120), dtype=np.int8)
    cells[0, :] = cells[-1, :] = cells[:, 0] = cells[:, -1] = OCCUPIED
    cells[:, 59:61] = OCCUPIED
    cells[30:50, 59:61] = 0  # a 1 m door in the partition at x = 2.5 m
    path = directory / "rooms.yaml"
    save_ros_map(OccupancyMap((-0.5, -0.5), 0.05, cells), path)
    return path


def scenes(directory: Path) -> list[tuple[str, dict[str, Any]]]:
    arena = {"grid": {"cols": 41, "rows": 41, "step": 0.1}}
    return [
        (
            "a box on the path",
            {"start": [0.0, 0.8, 0.0], "goals": [[1.8, 0.8]], "events": [{"at_s": 1.0, "add": [[1.0, 0.8]]}]},
        ),
        (
            "a wall across, gap at the top",
            {
                **arena,
                "start": [0.5, 0.5, 0.0],
                "goals": [[3.5, 0.5]],
                "events": [{"at_s": 1.5, "add": [[2.0, y / 10] for y in range(0, 31)]}],
            },
        ),
        (
            "three changes, one removed",
            {
                **arena,
                "start": [0.5, 2.0, 0.0],
                "goals": [[3.5, 2.0], [0.5, 2.0]],
                "events": [
                    {"at_s": 1.0, "add": [[1.8, 1.8], [1.8, 1.9], [1.8, 2.0], [1.8, 2.1], [1.8, 2.2]]},
                    {"at_s": 2.5, "add": [[2.8, 1.4], [2.8, 1.5], [2.8, 1.6], [2.8, 1.7]]},
                    {"at_s": 5.0, "remove": [[1.8, 2.0]]},
                    {"at_s": 9.0, "add": [[2.0, 2.4], [2.0, 2.5], [2.0, 2.6], [2.0, 2.7]]},
                ],
            },
        ),
        (
            "a floor plan, the door blocked",
            {
                "map": str(room_map(directory)),
                "start": [0.5, 1.5, 0.0],
                "goals": [[4.5, 1.5]],
                "events": [{"at_s": 1.0, "add": [[2.5, 1.6], [2.5, 1.7], [2.5, 1.8]]}],
            },
        ),
    ]


def final_bound(spec: MissionSpec) -> float:
    """L/v_max + v_max/a_max per goal, L planned on the map as the events leave it."""
    m = mission_map(spec)
    planner = planner_for(m)
    for event in sorted(spec.events, key=lambda e: e.at_s):
        for x, y in event.add:
            planner.add_obstacle(x, y)
        for x, y in event.remove:
            planner.remove_obstacle(x, y)
    here = (spec.start[0], spec.start[1])
    total = 0.0
    for goal in spec.goals:
        total += planner.plan(here, goal).length_m / V_MAX + V_MAX / A_MAX
        here = goal
    return total


def run_missions(directory: Path, seeds: int) -> list[dict[str, Any]]:
    rows = []
    for name, mission in scenes(directory):
        spec = MissionSpec.model_validate(mission)
        bound = final_bound(spec)
        for seed in range(1, seeds + 1):
            report = run_mission(spec, seed=seed)
            goals = report["goals"]
            rows.append(
                {
                    "scene": name,
                    "seed": seed,
                    "reached": all(g["reached"] for g in goals),
                    "reasons": [g.get("reason", "") for g in goals if not g["reached"]],
                    "collisions": report["collisions"],
                    "wall_contacts": report["wall_contacts"],
                    "time_s": sum(g["time_s"] for g in goals),
                    "bound_s": bound,
                    "replans": report["replans"],
                    "latencies_s": [
                        e["new_path_after_s"] for e in report["events"] if e["new_path_after_s"] is not None
                    ],
                    "trace": goals[0]["trace"] if seed == 1 else [],
                    "obstacles": [p for e in spec.events for p in e.add],
                }
            )
    return rows


def plot(rows: list[dict[str, Any]], out: Path) -> None:
    first = [r for r in rows if r["seed"] == 1]
    fig, axes = plt.subplots(1, len(first), figsize=(4 * len(first), 4))
    for ax, row in zip(np.atleast_1d(axes), first, strict=True):
        ax.plot([t[1] for t in row["trace"]], [t[2] for t in row["trace"]], color="tab:blue", linewidth=1)
        for x, y in row["obstacles"]:
            ax.plot(x, y, "s", color="tab:red", markersize=4)
        ax.set_aspect("equal")
        ax.set_title(row["scene"], fontsize=9)
        ax.set_xlabel("x (m)")
    fig.suptitle("True tracks (blue) around obstacles that appeared while driving (red)")
    fig.tight_layout()
    fig.savefig(out / f"{NAME}_tracks.png", dpi=100)
    plt.close(fig)


def run(out: Path, quick: bool) -> Section:
    with tempfile.TemporaryDirectory() as tmp:
        rows = run_missions(Path(tmp), 1 if quick else 3)
    planning = plan_times(2 if quick else 5)
    out.mkdir(parents=True, exist_ok=True)
    plot(rows, out)
    latencies = [v for r in rows for v in r["latencies_s"]]
    plan_s = [p["plan_time_s"] for r in rows for p in r["replans"]]
    p50, p99 = percentile(latencies, 50), percentile(latencies, 99)
    ratios = [r["time_s"] / r["bound_s"] for r in rows]
    worst_plan = max(planning["first_plan_s"]["high"], planning["replan_s"]["high"])
    checks = [
        ("every goal reached", all(r["reached"] for r in rows)),
        (
            "zero collisions and wall contacts",
            all(r["collisions"] == 0 and r["wall_contacts"] == 0 for r in rows),
        ),
        (f"time within {TIME_RATIO_TARGET} x the final map's bound", max(ratios) <= TIME_RATIO_TARGET),
        (f"change to new path p99 under {LATENCY_TARGET_S} s", p99 < LATENCY_TARGET_S),
    ]
    wall_clock = [(f"2000 x 2000 plans under {PLAN_TARGET_S} s", worst_plan < PLAN_TARGET_S)]
    mission_rows = [
        [
            r["scene"],
            r["seed"],
            "yes" if r["reached"] else "NO: " + "; ".join(r["reasons"]),
            r["collisions"],
            len(r["replans"]),
            f"{r['time_s']:.2f}",
            f"{r['bound_s']:.2f}",
            f"{r['time_s'] / r['bound_s']:.2f}",
        ]
        for r in rows
    ]

    def s(key: str) -> str:
        t = planning[key]
        return f"{t['median']:.3f} s ({t['low']:.3f} to {t['high']:.3f})"

    markdown = (
        (__doc__ or "").strip()
        + "\n\n"
        + table(
            ["scene", "seed", "reached", "collisions", "replans", "time (s)", "bound (s)", "ratio"],
            mission_rows,
        )
        + f"\nTime from a map change to the new path in the firmware (simulated): p50 {p50 * 1000:.0f} ms, "
        f"p99 {p99 * 1000:.0f} ms over {len(latencies)} replans; their plan times "
        f"{spread(plan_s).text('.4f', 's')} (median, range).\n\n"
        f"Floor plans of {planning['cells']} cells, planned on {planning['nodes']} nodes "
        f"({planning['step_m']:g} m), a {planning['path_length_m']:.0f} m path: a new map "
        f"{s('build_s')}, the first plan {s('first_plan_s')}, later plans {s('later_plan_s')}, "
        f"a replan after a change {s('replan_s')} (median, range).\n\n"
        + table(
            ["target", "met"],
            [[name, "yes" if ok else "**NO**"] for name, ok in checks]
            + [[f"{name} (wall clock: reported)", "yes" if ok else "**NO**"] for name, ok in wall_clock],
        )
        + f"\n![tracks]({NAME}_tracks.png)\n"
    )
    data = {
        "missions": [{k: v for k, v in r.items() if k not in ("trace",)} for r in rows],
        "latency_p50_s": p50,
        "latency_p99_s": p99,
        "replan_plan_times_s": plan_s,
        "planning_2000": planning,
        "checks": dict(checks + wall_clock),
    }
    return Section(NAME, markdown, data, all(ok for _, ok in checks), missed(wall_clock))


if __name__ == "__main__":
    sys.exit(section_main(run))

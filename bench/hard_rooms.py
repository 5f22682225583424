"""### Hard rooms: missions that see in the named rooms

The named rooms of docs/examples/ (issue 24: a tiled kitchen with off-white walls, chair legs, a
beige step and two lamps; an office on a glossy grey floor; a patterned carpet; a corridor of wood
planks), each file's boxes and look as the mission's world: the map knows none of the boxes, the
cart drives with the simulated ESP32-CAM and the gateway's perception, in lockstep, with the
calibration made once in the simulator (as bench/perception_missions.py's unknown arenas do).
Each mission goes across its room, from a corner to a goal among the furniture, and is compared
with the same mission on the known map: the boxes on a planning grid of 0.1 m (every node whose
cell a box overlaps is an obstacle), no boxes, no camera, same simulator seed.

*time unknown / known*: from the goal's request to arrival (the look before driving off counts).
Mapping, from the cells perception believes occupied at the mission's end (perception_missions'
mapping_quality): *precision, a cell* against the room's boxes grown by a cell and the walls;
*recall* of the box faces the cart could have seen; *false cells* farther than 0.1 m from every
box and wall (obstacles on open floor). A step 5 cm high is a box like the others.
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path
from typing import Any

from bench.common import Section, missed, spread, table
from bench.seeing_runs import calibration_file, paired_run
from cart2d.perception.camera_model import Mount
from cart2d.spec import repo_file

TIME_TARGET = 1.3  # unknown map / known map
PRECISION_TARGET = 0.9  # against the boxes grown by a cell
RECALL_TARGET = 0.9
SEEDS = (1, 2, 3)
STEP_M = 0.1  # the planning grid: the rooms' legs are 2.5 cm, a 0.2 m grid would block them coarsely
NODES = 19  # 1.8 m of nodes, the default arena the rooms are drawn for (walls 0.25 m beyond)
TIMEOUT_S = 90.0

# Start (x, y, heading) and goal of each room's mission: across the room, among its furniture.
MISSIONS: dict[str, tuple[tuple[float, float, float], tuple[float, float]]] = {
    "kitchen": ((0.0, 1.0, 0.0), (1.75, 0.8)),  # the straight line runs into a chair's front leg
    "office": ((0.0, 0.2, 0.0), (0.65, 1.2)),  # between two chairs, the bench and the desk
    "carpet": ((0.0, 0.2, 0.0), (1.2, 1.45)),  # round the cardboard box, past the table and sofa
    "corridor": ((0.0, 0.1, 0.0), (1.5, 0.1)),  # past the plant stand and the radiator, to the step
}
# CI's run (make bench-quick): a room whose missions are driven safely today, judged on the
# missions' targets only (QUICK_TARGETS), so that it guards them; the kitchen's cart runs into a
# leg, and the mapping targets are missed in every room (docs/perception.md): the full bench
# judges and reports those.
QUICK_ROOM = "office"
QUICK_TARGETS = ("reached", "no contact", "time")


def room_world(name: str) -> dict[str, Any]:
    world: dict[str, Any] = json.loads(repo_file("docs", "examples", f"{name}.json").read_text())
    return world


def known_nodes(boxes: list[dict[str, Any]]) -> list[tuple[float, float]]:
    """The planning nodes whose cell (STEP_M square) a box overlaps: the known map's obstacles."""
    nodes = set()
    half = STEP_M / 2
    for b in boxes:
        for i in range(NODES):
            for j in range(NODES):
                x, y = i * STEP_M, j * STEP_M
                if abs(x - b["x"]) < b["sx"] / 2 + half and abs(y - b["y"]) < b["sy"] / 2 + half:
                    nodes.add((round(x, 3), round(y, 3)))
    return sorted(nodes)


def missions(name: str) -> tuple[dict[str, Any], dict[str, Any]]:
    """The room's mission with its boxes unknown (the world, its look), and on the known map."""
    start, goal = MISSIONS[name]
    base = {
        "grid": {"cols": NODES, "rows": NODES, "step": STEP_M},
        "start": list(start),
        "goals": [list(goal)],
        "timeout_s": TIMEOUT_S,
    }
    world = room_world(name)
    unknown = {**base, "world": world}
    known = {**base, "obstacles": [list(n) for n in known_nodes(world["boxes"])]}
    return unknown, known


def room_run(name: str, calibration: Path, seed: int) -> dict[str, Any]:
    unknown_mission, known_mission = missions(name)
    run = paired_run(unknown_mission, known_mission, unknown_mission["world"]["boxes"], calibration, seed)
    return {"room": name, "seed": seed, **run.row()}


def _fmt(value: float | None, fmt: str = ".2f") -> str:
    return "n/a" if value is None else f"{value:{fmt}}"


def run_checks(r: dict[str, Any]) -> dict[str, bool]:
    """Each target for one run."""
    m = r["mapping"]
    return {
        "reached": r["reached"],
        "no contact": r["collisions"] == 0 and r["box_contacts"] == 0,
        "time": r["time_ratio"] is not None and r["time_ratio"] <= TIME_TARGET,
        "precision": m["precision_cell"] is not None and m["precision_cell"] >= PRECISION_TARGET,
        "recall": m["recall"] is not None and m["recall"] >= RECALL_TARGET,
        "no false cells": m["false_cells"] == 0,
    }


def _row(r: dict[str, Any]) -> list[object]:
    m = r["mapping"]
    failed = [name for name, ok in run_checks(r).items() if not ok]
    known = f"{_fmt(r['known_start_s'])} + {_fmt(r['known_time_s'])}"
    return [
        r["room"],
        r["seed"],
        "yes" if r["reached"] else f"**no** ({r['reason']})",
        f"{r['collisions']} + {r['box_contacts']}",
        f"{_fmt(r['start_s'])} + {_fmt(r['time_s'])} / {known}",
        _fmt(r["time_ratio"]),
        _fmt(m["precision_cell"]),
        f"{_fmt(m['recall'])} of {m['visible_box_cells']}",
        m["false_cells"],
        m["cells"],
        f"{_fmt(r['perception_wait_s'], '.1f')} ({_fmt(r['real_time_factor'])})",
        "MISSED: " + ", ".join(failed) if failed else "",
    ]


def run(out: Path, quick: bool) -> Section:
    rooms = [QUICK_ROOM] if quick else list(MISSIONS)
    seeds = SEEDS[:1] if quick else SEEDS
    with tempfile.TemporaryDirectory() as tmp:
        calibration, _ = calibration_file(Path(tmp), Mount.from_robot())
        runs = [room_run(name, calibration, seed) for name in rooms for seed in seeds]
    targets = {
        "reached": "every goal reached",
        "no contact": "0 collisions and 0 box contacts",
        "time": f"time <= {TIME_TARGET} x the known map's",
        "precision": f"mapping precision (boxes grown by a cell) >= {PRECISION_TARGET}",
        "recall": f"recall of visible faces >= {RECALL_TARGET}",
        "no false cells": "no false cells on open floor",
    }
    checks = []
    for key, text in targets.items():
        if quick and key not in QUICK_TARGETS:
            continue
        bad = [f"{r['room']} seed {r['seed']}" for r in runs if not run_checks(r)[key]]
        checks.append((f"hard rooms: {text}" + (f" (missed: {', '.join(bad)})" if bad else ""), not bad))
    header = [
        "room",
        "seed",
        "reached",
        "collisions + box contacts",
        "time s unknown / known (start + drive)",
        "unknown / known",
        "precision, a cell",
        "recall",
        "false cells",
        "cells",
        "waited s (rtf)",
        "",
    ]
    ratios = [r["time_ratio"] for r in runs if r["time_ratio"] is not None]
    markdown = (
        (__doc__ or "").strip()
        + f"\n\nRooms {', '.join(rooms)}; simulator seeds {', '.join(map(str, seeds))}"
        + (" (the quick run: one room, one seed, judged on the mission's targets)" if quick else "")
        + ".\n\n"
        + table(header, [_row(r) for r in runs])
        + (f"\nunknown / known over the runs that reached: {spread(ratios).text('.2f')}.\n" if ratios else "")
        + "\n"
        + "\n".join(f"- {name}: {'met' if ok else 'MISSED'}" for name, ok in checks)
        + "\n"
    )
    return Section(
        "hard rooms", markdown, {"runs": runs, "missed": missed(checks)}, all(ok for _, ok in checks)
    )

"""### Unknown arenas: missions that see

The scenes of the missions benchmark (bench/scenes.py) with their obstacles as physical boxes the
map does not show: each obstacle node's cell becomes a box of step x step centred on the node,
BOX_HEIGHT_M high, cardboard-coloured (the floor is light grey); the map has no obstacles. The
cart drives with the simulated ESP32-CAM and the gateway's perception (cart2d/tools/missions/camera.py),
seeing with a calibration made once in the simulator (calibrate_in_simulator, the real
procedure's floor board) and saved as a user's would be. Missions that see run the simulator in
real time and in lockstep with perception (cart2d/simulation/lockstep.py): perception runs on the
gateway's wall clock, and the simulator waits while it is more than two camera frames behind, so
what the cart has seen where it stands, and the times below, do not depend on the machine's load
(*waited s*: the wall seconds the simulator waited for perception; *rtf*: simulated seconds per
wall second over the whole mission). Each is compared with the same
scene with the map known (its obstacles on the map, no boxes: bench/missions.py's run_one), same
simulator seed. *time unknown / known*: from the goal's request to arrival, in firmware ticks:
*start* up to the first telemetry frame in PATH mode (planning and the upload; while it sees, the
frames taken in first and the look before driving off, cart2d/gateway/look.py: *look s* of it
turning on the spot, MANUAL mode), then *drive* in PATH mode. Targets: every goal reached, zero
collisions and box contacts, time <= TIME_TARGET x the known map's.

**Mapping**, from the cells perception believes occupied (p > 0.8, 2.5 cm) at the mission's end:
- *precision*: the fraction of perceived cells whose square overlaps a box or lies beyond an arena
  wall (the walls are physical obstacles the camera sees too). The gateway takes an obstacle
  seen by its face to be as deep as it is wide, up to seeing.OBSTACLE_DEPTH_M (behind the face), until
  views from elsewhere clear the floor behind it, and a hit marks its whole cell: a cell past a
  box's faces is expected, so precision is given against the boxes as they are, and against the
  boxes grown by a cell on every side (*precision, a cell*).
- *recall*: over the box cells the cart could have seen: the cells (of that size) inside a box
  along a face that is not against another box or outside the arena, whose centre is within RECALL_RANGE_M of
  some point of the driven trace (ground truth) lying in front of that face (occlusion by other
  boxes is not modelled, so this is a lower bound). Such a cell counts as found when a perceived
  cell is on it or on one of its 8 neighbours (a hit is placed within about a cell's size).
- *false obstacles*: perceived cells whose centre is farther than FALSE_MARGIN_M from every box
  and wall: obstacles on open floor.

**Frame-to-replan latency**: a box beyond the camera's range at the start (in the 4 m arena, 2 m
straight ahead on the way to the goal; the look before driving off does not reach it) comes into
view as the cart drives towards it. *in view*: the capture stamp (X-Timestamp, simulated time) of
the first processed frame from whose pose (the odometry pose perception used) a point of the box's
foot is in the picture and within the detector's range (plus RANGE_SLACK_M: a foot there is placed a
little nearer); *cause*: the stamp of the frame whose processing made the perceived layer block the
route (Seeing records it per replan); *in firmware*: the simulated time the replan's new path was in
the firmware (Replan.sim_t). In-view to cause is the evidence the log-odds grid needs (in view is
known to a frame: the box may have entered the view up to a frame period, 67 ms at 15 fps, before
that capture); cause to firmware is the frame's latency, processing, planning and upload. The
causing frame to firmware time is also given for every camera replan of the unknown-arena missions.
*driven backwards*: the odometry distance the cart drove in reverse (the firmware's polar law
reverses to a waypoint behind it): driven blind, the camera looks ahead.
"""

from __future__ import annotations

import math
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.patches import Rectangle

from bench.common import spread, table
from bench.scenes import Scene, scenes
from bench.seeing_runs import calibration_file, first_goal, paired_run, see, waited
from cart2d.perception.camera_model import Mount
from cart2d.perception.detection import DetectorConfig
from cart2d.perception.synthetic import true_pixels
from cart2d.tools.camera_calibration.simulated import simulated_lens

TIME_TARGET = 1.3  # unknown map / known map
SEEDS = (1, 2, 3)  # simulator seeds each unknown-arena scene runs with (its noise and the camera's)
BOX_HEIGHT_M = 0.3
BOX_COLOUR = "#b8742f"  # cardboard
# A foot at the range's end is placed up to ~7 cm nearer (JPEG, the calibration): it is hit while
# its true distance is up to that much beyond the detector's range.
RANGE_SLACK_M = 0.1
LATENCY_BOX = {"x": 2.4, "y": 2.0, "sx": 0.2, "sy": 0.6, "height": 0.3, "colour": "#3050c0"}


# A box stands inside its node's cell, 1 cm in from each edge: real obstacles do not sit on the
# planner's cell edges, and a face exactly on one makes a 1 mm error in its place decide which of
# two planner cells it blocks. The known map still blocks the whole cell.
BOX_INSET_M = 0.01


def boxes_of(scene: Scene) -> list[dict[str, Any]]:
    size = scene.grid.step_m - 2 * BOX_INSET_M
    return [
        {"x": x, "y": y, "sx": size, "sy": size, "height": BOX_HEIGHT_M, "colour": BOX_COLOUR}
        for x, y in (scene.grid.node_xy(i, j) for i, j in sorted(scene.obstacles))
    ]


def unknown_mission(scene: Scene) -> dict[str, Any]:
    mission = scene.mission("cart2d")
    mission["obstacles"] = []
    if scene.obstacles:
        mission["world"] = {"boxes": boxes_of(scene)}
    else:  # an empty world: the camera and perception still on, seeing the walls only
        mission["world"] = {"boxes": []}
    return mission


def camera_replans(report: dict[str, Any]) -> list[dict[str, Any]]:
    return [r for r in report.get("perception", {}).get("replan_frames", []) if r["outcome"] == "replanned"]


def driven_backwards_m(frame_log: list[list[float]]) -> float:
    """How far the cart drove backwards (odometry at the frames perception processed): the
    firmware's polar law reverses to a waypoint behind it, and the camera only looks ahead."""
    poses = np.array([f[1:] for f in frame_log], dtype=float).reshape(-1, 3)
    if len(poses) < 2:
        return 0.0
    step = np.diff(poses[:, :2], axis=0)
    heading = poses[:-1, 2] + np.remainder(np.diff(poses[:, 2]) + np.pi, 2 * np.pi) / 2 - np.pi / 2
    along = step[:, 0] * np.cos(heading) + step[:, 1] * np.sin(heading)
    return float(np.abs(along[along < 0]).sum())


def scene_row(scene: Scene, calibration: Path, seed: int) -> dict[str, Any]:
    run = paired_run(unknown_mission(scene), scene.mission("cart2d"), boxes_of(scene), calibration, seed)
    unknown, g, k = run.unknown, run.goal, run.known_goal
    perception = unknown.get("perception", {})
    latencies = [r["sim_t"] - r["frame_stamp_s"] for r in camera_replans(unknown) if r["sim_t"] is not None]
    return {
        "arena": scene.arena,
        "scene": scene.name,
        "seed": seed,
        "boxes": len(scene.obstacles),
        **run.row(),
        "wall_contacts": unknown.get("wall_contacts"),
        "look_s": g.get("look_s"),
        "path_length_m": g.get("path_length_m"),
        "known_path_length_m": k.get("path_length_m"),
        "replans": len(unknown.get("replans", [])),
        "camera_replans": len(camera_replans(unknown)),
        "backwards_m": driven_backwards_m(perception.get("frame_log", [])),
        "calibrated": perception.get("calibrated", False),
        "cause_to_firmware_s": latencies,
        "trace": run.trace.round(3).tolist(),
        "known_trace": [p[1:] for p in k.get("trace", [])],
        "cells": perception.get("cells", []),
        "box_list": boxes_of(scene),
        "size_m": scene.grid.size_m,
    }


def in_view(pose: tuple[float, float, float], box: dict[str, Any], mount: Mount) -> bool:
    """Whether a point of the box's foot is in the picture and within the detector's range, from
    the cart at `pose`."""
    x, y, theta = pose
    k = 24
    hx, hy = box["sx"] / 2, box["sy"] / 2
    s = np.linspace(-1.0, 1.0, k)
    foot = np.concatenate(
        [
            np.column_stack([box["x"] + hx * s, np.full(k, box["y"] - hy)]),
            np.column_stack([box["x"] + hx * s, np.full(k, box["y"] + hy)]),
            np.column_stack([np.full(k, box["x"] - hx), box["y"] + hy * s]),
            np.column_stack([np.full(k, box["x"] + hx), box["y"] + hy * s]),
        ]
    )
    c, sn = math.cos(theta), math.sin(theta)
    d = foot - [x, y]
    local = np.column_stack([c * d[:, 0] + sn * d[:, 1], -sn * d[:, 0] + c * d[:, 1]])
    settings = DetectorConfig()
    ahead = np.hypot(local[:, 0] - mount.x_m, local[:, 1] - mount.y_m)
    front = (
        (local[:, 0] > mount.x_m + 0.05)
        & (ahead >= settings.min_range_m)
        & (ahead <= settings.max_range_m + RANGE_SLACK_M)
    )
    if not front.any():
        return False
    uv = true_pixels(simulated_lens(mount), mount, local[front])
    inside = (
        (uv[:, 0] >= 0)
        & (uv[:, 0] <= mount.width_px - 1)
        & (uv[:, 1] >= 0)
        & (uv[:, 1] <= mount.height_px - 1)
    )
    return bool(inside.any())


def latency_run(calibration: Path, seed: int, mount: Mount) -> dict[str, Any]:
    mission = {
        "grid": {"cols": 41, "rows": 41, "step": 0.1},
        "start": [0.3, 2.0, 0.0],
        "goals": [[3.7, 2.0]],
        "world": {"boxes": [LATENCY_BOX]},
        "timeout_s": 60.0,
    }
    report = see(mission, calibration, seed)
    frames = report.get("perception", {}).get("frame_log", [])
    first = next(
        (f[0] for f in frames if f[0] is not None and in_view(tuple(f[1:]), LATENCY_BOX, mount)), None
    )
    causes = camera_replans(report)
    cause = causes[0] if causes else None
    out: dict[str, Any] = {
        "seed": seed,
        "reached": bool(first_goal(report).get("reached")),
        "box_contacts": report.get("box_contacts"),
        "frames": len(frames),
        "in_view_t": first,
        "cause_t": cause["frame_stamp_s"] if cause else None,
        "firmware_t": cause["sim_t"] if cause else None,
        "perception_wait_s": waited(report),
        "real_time_factor": report.get("real_time_factor"),
    }
    if first is not None and cause is not None and cause["sim_t"] is not None:
        out["in_view_to_cause_s"] = cause["frame_stamp_s"] - first
        out["cause_to_firmware_s"] = cause["sim_t"] - cause["frame_stamp_s"]
        out["in_view_to_firmware_s"] = cause["sim_t"] - first
    return out


def _plot(rows: list[dict[str, Any]], out: Path) -> None:
    if not rows:  # the quick run has no unknown-arena missions
        return
    cols = min(5, len(rows))
    n_rows = (len(rows) + cols - 1) // cols
    fig, axes = plt.subplots(n_rows, cols, figsize=(3.3 * cols, 3.4 * n_rows), squeeze=False)
    for ax, row in zip(axes.flat, rows, strict=False):
        for b in row["box_list"]:
            ax.add_patch(
                Rectangle((b["x"] - b["sx"] / 2, b["y"] - b["sy"] / 2), b["sx"], b["sy"], color="0.6", lw=0)
            )
        if row["cells"]:
            cells = np.array(row["cells"])
            ax.scatter(
                cells[:, 0], cells[:, 1], c=cells[:, 2], cmap="Reds", vmin=0.4, vmax=1.0, s=5, marker="s"
            )
        if row["known_trace"]:
            ax.plot(*zip(*row["known_trace"], strict=True), color="tab:green", lw=1, label="map known")
        if row["trace"]:
            ax.plot(*zip(*row["trace"], strict=True), color="tab:blue", lw=1.2, label="map unknown")
        w, h = row["size_m"]
        ax.set_xlim(-0.25, w + 0.25)
        ax.set_ylim(-0.25, h + 0.25)
        ax.set_aspect("equal")
        ratio = f"{row['time_ratio']:.2f}x" if row["time_ratio"] is not None else "not reached"
        ax.set_title(f"{row['arena']}: {row['scene']} ({ratio})", fontsize=8)
        ax.tick_params(labelsize=6)
    for ax in list(axes.flat)[len(rows) :]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=6)
    fig.suptitle(
        "Unknown arenas: boxes (grey), perceived cells (red, p), driven paths (ground truth)", fontsize=9
    )
    fig.tight_layout()
    fig.savefig(out / "perception_missions.png", dpi=100)
    plt.close(fig)


def _fmt(value: float | None, fmt: str = ".2f") -> str:
    return "n/a" if value is None else f"{value:{fmt}}"


def _median(values: list[float | None]) -> float | None:
    known = [v for v in values if v is not None]
    return spread(known).median if known else None


def _ratios(runs: list[dict[str, Any]]) -> list[float]:
    """Unknown / known time of the runs that reached (on both maps)."""
    return [r["time_ratio"] for r in runs if r["reached"] and r["time_ratio"] is not None]


def _scene_cells(runs: list[dict[str, Any]]) -> list[object]:
    """A scene's table row over its runs (one per simulator seed)."""
    first = runs[0]
    reached = sum(r["reached"] for r in runs)
    failed = [r["reason"] for r in runs if not r["reached"]]
    ratios = _ratios(runs)

    def med(key: str, mapping: bool = False, fmt: str = ".2f") -> str:
        return _fmt(_median([(r["mapping"] if mapping else r)[key] for r in runs]), fmt)

    return [
        first["arena"],
        first["scene"],
        first["boxes"],
        f"{reached} of {len(runs)}" + (f" (**{failed[0]}**)" if failed else ""),
        f"{sum(r['collisions'] or 0 for r in runs)} + {sum(r['box_contacts'] or 0 for r in runs)}",
        f"{med('start_s')} + {med('time_s')} / {med('known_start_s')} + {med('known_time_s')}",
        med("look_s"),
        spread(ratios).text(".2f") if ratios else "n/a",
        f"{med('replans', fmt='.0f')} ({med('camera_replans', fmt='.0f')})",
        med("precision", True),
        med("precision_cell", True),
        f"{med('recall', True)} of {med('visible_box_cells', True, '.0f')}",
        med("false_cells", True, ".0f"),
        med("cells", True, ".0f"),
        med("frames", fmt=".0f"),
        _fmt(max(r["backwards_m"] for r in runs)),
        f"{med('perception_wait_s', fmt='.1f')} ({med('real_time_factor')})",
    ]


def measure(out: Path, quick: bool, mount: Mount) -> tuple[str, dict[str, Any], list[tuple[str, bool]]]:
    """The unknown-arena missions, their mapping and the frame-to-replan latency: Markdown, data,
    the checks."""
    # The unknown-arena missions run in real time (perception runs on the wall clock): only the
    # full benchmark has them; the quick run measures the latency mission.
    chosen = [] if quick else scenes()
    with tempfile.TemporaryDirectory() as tmp:
        calibration, calibration_s = calibration_file(Path(tmp), mount)
        runs = [[scene_row(s, calibration, seed) for seed in SEEDS] for s in chosen]
        latency = [latency_run(calibration, seed, mount) for seed in ([1] if quick else [1, 2, 3])]
    rows = [r for scene_runs in runs for r in scene_runs]
    _plot([scene_runs[0] for scene_runs in runs], out)
    body = [_scene_cells(scene_runs) for scene_runs in runs]
    header = [
        "arena",
        "mission",
        "boxes",
        "reached",
        "collisions + box contacts",
        "time s unknown / known (start + drive)",
        "look s",
        "unknown / known, median (range)",
        "replans (by a frame)",
        "precision",
        "precision, a cell",
        "recall",
        "false cells",
        "cells",
        "frames",
        "driven backwards m",
        "waited s (rtf)",
    ]
    cause_to_fw = [x for r in rows for x in r["cause_to_firmware_s"]]
    lat_body = [
        [
            x["seed"],
            "yes" if x["reached"] else "**no**",
            x["box_contacts"],
            _fmt(x.get("in_view_to_cause_s"), ".3f"),
            _fmt(x.get("cause_to_firmware_s"), ".3f"),
            _fmt(x.get("in_view_to_firmware_s"), ".3f"),
            f"{_fmt(x.get('perception_wait_s'), '.1f')} ({_fmt(x.get('real_time_factor'))})",
        ]
        for x in latency
    ]

    def missed(what: str, ok: Callable[[list[dict[str, Any]]], bool]) -> tuple[str, bool]:
        names = [f"{r[0]['arena']} {r[0]['scene']}" for r in runs if not ok(r)]
        return f"unknown arenas: {what}" + (f" (missed: {', '.join(names)})" if names else ""), not names

    arenas = [
        missed("every goal reached, every run", lambda rs: all(r["reached"] for r in rs)),
        missed(
            "0 collisions and box contacts, every run",
            lambda rs: all(r["collisions"] == 0 and r["box_contacts"] == 0 for r in rs),
        ),
        missed(
            f"time <= {TIME_TARGET} x the known map's (the median of the runs that reached)",
            lambda rs: not (got := _ratios(rs)) or spread(got).median <= TIME_TARGET,
        ),
    ]
    checks = [
        *(arenas if rows else []),
        (
            "frame-to-replan latency measured (a box coming into view caused a replan)",
            all("in_view_to_firmware_s" in x for x in latency),
        ),
    ]
    markdown = (
        (__doc__ or "").strip()
        + f"\n\nCalibration in the simulator: {calibration_s:.1f} s. Each scene ran with simulator seeds "
        f"{', '.join(map(str, SEEDS))}: medians over the runs (times, ratio, replans, mapping), sums "
        "(collisions), the plot shows seed 1's.\n\n"
        + (table(header, body) if rows else "Quick run: unknown arenas in the full run only.\n")
        + "\nFrame-to-replan latency (simulated s), a box coming into range, per simulator seed:\n\n"
        + table(
            [
                "seed",
                "reached",
                "box contacts",
                "in view -> cause",
                "cause -> firmware",
                "in view -> firmware",
                "waited s (rtf)",
            ],
            lat_body,
        )
        + (
            f"\nCausing frame's capture to the new path in the firmware over the {len(cause_to_fw)} "
            f"camera replans of the unknown-arena missions: {spread(cause_to_fw).text('.3f', 's')}.\n"
            if cause_to_fw
            else "\n"
        )
        + ("\n![unknown arenas](perception_missions.png)\n" if rows else "")
    )
    data = {
        "missions": [
            {k: v for k, v in r.items() if k not in ("trace", "known_trace", "cells", "box_list", "size_m")}
            for r in rows
        ],
        "latency": latency,
        "calibration_s": calibration_s,
    }
    return markdown, data, checks

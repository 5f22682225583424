"""## Streamed paths: a path of hundreds of waypoints through the firmware's 32-point window

The cart drives a serpentine in the 4 m arena: rows 3 m long with a waypoint every 5 cm, joined
by half-circle turns of 0.25 m radius in 12-degree chords (as cart2d/planning/smoothing.py rounds corners).
The gateway's uploader (cart2d/link/path_stream.py, PathStream) sends the first frame, then keeps the
firmware's window full as telemetry reports the waypoints passed. The simulator runs in real
time, as a cart would, so the uploader's latency is the real one. Ground truth gives the speed
trace; telemetry gives the STARVED flag (the cart had fewer points ahead than it needs to brake
from v_max: a window boundary it would have to stop at).

The window's size is then checked against the gateway's own paths: for the benchmark missions'
planned and rounded paths, how far ahead W points reach at worst, against the distance the cart
needs: braking from v_max at 0.8 a_max, plus what it drives while the uploader reacts.

`python -m bench.streaming [--quick]`.
"""

from __future__ import annotations

import itertools
import math
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt

from bench.common import Section, section_main, table
from cart2d.link import Link, firmware, path_stream
from cart2d.link.protocol import Telemetry
from cart2d.params import planning_radius_m, robot, settings_table
from cart2d.planning import Grid, Planner, Point
from cart2d.planning.smoothing import CHORD_TURN_RAD, round_corners
from cart2d.simulation.simulator import SimOptions, Simulator
from cart2d.spec import load_spec
from cart2d.tools.missions.run import run_mission
from cart2d.tools.missions.spec import MissionSpec

NAME = "streaming"
ARENA_NODES, ARENA_STEP_M = 41, 0.1  # the 4 m arena
ROW_X_M = (0.5, 3.5)
ROW_GAP_M = 0.5  # the turns' diameter
SPACING_M = 0.05
_DEFAULTS = {s["name"]: float(s["default"]) for s in settings_table()}
V_MAX = _DEFAULTS["v_max_mps"]
A_MAX = _DEFAULTS["a_max_mps2"]
BRAKING_M = V_MAX**2 / (2 * 0.8 * A_MAX)  # firmware: the speed caps brake at 0.8 a_max
REACTION_S = 0.1  # the uploader's reaction, generously: a telemetry period (40 ms) and a request
STARVED = load_spec().flags["STARVED"]
# The floor the speed must keep in the middle of each row (from SETTLE_M after a turn to SETTLE_M
# before the next one), and everywhere between the first and the last row's middles.
SETTLE_M = 0.35
ROW_FLOOR_MPS = 0.9 * V_MAX
TURN_FLOOR_MPS = 0.3


def serpentine(rows: int, y0_m: float = 0.6) -> list[Point]:
    """Rows along x, alternately east and west, a waypoint every SPACING_M; each turn a half
    circle in chords of 12 degrees. The path starts at (ROW_X_M[0], y0_m) heading east."""
    x0, x1 = ROW_X_M
    per_row = round((x1 - x0) / SPACING_M)
    radius = ROW_GAP_M / 2
    chords = math.ceil(math.pi / CHORD_TURN_RAD)
    points: list[Point] = []
    for row in range(rows):
        y = y0_m + row * ROW_GAP_M
        east = row % 2 == 0
        if row > 0:
            # The turn onto this row: round the end of the previous one (x1 after an eastward row,
            # bulging east; x0 after a westward one, bulging west), counter-clockwise seen from
            # the row below when it bulges east.
            cx, side = (x0, -1.0) if east else (x1, 1.0)
            for k in range(1, chords + 1):
                a = -math.pi / 2 + math.pi * k / chords
                points.append((cx + side * radius * math.cos(a), y - radius + radius * math.sin(a)))
        step = SPACING_M if east else -SPACING_M
        start = x0 if east else x1
        points += [(start + k * step, y) for k in range(1, per_row + 1)]
    return points


def serpentine_mission() -> dict[str, Any]:
    """A `cart2d mission`: six walls across the 4 m arena, alternately open east and west; the
    gateway's planned and rounded path through them has 111 waypoints."""
    walls = [
        [round(0.1 * i, 1), round(0.1 * j, 1)]
        for k, j in enumerate((6, 12, 18, 24, 30, 36))
        for i in (range(31) if k % 2 == 0 else range(10, 41))
    ]
    return {
        "grid": {"cols": ARENA_NODES, "rows": ARENA_NODES, "step": ARENA_STEP_M},
        "obstacles": walls,
        "start": [0.3, 0.3, 0.0],
        "goals": [[0.3, 3.8]],
        "timeout_s": 200.0,
    }


def trace_speeds(trace: list[list[float]], margin_m: float, span: int = 5) -> tuple[list[float], list[float]]:
    """Times and speeds over `span` samples of a mission's ground-truth trace ([t, x, y] rows),
    leaving out the first and the last `margin_m` driven (starting, stopping)."""
    driven = [0.0]
    for a, b in itertools.pairwise(trace):
        driven.append(driven[-1] + math.dist(a[1:], b[1:]))
    times, speeds = [], []
    for k in range(len(trace) - span):
        if margin_m < driven[k] and driven[k + span] < driven[-1] - margin_m:
            times.append(trace[k][0])
            speeds.append((driven[k + span] - driven[k]) / (trace[k + span][0] - trace[k][0]))
    return times, speeds


@dataclass
class Drive:
    """One streamed drive: ground truth, telemetry flags, and what the uploader did."""

    points: list[Point]
    truth: list[dict[str, Any]] = field(default_factory=list)
    frames: list[Telemetry] = field(default_factory=list)
    stream: path_stream.PathStream | None = None
    status: firmware.Status | None = None
    wall_s: float = 0.0

    def starved_frames(self) -> int:
        return sum(1 for f in self.frames if f.flags & STARVED and f.mode == 2)


def drive(sim: Simulator, link: Link, points: list[Point], timeout_s: float = 300.0) -> Drive:
    """Streams `points` from the cart's pose and records until the firmware is idle again."""
    result = Drive(points)
    lock = threading.Lock()
    assert sim.side is not None

    def on_truth(message: dict[str, Any]) -> None:
        if message.get("type") == "truth":
            with lock:
                result.truth.append(message)

    sim.side.subscribe(on_truth)
    link.subscribe(result.frames.append)
    started = time.monotonic()
    result.stream = path_stream.upload_path(link, points)
    while True:
        status = firmware.read_status(link)
        if status.mode != "PATH":
            break
        if time.monotonic() - started > timeout_s:
            link.call("STOP")
            raise RuntimeError(f"the streamed path was not finished in {timeout_s} s")
        time.sleep(0.05)
    result.status = status
    result.wall_s = time.monotonic() - started
    with lock:
        result.truth = list(result.truth)
    return result


def start_sim(tmp: Path, start: tuple[float, float, float], speed: str = "1") -> Simulator:
    options = SimOptions(
        speed=speed,
        eeprom=tmp / "eeprom.bin",
        start=start,
        grid=(ARENA_NODES, ARENA_STEP_M),
        truth_hz=100.0,
        quiet=True,
    )
    return Simulator(options).start()


# -- the speed trace ---------------------------------------------------------------------------------
def _nearest(points: list[Point], x: float, y: float) -> int:
    return min(range(len(points)), key=lambda k: (points[k][0] - x) ** 2 + (points[k][1] - y) ** 2)


def row_middles(points: list[Point]) -> list[tuple[int, int]]:
    """Index ranges of the waypoints in each row's middle: at least SETTLE_M from its turns."""
    ranges = []
    per_row = round((ROW_X_M[1] - ROW_X_M[0]) / SPACING_M)
    chords = math.ceil(math.pi / CHORD_TURN_RAD)
    settle = math.ceil(SETTLE_M / SPACING_M)
    first = 0
    while first + per_row <= len(points):
        ranges.append((first + settle, first + per_row - 1 - settle))
        first += per_row + chords
    return ranges


def speed_floors(d: Drive) -> dict[str, float]:
    """The lowest true speed in the rows' middles, and between the first row's middle and the
    last one's (turns included)."""
    middles = row_middles(d.points)
    lo, hi = middles[0][0], middles[-1][1]
    in_rows, overall = math.inf, math.inf
    for sample in d.truth:
        k = _nearest(d.points, sample["x"], sample["y"])
        speed = abs(sample["v"])
        if lo <= k <= hi:
            overall = min(overall, speed)
        if any(a <= k <= b for a, b in middles):
            in_rows = min(in_rows, speed)
    return {"rows_min_mps": in_rows, "overall_min_mps": overall}


def plot_trace(d: Drive, path: Path) -> None:
    fig, (ax_path, ax_speed) = plt.subplots(1, 2, figsize=(12, 4.2), gridspec_kw={"width_ratios": [1, 2]})
    xs, ys = zip(*d.points, strict=True)
    ax_path.plot(xs, ys, ".", markersize=2, color="tab:gray", label=f"{len(d.points)} waypoints")
    ax_path.plot(
        [s["x"] for s in d.truth], [s["y"] for s in d.truth], color="tab:blue", linewidth=1, label="driven"
    )
    ax_path.set_aspect("equal")
    ax_path.set_xlim(-0.25, 4.25)
    ax_path.set_xlabel("x (m)")
    ax_path.set_ylabel("y (m)")
    ax_path.legend(loc="upper right", fontsize=8)
    t0 = d.truth[0]["t"]
    ax_speed.plot([s["t"] - t0 for s in d.truth], [s["v"] for s in d.truth], color="tab:blue", linewidth=1)
    ax_speed.axhline(V_MAX, color="tab:green", linestyle=":", label="v_max")
    ax_speed.axhline(
        ROW_FLOOR_MPS, color="tab:red", linestyle="--", label=f"floor in the rows ({ROW_FLOOR_MPS:.2f} m/s)"
    )
    ax_speed.set_xlabel("simulated time (s)")
    ax_speed.set_ylabel("true speed (m/s)")
    ax_speed.set_ylim(0, V_MAX * 1.15)
    ax_speed.legend(loc="lower center", fontsize=8)
    ax_speed.set_title("Speed along the streamed serpentine (ground truth)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


# -- the window against the gateway's paths ------------------------------------------------------------
def window_reach(points: list[Point], start: Point, window: int) -> float:
    """The shortest distance, along the path, from a waypoint to the last point the window can
    hold while that waypoint is current (window - 2 points further: the window starts at the
    point before it). Measured from the waypoint, not from the cart, which is further back."""
    chain = [start, *points]
    cumulative = [0.0]
    for a, b in itertools.pairwise(chain):
        cumulative.append(cumulative[-1] + math.dist(a, b))
    reach = math.inf
    for k in range(1, len(chain)):
        last = min(k + window - 2, len(chain) - 1)
        if last == len(chain) - 1:
            break  # the path's end is in the window: the cart stops there anyway
        reach = min(reach, cumulative[last] - cumulative[k])
    return reach


def mission_paths() -> list[tuple[str, Point, list[Point]]]:
    from bench.scenes import scenes

    out = []
    for s in scenes():
        planner = Planner(s.grid, planning_radius_m(), set(s.obstacles))
        plan = planner.plan(s.start[:2], s.goal)
        rounded = round_corners(
            plan.start, plan.waypoints, planner.graph.segment_free, path_stream.MAX_PATH_POINTS
        )
        out.append((f"{s.name}, {s.arena}", plan.start, rounded))
    m = serpentine_mission()
    grid = Grid(cols=ARENA_NODES, rows=ARENA_NODES, step_m=ARENA_STEP_M)
    nodes = {grid.nearest_node(x, y) for x, y in m["obstacles"]}
    planner = Planner(grid, planning_radius_m(), nodes)
    plan = planner.plan(tuple(m["start"][:2]), tuple(m["goals"][0]))
    rounded = round_corners(
        plan.start, plan.waypoints, planner.graph.segment_free, path_stream.MAX_PATH_POINTS
    )
    out.append(("serpentine mission, 4 m", plan.start, rounded))
    return out


# -- the same through the gateway: a planned mission -----------------------------------------------------
MISSION_FLOOR_MPS = 0.3


def run_serpentine_mission(out: Path) -> dict[str, Any]:
    """serpentine_mission() through `cart2d mission` (planner, rounded corners, the gateway's
    uploader); its ground-truth speed trace as a figure."""
    report = run_mission(MissionSpec.model_validate(serpentine_mission()))
    (goal,) = report["goals"]
    times, speeds = trace_speeds(goal["trace"], margin_m=0.3)
    fig, (ax_path, ax_speed) = plt.subplots(1, 2, figsize=(12, 4.8), gridspec_kw={"width_ratios": [1, 1.6]})
    planned = goal.get("planned_path", [])
    walls = serpentine_mission()["obstacles"]
    ax_path.plot([w[0] for w in walls], [w[1] for w in walls], "s", color="0.3", markersize=2, label="walls")
    if planned:
        ax_path.plot(*zip(*planned, strict=True), ".", color="tab:gray", markersize=3, label="waypoints")
    ax_path.plot([s[1] for s in goal["trace"]], [s[2] for s in goal["trace"]], color="tab:blue", linewidth=1)
    ax_path.set_aspect("equal")
    ax_path.set_xlabel("x (m)")
    ax_path.set_ylabel("y (m)")
    ax_path.legend(loc="lower right", fontsize=8)
    t0 = goal["trace"][0][0]
    ax_speed.plot([t - t0 for t in times], speeds, color="tab:blue", linewidth=1)
    ax_speed.axhline(V_MAX, color="tab:green", linestyle=":", label="v_max")
    ax_speed.axhline(MISSION_FLOOR_MPS, color="tab:red", linestyle="--", label="floor")
    ax_speed.set_ylim(0, V_MAX * 1.15)
    ax_speed.set_xlabel("simulated time (s)")
    ax_speed.set_ylabel("true speed (m/s), over 0.1 s")
    ax_speed.set_title(f"The serpentine mission: {len(planned) - 1} waypoints, streamed")
    ax_speed.legend(loc="lower center", fontsize=8)
    fig.tight_layout()
    fig.savefig(out / f"{NAME}_mission.png", dpi=110)
    plt.close(fig)
    length = goal.get("planned_length_m", 0.0)
    return {
        "reached": bool(goal["reached"]),
        "reason": goal.get("reason", ""),
        "waypoints": len(planned) - 1,
        "min_speed_mps": min(speeds) if speeds else 0.0,
        "time_s": goal.get("time_s", 0.0),
        "bound_s": length / V_MAX + V_MAX / A_MAX,
        "final_error_m": goal.get("final_error_m", math.nan),
        "collisions": report["collisions"],
    }


def mission_markdown(m: dict[str, Any]) -> str:
    state = "reached" if m["reached"] else f"NOT reached ({m['reason']})"
    return (
        "\n### Through the gateway: a serpentine mission\n\n"
        f"`cart2d mission` with six walls across the 4 m arena (bench/streaming.py, serpentine_mission): "
        f"the plan has {m['waypoints']} waypoints, all corners rounded. The goal was {state}, "
        f"{1000 * m['final_error_m']:.1f} mm off, {m['collisions']} collisions, in {m['time_s']:.1f} s "
        f"against the bound L/v_max + v_max/a_max = {m['bound_s']:.1f} s; the slowest speed between the "
        f"first and the last 0.3 m was {m['min_speed_mps']:.3f} m/s (floor {MISSION_FLOOR_MPS} m/s).\n\n"
        f"![mission speed trace]({NAME}_mission.png)\n"
    )


def run(out: Path, quick: bool) -> Section:
    started = time.monotonic()
    rows = 3 if quick else 6
    points = serpentine(rows)
    window = int(robot()["control"]["waypoint_capacity"])
    with tempfile.TemporaryDirectory() as tmp:
        sim = start_sim(Path(tmp), (ROW_X_M[0], 0.6, 0.0))
        try:
            with Link(sim.pty) as link:
                link.call("SET_POSE", ROW_X_M[0], 0.6, 0.0)
                d = drive(sim, link, points)
            truth_end = sim.truth()
        finally:
            sim.stop()
    out.mkdir(parents=True, exist_ok=True)
    plot_trace(d, out / f"{NAME}_speed.png")
    floors = speed_floors(d)
    goal = points[-1]
    end_error = math.hypot(truth_end["x"] - goal[0], truth_end["y"] - goal[1])
    stream = d.stream
    assert stream is not None and d.status is not None
    arrived = d.status.has("ARRIVED")
    targets = [
        (
            "arrives on the last waypoint",
            f"{1000 * end_error:.1f} mm" + ("" if arrived else ", NOT ARRIVED"),
            arrived,
        ),
        ("no STARVED telemetry frame", str(d.starved_frames()), d.starved_frames() == 0),
        (
            f"speed in the rows' middles ≥ {ROW_FLOOR_MPS:.2f} m/s",
            f"{floors['rows_min_mps']:.3f} m/s",
            floors["rows_min_mps"] >= ROW_FLOOR_MPS,
        ),
        (
            f"speed through the turns ≥ {TURN_FLOOR_MPS:.2f} m/s (no stop)",
            f"{floors['overall_min_mps']:.3f} m/s",
            floors["overall_min_mps"] >= TURN_FLOOR_MPS,
        ),
    ]
    ok = all(met for _, _, met in targets)
    need_m = BRAKING_M + V_MAX * REACTION_S
    reach_rows = []
    reach_data = []
    for name, start, path in mission_paths():
        reaches = {w: window_reach(path, start, w) for w in (16, window)}
        reach_data.append(
            {"mission": name, "waypoints": len(path), **{f"reach_{w}_m": r for w, r in reaches.items()}}
        )
        cells = [f"{r:.2f} m" if math.isfinite(r) else "whole path" for r in reaches.values()]
        reach_rows.append([name, str(len(path)), *cells])
    serp_reach = {w: window_reach(points, points[0], w) for w in (16, window)}

    md = ["## Streamed paths\n"]
    md.append(
        f"A serpentine of {len(points)} waypoints ({rows} rows of {ROW_X_M[1] - ROW_X_M[0]:g} m, a "
        f"waypoint every {100 * SPACING_M:g} cm, half-circle turns of {ROW_GAP_M / 2:g} m radius in 12° "
        f"chords) in the 4 m arena, streamed through the firmware's {window}-point window by the "
        f"gateway's uploader, the simulator in real time. Targets: {'met' if ok else 'MISSED'}.\n\n"
    )
    md.append(
        table(["target", "measured", ""], [[n, m, "met" if met else "**MISSED**"] for n, m, met in targets])
    )
    md.append(
        f"\nThe uploader sent {stream.appends} XY_APPEND frames after the first WAIT_XY_ARRAY "
        f"({stream.status_reads} STATUS reads: telemetry was on); the drive took {d.wall_s:.1f} s of "
        "wall time.\n"
    )
    md.append(f"\n![speed trace]({NAME}_speed.png)\n")
    md.append("\n### The window's size\n")
    md.append(
        f"The cart needs the received points to reach at least the braking distance from v_max "
        f"(v_max²/(1.6·a_max) = {BRAKING_M:.3f} m) plus what it drives while the uploader reacts "
        f"({REACTION_S * 1000:.0f} ms at v_max: {V_MAX * REACTION_S:.2f} m), {need_m:.2f} m, beyond the "
        "current waypoint. The shortest reach of the window along each path, from a waypoint to the "
        "last point the window holds with it (a window of 16, and the firmware's):\n\n"
    )
    md.append(
        table(
            ["path", "waypoints", "W = 16", f"W = {window}"],
            [
                *reach_rows,
                ["this serpentine", str(len(points)), *[f"{serp_reach[w]:.2f} m" for w in (16, window)]],
            ],
        )
    )
    mission: dict[str, Any] = {}
    if not quick:
        mission = run_serpentine_mission(out)
        ok = ok and mission["reached"] and mission["min_speed_mps"] >= MISSION_FLOOR_MPS
        md.append(mission_markdown(mission))
    md.append(f"\n_{'quick' if quick else 'full'} mode, {time.monotonic() - started:.0f} s._\n")
    data = {
        "waypoints": len(points),
        "window": window,
        "rows_min_speed_mps": floors["rows_min_mps"],
        "overall_min_speed_mps": floors["overall_min_mps"],
        "starved_frames": d.starved_frames(),
        "appends": stream.appends,
        "end_error_m": end_error,
        "arrived": arrived,
        "need_m": need_m,
        "window_reach": reach_data,
        "serpentine_reach_m": {str(w): r for w, r in serp_reach.items()},
        "checks": {name: met for name, _, met in targets},
        "mission": mission,
    }
    return Section(NAME, "\n".join(md), data, ok)


if __name__ == "__main__":
    sys.exit(section_main(run))

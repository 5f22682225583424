"""Missions: how fast, how precisely and how safely cart2d reaches its goals, against the
physical lower bound and against the seed's behaviour, through `cart2d mission`.

Each scene of bench/scenes.py runs with cart2d's behaviour and with the seed's (cart2d/
baseline.py), repeated with the start pose jittered (+-1 cm, +-3 deg, seeded). The time lower
bound of a run is T = L / v_max + v_max / a_max (cruise the whole length at v_max, plus the
time lost to accelerating from and braking to rest at a_max), with L the length the cart
actually drove (ground truth); the length lower bound is the true shortest collision-free path
for the footprint (bench/visibility.py).
"""

from __future__ import annotations

import json
import random
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
from matplotlib.patches import Rectangle

from bench.common import Section, section_main, spread, table
from bench.scenes import Scene, scenes
from bench.visibility import shortest_length
from cart2d.params import footprint_radius_m, planning_radius_m, settings_table
from cart2d.planning import point_square_distance

BEHAVIOURS = ("cart2d", "seed")
TIME_TARGET = 1.25  # x the lower bound
ERROR_TARGET_M = 0.01


def _defaults() -> dict[str, float]:
    return {s["name"]: float(s["default"]) for s in settings_table()}


def lower_bound_s(length_m: float) -> float:
    d = _defaults()
    v, a = d["v_max_mps"], d["a_max_mps2"]
    return length_m / v + v / a


def _jittered(scene: Scene, behaviour: str, repeat: int) -> dict[str, Any]:
    mission = scene.mission(behaviour)
    if repeat > 0:
        rng = random.Random(f"{scene.arena}/{scene.name}/{repeat}")
        x, y, theta = scene.start
        mission["start"] = [
            x + rng.uniform(-0.01, 0.01),
            y + rng.uniform(-0.01, 0.01),
            theta + rng.uniform(-0.05, 0.05),
        ]
    return mission


def run_one(mission: dict[str, Any], seed: int) -> dict[str, Any]:
    """One `cart2d mission` run in its own process; its report."""
    with tempfile.TemporaryDirectory() as tmp:
        mission_path, report_path = Path(tmp) / "mission.json", Path(tmp) / "report.json"
        mission_path.write_text(json.dumps(mission))
        subprocess.run(
            [
                sys.executable,
                "-m",
                "cart2d.tools.cli",
                "mission",
                str(mission_path),
                "--report",
                str(report_path),
                "--seed",
                str(seed),
            ],
            capture_output=True,
            timeout=600,
            check=False,
        )
        report: dict[str, Any] = json.loads(report_path.read_text())
        return report


def min_clearance_m(scene: Scene, trace: list[list[float]]) -> float | None:
    """The least distance, beyond the footprint, between the cart (ground truth) and any obstacle
    cell over the run; None without obstacles. Negative: a collision."""
    if not scene.obstacles or not trace:
        return None
    half = scene.grid.step_m / 2
    cells = [scene.grid.node_xy(i, j) for i, j in scene.obstacles]
    return (
        min(point_square_distance((x, y), c, half) for _, x, y in trace for c in cells) - footprint_radius_m()
    )


def _summary(scene: Scene, report: dict[str, Any]) -> dict[str, Any]:
    if "error" in report or not report["goals"]:
        return {"reached": False, "reason": report.get("error", "no goal")}
    g = report["goals"][0]
    out = {
        k: g.get(k)
        for k in (
            "reached",
            "time_s",
            "final_error_m",
            "max_deviation_m",
            "path_length_m",
            "planned_length_m",
            "reason",
        )
    }
    out["collisions"] = report["collisions"]
    out["wall_contacts"] = report["wall_contacts"]
    out["waypoints"] = len(g.get("planned_path", [])) - 1
    out["clearance_m"] = min_clearance_m(scene, g.get("trace", []))
    if g["reached"]:
        out["time_ratio"] = g["time_s"] / lower_bound_s(g["path_length_m"])
    return out


def measure(chosen: list[Scene], repeats: int, workers: int) -> list[dict[str, Any]]:
    jobs = [(s, b, r) for s in chosen for b in BEHAVIOURS for r in range(repeats)]
    with ThreadPoolExecutor(max_workers=workers) as pool:
        reports = list(pool.map(lambda job: run_one(_jittered(*job), seed=job[2] + 1), jobs))
    rows: list[dict[str, Any]] = []
    for scene in chosen:
        ends = (scene.start[:2], scene.goal)
        row: dict[str, Any] = {
            "scene": scene.name,
            "arena": scene.arena,
            "shortest_m": shortest_length(scene.grid, scene.obstacles, footprint_radius_m(), *ends),
            "shortest_with_clearance_m": shortest_length(
                scene.grid, scene.obstacles, planning_radius_m(), *ends
            ),
        }
        for behaviour in BEHAVIOURS:
            runs = [
                rep for (s, b, _), rep in zip(jobs, reports, strict=True) if s is scene and b == behaviour
            ]
            row[behaviour] = {"runs": [_summary(scene, r) for r in runs], "trace": _trace(runs[0])}
        rows.append(row)
    return rows


def _trace(report: dict[str, Any]) -> dict[str, Any]:
    goals = report.get("goals") or [{}]
    return {"planned": goals[0].get("planned_path", []), "driven": [p[1:] for p in goals[0].get("trace", [])]}


def _stats(runs: list[dict[str, Any]], key: str, scale: float = 1.0) -> str:
    values = [r[key] * scale for r in runs if r.get("reached") and r.get(key) is not None]
    return spread(values).text(".3g") if values else "n/a"


def _targets(row: dict[str, Any]) -> bool:
    runs = row["cart2d"]["runs"]
    return all(
        r.get("reached")
        and r["collisions"] == 0
        and r["wall_contacts"] == 0
        and r["final_error_m"] <= ERROR_TARGET_M
        and r["time_ratio"] <= TIME_TARGET
        for r in runs
    )


def _plot_ratios(rows: list[dict[str, Any]], out: Path) -> None:
    fig, ax = plt.subplots(figsize=(10, 4))
    labels = [f"{r['arena']}\n{r['scene']}" for r in rows]
    for k, behaviour in enumerate(BEHAVIOURS):
        medians, lows, highs = [], [], []
        for r in rows:
            values = [x["time_ratio"] for x in r[behaviour]["runs"] if x.get("reached")]
            s = spread(values) if values else None
            medians.append(s.median if s else 0.0)
            lows.append(s.median - s.low if s else 0.0)
            highs.append(s.high - s.median if s else 0.0)
        xs = [i + (k - 0.5) * 0.38 for i in range(len(rows))]
        ax.bar(xs, medians, 0.36, yerr=[lows, highs], label=behaviour, capsize=2)
    ax.axhline(TIME_TARGET, color="k", ls="--", lw=1, label=f"target {TIME_TARGET}x")
    ax.axhline(1.0, color="grey", lw=0.8)
    ax.set_xticks(range(len(rows)), labels, fontsize=7)
    ax.set_ylabel("time / lower bound")
    ax.set_title("Time to goal against T = L/v_max + v_max/a_max (L: driven length)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "missions_time_ratio.png", dpi=110)
    plt.close(fig)


def _plot_paths(rows: list[dict[str, Any]], chosen: list[Scene], out: Path) -> None:
    cols = 5
    n = len(rows)
    fig, axes = plt.subplots(
        (n + cols - 1) // cols, cols, figsize=(3.2 * cols, 3.3 * ((n + cols - 1) // cols))
    )
    for ax, row, scene in zip(axes.flat, rows, chosen, strict=False):
        step = scene.grid.step_m
        for i, j in scene.obstacles:
            x, y = scene.grid.node_xy(i, j)
            ax.add_patch(Rectangle((x - step / 2, y - step / 2), step, step, color="0.35"))
        for behaviour, colour in (("seed", "tab:orange"), ("cart2d", "tab:blue")):
            planned = row[behaviour]["trace"]["planned"]
            driven = row[behaviour]["trace"]["driven"]
            if planned:
                ax.plot(*zip(*planned, strict=True), ls=":", color=colour, lw=1)
            if driven:
                ax.plot(*zip(*driven, strict=True), color=colour, lw=1.2, label=behaviour)
        ax.plot(*scene.start[:2], "go", ms=4)
        ax.plot(*scene.goal, "r*", ms=7)
        w, h = scene.grid.size_m
        ax.set_xlim(-0.25, w + 0.25)
        ax.set_ylim(-0.25, h + 0.25)
        ax.set_aspect("equal")
        ax.set_title(f"{row['arena']}: {row['scene']}", fontsize=8)
        ax.tick_params(labelsize=6)
    for ax in list(axes.flat)[n:]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=7)
    fig.suptitle("Planned (dotted) and driven (ground truth) paths: cart2d against the seed's behaviour")
    fig.tight_layout()
    fig.savefig(out / "missions_paths.png", dpi=100)
    plt.close(fig)


def _markdown(rows: list[dict[str, Any]], repeats: int, ok: bool) -> str:
    header = [
        "arena",
        "mission",
        "behaviour",
        "reached",
        "time s",
        "time / bound",
        "driven m",
        "driven / shortest",
        "final error mm",
        "max deviation mm",
        "clearance mm",
        "collisions",
    ]
    body = []
    for row in rows:
        for behaviour in BEHAVIOURS:
            runs = row[behaviour]["runs"]
            reached = sum(bool(r.get("reached")) for r in runs)
            ratio = [r["path_length_m"] / row["shortest_m"] for r in runs if r.get("reached")]
            body.append(
                [
                    row["arena"],
                    row["scene"],
                    behaviour,
                    f"{reached}/{len(runs)}",
                    _stats(runs, "time_s"),
                    _stats(runs, "time_ratio"),
                    _stats(runs, "path_length_m"),
                    spread(ratio).text(".3g") if ratio else "n/a",
                    _stats(runs, "final_error_m", 1000),
                    _stats(runs, "max_deviation_m", 1000),
                    _stats(runs, "clearance_m", 1000),
                    spread([float(r.get("collisions", 0)) for r in runs]).text(".3g"),
                ]
            )
    ours = [r for row in rows for r in row["cart2d"]["runs"] if r.get("reached")]
    seed = [r for row in rows for r in row["seed"]["runs"] if r.get("reached")]
    return (
        "## Missions\n\n"
        f"Every scene ran {repeats} time(s) per behaviour through `cart2d mission` in the simulator "
        "(start pose jittered by up to 1 cm and 3 deg after the first run); numbers are medians with "
        "the range in brackets. *time / bound*: the time to goal (firmware ticks from the first to "
        "the last telemetry frame in PATH mode) over T = L / v_max + v_max / a_max with L the "
        "driven length (ground truth); *driven / shortest*: the driven length over the true shortest "
        "collision-free path for the 0.17 m footprint (visibility graph, bench/visibility.py); "
        "*clearance*: the least distance between the cart's footprint and an obstacle over the "
        "run (ground truth; the planner keeps 30 mm, robot.toml's clearance_m). The "
        "seed's behaviour: unit-weight 8-connected Dijkstra over nodes (no footprint), a waypoint at "
        "every node, 0.1 m tolerances, unit polar gains (cart2d/planning/baseline.py).\n\n"
        f"Targets for cart2d (every goal reached, no collision, final error <= 10 mm, time <= "
        f"{TIME_TARGET} x the bound): **{'met' if ok else 'MISSED'}**. Over all missions: cart2d "
        f"{spread([r['time_ratio'] for r in ours]).text('.3g')} x the bound, "
        f"{sum(r['collisions'] for r in ours)} collisions; the seed's behaviour "
        f"{spread([r['time_ratio'] for r in seed]).text('.3g') if seed else 'n/a'} x, "
        f"{sum(r['collisions'] for r in seed)} collisions.\n\n"
        + table(header, body)
        + "\nWhere *driven / shortest* is well above 1, the 30 mm clearance closes a gap that the bare "
        "footprint would pass; the shortest paths keeping that clearance too: "
        + ", ".join(
            f"{row['arena']} {row['scene']} {row['shortest_with_clearance_m'] / row['shortest_m']:.3g} x"
            for row in rows
        )
        + ".\n"
        + "\n![time ratios](missions_time_ratio.png)\n\n![paths](missions_paths.png)\n"
    )


def run(out: Path, quick: bool) -> Section:
    every = scenes()
    chosen = [s for s in every if s.name in ("U-trap", "cluttered field")] if quick else every
    repeats = 1 if quick else 3
    # CI (quick) runs one mission at a time: each is a simulator and a gateway, and two of each
    # on a busy 2-core machine can starve a link of its replies.
    rows = measure(chosen, repeats, workers=1 if quick else 2)
    ok = all(_targets(row) for row in rows)
    _plot_ratios(rows, out)
    _plot_paths(rows, chosen, out)
    data = {"repeats": repeats, "missions": [{k: v for k, v in r.items()} for r in rows]}
    return Section("missions", _markdown(rows, repeats, ok), data, ok)


if __name__ == "__main__":
    sys.exit(section_main(run))

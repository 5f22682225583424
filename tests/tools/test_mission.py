"""Headless missions (cart2d mission) in the simulator, judged by ground truth."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from bench.streaming import serpentine_mission, trace_speeds
from cart2d.tools.missions.run import run_mission
from cart2d.tools.missions.spec import MissionSpec, write_report

WALL = [[0.8, 0.0], [0.8, 0.2], [0.8, 0.4], [0.8, 0.6], [0.8, 0.8]]


def test_missions_through_obstacles_reach_every_goal_without_collision() -> None:
    spec = MissionSpec.model_validate(
        {
            "obstacles": [*WALL, [1.2, 1.4], [0.4, 1.2]],
            "start": [0.0, 0.0, 0.0],
            "goals": [[1.6, 0.2], [1.6, 1.8], [0.0, 1.8], [0.0, 0.0]],
        }
    )
    report = run_mission(spec)
    assert [g["reached"] for g in report["goals"]] == [True] * 4
    assert report["collisions"] == 0 and report["wall_contacts"] == 0
    for goal in report["goals"]:
        assert goal["final_error_m"] < 0.01
        assert goal["odometry_error_m"] < 0.002
        # Driven (ground truth) close to planned: the cart follows its plan (and may cut the
        # chords of a rounded corner by millimetres).
        assert (
            0.98 * goal["planned_length_m"] <= goal["path_length_m"] < 1.15 * goal["planned_length_m"] + 0.05
        )
        assert goal["max_deviation_m"] < 0.03  # within the planner's clearance margin
    # How fast it ran on the wall clock (real_time_factor) is the bench's to report, not a test's.


def test_a_larger_arena_with_a_finer_grid() -> None:
    spec = MissionSpec.model_validate(
        {
            "grid": {"cols": 41, "rows": 41, "step": 0.1},
            "obstacles": [[2.0, y / 10] for y in range(0, 31)],
            "start": [0.5, 0.5, 0.0],
            "goals": [[3.5, 0.5]],
            "timeout_s": 120,
        }
    )
    report = run_mission(spec)
    (goal,) = report["goals"]
    assert goal["reached"] and goal["final_error_m"] < 0.01 and report["collisions"] == 0
    assert goal["planned_length_m"] > 6.0  # around the wall's end at y = 3.0 m, not through it


def run_cli_raw(mission_path: Path, report_path: Path | None) -> subprocess.CompletedProcess[str]:
    report = ["--report", str(report_path)] if report_path is not None else []
    return subprocess.run(
        [sys.executable, "-m", "cart2d.tools.cli", "mission", str(mission_path), *report],
        capture_output=True,
        text=True,
        timeout=120,
    )


def run_cli(tmp_path: Path, mission: object) -> tuple[int, dict[str, Any]]:
    mission_path, report_path = tmp_path / "mission.json", tmp_path / "report.json"
    mission_path.write_text(json.dumps(mission))
    done = run_cli_raw(mission_path, report_path)
    return done.returncode, json.loads(report_path.read_text())


def test_cli_reports_unreachable_and_invalid_goals_without_driving(tmp_path: Path) -> None:
    walled = [[1.4, 1.4], [1.4, 1.6], [1.4, 1.8], [1.6, 1.4], [1.8, 1.4]]
    code, report = run_cli(tmp_path, {"obstacles": walled, "goals": [[1.8, 1.8], [9.0, 0.0], [0.4, 0.0]]})
    assert code == 1
    unreachable, off_map, ok = report["goals"]
    assert not unreachable["reached"] and "cannot be reached" in unreachable["reason"]
    assert not off_map["reached"] and "off the map" in off_map["reason"]
    assert unreachable["path_length_m"] == 0.0 and off_map["path_length_m"] == 0.0
    assert ok["reached"]


GOAL = {"goals": [[0.4, 0.0]]}
NOT_FINITE = [f"goals[{k}][{k}]: input should be a finite number" for k in (0, 1)]


@pytest.mark.parametrize(
    ("content", "lines"),
    [
        ({**GOAL, "settings": {"v_max_mps": 9}}, ["settings.v_max_mps: 9 is out of its range, from "]),
        ({**GOAL, "settings": {"warp_factor": 9}}, ["settings: unknown firmware setting 'warp_factor'"]),
        ({**GOAL, "faults": {"warp": 1}}, ["faults: unknown fault 'warp'"]),
        ({**GOAL, "faults": {"enc_slip_l": 1.5}}, ["faults: fault enc_slip_l takes a number from 0 to 0.99"]),
        ('{"goals": [[0.4, 0.0]],}', ["is not JSON: "]),
        ({**GOAL, "goal": [1, 1]}, ["unknown key 'goal' (a mission has: grid, map, "]),
        ({**GOAL, "grid": {"cols": 10, "size": 3}}, ["unknown key 'size' in grid"]),
        ({"goals": []}, ["no goals: a mission needs at least one goal [x, y]"]),
        ({}, ["no goals: a mission needs at least one goal [x, y]"]),
        (
            '{"goals": [[NaN, 0.0], [0.4, Infinity]]}',
            NOT_FINITE,
        ),
        ([1, 2], ["holds list, not a JSON object"]),
        (
            {**GOAL, "start": [-0.2, 0.0, 0.0], "settings": {"tol_final_m": 0}, "obstacles": [[9, 9]]},
            [
                "settings.tol_final_m: 0 is out of its range",
                "start (-0.2, 0) puts the cart (0.17 m around its centre) into the arena's walls",
                "obstacles[0]: the point (9.000, 9.000) is off the map",
            ],
        ),
    ],
)
def test_cli_refuses_a_mission_with_problems_before_it_runs(
    tmp_path: Path, content: object, lines: list[str]
) -> None:
    """One line per problem, exit status 2, no traceback, no report: nothing ran."""
    mission_path = tmp_path / "mission.json"
    mission_path.write_text(content if isinstance(content, str) else json.dumps(content))
    done = run_cli_raw(mission_path, tmp_path / "report.json")
    assert done.returncode == 2
    said = done.stderr.splitlines()
    assert len(said) == len(lines), done.stderr
    for line, words in zip(said, lines, strict=True):
        assert line.startswith("cart2d mission: ") and words in line, line
    assert "Traceback" not in done.stderr and "pydantic" not in done.stderr and "0 of 0" not in done.stderr
    assert not (tmp_path / "report.json").exists()


@pytest.mark.parametrize(
    ("report", "words"),
    [
        ("missing/report.json", "folder {tmp}/missing does not exist"),
        ("", "is a folder"),
        ("/proc/cart2d-report.json", "the report /proc/cart2d-report.json cannot be written"),
        ("mission.json", "would overwrite the mission file"),
    ],
)
def test_cli_checks_where_the_report_goes_before_the_mission_runs(
    tmp_path: Path, report: str, words: str
) -> None:
    mission_path = tmp_path / "mission.json"
    mission_path.write_text(json.dumps(GOAL))
    done = run_cli_raw(mission_path, tmp_path / report if not report.startswith("/") else Path(report))
    assert done.returncode == 2
    (line,) = done.stderr.splitlines()
    assert words.format(tmp=tmp_path) in line and "Traceback" not in done.stderr


def test_cli_says_when_the_mission_file_is_not_there(tmp_path: Path) -> None:
    done = run_cli_raw(tmp_path / "nowhere.json", tmp_path / "report.json")
    assert done.returncode == 2
    assert done.stderr.splitlines() == [
        f"cart2d mission: there is no mission file {tmp_path / 'nowhere.json'}"
    ]


def test_cli_writes_the_report_beside_the_mission_by_default(tmp_path: Path) -> None:
    mission_path = tmp_path / "short.json"
    mission_path.write_text(json.dumps({"goals": [[0.4, 0.0]]}))
    done = run_cli_raw(mission_path, None)
    assert done.returncode == 0, done.stderr
    report = json.loads((tmp_path / "short.report.json").read_text())
    assert report["goals"][0]["reached"]
    assert done.stderr.strip().endswith(f"1 of 1 goals reached; report in {tmp_path / 'short.report.json'}")


def test_a_report_is_valid_json_whatever_numbers_it_holds(tmp_path: Path) -> None:
    path = tmp_path / "report.json"
    write_report(path, {"goals": [{"final_error_m": math.nan, "trace": [[0.0, math.inf, -math.inf]]}]})

    def no_constants(name: str) -> None:
        raise AssertionError(f"{name} is not JSON")

    report = json.loads(path.read_text(), parse_constant=no_constants)
    assert report == {"goals": [{"final_error_m": None, "trace": [[0.0, None, None]]}]}


def test_cli_succeeds_when_every_goal_is_reached(tmp_path: Path) -> None:
    code, report = run_cli(tmp_path, {"goals": [[0.6, 0.4]], "settings": {"v_max_mps": 0.3}})
    assert code == 0 and report["goals"][0]["reached"]


def test_the_seeds_behaviour_sends_every_node_in_buffers_full_and_is_slower() -> None:
    # 40 nodes in a row on a 0.1 m grid: more than the firmware's 32, so two uploads.
    mission = {
        "grid": {"cols": 41, "rows": 41, "step": 0.1},
        "start": [0.0, 0.0, 0.0],
        "goals": [[4.0, 0.0]],
    }
    seed = run_mission(MissionSpec.model_validate({**mission, "behaviour": "seed"}))
    ours = run_mission(MissionSpec.model_validate(mission))
    (s,), (o,) = seed["goals"], ours["goals"]
    assert s["reached"] and o["reached"]
    assert len(s["planned_path"]) == 41 and len(o["planned_path"]) == 2  # start + every node / the goal
    assert s["final_error_m"] < 0.1 and o["final_error_m"] < 0.01
    # both drove about the 4 m; the seed's unit gains creep and stop between the two buffers
    assert 3.9 < s["path_length_m"] < 4.1 and 3.9 < o["path_length_m"] < 4.1
    assert o["time_s"] < 0.8 * s["time_s"]
    assert 8.5 - 0.08 < o["time_s"] < 1.1 * 8.5  # 4 m / 0.5 m/s + 0.5 s, ticks counted to 40 ms
    assert o["max_deviation_m"] < 0.01


def test_a_serpentine_of_hundreds_of_waypoints_is_streamed_without_a_stop() -> None:
    # Six walls across the 4 m arena, alternately open east and west: the planned and rounded
    # path winds through them in 111 waypoints, more than three windows of the firmware.
    report = run_mission(MissionSpec.model_validate(serpentine_mission()))
    (goal,) = report["goals"]
    assert goal["reached"], goal.get("reason")
    assert len(goal["planned_path"]) > 100 + 1  # the start, then the waypoints
    assert report["collisions"] == 0 and report["wall_contacts"] == 0
    assert goal["final_error_m"] < 0.01
    # Ground truth: from 0.3 m after the start to 0.3 m before the goal the cart never slows
    # below 0.3 m/s (every corner is rounded: none needs a stop), so no window boundary stopped it.
    _, speeds = trace_speeds(goal["trace"], margin_m=0.3)
    assert len(speeds) > 500 and min(speeds) > 0.3, min(speeds)

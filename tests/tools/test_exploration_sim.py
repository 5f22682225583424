"""Exploration in the simulator (issue 26): a 3 m arena with two boxes the map does not show,
the simulated camera calibrated first as the README asks (`cart2d camera calibrate --sim`), and
perception in lockstep with the simulator in real time. It ends with no
reachable frontier left, without a collision or a box contact, and the map it saved loads back
with both boxes on it and the reachable floor seen free."""

from __future__ import annotations

from pathlib import Path

from cart2d.maps.world import Box
from cart2d.tools.exploration_run import Exploring, explore_in_simulator
from tests.support.cli import cart2d

BOXES = (Box(0.9, 1.8, 0.25, 0.25, id="a"), Box(2.0, 0.9, 0.25, 0.25, id="b"))


def test_a_room_with_boxes_is_explored_to_the_end_and_its_map_loads_back(tmp_path: Path) -> None:
    calibration = tmp_path / "camera_calibration.json"
    made = cart2d(tmp_path, "camera", "calibrate", "--sim", "--out", str(calibration))
    assert made.returncode == 0, made.stderr
    # in real time: a frame's pose is looked up by its stamp on the firmware's clock
    # (cart2d/gateway/poses.py), right at any speed, but at full speed beside two busy loops the
    # cart still touched a box or stopped at a false obstacle in 5 of 15 runs (none of 5 alone):
    # a cause not found yet, so the simulator keeps the gateway's pace
    run = Exploring(
        (14, 14, 0.2), BOXES, (0.3, 0.3, 0.785), timeout_s=240.0, speed="1", calibration=calibration
    )
    report = explore_in_simulator(run)
    end = report["exploration"]
    where = {k: report[k] for k in ("contacts_at", "collisions", "box_contacts", "sim_s", "lockstep")}
    assert end["state"] == "finished", f"{end['sentence']}\n{where}\n{end['set_aside']}"
    assert end["sentence"].startswith("exploration finished: no reachable frontier left")
    assert end["sentence"].endswith("explored.yaml")
    assert report["collisions"] == 0 and report["box_contacts"] == 0
    saved = report["saved"]  # loaded back from its YAML and PGM
    assert saved["seen_share"] >= 0.9, saved
    assert saved["boxes"]["boxes_found"] == len(BOXES), saved

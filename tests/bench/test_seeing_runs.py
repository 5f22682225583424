"""The measures of a mission that sees (bench/seeing_runs.py) on hand-made cases: precision
against the boxes and walls, as they are and grown by a cell; recall over the box faces the
driven trace faced; false obstacles on open floor; a paired run's figures."""

from __future__ import annotations

import numpy as np
import pytest

from bench.seeing_runs import PairedRun, face_cells, mapping_quality

WALLS = {"x_min": 0.0, "y_min": 0.0, "x_max": 2.0, "y_max": 2.0}
BOX = {"x": 1.0, "y": 1.0, "sx": 0.2, "sy": 0.2}  # 0.9 .. 1.1 both ways


def test_precision_recall_and_false_obstacles_of_a_hand_made_map() -> None:
    cells = [
        [0.925, 1.025, 0.9],  # inside the box
        [0.875, 1.025, 0.9],  # the cell just past its west face: counts against the box grown by a cell
        [0.525, 0.525, 0.9],  # open floor, far from everything
        [2.025, 1.025, 0.9],  # beyond the east wall
    ]
    # the cart drove past the west face only, 0.4 m from it
    trace = np.column_stack([np.full(11, 0.5), np.linspace(0.95, 1.05, 11)])
    q = mapping_quality(cells, 0.05, [BOX], WALLS, trace)
    assert q["cells"] == 4 and q["wall_cells"] == 1
    assert q["precision"] == pytest.approx(2 / 4)
    assert q["precision_cell"] == pytest.approx(3 / 4)
    assert q["false_cells"] == 1
    # the west face's 4 cells faced the trace; the one at y 0.925 has no perceived cell beside it
    assert q["visible_box_cells"] == 4 and q["found_box_cells"] == 3
    assert q["recall"] == pytest.approx(0.75)


def test_faces_against_another_box_or_beyond_a_wall_cannot_be_seen() -> None:
    pair = [BOX, {**BOX, "x": 1.2}]
    assert len(face_cells(pair, WALLS, 0.05)) == 6
    at_wall = [{**BOX, "x": 1.9}]  # its east face is the wall's
    assert len(face_cells(at_wall, WALLS, 0.05)) == 3


def paired(reached: bool) -> PairedRun:
    goal = {"reached": reached, "start_s": 1.5, "time_s": 10.5, "reason": "" if reached else "timeout"}
    unknown = {
        "collisions": 0,
        "box_contacts": 1,
        "perception": {"frames": 90, "lockstep": {"perception_wait_s": 2.0}},
    }
    known = {"reached": True, "start_s": 0.5, "time_s": 7.5}
    return PairedRun(unknown, {}, goal, known, np.zeros((0, 2)), {"cells": 0})


def test_a_paired_run_compares_from_the_request_and_only_when_both_arrived() -> None:
    row = paired(True).row()
    assert row["time_ratio"] == pytest.approx(12.0 / 8.0)  # the look and the planning count
    assert row["frames"] == 90 and row["perception_wait_s"] == 2.0 and row["box_contacts"] == 1
    missed = paired(False).row()
    assert missed["time_ratio"] is None and missed["reason"] == "timeout" and missed["known_reached"]

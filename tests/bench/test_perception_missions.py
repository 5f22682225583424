"""The perception benchmark's measures of a map (bench/perception_missions.py) on hand-made cases:
precision against the boxes and walls, as they are and grown by a cell; recall over the box
faces the driven trace faced; false obstacles on open floor; whether a box is in the camera's view."""

from __future__ import annotations

import numpy as np
import pytest

from bench.perception_missions import driven_backwards_m, face_cells, in_view, mapping_quality
from cart2d.perception.camera_model import Mount

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


def test_a_box_ahead_is_in_view_one_beside_or_too_far_is_not() -> None:
    mount = Mount.from_robot()
    assert in_view((0.0, 0.0, 0.0), {**BOX, "x": 1.0, "y": 0.0}, mount)
    assert not in_view((0.0, 0.0, 0.0), {**BOX, "x": 0.0, "y": 1.0}, mount)  # 90 degrees left
    assert not in_view((0.0, 0.0, 0.0), {**BOX, "x": 2.5, "y": 0.0}, mount)  # beyond the detector's range
    assert in_view((0.0, 0.0, np.pi / 2), {**BOX, "x": 0.0, "y": 1.0}, mount)


def test_only_the_distance_driven_against_the_heading_counts_as_backwards() -> None:
    ahead = [[0.0, 0.0, 0.0, 0.0], [0.1, 0.1, 0.0, 0.0], [0.2, 0.2, 0.0, 0.0]]
    assert driven_backwards_m(ahead) == pytest.approx(0.0)
    # facing -y (heading -pi/2) while moving +y by 0.3 m, then turning on the spot
    reverse = [[0.0, 0.0, 0.0, -np.pi / 2], [0.1, 0.0, 0.3, -np.pi / 2], [0.2, 0.0, 0.3, np.pi]]
    assert driven_backwards_m(reverse) == pytest.approx(0.3)

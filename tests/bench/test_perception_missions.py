"""The perception benchmark's measures (bench/perception_missions.py) on hand-made cases: whether
a box is in the camera's view, and how far the cart drove backwards."""

from __future__ import annotations

import numpy as np
import pytest

from bench.perception_missions import driven_backwards_m, in_view
from cart2d.perception.camera_model import Mount

WALLS = {"x_min": 0.0, "y_min": 0.0, "x_max": 2.0, "y_max": 2.0}
BOX = {"x": 1.0, "y": 1.0, "sx": 0.2, "sy": 0.2}  # 0.9 .. 1.1 both ways


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

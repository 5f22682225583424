"""The gateway's perception step: JPEG + pose in, hits, field of view and cells in map coordinates."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
from matplotlib.path import Path as Polygon

from cart2d.perception.calibration import CameraCalibration
from cart2d.perception.camera_model import Mount
from cart2d.perception.occupancy import LogOddsGrid
from cart2d.perception.pipeline import Perception
from cart2d.perception.synthetic import Box, SyntheticCamera

MOUNT = Mount.from_robot()
CALIBRATION = CameraCalibration.nominal(MOUNT)


def perception() -> Perception:
    return Perception(LogOddsGrid((-1.0, -1.0), 0.05, 100, 100), CALIBRATION, MOUNT)


def test_the_field_of_view_is_the_floor_ahead_within_range() -> None:
    p = perception()
    fov = Polygon(p.fov_base)
    assert fov.contains_point((MOUNT.x_m + 1.0, 0.0))
    assert fov.contains_point((MOUNT.x_m + 0.5, 0.15))
    assert not fov.contains_point((MOUNT.x_m + 0.1, 0.0))  # under the camera: not seen
    assert not fov.contains_point((MOUNT.x_m + 1.6, 0.0))  # beyond max range
    assert not fov.contains_point((MOUNT.x_m + 0.5, 0.6))  # outside the picture


def test_a_box_seen_from_a_pose_is_mapped_where_it_is() -> None:
    p = perception()
    camera = SyntheticCamera(CALIBRATION.intrinsics, MOUNT, seed=2)
    box = Box(1.5, 1.6, 0.3, 0.3, 0.25, (150, 90, 30))
    pose = (1.5, 0.3, math.pi / 2)  # facing +y, the box 1.3 m ahead
    for _ in range(4):
        data = cv2.imencode(".jpg", camera.render(pose, boxes=[box]), [cv2.IMWRITE_JPEG_QUALITY, 80])[1]
        frame = p.process_jpeg(data.tobytes(), pose)
    canvas = camera.render(pose, boxes=[box])
    before = canvas.copy()
    frame.draw(canvas)  # in place, as the camera feed's Overlay.draw
    assert (canvas != before).any()
    assert np.abs(frame.hits[:, 1] - (box.y - box.sy / 2)).max() < 0.06  # the near face, y = 1.45
    assert Polygon(frame.fov).contains_point((1.5, 1.0))  # the field of view turned with the cart
    cells = np.array([c[:2] for c in p.cells()])
    assert len(cells) > 3
    assert np.all(np.abs(cells[:, 0] - box.x) < box.sx / 2 + 0.05)
    assert np.all(np.abs(cells[:, 1] - (box.y - box.sy / 2)) < 0.08)
    p.clear()
    assert p.cells() == []


def test_a_broken_jpeg_is_refused() -> None:
    with pytest.raises(ValueError, match="JPEG"):
        perception().process_jpeg(b"not a picture", (0.0, 0.0, 0.0))

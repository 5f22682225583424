"""The detector's cues on synthetic pictures (cart2d/perception/synthetic.py): a thin leg is seen
whole, a shadow on the floor is not an obstacle, a floor model that began with an obstacle in its
patch forgets it, the parallax cue's mask adds what appearance cannot see, and a hit that more
cues saw weighs more in the grid."""

from __future__ import annotations

import cv2
import numpy as np
import numpy.typing as npt
import pytest

from cart2d.perception.calibration import CameraCalibration
from cart2d.perception.camera_model import Mount
from cart2d.perception.detection import ObstacleDetector
from cart2d.perception.occupancy import LogOddsGrid
from cart2d.perception.synthetic import Box, SyntheticCamera

MOUNT = Mount.from_robot()
NOMINAL = CameraCalibration.nominal(MOUNT)


def detector_and_camera(seed: int = 1) -> tuple[ObstacleDetector, SyntheticCamera]:
    return ObstacleDetector(NOMINAL, MOUNT), SyntheticCamera(NOMINAL.intrinsics, MOUNT, seed=seed)


def shade(
    image: npt.NDArray[np.uint8], corners_m: list[tuple[float, float]], light: float
) -> npt.NDArray[np.uint8]:
    """The picture with the floor quadrilateral `corners_m` (base_link) getting only `light` of
    the light: a shadow cast on it."""
    uv, ok = NOMINAL.ground.grounds_to_pixels(np.array(corners_m))
    assert ok.all()
    mask = np.zeros(image.shape[:2], np.uint8)
    cv2.fillConvexPoly(mask, np.round(uv).astype(np.int32), 255)
    out = image.astype(np.float32)
    out[mask > 0] *= light
    return np.asarray(np.clip(out, 0, 255), dtype=np.uint8)


@pytest.mark.parametrize("ahead_m", [1.0, 1.2])
def test_a_thin_leg_two_centimetres_wide_is_found_out_to_the_range(ahead_m: float) -> None:
    detector, camera = detector_and_camera()
    detector.learn(camera.render())
    leg = Box(ahead_m, -0.1, 0.02, 0.02, 0.45, (50, 60, 80))  # a dark chair leg, 6 to 5 pixels wide
    detection = detector.detect(camera.render(boxes=[leg]))
    assert len(detection.hits) >= 3
    assert np.all(np.hypot(detection.hits[:, 0] - leg.x, detection.hits[:, 1] - leg.y) < 0.04)


def test_a_shadow_on_the_floor_is_no_obstacle_and_a_dark_box_is() -> None:
    detector, camera = detector_and_camera(seed=2)
    detector.learn(camera.render())
    # a person's shadow across the floor ahead, at half the light, 0.5 to 0.9 m
    shadow = [(0.5, 0.25), (0.9, 0.3), (0.9, 0.1), (0.5, -0.05)]
    for _ in range(5):
        detection = detector.detect(shade(camera.render(), shadow, 0.5))
        assert len(detection.hits) == 0
    dark = Box(0.8, -0.2, 0.15, 0.15, 0.2, (30, 32, 34))  # darker than any shadow leaves the floor
    assert len(detector.detect(camera.render(boxes=[dark])).hits) > 10


def test_a_floor_model_that_learnt_an_obstacle_at_the_start_forgets_it() -> None:
    detector, camera = detector_and_camera(seed=3)
    red = (40, 60, 170)
    # the first frame's patch holds a red box: red is learnt as floor
    detector.detect(camera.render(boxes=[Box(0.3, 0.0, 0.1, 0.2, 0.1, red)]))
    ahead = Box(1.0, 0.0, 0.2, 0.3, 0.2, red)
    assert len(detector.detect(camera.render(boxes=[ahead])).hits) < 20  # taken for floor at first
    for _ in range(60):  # the cart drives on: the patch shows the floor alone
        detector.detect(camera.render())
    assert len(detector.detect(camera.render(boxes=[ahead])).hits) > 20


def test_what_the_parallax_cue_flags_is_an_obstacle_though_it_looks_like_floor() -> None:
    detector, camera = detector_and_camera(seed=4)
    detector.learn(camera.render())
    image = camera.render()
    assert len(detector.detect(image).hits) == 0
    off_plane = np.zeros(image.shape[:2], dtype=np.bool_)  # as if a floor-coloured box stood there
    uv, _ = NOMINAL.ground.grounds_to_pixels(np.array([[0.8, 0.1], [0.8, -0.1]]))
    (u0, v0), (u1, _) = np.round(uv).astype(int)
    off_plane[v0 - 30 : v0 + 1, min(u0, u1) : max(u0, u1) + 1] = True
    detection = detector.detect(image, off_plane)
    assert len(detection.hits) > 10
    assert np.all(np.abs(detection.hits[:, 0] - 0.8) < 0.03)
    assert np.all(detection.support == 1)  # the parallax cue alone saw it


def test_a_hit_more_cues_saw_weighs_more_in_the_grid() -> None:
    detector, camera = detector_and_camera(seed=5)
    detector.learn(camera.render())
    detection = detector.detect(camera.render(boxes=[Box(0.8, 0.0, 0.2, 0.3, 0.2, (40, 60, 170))]))
    assert len(detection.hits) > 10 and detection.support.max() >= 2  # appearance and the boundary
    one_cue = LogOddsGrid((-1.0, -2.0), 0.025, 160, 160)
    many = LogOddsGrid((-1.0, -2.0), 0.025, 160, 160)
    weak = detector.detect(camera.render(boxes=[Box(0.8, 0.0, 0.2, 0.3, 0.2, (40, 60, 170))]))
    weak.support = np.ones_like(weak.support)
    one_cue.integrate((0.0, 0.0, 0.0), weak)
    many.integrate((0.0, 0.0, 0.0), detection)
    assert many.log_odds.max() > one_cue.log_odds.max()
    assert (many.log_odds > 0).sum() == (one_cue.log_odds > 0).sum()  # the same cells, believed sooner

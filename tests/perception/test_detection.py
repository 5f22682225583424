"""Obstacle detection on synthetic images: boxes drawn where a known 3-D box projects (through the
lens with and without distortion) must give hits at the box's foot, an empty floor none."""

from __future__ import annotations

import cv2
import numpy as np
import numpy.typing as npt
import pytest

from cart2d.perception.calibration import CameraCalibration
from cart2d.perception.camera_model import FloatArray, GroundProjection, Intrinsics, Mount
from cart2d.perception.detection import DetectorConfig, ObstacleDetector, draw_overlay
from cart2d.perception.synthetic import Box, SyntheticCamera

MOUNT = Mount.from_robot()
NOMINAL = CameraCalibration.nominal(MOUNT)
DISTORTED = Intrinsics(320, 240, 316.0, 316.0, 162.0, 118.0, (-0.12, 0.03, 0.0, 0.0, 0.0))
CONFIG = DetectorConfig()


def outside_footprint_m(points: FloatArray, box: Box) -> FloatArray:
    """How far each point is from the box's footprint (0 inside)."""
    dx = np.maximum(np.abs(points[:, 0] - box.x) - box.sx / 2, 0.0)
    dy = np.maximum(np.abs(points[:, 1] - box.y) - box.sy / 2, 0.0)
    return np.asarray(np.hypot(dx, dy))


def inside_footprint_m(points: FloatArray, box: Box) -> FloatArray:
    """How deep inside the footprint each point is (0 outside)."""
    dx = box.sx / 2 - np.abs(points[:, 0] - box.x)
    dy = box.sy / 2 - np.abs(points[:, 1] - box.y)
    return np.asarray(np.maximum(np.minimum(dx, dy), 0.0))


def detector_and_camera(distorted: bool, seed: int = 1) -> tuple[ObstacleDetector, SyntheticCamera]:
    if distorted:
        calibration = CameraCalibration(DISTORTED, GroundProjection.ideal(MOUNT, DISTORTED))
        return ObstacleDetector(calibration, MOUNT), SyntheticCamera(DISTORTED, MOUNT, seed=seed)
    return ObstacleDetector(NOMINAL, MOUNT), SyntheticCamera(NOMINAL.intrinsics, MOUNT, seed=seed)


BOXES = [
    Box(0.75, 0.0, 0.2, 0.3, 0.2, (40, 60, 170)),  # red, straight ahead
    Box(1.1, -0.3, 0.25, 0.2, 0.3, (150, 90, 30)),  # blue, to the right
    Box(1.1, 0.35, 0.15, 0.15, 0.15, (40, 140, 60)),  # green, far left (the picture ends at ~1.3 m)
    Box(0.6, 0.2, 0.1, 0.1, 0.25, (60, 60, 60)),  # dark grey, a thin post
]


@pytest.mark.parametrize("distorted", [False, True], ids=["pinhole", "distorted"])
@pytest.mark.parametrize("box", BOXES, ids=["ahead", "right", "far-left", "post"])
def test_hits_lie_on_the_boxs_foot(box: Box, distorted: bool) -> None:
    detector, camera = detector_and_camera(distorted)
    detector.learn(camera.render())
    detection = detector.detect(camera.render(boxes=[box]))
    assert len(detection.hits) > 0
    assert outside_footprint_m(detection.hits, box).max() < 0.03  # on its boundary, within 3 cm
    assert inside_footprint_m(detection.hits, box).max() < 0.03  # not deep inside (not a point up the box)
    # the near face is seen along its width: hits spread over most of the box's visible width
    visible = detection.hits[:, 1]
    assert visible.max() - visible.min() > 0.7 * min(box.sy, 2 * 0.2)
    near = detection.hits[np.abs(detection.hits[:, 1] - box.y) < box.sy / 4]
    assert np.abs(near[:, 0] - (box.x - box.sx / 2)).max() < 0.03  # the middle of the near face


@pytest.mark.parametrize("distorted", [False, True], ids=["pinhole", "distorted"])
def test_an_empty_floor_has_no_hits_and_free_rays_to_max_range(distorted: bool) -> None:
    detector, camera = detector_and_camera(distorted, seed=4)
    for _ in range(10):  # new noise each frame, and the floor model updating itself
        detection = detector.detect(camera.render())
        assert len(detection.hits) == 0
        assert detection.floor_mask.mean() > 0.99
        reach = np.linalg.norm(detection.free - detection.origin, axis=1)
        assert len(reach) == 320  # one ray per scan line
        # the lines in the middle of the picture reach max range; those at the sides leave the
        # picture sooner, and none goes beyond
        assert reach.max() <= CONFIG.max_range_m + 1e-9
        assert np.sort(reach)[-100:].min() > CONFIG.max_range_m - 0.02


def jpeg(image: npt.NDArray[np.uint8]) -> npt.NDArray[np.uint8]:
    """Through the camera's JPEG (quality 80, 4:2:0 chroma): ringing round edges, blotchy colour."""
    data = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, 80])[1]
    return np.asarray(cv2.imdecode(data, cv2.IMREAD_COLOR), dtype=np.uint8)


def test_through_jpeg_a_drive_sees_the_box_and_nothing_else() -> None:
    detector, camera = detector_and_camera(True, seed=11)
    box = Box(1.2, 0.1, 0.25, 0.3, 0.25, (40, 60, 170))
    # Towards the box, swaying, until it is 0.7 m ahead: nearer, a box as tall as the lens shows
    # its top beside its foot (docs/perception.md, Limits).
    for k in range(20):
        x, theta = 0.02 * k, 0.25 * np.sin(k / 6)
        empty = detector.detect(jpeg(camera.render((x, 0.0, theta))))
        assert len(empty.hits) == 0
        seen = detector.detect(jpeg(camera.render((x, 0.0, theta), boxes=[box])))
        assert len(seen.hits) > 0
        c, s = np.cos(theta), np.sin(theta)
        world = seen.hits @ np.array([[c, -s], [s, c]]).T + [x, 0.0]
        # JPEG's chroma subsampling and ringing bleed the box's colour onto the floor below it by
        # up to 3 rows (the box looks nearer), never above; one row spans d^2 / (h f) of floor at d
        ahead_m = np.linalg.norm(seen.hits - seen.origin, axis=1)
        row_m = ahead_m**2 / (MOUNT.height_m * DISTORTED.fy)
        assert np.all(outside_footprint_m(world, box) < 0.01 + 3 * row_m)
        assert np.all(inside_footprint_m(world, box) < 0.01 + row_m)


def test_a_box_beyond_max_range_is_no_hit_and_the_rays_stop_at_max_range() -> None:
    detector, camera = detector_and_camera(False)
    detector.learn(camera.render())
    detection = detector.detect(camera.render(boxes=[Box(2.2, 0.0, 0.3, 0.6, 0.3)]))
    assert len(detection.hits) == 0
    assert np.linalg.norm(detection.free - detection.origin, axis=1).max() <= CONFIG.max_range_m + 1e-9


def test_a_box_in_front_of_the_cart_is_never_learnt_as_floor() -> None:
    detector, camera = detector_and_camera(False)
    red = (40, 60, 170)
    detector.learn(camera.render())
    for _ in range(40):  # a red box sits in the floor patch: those pixels must not teach the floor
        detector.detect(camera.render(boxes=[Box(0.45, 0.0, 0.1, 0.12, 0.2, red)]))
    later = detector.detect(camera.render(boxes=[Box(1.0, 0.0, 0.2, 0.3, 0.2, red)]))
    assert len(later.hits) > 20
    assert outside_footprint_m(later.hits, Box(1.0, 0.0, 0.2, 0.3, 0.2)).max() < 0.03


def test_the_floor_model_follows_a_slow_change_of_light() -> None:
    detector, camera = detector_and_camera(False, seed=7)
    grey = np.array([170, 175, 180])
    detector.learn(camera.render(floor_bgr=(170, 175, 180)))
    for k in range(1, 61):  # 20 % darker over 60 frames
        shade = tuple(int(c) for c in grey * (1.0 - 0.2 * k / 60))
        detection = detector.detect(camera.render(floor_bgr=shade))  # type: ignore[arg-type]
    assert len(detection.hits) == 0


def test_the_overlay_marks_the_floor_and_the_hits() -> None:
    detector, camera = detector_and_camera(False)
    image = camera.render(boxes=[BOXES[0]])
    detection = detector.detect(image)
    overlay = draw_overlay(image, detection)
    assert overlay.shape == image.shape
    u, v = detection.lowest_px[detection.is_hit][len(detection.hits) // 2]
    assert tuple(overlay[round(v), round(u)]) == (0, 0, 255)
    floor = np.argwhere(detection.floor_mask)[0]
    assert overlay[floor[0], floor[1], 1] > image[floor[0], floor[1], 1]  # tinted green


def test_an_image_of_another_size_is_refused() -> None:
    detector, _ = detector_and_camera(False)
    with pytest.raises(ValueError, match="640 x 480"):
        detector.detect(np.zeros((480, 640, 3), np.uint8))


def silhouette(lowest_rows: dict[int, int]) -> npt.NDArray[np.bool_]:
    """An obstacle image in scan-line coordinates (row, line): line k non-floor from the top down to
    row lowest_rows[k], the other lines all floor."""
    mask = np.zeros((240, 320), dtype=bool)
    for line, row in lowest_rows.items():
        mask[: row + 1, line] = True
    return mask


@pytest.mark.parametrize("side", ["left", "right"])
def test_lines_grazing_a_silhouette_at_the_pictures_side_give_no_hit(side: str) -> None:
    # As the simulator's camera showed a box's near corner at the picture's side: four lines lean
    # along its vertical edge and first meet it 50 rows (~0.2 m of floor) above its foot, which the
    # lines further in show; past the corner the floor is clear. Only the lines on the foot may hit.
    detector, _ = detector_and_camera(False)
    rows = {k: 125 + k // 2 for k in range(2, 6)} | {k: 175 + k // 10 for k in range(6, 60)}
    if side == "right":
        rows = {319 - k: row for k, row in rows.items()}
    obstacle = silhouette(rows) & detector.scan_in_range
    detection = detector._rays(np.ones_like(obstacle), obstacle)
    assert sorted(np.nonzero(detection.is_hit)[0]) == sorted(k for k, r in rows.items() if r >= 175)


def test_a_face_rising_steadily_across_the_lines_is_all_hits() -> None:
    # a face seen at a slant: its foot two rows lower (nearer) on each line to the right, 40 lines
    detector, _ = detector_and_camera(False)
    rows = {k: 120 + 2 * (k - 100) for k in range(100, 140)}
    obstacle = silhouette(rows) & detector.scan_in_range
    detection = detector._rays(np.ones_like(obstacle), obstacle)
    assert sorted(np.nonzero(detection.is_hit)[0]) == list(range(100, 140))

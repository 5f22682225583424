"""Tag detection and the pose it gives, against markers drawn at known poses: each marker's
corners projected by hand (the pinhole with the mount's rotation, no library), the bitmap warped
onto them, and the cart's pose read back from the picture."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from cart2d.localisation.markers import Marker, MarkerMap, bitmap
from cart2d.localisation.tags import Sighting, TagDetector, TagLocaliser
from cart2d.perception.camera_model import Intrinsics, Mount

MOUNT = Mount.from_robot()
INTRINSICS = Intrinsics.nominal(MOUNT)
Pose = tuple[float, float, float]


def project(pose: tuple[float, float, float], point: np.ndarray) -> tuple[float, float]:
    """A map point seen by the cart at `pose`: into base_link, into the camera by the mount's
    rows (right, down, forward), then u = fx x/z + cx (hand-written, no OpenCV)."""
    x, y, th = pose
    dx, dy = point[0] - x, point[1] - y
    base = np.array([math.cos(th) * dx + math.sin(th) * dy, -math.sin(th) * dx + math.cos(th) * dy, point[2]])
    cam = MOUNT.rotation() @ (base - MOUNT.centre())
    assert cam[2] > 0
    return INTRINSICS.fx * cam[0] / cam[2] + INTRINSICS.cx, INTRINSICS.fy * cam[1] / cam[2] + INTRINSICS.cy


def draw(
    marker: Marker, pose: tuple[float, float, float], oversample: int = 4
) -> tuple[np.ndarray, np.ndarray]:
    """The picture (grey wall, the marker with a white margin) and the black square's corners."""
    cells = bitmap(marker.id)
    n = cells.shape[0]
    side = n + 2  # a one-cell white margin
    sheet = np.full((side, side), 255, np.uint8)
    sheet[1:-1, 1:-1] = cells * 255
    # the sheet's outer corners in map, from the marker's frame (x right, y up)
    half = marker.size_m / 2 * side / n
    local = np.array([[-half, half, 0], [half, half, 0], [half, -half, 0], [-half, -half, 0]])
    outer = local @ marker.rotation().T + marker.centre()
    uv = np.array([project(pose, p) for p in outer])
    w, h = INTRINSICS.width, INTRINSICS.height
    s = oversample
    # pixel centres at integers, a pixel's area [u - 0.5, u + 0.5]: the sheet's outer edges are
    # at -0.5 and side - 0.5; pixel u's area is the oversampled canvas's [s u - 0.5, s u + s - 0.5]
    src = np.array([[0, 0], [side, 0], [side, side], [0, side]], np.float32) - 0.5
    dst = ((uv + 0.5) * s - 0.5).astype(np.float32)
    homography = cv2.getPerspectiveTransform(src, dst)
    big = cv2.warpPerspective(sheet, homography, (w * s, h * s), flags=cv2.INTER_NEAREST, borderValue=170)
    picture = cv2.resize(big, (w, h), interpolation=cv2.INTER_AREA)
    corners = np.array([project(pose, p) for p in marker.corners()])
    return picture, corners


CASES = [
    # (marker on the wall facing -x at x = d, cart at the origin looking at it)
    ((0.0, 0.0, 0.0), Marker(7, 0.1, 0.5, 0.0, 0.06, 180.0)),
    ((0.1, -0.05, 0.3), Marker(12, 0.1, 0.6, 0.15, 0.06, 180.0)),
    ((0.0, 0.0, 0.0), Marker(3, 0.12, 0.45, 0.05, 0.0, 90.0, "floor")),
    ((1.0, 1.0, math.pi / 2), Marker(4, 0.15, 0.95, 1.5, 0.0, 120.0, "floor")),
]


@pytest.mark.parametrize(("pose", "marker"), CASES)
def test_the_corners_are_found_where_they_project(pose: Pose, marker: Marker) -> None:
    picture, corners = draw(marker, pose)
    sightings = TagDetector().detect(picture)
    assert [s.tag_id for s in sightings] == [marker.id]
    assert np.abs(sightings[0].corners_px - corners).max() < 0.75  # a pixel's noise-free quad fit


@pytest.mark.parametrize(("pose", "marker"), CASES)
def test_the_fix_is_the_pose_the_marker_was_drawn_from(
    pose: tuple[float, float, float], marker: Marker
) -> None:
    picture, _ = draw(marker, pose)
    localiser = TagLocaliser(MarkerMap((marker,)), INTRINSICS, MOUNT)
    (fix,) = localiser.fixes(TagDetector().detect(picture))
    error = np.array(fix.pose) - np.array(pose)
    error[2] = math.remainder(error[2], math.tau)
    assert math.hypot(error[0], error[1]) < 0.01
    assert abs(error[2]) < math.radians(1.0)
    # and the error is within what the fix says of itself (3 sigma)
    assert float(error @ np.linalg.inv(fix.covariance) @ error) < 14.2


def test_a_marker_not_in_the_file_gives_no_fix() -> None:
    pose, marker = CASES[0]
    picture, _ = draw(marker, pose)
    other = Marker(marker.id + 1, 0.1, 0.5, 0.0, 0.06, 180.0)
    assert TagLocaliser(MarkerMap((other,)), INTRINSICS, MOUNT).fixes(TagDetector().detect(picture)) == []


def test_the_covariance_grows_with_range() -> None:
    near = Marker(7, 0.1, 0.45, 0.0, 0.06, 180.0)
    far = Marker(7, 0.1, 0.7, 0.0, 0.06, 180.0)
    sizes = []
    for marker in (near, far):
        picture, _ = draw(marker, (0.0, 0.0, 0.0))
        (fix,) = TagLocaliser(MarkerMap((marker,)), INTRINSICS, MOUNT).fixes(TagDetector().detect(picture))
        sizes.append(np.trace(fix.covariance[:2, :2]))
    assert sizes[1] > 1.5 * sizes[0]


@pytest.mark.parametrize(
    "corners",
    [
        [[100, 100], [120, 100], [140, 100], [160, 100]],  # in a line
        [[100, 100]] * 4,  # one point
        [[100, 100], [140, 140], [140, 100], [100, 140]],  # crossed
        [[math.nan, 100], [140, 100], [140, 140], [100, 140]],  # not finite: its covariance raised
        [[1e30, 1e30], [-1e30, 1e30], [-1e30, -1e30], [1e30, -1e30]],
    ],
    ids=["collinear", "one point", "crossed", "nan", "huge"],
)
def test_corners_that_give_no_pose_give_no_fix_and_raise_nothing(corners: list[list[float]]) -> None:
    marker = CASES[0][1]
    localiser = TagLocaliser(MarkerMap((marker,)), INTRINSICS, MOUNT)
    sighting = Sighting(marker.id, np.array(corners, dtype=float))
    assert localiser.fix(marker, sighting) is None
    assert localiser.fixes([sighting]) == []

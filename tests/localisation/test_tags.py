"""Tag detection and the pose it gives, against markers drawn at known poses: each marker's
corners projected by hand (the pinhole with the mount's rotation, no library), the bitmap warped
onto them, and the cart's pose read back from the picture."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cart2d.localisation.markers import Marker, MarkerMap
from cart2d.localisation.tags import Sighting, TagDetector, TagLocaliser
from tests.support.tags import CASES, INTRINSICS, MOUNT, Pose, draw


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

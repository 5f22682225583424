"""The two-pass detector (a cheap candidate search over the frame, OpenCV's AprilTag detection in
crops round the candidates): the corners the AprilTag detection over the whole frame gives, in
this project's pixel-centre convention, found once each, nothing in an empty picture."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from cart2d.localisation import tags
from cart2d.localisation.markers import Marker, dictionary
from cart2d.localisation.tags import Sighting, TagDetector
from tests.support.tags import CASES, Pose, draw


@pytest.mark.parametrize(("pose", "marker"), CASES)
def test_the_crops_give_the_whole_frame_detections_corners(pose: Pose, marker: Marker) -> None:
    picture, _ = draw(marker, pose)
    (cropped,) = TagDetector().detect(picture)
    (whole,) = TagDetector(crops=False).detect(picture)
    assert cropped.tag_id == whole.tag_id == marker.id
    assert np.abs(cropped.corners_px - whole.corners_px).max() < 0.05


def test_the_corners_have_no_offset_from_their_projections() -> None:
    """Over the drawn cases the corners are unbiased: CORNER_OFFSET_PX taken off once, with the
    crop's origin added (left on, or taken off twice, they are ~0.4 px off in x and y)."""
    offsets = []
    for pose, marker in CASES:
        picture, corners = draw(marker, pose)
        (seen,) = TagDetector().detect(picture)
        offsets.append(seen.corners_px - corners)
    bias = np.concatenate(offsets).mean(axis=0)
    assert np.abs(bias).max() < 0.2, bias


def test_a_tag_the_candidate_search_cannot_decode_is_found_in_its_crop() -> None:
    """A floor tag 0.8 m ahead, foreshortened to ~18 px high: the ArUco search's integer corners
    do not decode it, its rejected quad is cropped and the AprilTag detection decodes it."""
    marker = Marker(2, 0.15, 0.8, 0.0, 0.0, 180.0, "floor")
    picture, corners = draw(marker, (0.0, 0.0, 0.0))
    search = cv2.aruco.ArucoDetector(dictionary(), cv2.aruco.DetectorParameters())
    assert search.detectMarkers(picture)[1] is None  # the case this test is about
    (seen,) = TagDetector().detect(picture)
    assert seen.tag_id == 2
    assert np.abs(seen.corners_px - corners).max() < 0.75


def test_two_tags_in_one_picture_are_each_found_once() -> None:
    (pose, left), (_, right) = CASES[0], CASES[2]
    first, _ = draw(left, pose)
    second, _ = draw(right, pose)
    picture = np.minimum(first, second)  # both on the grey wall (170): the darker pixel is the tag's
    assert sorted(s.tag_id for s in TagDetector().detect(picture)) == sorted([left.id, right.id])


def test_a_picture_without_tags_gives_no_sighting() -> None:
    rng = np.random.default_rng(1)
    picture = np.clip(170 + rng.normal(0, 2, (240, 320)), 0, 255).astype(np.uint8)
    cv2.rectangle(picture, (40, 40), (120, 120), 30, -1)  # a dark square with no code in it
    assert TagDetector().detect(picture) == []


def test_a_cluttered_picture_costs_at_most_max_crops_crops(monkeypatch: pytest.MonkeyPatch) -> None:
    """Twelve dark squares with no code beside a tag: the tag is found, and the AprilTag
    detection runs in MAX_CROPS crops at most (each costs: the frame's cost stays bounded)."""
    pose, marker = CASES[0]
    picture, _ = draw(marker, pose)
    for k in range(12):
        x, y = 5 + 80 * (k % 4), 150 + 30 * (k // 4)
        cv2.rectangle(picture, (x, y), (x + 25, y + 25), 30, -1)
    crops = []
    in_frame = tags._sightings

    def counted(
        detector: cv2.aruco.ArucoDetector, gray: np.ndarray, origin: tuple[int, int]
    ) -> list[Sighting]:
        crops.append(origin)
        return in_frame(detector, gray, origin)

    monkeypatch.setattr(tags, "_sightings", counted)
    assert [s.tag_id for s in TagDetector().detect(picture)] == [marker.id]
    assert 1 < len(crops) <= tags.MAX_CROPS

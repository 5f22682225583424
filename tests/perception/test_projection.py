"""The camera's ground projection against cases computed by hand from the mount's geometry."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cart2d.perception.camera_model import GroundProjection, Intrinsics, Mount

MOUNT = Mount(x_m=0.10, y_m=0.02, height_m=0.25, pitch_deg=25.0, width_px=320, height_px=240, hfov_deg=55.0)
LENS = Intrinsics.nominal(MOUNT)
GROUND = GroundProjection.ideal(MOUNT, LENS)
PITCH = math.radians(MOUNT.pitch_deg)


def test_nominal_focal_length_from_the_field_of_view() -> None:
    # half the width over tan(half the field of view): 160 / tan(27.5 deg) = 160 / 0.520567
    assert LENS.fx == pytest.approx(307.357, abs=1e-3)
    assert LENS.fy == LENS.fx
    assert (LENS.cx, LENS.cy) == (159.5, 119.5)


def test_the_optical_axis_meets_the_floor_at_height_over_tan_pitch() -> None:
    hit = GROUND.pixel_to_ground(LENS.cx, LENS.cy)
    assert hit is not None
    assert hit[0] == pytest.approx(MOUNT.x_m + MOUNT.height_m / math.tan(PITCH), abs=1e-9)  # 0.636 m
    assert hit[1] == pytest.approx(MOUNT.y_m, abs=1e-9)


@pytest.mark.parametrize("ahead_m", [0.3, 0.5, 1.0, 2.0])
def test_a_point_on_the_centre_line_maps_to_the_predicted_row(ahead_m: float) -> None:
    # a ray that meets the floor ahead_m in front of the lens dips atan(h / d) below horizontal,
    # that is atan(h / d) - pitch below the optical axis: v = cy + fy tan(that)
    below_axis = math.atan(MOUNT.height_m / ahead_m) - PITCH
    pixel = GROUND.ground_to_pixel(MOUNT.x_m + ahead_m, MOUNT.y_m)
    assert pixel is not None
    assert pixel[0] == pytest.approx(LENS.cx, abs=1e-9)
    assert pixel[1] == pytest.approx(LENS.cy + LENS.fy * math.tan(below_axis), abs=1e-9)


def test_a_point_to_the_left_appears_left_of_centre_by_its_bearing() -> None:
    # 1 m ahead of the lens and 0.2 m to its left: in the camera frame x = -0.2 and the depth is
    # the distance along the optical axis, d cos(pitch) + h sin(pitch)
    depth = 1.0 * math.cos(PITCH) + MOUNT.height_m * math.sin(PITCH)
    pixel = GROUND.ground_to_pixel(MOUNT.x_m + 1.0, MOUNT.y_m + 0.2)
    assert pixel is not None
    assert pixel[0] == pytest.approx(LENS.cx - LENS.fx * 0.2 / depth, abs=1e-9)


def test_columns_symmetric_about_the_centre_see_mirrored_points() -> None:
    for offset, row in [(40.0, 200.0), (150.0, 130.0), (10.0, 239.0)]:
        left = GROUND.pixel_to_ground(LENS.cx - offset, row)
        right = GROUND.pixel_to_ground(LENS.cx + offset, row)
        assert left is not None and right is not None
        assert left[0] == pytest.approx(right[0], abs=1e-9)
        assert left[1] - MOUNT.y_m == pytest.approx(-(right[1] - MOUNT.y_m), abs=1e-9)
        assert left[1] > MOUNT.y_m  # u to the left is y to the left


def test_pixels_at_or_above_the_horizon_see_no_floor() -> None:
    # the row looking straight ahead: 119.5 - 307.357 tan(25 deg) = -23.8, just above the image (the
    # top row looks 3.7 degrees down); the maths holds off the image as well
    horizon_v = LENS.cy - LENS.fy * math.tan(PITCH)
    assert horizon_v == pytest.approx(-23.82, abs=0.01)
    assert GROUND.pixel_to_ground(LENS.cx, horizon_v - 1.0) is None
    assert GROUND.pixel_to_ground(0.0, horizon_v - 100.0) is None
    just_below = GROUND.pixel_to_ground(LENS.cx, horizon_v + 1.0)
    assert just_below is not None and just_below[0] > 10.0  # far, but on the floor ahead
    xy, valid = GROUND.pixels_to_ground([[LENS.cx, horizon_v - 5.0], [LENS.cx, horizon_v + 5.0]])
    assert valid.tolist() == [False, True]
    assert np.isnan(xy[0]).all()


def test_points_behind_the_camera_have_no_pixel() -> None:
    assert GROUND.ground_to_pixel(MOUNT.x_m - 0.5, 0.0) is None


def test_round_trips() -> None:
    rng = np.random.default_rng(3)
    floor = np.column_stack([rng.uniform(0.35, 3.0, 200), rng.uniform(-1.0, 1.0, 200)])
    pixels, seen = GROUND.grounds_to_pixels(floor)
    assert seen.all()
    back, valid = GROUND.pixels_to_ground(pixels)
    assert valid.all()
    np.testing.assert_allclose(back, floor, atol=1e-9)


def test_a_fitted_homography_of_either_sign_is_the_same_projection() -> None:
    flipped = GroundProjection.fitted(-3.0 * GROUND.floor_to_pixel, (1.0, 0.0))
    assert flipped.pixel_to_ground(100.0, 200.0) == pytest.approx(GROUND.pixel_to_ground(100.0, 200.0))
    assert flipped.pixel_to_ground(100.0, -40.0) is None


def test_undistortion_inverts_the_lens_model() -> None:
    import cv2

    lens = Intrinsics(320, 240, 300.0, 302.0, 161.0, 118.0, (-0.12, 0.03, 0.0, 0.0, 0.0))
    rays = np.array([[0.5, -0.38, 1.0], [-0.25, 0.3, 1.0], [0.0, 0.0, 1.0]])  # a corner, inside, the centre
    distorted, _ = cv2.projectPoints(rays, np.zeros(3), np.zeros(3), lens.matrix(), lens.dist_array())
    ideal = rays[:, :2] * [lens.fx, lens.fy] + [lens.cx, lens.cy]
    np.testing.assert_allclose(lens.undistort(distorted.reshape(-1, 2)), ideal, atol=1e-4)
    assert np.abs(distorted.reshape(-1, 2) - ideal).max() > 2.0  # the lens really bends them


def test_a_degenerate_homography_is_refused() -> None:
    with pytest.raises(ValueError, match="invertible"):
        GroundProjection(np.array([[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 0.0, 1.0]]))
    with pytest.raises(ValueError, match="finite"):
        GroundProjection(np.full((3, 3), np.nan))

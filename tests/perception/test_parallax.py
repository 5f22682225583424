"""The parallax cue on synthetic warps: a textured floor and a textured wall rendered through
known homographies from two poses. What lies on the floor (its texture, a shadow on it) must line
up after the floor's warp; the wall, standing above the floor, must not."""

from __future__ import annotations

import math

import cv2
import numpy as np
import numpy.typing as npt
import pytest

from cart2d.perception.calibration import CameraCalibration
from cart2d.perception.camera_model import FloatArray, Mount
from cart2d.perception.parallax import ParallaxCue, floor_homography, motion_on_floor

MOUNT = Mount.from_robot()
CALIBRATION = CameraCalibration.nominal(MOUNT)
TEXTURE_PX_PER_M = 400.0  # the textures' scale: 2.5 mm a texel
WALL_X_M = 0.6  # the wall stands across the floor this far ahead of the first pose (0.14 m of it in view)
SIZE = (CALIBRATION.intrinsics.width, CALIBRATION.intrinsics.height)


def texture(seed: int, size: tuple[int, int], grain: float = 20.0) -> npt.NDArray[np.uint8]:
    """Smooth random blotches with some grain (about 1 cm across): something to line up."""
    rng = np.random.default_rng(seed)
    coarse = cv2.resize(rng.normal(0, 1, (size[1] // 16, size[0] // 16)).astype(np.float32), size)
    fine = np.asarray(cv2.GaussianBlur(rng.normal(0, 1, (size[1], size[0])).astype(np.float32), (0, 0), 2.0))
    fine = np.asarray(fine / float(fine.std()), dtype=np.float32)
    grey = 140 + 25 * coarse + grain * fine
    return np.asarray(np.clip(grey, 0, 255), dtype=np.uint8)


def camera_from_map(pose: tuple[float, float, float]) -> tuple[FloatArray, FloatArray]:
    """(R, t): p_camera = R p_map + t for the cart at `pose`."""
    x, y, theta = pose
    c, s = math.cos(theta), math.sin(theta)
    base_to_map = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    r_cb, t_cb = MOUNT.extrinsics()
    r = r_cb @ base_to_map.T
    return r, t_cb - r @ np.array([x, y, 0.0])


def render(
    pose: tuple[float, float, float], shadow: bool = False, wall: bool = True
) -> npt.NDArray[np.uint8]:
    """The floor (texture 1, metres -2..2 each way from the origin, optionally with a dark
    rectangle: a shadow cast on it) and a wall across it at x = WALL_X_M (texture 2, 0.4 m high)."""
    k = CALIBRATION.intrinsics.matrix()
    r, t = camera_from_map(pose)
    floor_tex = texture(1, (1600, 1600))
    if shadow:
        # a shadow 0.2 m by 0.3 m at x 0.5..0.7, y -0.15..0.15: half the light
        x0, x1 = int((0.5 + 2) * TEXTURE_PX_PER_M), int((0.7 + 2) * TEXTURE_PX_PER_M)
        y0, y1 = int((-0.15 + 2) * TEXTURE_PX_PER_M), int((0.15 + 2) * TEXTURE_PX_PER_M)
        floor_tex[y0:y1, x0:x1] = floor_tex[y0:y1, x0:x1] // 2
    # texel (i, j) of the floor is map point (i / s - 2, j / s - 2)
    texel_to_floor = np.array([[1 / TEXTURE_PX_PER_M, 0, -2.0], [0, 1 / TEXTURE_PX_PER_M, -2.0], [0, 0, 1]])
    floor_h = k @ np.column_stack([r[:, 0], r[:, 1], t]) @ texel_to_floor
    out = cv2.warpPerspective(floor_tex, floor_h, SIZE, flags=cv2.INTER_LINEAR)
    if wall:
        wall_tex = texture(2, (1600, 160), grain=40.0)  # a bookcase, a patterned skirting
        # texel (i, j) of the wall is map point (WALL_X_M, i / s - 2, 0.4 - j / s)
        texel_to_wall = np.array(
            [[1 / TEXTURE_PX_PER_M, 0, -2.0], [0, -1 / TEXTURE_PX_PER_M, 0.4], [0, 0, 1]]
        )
        wall_h = k @ np.column_stack([r[:, 1], r[:, 2], r[:, 0] * WALL_X_M + t]) @ texel_to_wall
        drawn = cv2.warpPerspective(wall_tex, wall_h, SIZE, flags=cv2.INTER_LINEAR)
        mask = cv2.warpPerspective(np.full_like(wall_tex, 255), wall_h, SIZE, flags=cv2.INTER_NEAREST)
        out[mask > 0] = drawn[mask > 0]
    return np.asarray(cv2.cvtColor(out, cv2.COLOR_GRAY2BGR), dtype=np.uint8)


def wall_mask(pose: tuple[float, float, float]) -> npt.NDArray[np.bool_]:
    """Where the wall is in the picture taken at `pose`."""
    k = CALIBRATION.intrinsics.matrix()
    r, t = camera_from_map(pose)
    texel_to_wall = np.array([[1 / TEXTURE_PX_PER_M, 0, -2.0], [0, -1 / TEXTURE_PX_PER_M, 0.4], [0, 0, 1]])
    wall_h = k @ np.column_stack([r[:, 1], r[:, 2], r[:, 0] * WALL_X_M + t]) @ texel_to_wall
    mask = cv2.warpPerspective(np.full((160, 1600), 255, np.uint8), wall_h, SIZE, flags=cv2.INTER_NEAREST)
    return np.asarray(mask > 0, dtype=np.bool_)


EARLIER = (0.0, 0.0, 0.0)
LATER = (0.06, 0.01, 0.05)  # 6 cm on, a little left, turned 3 degrees


def test_the_floor_homography_maps_a_floor_point_where_the_later_pose_sees_it() -> None:
    g = CALIBRATION.ground.floor_to_pixel
    h = floor_homography(g, EARLIER, LATER)
    floor_point = np.array([0.8, 0.1])  # in the map = base_link of EARLIER
    before = g @ np.append(floor_point, 1.0)
    after = h @ before
    x, y, theta = LATER
    c, s = math.cos(theta), math.sin(theta)
    in_later = np.array([[c, s], [-s, c]]) @ (floor_point - [x, y])
    expected = g @ np.append(in_later, 1.0)
    assert after[:2] / after[2] == pytest.approx(expected[:2] / expected[2], abs=1e-9)
    assert motion_on_floor(EARLIER, EARLIER) == pytest.approx(np.eye(3))


def test_the_floor_lines_up_and_the_wall_does_not() -> None:
    cue = ParallaxCue(CALIBRATION)
    assert cue.observe(render(EARLIER), EARLIER) is None  # nothing to compare with yet
    off = cue.observe(render(LATER), LATER)
    assert off is not None
    wall = wall_mask(LATER)
    floor = ~cv2.dilate(wall.astype(np.uint8), np.ones((9, 9), np.uint8)).astype(bool)
    floor[:, :8] = floor[:, -8:] = False  # the picture's sides: new floor the earlier frame lacked
    floor[-8:, :] = False
    assert off[floor].mean() < 0.01  # the floor lines up
    assert off[wall].mean() > 0.3  # the wall, textured, does not (where its texture is smooth: no say)


def test_a_shadow_on_the_floor_lines_up_with_the_floor() -> None:
    cue = ParallaxCue(CALIBRATION)
    cue.observe(render(EARLIER, shadow=True, wall=False), EARLIER)
    off = cue.observe(render(LATER, shadow=True, wall=False), LATER)
    assert off is not None
    inner = np.zeros_like(off)
    inner[8:-8, 8:-8] = True
    assert off[inner].mean() < 0.01


def test_a_wrong_motion_is_seen_as_parallax_everywhere() -> None:
    # the same pictures, but odometry claims the cart stood still: the floor does not line up
    # (which is why the cue needs the poses at capture, not at arrival)
    cue = ParallaxCue(CALIBRATION)
    earlier, later = render(EARLIER, wall=False), render(LATER, wall=False)
    h = floor_homography(CALIBRATION.ground.floor_to_pixel, EARLIER, EARLIER)
    off = cue.off_plane(cue.prepare(earlier), cue.prepare(later), h)
    assert off.mean() > 0.2


def test_too_short_a_baseline_says_nothing_and_keeps_the_earlier_frame() -> None:
    cue = ParallaxCue(CALIBRATION)
    cue.observe(render(EARLIER), EARLIER)
    assert cue.observe(render((0.01, 0.0, 0.3)), (0.01, 0.0, 0.3)) is None  # a turn, 1 cm on
    assert cue.previous is not None and cue.previous[1] == EARLIER
    assert cue.observe(render(LATER), LATER) is not None

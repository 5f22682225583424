"""The floor's geometry as a cue: plane-induced parallax between two frames (Hartley & Zisserman,
Multiple View Geometry, 2nd ed., section 13.1; Irani & Anandan's "plane + parallax").

Between two frames the cart's odometry says how it moved on the floor. The floor plane then
moves in the picture by one homography, H = G M G^-1, with G the ground homography (floor point
in base_link -> undistorted pixel) and M the cart's motion on the floor (base_link of the earlier
frame -> base_link of the later one). Warped by H, the earlier picture lines up with the later one
wherever it shows floor; what stands above the floor (a wall, a leg, a step) does not, by an
amount that grows with its height and with the distance driven. A shadow lies on the floor and
lines up; so does a pattern on a carpet. Where the picture has no texture (a plain wall's middle)
nothing shows either way: this cue then says nothing, and the others decide.

All image work is OpenCV: cv2.remap to and from the undistorted picture (maps computed once),
cv2.warpPerspective for H, cv2.absdiff, cv2.Sobel and cv2.GaussianBlur for the residual and how
much of it texture alone explains, cv2.morphologyEx to drop specks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from cart2d.perception.calibration import CameraCalibration
from cart2d.perception.camera_model import FloatArray

Pose = tuple[float, float, float]  # x, y (m), theta (rad) of base_link in the map
GreyImage = npt.NDArray[np.uint8]


@dataclass(frozen=True)
class ParallaxConfig:
    # Below this much driving (m) nothing above the floor moves by enough to tell: a pure turn on
    # the spot (the lens over the wheel axis) moves every point alike, floor or not.
    min_baseline_m: float = 0.02
    blur_px: int = 5  # both pictures are smoothed alike before comparing: JPEG blocks, noise
    # The residual a pixel may show for the floor: noise, plus its gradient times how far the
    # warp may be off (odometry and the homography: about a pixel).
    noise_levels: float = 6.0
    misregistration_px: float = 1.0
    open_px: int = 3  # specks smaller than this are dropped (vertical and horizontal)
    # The homography odometry predicts is refined on the pictures themselves (corners tracked with
    # cv2.calcOpticalFlowPyrLK from where it puts them; cv2.findHomography, USAC_ACCURATE: RANSAC
    # with local optimisation): the nominal lens is centimetres off, odometry slips. Without
    # min_tracks inliers, or if the fit strays more than max_correction_px from the prediction
    # anywhere on the floor, the cue says nothing.
    max_corners: int = 80
    min_tracks: int = 12
    ransac_px: float = 1.5
    ransac_iterations: int = 200  # the floor is most of the tracks: a few hundred draws find it
    max_correction_px: float = 12.0


def motion_on_floor(earlier: Pose, later: Pose) -> FloatArray:
    """M, 3 x 3: floor points in base_link of `earlier` -> the same points in base_link of `later`."""

    def base_to_map(pose: Pose) -> FloatArray:
        x, y, theta = pose
        c, s = math.cos(theta), math.sin(theta)
        return np.array([[c, -s, x], [s, c, y], [0.0, 0.0, 1.0]])

    return np.asarray(np.linalg.inv(base_to_map(later)) @ base_to_map(earlier), dtype=np.float64)


def floor_homography(floor_to_pixel: FloatArray, earlier: Pose, later: Pose) -> FloatArray:
    """H, 3 x 3: an undistorted pixel of the earlier frame showing floor -> where the later frame
    shows that floor point."""
    g = np.asarray(floor_to_pixel, dtype=np.float64)
    h = g @ motion_on_floor(earlier, later) @ np.linalg.inv(g)
    return np.asarray(h / h[2, 2], dtype=np.float64)


def _undistort_maps(
    calibration: CameraCalibration,
) -> tuple[npt.NDArray[np.float32], npt.NDArray[np.float32]]:
    """cv2.remap maps raw image -> undistorted image (same K)."""
    lens = calibration.intrinsics
    map_x, map_y = cv2.initUndistortRectifyMap(
        lens.matrix(), lens.dist_array(), np.eye(3), lens.matrix(), (lens.width, lens.height), cv2.CV_32FC1
    )
    return np.asarray(map_x, dtype=np.float32), np.asarray(map_y, dtype=np.float32)


def _distort_maps(calibration: CameraCalibration) -> tuple[npt.NDArray[np.float32], npt.NDArray[np.float32]]:
    """cv2.remap maps undistorted image -> raw image: for each raw pixel, its undistorted pixel."""
    lens = calibration.intrinsics
    grid = np.stack(np.meshgrid(np.arange(lens.width), np.arange(lens.height)), axis=-1).reshape(-1, 2)
    ideal = lens.undistort(grid.astype(np.float64)).reshape(lens.height, lens.width, 2)
    return ideal[..., 0].astype(np.float32), ideal[..., 1].astype(np.float32)


class ParallaxCue:
    """Per frame, with the pose at its capture: where the picture does not line up with the last
    frame warped by the floor's homography (True = above the floor), in raw pixels; None while
    there is no earlier frame far enough back."""

    def __init__(self, calibration: CameraCalibration, config: ParallaxConfig | None = None) -> None:
        self.calibration = calibration
        self.config = config or ParallaxConfig()
        lens = calibration.intrinsics
        self.size = (lens.width, lens.height)
        self.distorted = any(lens.dist)
        if self.distorted:
            self.undistort_x, self.undistort_y = _undistort_maps(calibration)
            self.distort_x, self.distort_y = _distort_maps(calibration)
        k = self.config.open_px
        self.open_across = cv2.getStructuringElement(cv2.MORPH_RECT, (k, 1))
        self.open_up = cv2.getStructuringElement(cv2.MORPH_RECT, (1, k))
        self.previous: tuple[GreyImage, Pose] | None = None

    def reset(self) -> None:
        self.previous = None

    def prepare(self, bgr: npt.NDArray[np.uint8]) -> GreyImage:
        """A raw picture as the cue compares it: grey, undistorted, smoothed."""
        grey = cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY)
        if self.distorted:
            grey = cv2.remap(grey, self.undistort_x, self.undistort_y, cv2.INTER_LINEAR, borderValue=0)
        b = self.config.blur_px
        return np.asarray(cv2.GaussianBlur(grey, (b, b), 0), dtype=np.uint8)

    def observe(self, bgr: npt.NDArray[np.uint8], pose: Pose) -> npt.NDArray[np.bool_] | None:
        """The later frame and its pose: the off-plane mask, or None if the cart has not moved
        min_baseline_m since the frame kept (which is then kept on; a frame far enough from it
        replaces it)."""
        grey = self.prepare(bgr)
        if self.previous is None:
            self.previous = (grey, pose)
            return None
        earlier, earlier_pose = self.previous
        if math.dist(earlier_pose[:2], pose[:2]) < self.config.min_baseline_m:
            return None
        self.previous = (grey, pose)
        predicted = floor_homography(self.calibration.ground.floor_to_pixel, earlier_pose, pose)
        refined = self.refine(earlier, grey, predicted)
        return None if refined is None else self.off_plane(earlier, grey, refined)

    def refine(self, earlier: GreyImage, later: GreyImage, predicted: FloatArray | None) -> FloatArray | None:
        """The floor's homography between two prepared pictures, fitted to corners of the lower
        half of the earlier one (the floor nearest the cart) tracked into the later one from where
        `predicted` puts them (from where they were, without a prediction); None if too few
        track, or if the fit strays more than max_correction_px from the prediction."""
        k = self.config
        width, height = self.size
        near = np.zeros_like(earlier)
        near[height // 2 :, :] = 255
        corners = cv2.goodFeaturesToTrack(earlier, k.max_corners, 0.01, 6, mask=near)
        if corners is None or len(corners) < k.min_tracks:
            return None
        start = np.asarray(corners, dtype=np.float32)
        guess = (
            start if predicted is None else np.asarray(cv2.perspectiveTransform(start, predicted), np.float32)
        )
        tracked, status, _ = cv2.calcOpticalFlowPyrLK(
            earlier,
            later,
            start,
            guess.copy(),
            winSize=(15, 15),
            maxLevel=2,
            flags=cv2.OPTFLOW_USE_INITIAL_FLOW,
        )
        ok = status.ravel() == 1
        if int(ok.sum()) < k.min_tracks:
            return None
        fitted, inliers = cv2.findHomography(
            start[ok],
            tracked[ok],
            cv2.USAC_ACCURATE,
            k.ransac_px,
            maxIters=k.ransac_iterations,
            confidence=0.99,
        )
        if fitted is None or inliers is None or int(inliers.sum()) < k.min_tracks:
            return None
        if predicted is not None:
            probe = np.array(
                [
                    [[0, height - 1]],
                    [[width - 1, height - 1]],
                    [[0, height // 2]],
                    [[width - 1, height // 2]],
                ],
                np.float32,
            )
            gap = cv2.perspectiveTransform(probe, fitted) - cv2.perspectiveTransform(probe, predicted)
            if float(np.abs(gap).max()) > k.max_correction_px:
                return None
        return np.asarray(fitted, dtype=np.float64)

    def off_plane(
        self, earlier: GreyImage, later: GreyImage, homography: FloatArray
    ) -> npt.NDArray[np.bool_]:
        """Two prepared (undistorted, smoothed) pictures and the floor's homography between them ->
        raw pixels of the later one that the earlier one, warped, does not explain."""
        k = self.config
        width, height = self.size
        warped = cv2.warpPerspective(
            earlier, homography, (width, height), flags=cv2.INTER_LINEAR, borderValue=0
        )
        seen = cv2.warpPerspective(
            np.full_like(earlier, 255), homography, (width, height), flags=cv2.INTER_NEAREST, borderValue=0
        )
        # one gain for the whole picture: auto-exposure brightens or darkens everything alike
        overlap = seen > 0
        gain = (
            float(later[overlap].mean()) / max(float(warped[overlap].mean()), 1.0) if overlap.any() else 1.0
        )
        residual = cv2.absdiff(later.astype(np.float32), warped.astype(np.float32) * gain)
        gx = cv2.Sobel(later, cv2.CV_32F, 1, 0, ksize=3, scale=1.0 / 8.0)
        gy = cv2.Sobel(later, cv2.CV_32F, 0, 1, ksize=3, scale=1.0 / 8.0)
        explained = k.noise_levels + k.misregistration_px * cv2.magnitude(gx, gy)
        flagged = ((residual > explained) & (seen > 0)).astype(np.uint8)
        cleaned = cv2.morphologyEx(flagged, cv2.MORPH_OPEN, self.open_across)
        cleaned = cv2.morphologyEx(cleaned, cv2.MORPH_OPEN, self.open_up)
        if self.distorted:
            cleaned = cv2.remap(cleaned, self.distort_x, self.distort_y, cv2.INTER_NEAREST, borderValue=0)
        return np.asarray(cleaned > 0, dtype=np.bool_)

"""The mounted camera as geometry: where it sits on the cart (Mount), its lens (Intrinsics) and
the homography between the floor and the undistorted image (GroundProjection).

Frames (REP-103/105): base_link is x forward, y left, z up, origin on the floor under the
wheel-axis centre. The camera frame is OpenCV's: x right, y down, z along the optical axis.
Pixels (u, v): u right, v down, origin top-left, pixel centres at integers.

A floor point (X, Y, 0) seen by a pinhole camera with rotation R (base_link -> camera) and
centre C is at  s [u v 1]^T = K [r1 r2 t] [X Y 1]^T  with r1, r2 the first two columns of R and
t = -R C (Hartley & Zisserman, Multiple View Geometry, 2nd ed., section 8.1.1): a homography.
s is the point's depth along the optical axis, so a pixel whose back-projected s is not positive
looks at or above the horizon and sees no floor.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

from cart2d.params import robot

FloatArray = npt.NDArray[np.float64]
# Depth scale below which a pixel is taken to be on the horizon: the floor point would be
# thousands of metres away, far beyond any range perception uses.
MIN_DEPTH_SCALE = 1e-6


@dataclass(frozen=True)
class Mount:
    """Where the lens is on the cart ([camera] in config/robot.toml, measured by the user)."""

    x_m: float
    y_m: float
    height_m: float
    pitch_deg: float  # optical axis below horizontal
    width_px: int
    height_px: int
    hfov_deg: float

    @classmethod
    def from_robot(cls) -> Mount:
        c = robot()["camera"]
        return cls(
            x_m=float(c["mount_x_m"]),
            y_m=float(c["mount_y_m"]),
            height_m=float(c["height_m"]),
            pitch_deg=float(c["pitch_deg"]),
            width_px=int(c["width_px"]),
            height_px=int(c["height_px"]),
            hfov_deg=float(c["hfov_deg"]),
        )

    def rotation(self) -> FloatArray:
        """R, base_link -> camera: its rows are the camera's x (right), y (down) and z (forward)
        axes in base_link. A pitch down is a positive rotation about base_link's y (left)."""
        p = math.radians(self.pitch_deg)
        right = [0.0, -1.0, 0.0]
        down = [-math.sin(p), 0.0, -math.cos(p)]
        forward = [math.cos(p), 0.0, -math.sin(p)]
        return np.array([right, down, forward], dtype=np.float64)

    def centre(self) -> FloatArray:
        """The lens centre in base_link, m."""
        return np.array([self.x_m, self.y_m, self.height_m], dtype=np.float64)

    def extrinsics(self) -> tuple[FloatArray, FloatArray]:
        """(R, t) with p_camera = R p_base + t."""
        r = self.rotation()
        return r, -r @ self.centre()


@dataclass(frozen=True)
class Intrinsics:
    """A pinhole camera with OpenCV's distortion model (k1, k2, p1, p2[, k3...])."""

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    dist: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0, 0.0)

    @classmethod
    def nominal(cls, mount: Mount | None = None) -> Intrinsics:
        """The stock lens as its data sheet describes it: the focal length from the horizontal
        field of view, the principal point in the middle of the image, no distortion."""
        m = mount or Mount.from_robot()
        f = (m.width_px / 2.0) / math.tan(math.radians(m.hfov_deg) / 2.0)
        return cls(m.width_px, m.height_px, f, f, (m.width_px - 1) / 2.0, (m.height_px - 1) / 2.0)

    def matrix(self) -> FloatArray:
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    def dist_array(self) -> FloatArray:
        return np.array(self.dist, dtype=np.float64)

    def undistort(self, uv: npt.ArrayLike) -> FloatArray:
        """Pixels (N x 2) of the raw image -> the same rays as pixels of the ideal pinhole camera
        with this K (cv2.undistortPoints with P = K)."""
        pts = np.asarray(uv, dtype=np.float64).reshape(-1, 1, 2)
        if not any(self.dist):
            return pts.reshape(-1, 2).copy()
        out = cv2.undistortPointsIter(
            pts,
            self.matrix(),
            self.dist_array(),
            np.eye(3),
            self.matrix(),
            (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 40, 1e-6),
        )
        return np.asarray(out, dtype=np.float64).reshape(-1, 2)

    def distort(self, ideal_uv: npt.ArrayLike) -> FloatArray:
        """The inverse of undistort: pixels of the ideal pinhole camera -> pixels of the raw image."""
        pts = np.asarray(ideal_uv, dtype=np.float64).reshape(-1, 2)
        rays = np.column_stack(
            [(pts[:, 0] - self.cx) / self.fx, (pts[:, 1] - self.cy) / self.fy, np.ones(len(pts))]
        )
        uv, _ = cv2.projectPoints(rays, np.zeros(3), np.zeros(3), self.matrix(), self.dist_array())
        return np.asarray(uv, dtype=np.float64).reshape(-1, 2)

    def as_dict(self) -> dict[str, Any]:
        return {
            "width": self.width,
            "height": self.height,
            "fx": self.fx,
            "fy": self.fy,
            "cx": self.cx,
            "cy": self.cy,
            "dist": list(self.dist),
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Intrinsics:
        return cls(
            int(d["width"]),
            int(d["height"]),
            float(d["fx"]),
            float(d["fy"]),
            float(d["cx"]),
            float(d["cy"]),
            tuple(float(k) for k in d["dist"]),
        )


def ideal_homography(mount: Mount, intrinsics: Intrinsics) -> FloatArray:
    """Floor (base_link x, y in m) -> undistorted pixel, from the measured mount alone: what the
    gateway uses before a calibration."""
    r, t = mount.extrinsics()
    return intrinsics.matrix() @ np.column_stack([r[:, 0], r[:, 1], t])


@dataclass
class GroundProjection:
    """The homography between the floor and the undistorted image. `floor_to_pixel` is scaled
    so that a floor point in front of the camera has a positive depth scale (see module doc)."""

    floor_to_pixel: FloatArray
    pixel_to_floor: FloatArray = field(init=False)

    def __post_init__(self) -> None:
        h = np.asarray(self.floor_to_pixel, dtype=np.float64)
        if h.shape != (3, 3) or not np.all(np.isfinite(h)) or np.linalg.norm(h) == 0.0:
            raise ValueError("the ground homography must be a finite 3 x 3 matrix")
        h = h / np.linalg.norm(h)
        if abs(np.linalg.det(h)) < 1e-12:
            raise ValueError("the ground homography must be invertible")
        self.floor_to_pixel = np.asarray(h, dtype=np.float64)
        self.pixel_to_floor = np.asarray(np.linalg.inv(self.floor_to_pixel), dtype=np.float64)

    @classmethod
    def ideal(cls, mount: Mount, intrinsics: Intrinsics) -> GroundProjection:
        return cls(ideal_homography(mount, intrinsics))

    @classmethod
    def fitted(cls, homography: FloatArray, floor_point: tuple[float, float]) -> GroundProjection:
        """A homography known only up to scale and sign (cv2.findHomography), its sign fixed by a
        floor point the camera is known to see."""
        h = np.asarray(homography, dtype=np.float64)
        if (h @ np.array([floor_point[0], floor_point[1], 1.0]))[2] < 0.0:
            h = -h
        return cls(h)

    def pixels_to_ground(self, uv: npt.ArrayLike) -> tuple[FloatArray, npt.NDArray[np.bool_]]:
        """Undistorted pixels (N x 2) -> floor points (N x 2, base_link m) and which are valid
        (below the horizon); invalid rows are NaN."""
        pts = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
        homogeneous = np.column_stack([pts, np.ones(len(pts))]) @ self.pixel_to_floor.T
        w = homogeneous[:, 2]
        # s = 1/w up to the common positive scale: w > 0 means the ray meets the floor ahead
        valid = w > MIN_DEPTH_SCALE * np.abs(homogeneous[:, :2]).max(axis=1, initial=0.0)
        out = np.full((len(pts), 2), np.nan)
        out[valid] = homogeneous[valid, :2] / w[valid, None]
        return out, valid

    def pixel_to_ground(self, u: float, v: float) -> tuple[float, float] | None:
        """One undistorted pixel -> (x, y) on the floor in base_link m; None at or above the horizon."""
        xy, valid = self.pixels_to_ground([[u, v]])
        return (float(xy[0, 0]), float(xy[0, 1])) if valid[0] else None

    def grounds_to_pixels(self, xy: npt.ArrayLike) -> tuple[FloatArray, npt.NDArray[np.bool_]]:
        """Floor points (N x 2) -> undistorted pixels (N x 2) and which are in front of the camera."""
        pts = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        homogeneous = np.column_stack([pts, np.ones(len(pts))]) @ self.floor_to_pixel.T
        w = homogeneous[:, 2]
        valid = w > MIN_DEPTH_SCALE * np.abs(homogeneous[:, :2]).max(axis=1, initial=0.0)
        out = np.full((len(pts), 2), np.nan)
        out[valid] = homogeneous[valid, :2] / w[valid, None]
        return out, valid

    def ground_to_pixel(self, x: float, y: float) -> tuple[float, float] | None:
        """A floor point (base_link m) -> its undistorted pixel; None if it is behind the camera."""
        uv, valid = self.grounds_to_pixels([[x, y]])
        return (float(uv[0, 0]), float(uv[0, 1])) if valid[0] else None

"""Pictures of AprilTags drawn by hand (no OpenCV projection) where the camera of robot.toml
sees them from a pose: the tag tests' pictures and their true corners."""

from __future__ import annotations

import math

import cv2
import numpy as np

from cart2d.localisation.markers import Marker, bitmap
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

"""AprilTag 36h11 sightings and the cart's pose in `map` they give (docs/localisation.md).

Detection is OpenCV's (cv2.aruco, DICT_APRILTAG_36h11, CORNER_REFINE_APRILTAG), run only in crops
round the candidates a cheap search found (TagDetector). Its corners come in the order of the
bitmap cv2.aruco.generateImageMarker draws (top-left, top-right, bottom-right, bottom-left), the
order SOLVEPNP_IPPE_SQUARE wants; the AprilTag detection places them on pixel edges counted from
the pixel's corner, half a pixel off this project's convention (pixel centres at integers,
cart2d/perception/camera_model.py), which CORNER_OFFSET_PX undoes, with the crop's origin added.

The pose: solvePnPGeneric with SOLVEPNP_IPPE_SQUARE gives the marker in the camera, both of a
planar square's two solutions; the one whose camera stands where the cart carries it (height and
pitch of [camera] in robot.toml) is taken. Chained with the marker's surveyed pose and the mount,
that is the cart's base_link in `map`. Its covariance is the corners' pixel noise carried through
the pose (the projection's Jacobian, so range, viewing angle and the tag's size in pixels all
count), plus the survey's own error.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import cv2
import numpy as np
import numpy.typing as npt

from cart2d.localisation.markers import Marker, MarkerMap, dictionary, object_points


class Lens(Protocol):
    """The calibrated camera (cart2d/perception/camera_model.py's Intrinsics)."""

    def matrix(self) -> FloatArray: ...
    def dist_array(self) -> FloatArray: ...


class Mounted(Protocol):
    """Where it sits on the cart (camera_model.py's Mount)."""

    @property
    def height_m(self) -> float: ...
    def extrinsics(self) -> tuple[FloatArray, FloatArray]: ...


FloatArray = npt.NDArray[np.float64]
CORNER_OFFSET_PX = 0.5  # CORNER_REFINE_APRILTAG's corners minus pixel-centre coordinates
CORNER_SIGMA_PX = 0.35  # a refined corner's noise at [sim.camera] noise_sigma 2 and JPEG 80 (bench)
SURVEY_SIGMA_M = 0.003  # a marker's place as a tape measure gives it
SURVEY_SIGMA_RAD = math.radians(0.5)
MIN_SIDE_PX = 12.0  # smaller than this the bits are a pixel or two: no pose is trusted from it
MAX_CAMERA_MISFIT_M = 0.08  # a solution whose camera is this far from the mount's height is wrong
MAX_CROPS = 8  # pass 2's crops per frame at most (~0.2 ms each at QVGA): a cluttered frame's bound
CROP_MARGIN_RATE = 0.3  # a crop's margin round a candidate, in its sides: the tag's white border in it
CROP_MARGIN_MIN_PX = 6.0


@dataclass(frozen=True)
class Sighting:
    tag_id: int
    corners_px: FloatArray  # 4 x 2, pixel-centre coordinates, OpenCV's order

    def side_px(self) -> float:
        c = self.corners_px
        return float(np.mean([np.linalg.norm(c[i] - c[(i + 1) % 4]) for i in range(4)]))


@dataclass(frozen=True)
class TagFix:
    """The cart's pose in `map` from one marker: (x, y, theta) and its 3 x 3 covariance."""

    tag_id: int
    pose: tuple[float, float, float]
    covariance: FloatArray
    range_m: float
    side_px: float


class TagDetector:
    """AprilTag 36h11 sightings in a picture, in two passes (bench/localisation.py measures both):

    1. OpenCV's ArUco candidate search over the whole frame (adaptive threshold, contours, no
       refinement): ~0.5 ms at QVGA; quads too small to give a trusted pose are not looked for.
    2. OpenCV's AprilTag detection (CORNER_REFINE_APRILTAG, which is its own quad search and line
       fit, not a refinement of pass 1's corners) in a small crop round each candidate, decoded
       or not (pass 1 rejects some foreshortened tags its integer corners cannot decode).

    The AprilTag detection over the whole frame (`crops=False`) costs 5-30 ms per QVGA frame and
    gives the same corners: it stays as the bench's reference."""

    def __init__(self, crops: bool = True) -> None:
        self._crops = crops
        self._precise = _aruco_detector(cv2.aruco.CORNER_REFINE_APRILTAG)
        self._searches: dict[int, cv2.aruco.ArucoDetector] = {}

    def detect(self, image: npt.NDArray[np.uint8]) -> list[Sighting]:
        gray = image if image.ndim == 2 else np.asarray(cv2.cvtColor(image, cv2.COLOR_BGR2GRAY), np.uint8)
        if not self._crops:
            return _sightings(self._precise, gray, (0, 0))
        # one candidate per tag: OpenCV's search keeps one of the concentric quads (a tag's inner
        # and outer contours, its sheet's edge) before decoding, the rejected ones as the decoded
        found = (self._in_crop(gray, quad) for quad in self._candidates(gray))
        return [s for s in found if s is not None]

    def _candidates(self, gray: npt.NDArray[np.uint8]) -> list[FloatArray]:
        """Pass 1's quads: the decoded ones first, then the rejected ones, the largest first."""
        longest = max(gray.shape)
        search = self._searches.get(longest)
        if search is None:
            search = _aruco_detector(
                cv2.aruco.CORNER_REFINE_NONE, min_perimeter_rate=4 * MIN_SIDE_PX / longest
            )
            self._searches[longest] = search
        corners, ids, rejected = search.detectMarkers(gray)
        decoded = [np.asarray(c, np.float64).reshape(4, 2) for c in corners] if ids is not None else []
        others = sorted(
            (np.asarray(c, np.float64).reshape(4, 2) for c in rejected),
            key=lambda q: -_perimeter(q),
        )
        plausible = [q for q in others if _perimeter(q) >= 4 * MIN_SIDE_PX]
        return (decoded + plausible)[:MAX_CROPS]

    def _in_crop(self, gray: npt.NDArray[np.uint8], quad: FloatArray) -> Sighting | None:
        """The AprilTag detection in the quad's bounding box and a margin; the tag nearest the
        quad's centre, within half its side."""
        margin = max(CROP_MARGIN_MIN_PX, CROP_MARGIN_RATE * _perimeter(quad) / 4)
        h, w = gray.shape
        x0, y0 = (max(0, math.floor(v - margin)) for v in quad.min(axis=0))
        x1 = min(w, math.ceil(quad[:, 0].max() + margin) + 1)
        y1 = min(h, math.ceil(quad[:, 1].max() + margin) + 1)
        found = _sightings(self._precise, gray[y0:y1, x0:x1], (x0, y0))
        centre = quad.mean(axis=0)
        near = [s for s in found if np.linalg.norm(s.corners_px.mean(axis=0) - centre) <= s.side_px() / 2]
        return min(
            near, key=lambda s: float(np.linalg.norm(s.corners_px.mean(axis=0) - centre)), default=None
        )


def _aruco_detector(refinement: int, min_perimeter_rate: float | None = None) -> cv2.aruco.ArucoDetector:
    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = refinement
    if min_perimeter_rate is not None:
        params.minMarkerPerimeterRate = min_perimeter_rate
    return cv2.aruco.ArucoDetector(dictionary(), params)


def _sightings(
    detector: cv2.aruco.ArucoDetector, gray: npt.NDArray[np.uint8], origin: tuple[int, int]
) -> list[Sighting]:
    """AprilTag-detected corners, moved from the crop at `origin` to the frame and to pixel centres."""
    corners, ids, _ = detector.detectMarkers(gray)
    if ids is None:
        return []
    shift = np.array(origin, np.float64) - CORNER_OFFSET_PX
    return [
        Sighting(int(i), np.asarray(c, dtype=np.float64).reshape(4, 2) + shift)
        for c, i in zip(corners, ids.ravel(), strict=True)
    ]


def _perimeter(quad: FloatArray) -> float:
    return float(sum(np.linalg.norm(quad[i] - quad[(i + 1) % 4]) for i in range(4)))


def _homogeneous(r: FloatArray, t: FloatArray) -> FloatArray:
    out = np.eye(4)
    out[:3, :3] = r
    out[:3, 3] = np.ravel(t)
    return out


def planar(transform: FloatArray) -> tuple[float, float, float]:
    """A 3-D base_link pose in map -> (x, y, yaw)."""
    return float(transform[0, 3]), float(transform[1, 3]), math.atan2(transform[1, 0], transform[0, 0])


class TagLocaliser:
    """Sightings -> fixes, for one camera (its calibrated intrinsics) on one mount."""

    def __init__(self, markers: MarkerMap, intrinsics: Lens, mount: Mounted) -> None:
        self.markers = markers.by_id()
        self.intrinsics = intrinsics
        self.mount = mount
        r, t = self.mount.extrinsics()
        self._camera_from_base = _homogeneous(r, t)
        self._k = intrinsics.matrix()
        self._dist = intrinsics.dist_array()

    def fixes(self, sightings: list[Sighting]) -> list[TagFix]:
        out = []
        for s in sightings:
            marker = self.markers.get(s.tag_id)
            if marker is not None and s.side_px() >= MIN_SIDE_PX:
                fix = self.fix(marker, s)
                if fix is not None:
                    out.append(fix)
        return out

    def base_in_map(self, marker: Marker, rvec: FloatArray, tvec: FloatArray) -> FloatArray:
        camera_from_marker = _homogeneous(np.asarray(cv2.Rodrigues(rvec)[0], dtype=np.float64), tvec)
        map_from_camera = marker.transform() @ np.linalg.inv(camera_from_marker)
        return np.asarray(map_from_camera @ self._camera_from_base, dtype=np.float64)

    def _camera_misfit(self, base: FloatArray) -> float:
        """How far the solution's base_link is off the floor and upright: metres, tilt as the
        lens's displacement it would cause."""
        tilt = math.hypot(base[2, 0], base[2, 1])  # z of base_link's x and y axes in map
        return float(abs(base[2, 3]) + tilt * self.mount.height_m)

    def fix(self, marker: Marker, sighting: Sighting) -> TagFix | None:
        """The cart's pose from one sighting; None if the corners give no pose a cart can have
        (off the floor, tilted) or none at all (degenerate, not finite)."""
        obj = object_points(marker.size_m)
        img = sighting.corners_px.reshape(4, 1, 2)
        if not np.all(np.isfinite(img)):
            return None  # OpenCV's solver answers NaN corners with a NaN pose, whose covariance raised
        n, rvecs, tvecs, _ = cv2.solvePnPGeneric(
            obj, img, self._k, self._dist, flags=cv2.SOLVEPNP_IPPE_SQUARE
        )
        best: tuple[float, FloatArray, FloatArray, FloatArray] | None = None
        for k in range(n):
            rvec = np.asarray(rvecs[k], dtype=np.float64).ravel()
            tvec = np.asarray(tvecs[k], dtype=np.float64).ravel()
            base = self.base_in_map(marker, rvec, tvec)
            misfit = self._camera_misfit(base)
            if best is None or misfit < best[0]:
                best = (misfit, base, rvec, tvec)
        if best is None or best[0] > MAX_CAMERA_MISFIT_M:
            return None
        _, base, rvec, tvec = best
        try:
            covariance = self._covariance(marker, rvec, tvec)
        except np.linalg.LinAlgError:
            return None
        if not np.all(np.isfinite(covariance)):
            return None
        return TagFix(marker.id, planar(base), covariance, float(np.linalg.norm(tvec)), sighting.side_px())

    def _covariance(self, marker: Marker, rvec: FloatArray, tvec: FloatArray) -> FloatArray:
        """Pixel noise on the corners through the pose: Σ6 = σ² (JᵀJ)⁻¹ from the projection's
        Jacobian (Gauss-Newton's covariance of the marker in the camera), carried to (x, y, θ)
        by finite differences, plus the survey's error."""
        obj = object_points(marker.size_m)
        _, jac = cv2.projectPoints(obj, rvec, tvec, self._k, self._dist)
        j = np.asarray(jac, dtype=np.float64)[:, :6]
        info = j.T @ j
        cov6 = CORNER_SIGMA_PX**2 * np.linalg.pinv(info)
        x0 = np.array(planar(self.base_in_map(marker, rvec, tvec)))
        g = np.zeros((3, 6))
        for k in range(6):
            step = 1e-6
            d = np.zeros(6)
            d[k] = step
            x1 = np.array(planar(self.base_in_map(marker, rvec + d[:3], tvec + d[3:])))
            diff = x1 - x0
            diff[2] = math.remainder(diff[2], math.tau)
            g[:, k] = diff / step
        cov = g @ cov6 @ g.T
        cov += np.diag([SURVEY_SIGMA_M**2, SURVEY_SIGMA_M**2, SURVEY_SIGMA_RAD**2])
        return np.asarray((cov + cov.T) / 2, dtype=np.float64)

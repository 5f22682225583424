"""Camera calibration: the lens from checkerboard views (Zhang's method, cv2.calibrateCamera) and
the ground homography from a checkerboard lying on the floor at a known place in front of the cart
(cv2.findHomography between the board's floor positions and its undistorted corners). The result
is saved atomically as JSON next to the gateway's settings and reloaded at start.

Z. Zhang, "A flexible new technique for camera calibration", IEEE TPAMI 22(11), 2000; OpenCV's
calib3d documentation for the corner order and the distortion model.
"""

from __future__ import annotations

import json
import logging
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

from cart2d.perception.camera_model import FloatArray, GroundProjection, Intrinsics, Mount
from cart2d.store import atomic_write, default_directory

log = logging.getLogger(__name__)

CALIBRATION_FILE = "camera-calibration.json"
MIN_VIEWS = 5  # Zhang's method needs 3; a few more make the distortion estimate stable
CALIBRATION_FLAGS = cv2.CALIB_FIX_K3  # k1, k2 and the tangential terms: k3 is noise at QVGA
RANSAC_THRESHOLD_PX = 1.0  # a corner further than this from the fitted plane's image is an outlier
MIN_GROUND_INLIERS = 0.8  # of the floor board's corners
SUBPIX_CRITERIA = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_MAX_ITER, 40, 0.001)
SB_FLAGS = cv2.CALIB_CB_NORMALIZE_IMAGE  # equalized first: it finds the board in unevenly lit views
CLASSIC_FLAGS = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE


@dataclass(frozen=True)
class Board:
    """A checkerboard: `cols` x `rows` INNER corners, `square_m` apart."""

    cols: int = 9
    rows: int = 6
    square_m: float = 0.03

    def object_points(self) -> npt.NDArray[np.float32]:
        """The inner corners in the board's plane (z = 0), in findChessboardCorners' order: rows of
        `cols` corners, the first corner at the origin."""
        i, j = np.meshgrid(np.arange(self.cols), np.arange(self.rows))
        pts = np.column_stack([i.ravel(), j.ravel(), np.zeros(i.size)]) * self.square_m
        return pts.astype(np.float32)


@dataclass(frozen=True)
class GroundBoard:
    """The board lying flat on the floor, square to the cart, its `cols` side across (along y),
    its middle at (centre_x_m, centre_y_m) in base_link: what the user measures."""

    board: Board
    centre_x_m: float
    centre_y_m: float = 0.0

    def pose_in_base(self) -> tuple[FloatArray, FloatArray]:
        """(R, t): base_link point = R @ board point + t, the board face up (its z axis up), its
        columns running to the cart's right (-y) and its rows away from the cart (+x)."""
        rotation = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
        b = self.board
        middle = np.array([(b.cols - 1) * b.square_m / 2, (b.rows - 1) * b.square_m / 2, 0.0])
        return rotation, np.array([self.centre_x_m, self.centre_y_m, 0.0]) - rotation @ middle

    def floor_grid(self) -> FloatArray:
        """Corner positions on the floor, rows x cols x 2: row index towards the cart (-x), column
        index to the cart's right (-y), as the camera would list them looking at the board."""
        s = self.board.square_m
        j, i = np.meshgrid(np.arange(self.board.rows), np.arange(self.board.cols), indexing="ij")
        x = self.centre_x_m + ((self.board.rows - 1) / 2 - j) * s
        y = self.centre_y_m + ((self.board.cols - 1) / 2 - i) * s
        return np.stack([x, y], axis=-1)


def find_corners(bgr: npt.NDArray[np.uint8], board: Board) -> FloatArray | None:
    """The board's inner corners in a raw image (N x 2, sub-pixel), or None if it is not seen whole.
    cv2.findChessboardCornersSB finds the board where the older finder misses it (steep, blurred,
    unevenly lit views); findChessboardCorners when it does not. Either's corners are refined by
    cornerSubPix: measured on QVGA views of a known lens, the sector finder's own corners put the
    principal point 2 px off, refined ones 0.3 px; on OpenCV's real views the RMS error falls from
    0.26 to 0.20 px."""
    gray = cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY) if bgr.ndim == 3 else bgr
    size = (board.cols, board.rows)
    found, corners = cv2.findChessboardCornersSB(gray, size, flags=SB_FLAGS)
    if not found:
        found, corners = cv2.findChessboardCorners(gray, size, flags=CLASSIC_FLAGS)
    if not found:
        return None
    pts = np.asarray(corners, dtype=np.float32).reshape(-1, 2)
    # the search window must stay inside one square: half the closest corner spacing, and at most
    # 11 x 11 px (OpenCV's C++ sample's 23 x 23 slides corners of a steep VGA view by 7 px)
    grid = pts.reshape(board.rows, board.cols, 2)
    spacing = min(float(np.min(np.linalg.norm(np.diff(grid, axis=axis), axis=-1))) for axis in (0, 1))
    half = int(np.clip(spacing / 2 - 1, 2, 5))
    refined = cv2.cornerSubPix(gray, pts.reshape(-1, 1, 2), (half, half), (-1, -1), SUBPIX_CRITERIA)
    return np.asarray(refined, dtype=np.float64).reshape(-1, 2)


@dataclass(frozen=True)
class LensFit:
    intrinsics: Intrinsics
    rms_px: float  # RMS reprojection error over every corner of every view
    views: int
    # per view, each corner's distance (px) from where the fitted lens and the view's pose put it
    residuals_px: tuple[FloatArray, ...] = ()


def calibrate_lens(corners_per_view: Sequence[FloatArray], board: Board, width: int, height: int) -> LensFit:
    """Intrinsics and distortion from the corners of at least MIN_VIEWS views of `board`."""
    if len(corners_per_view) < MIN_VIEWS:
        raise ValueError(
            f"{len(corners_per_view)} views with the whole board: at least {MIN_VIEWS} are needed"
        )
    objects = [board.object_points()] * len(corners_per_view)
    images = [np.asarray(c, dtype=np.float32).reshape(-1, 1, 2) for c in corners_per_view]
    rms, k, dist, rvecs, tvecs = cv2.calibrateCamera(
        objects, images, (width, height), np.eye(3), np.zeros(5), flags=CALIBRATION_FLAGS
    )
    residuals = []
    for seen, rvec, tvec in zip(images, rvecs, tvecs, strict=True):
        placed, _ = cv2.projectPoints(board.object_points(), rvec, tvec, k, dist)
        residuals.append(
            np.linalg.norm(placed.reshape(-1, 2) - seen.reshape(-1, 2), axis=1).astype(np.float64)
        )
    d = np.asarray(dist, dtype=np.float64).ravel()
    lens = Intrinsics(
        width,
        height,
        float(k[0, 0]),
        float(k[1, 1]),
        float(k[0, 2]),
        float(k[1, 2]),
        tuple(float(x) for x in d),
    )
    return LensFit(lens, float(rms), len(corners_per_view), tuple(residuals))


@dataclass(frozen=True)
class GroundFit:
    ground: GroundProjection
    rms_m: float  # the board's own corners (inliers) projected back to the floor, against where they are
    max_m: float
    outliers: int  # corners RANSAC left out


def _orderings(grid: FloatArray) -> list[FloatArray]:
    """The board's floor corners in every order findChessboardCorners may list them in: it may
    start from any end of the rows and of the columns."""
    return [grid[::a, ::b].reshape(-1, 2) for a in (1, -1) for b in (1, -1)]


def fit_ground(corners: FloatArray, lens: Intrinsics, placed: GroundBoard, mount: Mount) -> GroundFit:
    """The ground homography from the raw corners of the board lying on the floor. Which detected
    corner is which floor point is settled by the mount as measured: the order whose floor points
    the nominal model puts nearest the corners (the wrong ones are a board's width off)."""
    undistorted = lens.undistort(corners)
    nominal = GroundProjection.ideal(mount, lens)

    def mismatch(floor: FloatArray) -> float:
        predicted, seen = nominal.grounds_to_pixels(floor)
        return float(np.mean(np.linalg.norm(predicted - undistorted, axis=1))) if seen.all() else math.inf

    floor = min(_orderings(placed.floor_grid()), key=mismatch)
    # RANSAC, then least squares on the inliers: cornerSubPix can slide a corner of the far,
    # foreshortened rows by pixels, and one such corner tilts the whole plane
    h, inliers = cv2.findHomography(floor, undistorted, cv2.RANSAC, RANSAC_THRESHOLD_PX)
    if h is None or inliers is None or int(inliers.sum()) < MIN_GROUND_INLIERS * len(floor):
        raise ValueError("no homography fits the board's corners on the floor")
    ground = GroundProjection.fitted(np.asarray(h, dtype=np.float64), (placed.centre_x_m, placed.centre_y_m))
    keep = inliers.ravel().astype(bool)
    back, valid = ground.pixels_to_ground(undistorted[keep])
    if not valid.all():
        raise ValueError("the fitted homography puts the board above the horizon")
    err = np.linalg.norm(back - floor[keep], axis=1)
    return GroundFit(ground, float(np.sqrt(np.mean(err**2))), float(err.max()), int((~keep).sum()))


@dataclass
class CameraCalibration:
    """What perception needs of the camera: the lens and the floor's homography, with how well
    they fit. `nominal` is the model from the mount and the stock lens, before any calibration."""

    intrinsics: Intrinsics
    ground: GroundProjection
    rms_px: float | None = None
    views: int = 0
    ground_rms_m: float | None = None
    ground_max_m: float | None = None
    created: str = ""

    @classmethod
    def nominal(cls, mount: Mount | None = None) -> CameraCalibration:
        m = mount or Mount.from_robot()
        lens = Intrinsics.nominal(m)
        return cls(lens, GroundProjection.ideal(m, lens))

    @classmethod
    def of(cls, lens: LensFit, ground: GroundFit) -> CameraCalibration:
        return cls(
            lens.intrinsics,
            ground.ground,
            lens.rms_px,
            lens.views,
            ground.rms_m,
            ground.max_m,
            time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        )

    @property
    def calibrated(self) -> bool:
        return self.rms_px is not None

    def pixels_to_ground(self, raw_uv: npt.ArrayLike) -> tuple[FloatArray, npt.NDArray[np.bool_]]:
        """Raw image pixels (N x 2) -> floor points in base_link (N x 2) and which are valid."""
        return self.ground.pixels_to_ground(self.intrinsics.undistort(raw_uv))

    def summary(self) -> dict[str, Any]:
        """What /api/camera shows."""
        return {
            "calibrated": self.calibrated,
            "rms_px": self.rms_px,
            "views": self.views,
            "ground_rms_m": self.ground_rms_m,
            "ground_max_m": self.ground_max_m,
            "created": self.created,
        }

    def to_json(self) -> str:
        data = {
            "version": 1,
            "intrinsics": self.intrinsics.as_dict(),
            "floor_to_pixel": self.ground.floor_to_pixel.tolist(),
            **self.summary(),
        }
        return json.dumps(data, indent=2) + "\n"

    @classmethod
    def from_json(cls, text: str) -> CameraCalibration:
        """ValueError if `text` is not a calibration this version wrote."""
        try:
            d = json.loads(text)
            if d.get("version") != 1:
                raise ValueError(f"unknown calibration version {d.get('version')!r}")
            return cls(
                Intrinsics.from_dict(d["intrinsics"]),
                GroundProjection(np.array(d["floor_to_pixel"], dtype=np.float64)),
                None if d["rms_px"] is None else float(d["rms_px"]),
                int(d["views"]),
                None if d["ground_rms_m"] is None else float(d["ground_rms_m"]),
                None if d["ground_max_m"] is None else float(d["ground_max_m"]),
                str(d["created"]),
            )
        except (KeyError, TypeError, AttributeError, json.JSONDecodeError) as exc:
            raise ValueError(f"not a camera calibration: {exc!r}") from exc


def calibration_path(directory: Path | None = None) -> Path:
    """Next to the gateway's settings (cart2d.store.default_directory)."""
    return (directory or default_directory()) / CALIBRATION_FILE


def save_calibration(calibration: CameraCalibration, path: Path | None = None) -> Path:
    target = path or calibration_path()
    atomic_write(target, calibration.to_json().encode())
    return target


def load_calibration(path: Path | None = None, mount: Mount | None = None) -> CameraCalibration:
    """The saved calibration; the nominal model if there is none or it cannot be read (with a warning)."""
    source = path or calibration_path()
    try:
        return CameraCalibration.from_json(source.read_text(encoding="utf-8"))
    except FileNotFoundError:
        return CameraCalibration.nominal(mount)
    except (OSError, ValueError) as exc:
        log.warning("%s: %s; using the nominal camera model", source, exc)
        return CameraCalibration.nominal(mount)

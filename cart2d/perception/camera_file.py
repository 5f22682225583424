"""A camera described in a file, for pictures taken without a cart (`cart2d camera detect`,
the real photographs of tests/data/real/): either a calibration `cart2d camera calibrate` saved,
or a nominal model of the camera (its size, horizontal field of view, height and pitch, and
optionally the detector's maximum range):

    {"width_px": 320, "height_px": 240, "hfov_deg": 55, "height_m": 0.25, "pitch_deg": 32,
     "max_range_m": 1.25}

Either kind may also set the floor patch the detector learns the floor from (DETECTOR_KEYS,
metres: `patch_depth_m`, `patch_half_width_m`): the cart's patch, 0.15 m deep, is a handful of
rows of a camera a few centimetres above the floor.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import cv2
import numpy as np
import numpy.typing as npt

from cart2d.perception.calibration import CameraCalibration
from cart2d.perception.camera_model import Mount
from cart2d.perception.detection import Detection, DetectorConfig, ObstacleDetector
from cart2d.perception.parallax import ParallaxCue

# With no odometry the floor's homography is fitted on corners of the pictures' lower half (the
# floor nearest the camera): a fit that leaves more than this share of that half unexplained has
# locked on something else (a periodic mat, motion blur), and the parallax cue then says nothing.
MAX_UNEXPLAINED_NEAR_FLOOR = 0.1
NOMINAL_KEYS = ("width_px", "height_px", "hfov_deg", "height_m", "pitch_deg")
DETECTOR_KEYS = ("max_range_m", "patch_depth_m", "patch_half_width_m")


@dataclasses.dataclass
class Camera:
    calibration: CameraCalibration
    mount: Mount
    config: DetectorConfig


def load_camera(path: Path) -> Camera:
    """ValueError with a sentence if `path` is neither a calibration nor a nominal model."""
    try:
        d = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as exc:
        raise ValueError(f"{path}: cannot read it as JSON ({exc})") from exc
    if not isinstance(d, dict):
        raise ValueError(f"{path}: a camera file is a JSON object")
    try:
        settings = {k: float(d[k]) for k in DETECTOR_KEYS if k in d}
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{path}: {', '.join(DETECTOR_KEYS)} are numbers ({exc})") from exc
    if any(not value > 0 for value in settings.values()):
        raise ValueError(f"{path}: {', '.join(DETECTOR_KEYS)} must be above 0")
    config = DetectorConfig()
    for key, value in settings.items():
        config = dataclasses.replace(config, **{key: value})  # type: ignore[arg-type]  # floats all
    if "version" in d:
        calibration = CameraCalibration.from_json(json.dumps(d))
        robot = Mount.from_robot()
        lens = calibration.intrinsics
        mount = dataclasses.replace(robot, width_px=lens.width, height_px=lens.height)
        return Camera(calibration, mount, config)
    missing = [k for k in NOMINAL_KEYS if k not in d]
    if missing:
        raise ValueError(
            f"{path}: a nominal camera needs {', '.join(NOMINAL_KEYS)} (missing: {', '.join(missing)})"
        )
    try:
        mount = Mount(
            x_m=float(d.get("mount_x_m", 0.0)),
            y_m=float(d.get("mount_y_m", 0.0)),
            height_m=float(d["height_m"]),
            pitch_deg=float(d["pitch_deg"]),
            width_px=int(d["width_px"]),
            height_px=int(d["height_px"]),
            hfov_deg=float(d["hfov_deg"]),
        )
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{path}: {exc}") from exc
    if not (mount.height_m > 0 and 0 < mount.pitch_deg < 90 and 10 <= mount.hfov_deg <= 170):
        raise ValueError(
            f"{path}: height_m must be above 0, pitch_deg between 0 and 90 (down), hfov_deg 10 to 170"
        )
    if mount.width_px < 16 or mount.height_px < 16:
        raise ValueError(f"{path}: width_px and height_px must be at least 16")
    return Camera(CameraCalibration.nominal(mount), mount, config)


def read_picture(path: Path, camera: Camera) -> npt.NDArray[np.uint8]:
    if not path.is_file():
        raise ValueError(f"{path}: no such file")
    image = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if image is None:
        raise ValueError(f"{path}: not a picture OpenCV can read")
    lens = camera.calibration.intrinsics
    if (image.shape[1], image.shape[0]) != (lens.width, lens.height):
        raise ValueError(
            f"{path}: {image.shape[1]} x {image.shape[0]} pixels; the camera file is for "
            f"{lens.width} x {lens.height}"
        )
    return np.asarray(image, dtype=np.uint8)


def detect_pair(
    detector: ObstacleDetector,
    parallax: ParallaxCue,
    image: npt.NDArray[np.uint8],
    before: npt.NDArray[np.uint8] | None,
) -> Detection:
    """One picture, with the parallax cue against `before` when there is one (the floor's
    homography fitted on the two pictures, and dropped if it does not explain the near floor it
    was fitted on)."""
    off_plane = None
    if before is not None:
        earlier, later = parallax.prepare(before), parallax.prepare(image)
        fitted = parallax.refine(earlier, later, None)
        if fitted is not None:
            off_plane = parallax.off_plane(earlier, later, fitted)
            near_floor = off_plane[off_plane.shape[0] // 2 :]
            if float(near_floor.mean()) > MAX_UNEXPLAINED_NEAR_FLOOR:
                off_plane = None
    return detector.detect(image, off_plane)

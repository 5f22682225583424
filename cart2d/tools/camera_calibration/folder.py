"""`cart2d camera calibrate --images DIR`: the lens from a folder of pictures of a checkerboard,
with no cart: the same checks and report as with the camera (lens.lens_from_views). Pictures of
another camera than the cart's are the usual case, so nothing is saved unless --out is given;
then the file holds the lens and the floor's homography of that lens mounted as
config/robot.toml [camera] says (no board on the floor was seen)."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import cv2
import numpy as np

from cart2d.perception.calibration import Board, CameraCalibration
from cart2d.perception.calibration_checks import CheckedFit
from cart2d.perception.camera_model import GroundProjection, Mount
from cart2d.tools.camera_calibration.lens import Image, lens_from_views

PICTURE_SUFFIXES = (".jpg", ".jpeg", ".png", ".bmp", ".tif", ".tiff")


def pictures(directory: Path) -> list[Path]:
    """The folder's pictures in name order; ValueError if it is not a folder or holds none."""
    if not directory.is_dir():
        raise ValueError(f"{directory} is not a folder")
    found = sorted(p for p in directory.iterdir() if p.suffix.lower() in PICTURE_SUFFIXES and p.is_file())
    if not found:
        raise ValueError(f"{directory} holds no pictures ({', '.join(PICTURE_SUFFIXES)})")
    return found


def read_pictures(paths: list[Path]) -> Iterator[tuple[str, Image]]:
    for path in paths:
        image = cv2.imread(str(path), cv2.IMREAD_COLOR)
        if image is None:
            raise ValueError(f"{path.name} is not a picture OpenCV can read")
        yield path.name, np.asarray(image, dtype=np.uint8)


def calibrate_folder(directory: Path, board: Board, say: Callable[[str], None] = print) -> CheckedFit:
    return lens_from_views(read_pictures(pictures(directory)), board, say)


def with_nominal_ground(checked: CheckedFit, mount: Mount) -> CameraCalibration:
    """What --out saves: the fitted lens, the floor where the mount as measured puts it."""
    lens = checked.lens
    return CameraCalibration(
        lens.intrinsics, GroundProjection.ideal(mount, lens.intrinsics), lens.rms_px, lens.views
    )

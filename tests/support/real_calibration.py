"""OpenCV's real chessboard photographs (tests/data/real/calibration/, README there), their
published calibration, and the bad views the tests make from them at run time: a corner pushed
aside (a thumb on the board, a dent) and a board that is not flat."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

from cart2d.perception.calibration import Board

REAL_DIR = Path(__file__).resolve().parents[1] / "data" / "real" / "calibration"
Image = npt.NDArray[np.uint8]


def published() -> dict[str, Any]:
    data: dict[str, Any] = json.loads((REAL_DIR / "published.json").read_text(encoding="utf-8"))
    return data


def board() -> Board:
    b = published()["board"]
    return Board(int(b["cols"]), int(b["rows"]), float(b["square_m"]))


def view_paths() -> list[Path]:
    return [REAL_DIR / name for name in published()["views"]]


def read(path: Path) -> Image:
    image = cv2.imread(str(path), cv2.IMREAD_COLOR)
    assert image is not None, path
    return np.asarray(image, dtype=np.uint8)


def dent(image: Image, centre: npt.ArrayLike, shift_px: tuple[float, float], radius_px: float) -> Image:
    """The picture pushed by `shift_px` at `centre`, less and less further out (a Gaussian of
    `radius_px`): a corner there moves with it, the others hardly."""
    h, w = image.shape[:2]
    x, y = np.meshgrid(np.arange(w, dtype=np.float32), np.arange(h, dtype=np.float32))
    cu, cv = (float(c) for c in np.asarray(centre, dtype=np.float64).ravel()[:2])
    weight = np.exp(-((x - cu) ** 2 + (y - cv) ** 2) / (2 * radius_px**2)).astype(np.float32)
    map_x = (x - shift_px[0] * weight).astype(np.float32)
    map_y = (y - shift_px[1] * weight).astype(np.float32)
    return np.asarray(cv2.remap(image, map_x, map_y, cv2.INTER_LINEAR), dtype=np.uint8)


def wave(image: Image, amplitude_px: float, seed: int) -> Image:
    """The picture warped by a sine wave across and down it: a board that is not flat, in a way no
    lens explains."""
    h, w = image.shape[:2]
    rng = np.random.default_rng(seed)
    x, y = np.meshgrid(np.arange(w, dtype=np.float32), np.arange(h, dtype=np.float32))
    across, down, phase_x, phase_y = (
        rng.uniform(2, 4),
        rng.uniform(2, 4),
        rng.uniform(0, 6.3),
        rng.uniform(0, 6.3),
    )
    map_x = x + amplitude_px * np.sin(2 * np.pi * down * y / h + phase_y)
    map_y = y + amplitude_px * np.sin(2 * np.pi * across * x / w + phase_x)
    warped = cv2.remap(image, map_x.astype(np.float32), map_y.astype(np.float32), cv2.INTER_LINEAR)
    return np.asarray(warped, dtype=np.uint8)


def as_esp32_cam_sends(image: Image) -> Image:
    """The picture at QVGA (320 x 240), through a JPEG of quality 80, as the ESP32-CAM sends it."""
    small = cv2.resize(image, (320, 240), interpolation=cv2.INTER_AREA)
    jpeg = cv2.imencode(".jpg", small, [cv2.IMWRITE_JPEG_QUALITY, 80])[1]
    return np.asarray(cv2.imdecode(jpeg, cv2.IMREAD_COLOR), dtype=np.uint8)


def copy_views(target: Path) -> Path:
    """The real views (only the pictures) in `target`."""
    target.mkdir(parents=True, exist_ok=True)
    for path in view_paths():
        shutil.copy(path, target / path.name)
    return target

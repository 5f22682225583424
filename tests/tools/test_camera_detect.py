"""`cart2d camera detect`: a picture and a camera file in, the floor mask, hits and an overlay
out; bad input refused with exit status 2 and a line, nothing written."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from cart2d.perception.calibration import CameraCalibration
from cart2d.perception.camera_model import Mount
from cart2d.perception.synthetic import Box, SyntheticCamera
from cart2d.tools.cli import main

MOUNT = Mount.from_robot()
NOMINAL = {
    "width_px": 320,
    "height_px": 240,
    "hfov_deg": MOUNT.hfov_deg,
    "height_m": MOUNT.height_m,
    "pitch_deg": MOUNT.pitch_deg,
}


def pictures(tmp_path: Path) -> tuple[Path, Path]:
    """A picture of a box 0.7 m ahead, as the cart's camera takes it, and a nominal camera file."""
    camera = SyntheticCamera(CameraCalibration.nominal(MOUNT).intrinsics, MOUNT, seed=1)
    box = tmp_path / "box.jpg"
    cv2.imwrite(str(box), camera.render(boxes=[Box(0.8, 0.0, 0.2, 0.3, 0.2, (40, 60, 170))]))
    file = tmp_path / "camera.json"
    file.write_text(json.dumps(NOMINAL))
    return box, file


def test_a_picture_gives_its_hits_floor_mask_and_overlay(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    box, file = pictures(tmp_path)
    assert main(["camera", "detect", str(box), "--camera", str(file), "--json", "--out", str(tmp_path)]) == 0
    out = json.loads(capsys.readouterr().out)
    (picture,) = out["pictures"]
    hits = np.array(picture["hits_m"])
    assert len(hits) > 20 and np.all(np.abs(hits[:, 0] - 0.7) < 0.03)  # the box's near face, 0.7 m ahead
    assert len(picture["hits_px"]) == len(hits)
    assert 0.3 < picture["floor_share"] < 0.95
    overlay = cv2.imread(picture["overlay_png"])
    mask = cv2.imread(picture["floor_mask_png"], cv2.IMREAD_GRAYSCALE)
    assert overlay is not None and mask is not None
    assert overlay.shape == (240, 320, 3) and mask.shape == (240, 320)
    assert abs((mask > 0).mean() - picture["floor_share"]) < 1e-3


def test_a_calibration_file_is_a_camera_file_too(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    box, _ = pictures(tmp_path)
    calibration = tmp_path / "camera-calibration.json"
    calibration.write_text(CameraCalibration.nominal(MOUNT).to_json())
    assert main(["camera", "detect", str(box), "--camera", str(calibration), "--out", str(tmp_path)]) == 0
    assert "box.jpg: floor" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("camera", "says"),
    [
        ({"width_px": 320, "height_px": 240, "hfov_deg": 55}, "missing: height_m, pitch_deg"),
        ({**NOMINAL, "pitch_deg": -5}, "pitch_deg between 0 and 90"),
        ({**NOMINAL, "width_px": 640, "height_px": 480}, "the camera file is for 640 x 480"),
    ],
)
def test_a_bad_camera_file_is_refused_and_nothing_written(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], camera: dict[str, float], says: str
) -> None:
    box, file = pictures(tmp_path)
    file.write_text(json.dumps(camera))
    out = tmp_path / "out"
    out.mkdir()
    assert main(["camera", "detect", str(box), "--camera", str(file), "--out", str(out)]) == 2
    assert says in capsys.readouterr().err
    assert not any(out.iterdir())


def test_a_file_that_is_no_picture_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    _, file = pictures(tmp_path)
    text = tmp_path / "notes.jpg"
    text.write_text("not a picture")
    assert main(["camera", "detect", str(text), "--camera", str(file), "--out", str(tmp_path)]) == 2
    assert "not a picture OpenCV can read" in capsys.readouterr().err

"""Camera calibration on synthetic views of a lens whose truth is known (OpenCV-rendered, with the
simulated OV2640's distortion and noise), the calibration file, and the real-camera path against
a local HTTP server standing in for the ESP32-CAM's /capture."""

from __future__ import annotations

import contextlib
import http.server
import logging
import threading
from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np
import numpy.typing as npt
import pytest

from cart2d.perception.calibration import (
    Board,
    CameraCalibration,
    GroundBoard,
    find_corners,
    fit_ground,
    load_calibration,
    save_calibration,
)
from cart2d.perception.camera_model import Intrinsics, Mount
from cart2d.perception.synthetic import SyntheticCamera, floor_board, true_pixels
from cart2d.tools import cli
from cart2d.tools.camera_calibration.views import calibrate, camera_views, synthetic_views

MOUNT = Mount.from_robot()
BOARD = Board(9, 6, 0.03)
ON_FLOOR = GroundBoard(BOARD, 0.55, 0.0)


@pytest.fixture(scope="module")
def calibrated() -> tuple[Intrinsics, CameraCalibration]:
    truth, views, floor = synthetic_views(BOARD, ON_FLOOR, 12, MOUNT, seed=5)
    return truth, calibrate(views, floor, BOARD, ON_FLOOR, MOUNT, say=lambda _: None)


def test_the_lens_is_recovered(calibrated: tuple[Intrinsics, CameraCalibration]) -> None:
    truth, result = calibrated
    lens = result.intrinsics
    assert lens.fx == pytest.approx(truth.fx, rel=0.01)
    assert lens.fy == pytest.approx(truth.fy, rel=0.01)
    assert lens.cx == pytest.approx(truth.cx, abs=2.0)
    assert lens.cy == pytest.approx(truth.cy, abs=2.0)
    assert lens.dist[0] == pytest.approx(truth.dist[0], abs=0.02)
    assert result.rms_px is not None and result.rms_px < 0.3
    # what matters of k1 and k2 together (they trade off): each pixel's ray, in pixels of the true
    # lens; worst in the image's corners, which a held board hardly reaches
    grid = np.stack(np.meshgrid(np.arange(0, 320, 8), np.arange(0, 240, 8)), -1).reshape(-1, 2)
    rays_true = (truth.undistort(grid) - [truth.cx, truth.cy]) / [truth.fx, truth.fy]
    rays_fit = (lens.undistort(grid) - [lens.cx, lens.cy]) / [lens.fx, lens.fy]
    ray_error_px = np.abs(rays_fit - rays_true).max(axis=1) * truth.fx
    assert np.median(ray_error_px) < 1.0
    assert ray_error_px.max() < 3.0


@pytest.mark.parametrize("ahead_m", [0.3, 0.5, 1.0, 1.5])
def test_pixels_land_on_the_floor_where_the_truth_is(
    calibrated: tuple[Intrinsics, CameraCalibration], ahead_m: float
) -> None:
    truth, result = calibrated
    floor = np.array([[MOUNT.x_m + ahead_m, y] for y in np.linspace(-0.3 * ahead_m, 0.3 * ahead_m, 7)])
    seen, valid = result.pixels_to_ground(true_pixels(truth, MOUNT, floor))
    assert valid.all()
    error_m = np.linalg.norm(seen - floor, axis=1).max()
    assert error_m < (0.02 if ahead_m <= 1.0 else 0.03)
    nominal_error_m = np.linalg.norm(
        CameraCalibration.nominal(MOUNT).pixels_to_ground(true_pixels(truth, MOUNT, floor))[0] - floor, axis=1
    ).max()
    assert nominal_error_m > 2 * error_m  # the calibration is what makes it right


def test_the_floor_board_is_placed_whichever_corner_opencv_lists_first() -> None:
    truth = Intrinsics(320, 240, 310.0, 310.0, 160.0, 120.0, (-0.12, 0.03, 0.0, 0.0, 0.0))
    image = SyntheticCamera(truth, MOUNT, seed=2).render(boards=[floor_board(BOARD, 0.6, 0.05)])
    corners = find_corners(image, BOARD)
    assert corners is not None
    placed = GroundBoard(BOARD, 0.6, 0.05)
    as_found = fit_ground(corners, truth, placed, MOUNT)
    reversed_order = fit_ground(corners[::-1].copy(), truth, placed, MOUNT)
    for fit in (as_found, reversed_order):
        assert fit.rms_m < 0.002
        point = fit.ground.pixel_to_ground(*truth.undistort(true_pixels(truth, MOUNT, [[1.0, 0.2]]))[0])
        assert point == pytest.approx((1.0, 0.2), abs=0.01)


def test_the_boards_are_placed_in_the_world_of_a_cart_anywhere() -> None:
    # the poses the simulator is given: the cart elsewhere and turned, the ground still base_link
    cart = (1.2, -0.7, 2.0)
    truth, views, floor = synthetic_views(BOARD, ON_FLOOR, 9, MOUNT, seed=3, cart=cart)
    result = calibrate(views, floor, BOARD, ON_FLOOR, MOUNT, say=lambda _: None)
    assert result.views == 9
    ahead = np.array([[MOUNT.x_m + 1.0, y] for y in (-0.25, 0.0, 0.25)])
    seen, _ = result.pixels_to_ground(true_pixels(truth, MOUNT, ahead))
    assert np.linalg.norm(seen - ahead, axis=1).max() < 0.02


def test_too_few_views_is_an_error() -> None:
    _, views, floor = synthetic_views(BOARD, ON_FLOOR, 3, MOUNT)
    with pytest.raises(ValueError, match="at least 5"):
        calibrate(views, floor, BOARD, ON_FLOOR, MOUNT, say=lambda _: None)


def test_saved_and_reloaded(tmp_path: Path, calibrated: tuple[Intrinsics, CameraCalibration]) -> None:
    _, result = calibrated
    path = save_calibration(result, tmp_path / "cal.json")
    again = load_calibration(path, MOUNT)
    assert again.calibrated and again.intrinsics == result.intrinsics
    np.testing.assert_allclose(again.ground.floor_to_pixel, result.ground.floor_to_pixel)
    assert again.summary() == result.summary()
    assert not list(tmp_path.glob(".*.tmp"))  # written through atomic_write


def test_a_missing_or_broken_file_falls_back_to_the_nominal_model(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    assert not load_calibration(tmp_path / "none.json", MOUNT).calibrated
    broken = tmp_path / "broken.json"
    broken.write_text('{"version": 1, "intrinsics": {}}')
    with caplog.at_level(logging.WARNING):
        fallback = load_calibration(broken, MOUNT)
    assert not fallback.calibrated and "nominal" in caplog.text
    assert fallback.intrinsics == Intrinsics.nominal(MOUNT)


def test_the_command_calibrates_and_saves(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "camera.json"
    assert cli.main(["camera", "calibrate", "--synthetic", "--views", "9", "--out", str(out)]) == 0
    assert "RMS reprojection error" in capsys.readouterr().out
    assert load_calibration(out, MOUNT).calibrated


@contextlib.contextmanager
def esp32_cam(images: list[npt.NDArray[np.uint8]]) -> Iterator[tuple[str, list[int]]]:
    """/capture answers the next of `images` as a JPEG, like the stock CameraWebServer's; the
    lengths of the JPEGs served so far."""
    jpegs = [cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, 90])[1].tobytes() for image in images]
    served: list[int] = []

    class Handler(http.server.BaseHTTPRequestHandler):
        def do_GET(self) -> None:
            if self.path != "/capture":
                self.send_error(404)
                return
            body = jpegs[min(len(served), len(jpegs) - 1)]
            served.append(len(body))
            self.send_response(200)
            self.send_header("Content-Type", "image/jpeg")
            self.send_header("Content-Length", str(len(body)))
            self.end_headers()
            self.wfile.write(body)

        def log_message(self, *args: object) -> None:
            pass

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}", served
    finally:
        server.shutdown()
        server.server_close()


@pytest.fixture
def fake_esp32_cam() -> Iterator[tuple[str, list[int]]]:
    _, views, floor = synthetic_views(BOARD, ON_FLOOR, 6, MOUNT, seed=9)
    with esp32_cam([*views, floor]) as camera:
        yield camera


def test_a_camera_at_another_framesize_is_refused_with_the_fix() -> None:
    _, views, _ = synthetic_views(BOARD, ON_FLOOR, 1, MOUNT)
    vga = np.asarray(cv2.resize(next(views), (640, 480)), dtype=np.uint8)
    with esp32_cam([vga]) as (url, _):
        views_of_camera, _ = camera_views(url, BOARD, ON_FLOOR, 6, MOUNT, lambda _: "")
        with pytest.raises(ValueError, match=r"640 x 480 .* framesize to 320 x 240"):
            next(views_of_camera)


def test_a_real_camera_is_read_from_capture_between_prompts(fake_esp32_cam: tuple[str, list[int]]) -> None:
    url, served = fake_esp32_cam
    prompts: list[str] = []

    def ask(prompt: str) -> str:
        prompts.append(prompt)
        return ""

    views, floor_view = camera_views(url, BOARD, ON_FLOOR, 6, MOUNT, ask)
    result = calibrate(views, floor_view, BOARD, ON_FLOOR, MOUNT, say=lambda _: None)
    assert len(served) == 7 and len(prompts) == 7  # one capture after each Enter
    assert "press Enter" in prompts[0] and "floor" in prompts[-1]
    assert result.calibrated and result.ground_rms_m is not None and result.ground_rms_m < 0.005


def test_the_command_against_a_camera_prompts_and_saves(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    _, views, floor = synthetic_views(BOARD, ON_FLOOR, 6, MOUNT, seed=4)
    prompts: list[str] = []

    def enter(prompt: str = "") -> str:
        prompts.append(prompt)
        return ""

    monkeypatch.setattr("builtins.input", enter)
    out = tmp_path / "camera.json"
    with esp32_cam([*views, floor]) as (url, served):
        code = cli.main(["camera", "calibrate", "--camera", url, "--views", "6", "--out", str(out)])
    assert code == 0 and len(served) == len(prompts) == 7
    assert "saved to" in capsys.readouterr().out
    assert load_calibration(out, MOUNT).calibrated


def test_the_command_says_why_when_the_camera_is_not_there(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr("builtins.input", lambda prompt="": "")
    with esp32_cam([]) as (url, _):
        pass  # the server is gone: its port refuses
    out = tmp_path / "camera.json"
    assert cli.main(["camera", "calibrate", "--camera", url, "--views", "5", "--out", str(out)]) == 1
    assert "cart2d camera calibrate:" in capsys.readouterr().err
    assert not out.exists()

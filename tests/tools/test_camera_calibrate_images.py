"""`cart2d camera calibrate --images DIR --board COLSxROWS@SQUARE_M`: the lens from a folder of
real photographs (OpenCV's, tests/data/real/calibration/), with the checks and report of the
camera's calibration: each view's error, a bad view dropped by name, a poor fit refused with
nothing saved, the parts of the picture no board reached; bad input refused with status 2."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from cart2d.perception.calibration import find_corners, load_calibration
from cart2d.perception.calibration_checks import MAX_RMS_PX
from cart2d.tools import cli
from tests.support.real_calibration import board, copy_views, dent, published, read, view_paths, wave

BOARD_ARG = "9x6@0.025"


def calibrate(*args: str) -> int:
    return cli.main(["camera", "calibrate", *args])


def test_a_folder_with_a_dented_view_is_calibrated_without_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = copy_views(tmp_path / "views")
    image = read(folder / "left03.jpg")
    corners = find_corners(image, board())
    assert corners is not None
    spacing = float(np.linalg.norm(corners[1] - corners[0]))
    cv2.imwrite(str(folder / "left03-dented.jpg"), dent(image, corners[2 * 9 + 4], (8.0, 0.0), spacing / 3))
    out = tmp_path / "lens.json"
    assert calibrate("--images", str(folder), "--board", BOARD_ARG, "--out", str(out)) == 0
    said = capsys.readouterr().out
    assert "DROPPED left03-dented.jpg: corner " in said
    for path in view_paths():
        assert f"{path.name}: board found" in said  # every real view found ...
        assert f"  {path.name}: " in said  # ... and kept, with its own error
    assert "fitted again without the 1 dropped" in said
    saved = load_calibration(out)
    reference = published()["python_sample"]
    assert saved.calibrated and saved.views == len(view_paths())
    assert saved.intrinsics.fx == pytest.approx(reference["fx"], rel=0.005)
    assert saved.rms_px is not None and saved.rms_px == pytest.approx(reference["rms_px"], abs=0.1)


def test_a_fit_above_the_limit_is_refused_and_nothing_saved(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = tmp_path / "bent"
    folder.mkdir()
    for seed, path in enumerate(view_paths()[:7]):
        cv2.imwrite(str(folder / path.name), wave(read(path), 2.5, seed))
    out = tmp_path / "lens.json"
    assert calibrate("--images", str(folder), "--board", BOARD_ARG, "--out", str(out)) == 1
    err = capsys.readouterr().err
    assert f"above the {MAX_RMS_PX:.1f} px a calibration may have" in err and "nothing was saved" in err
    assert not out.exists()


def test_the_parts_of_the_picture_no_board_reached_are_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # each view in the top half of a picture twice as tall: no board in its bottom third
    folder = tmp_path / "top"
    folder.mkdir()
    for path in view_paths()[:6]:
        image = read(path)
        canvas = np.full((image.shape[0] * 2, image.shape[1], 3), 128, dtype=np.uint8)
        canvas[: image.shape[0]] = image
        cv2.imwrite(str(folder / path.name), canvas)
    assert calibrate("--images", str(folder), "--board", BOARD_ARG) == 0
    said = capsys.readouterr().out
    first = next(line for line in said.splitlines() if line.startswith("left01.jpg: "))
    assert first.startswith("left01.jpg: board found; no board yet in the picture's top left, ")
    assert (
        "coverage of the views kept: no board yet in the picture's bottom left, bottom middle, bottom right"
        in said
    )
    assert "nothing saved (no --out)" in said


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["--images", "{missing}", "--board", BOARD_ARG], "is not a folder"),
        (["--images", "{empty}", "--board", BOARD_ARG], "holds no pictures"),
        (["--images", "{empty}", "--board", "9x6@a"], "COLSxROWS"),
        (["--images", "{empty}", "--board", "9x6@0.025", "--square-m", "0.03"], "given twice"),
    ],
)
def test_bad_input_is_refused_with_status_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str], says: str
) -> None:
    (tmp_path / "empty").mkdir()
    (tmp_path / "empty" / "notes.txt").write_text("not a picture")
    filled = [a.format(missing=tmp_path / "missing", empty=tmp_path / "empty") for a in args]
    out = tmp_path / "lens.json"
    assert status(*filled, "--out", str(out)) == 2
    assert says in capsys.readouterr().err
    assert not out.exists()


def status(*args: str) -> int:
    """The command's exit status, argparse's refusals (SystemExit) included."""
    try:
        return calibrate(*args)
    except SystemExit as exc:
        return int(exc.code or 0)


def test_published_reference_lists_every_picture_kept() -> None:
    names = json.loads((view_paths()[0].parent / "published.json").read_text())["views"]
    assert sorted(p.name for p in view_paths()[0].parent.glob("*.jpg")) == sorted(names)

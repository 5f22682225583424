"""### Real calibration

`cart2d camera calibrate --images`'s procedure (cart2d/tools/camera_calibration/lens.py) on real
photographs: OpenCV's own 13 chessboard views (9 x 6 inner corners, 25 mm squares, 640 x 480;
tests/data/real/calibration/, README there for their source, licence and the published
calibrations), against the calibration OpenCV's Python sample publishes for them (fx 532.80,
fy 532.92 px, RMS 0.196 px). Also: which views each finder finds the board in; the corners of
OpenCV's C++ sample (an 11 x 11 search window), which made the published left_intrinsics.yml
(RMS 0.39 px, fx 535.9 px), through the same checks; a view with a corner pushed 8 px aside
(tests/support/real_calibration.py: dent) added to the set; the views at QVGA through a JPEG of
quality 80, as the ESP32-CAM sends them (at half the size, fx and fy are half). The cost:
find_corners' CPU time per 640 x 480 view on one core.

Targets: every usable view used; fx and fy within 0.5 % of the published values; the RMS error
within 0.1 px of the published one; the view with the pushed corner dropped and named.

A part of the "real photographs" section: `add_to(section, quick)`; alone,
`python -m bench.real_calibration`.
"""

from __future__ import annotations

import statistics
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from bench.common import Section, missed, section_main, table
from cart2d.perception.calibration import CLASSIC_FLAGS, SB_FLAGS, calibrate_lens, find_corners
from cart2d.perception.calibration_checks import CheckedFit, fit_dropping_outliers
from cart2d.perception.camera_model import FloatArray
from tests.support.real_calibration import as_esp32_cam_sends, board, dent, published, read, view_paths

NAME = "real_calibration"
FX_TOLERANCE = 0.005  # of the published value
RMS_TOLERANCE_PX = 0.1
DENT_SHIFT_PX = (8.0, 0.0)


@dataclass
class Measured:
    markdown: str
    data: dict[str, Any]
    checks: list[tuple[str, bool]]


def _sample_corners(gray: np.ndarray) -> FloatArray | None:
    """OpenCV's samples/cpp/calibration.cpp: findChessboardCorners, cornerSubPix 11 x 11."""
    b = board()
    found, corners = cv2.findChessboardCorners(gray, (b.cols, b.rows), flags=CLASSIC_FLAGS)
    if not found:
        return None
    criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_MAX_ITER, 30, 0.1)
    return np.asarray(
        cv2.cornerSubPix(gray, corners, (11, 11), (-1, -1), criteria), dtype=np.float64
    ).reshape(-1, 2)


def _found_by_each_finder(*image_sets: dict[str, np.ndarray]) -> list[list[object]]:
    b = board()
    size = (b.cols, b.rows)

    def sector(gray: np.ndarray) -> bool:
        return bool(cv2.findChessboardCornersSB(gray, size, flags=SB_FLAGS)[0])

    def older(gray: np.ndarray) -> bool:
        return bool(cv2.findChessboardCorners(gray, size, flags=CLASSIC_FLAGS)[0])

    def ours(gray: np.ndarray) -> bool:
        return find_corners(gray, b) is not None

    rows: list[list[object]] = []
    for label, finder in (
        ("findChessboardCornersSB (NORMALIZE_IMAGE)", sector),
        ("findChessboardCorners (ADAPTIVE_THRESH, NORMALIZE_IMAGE)", older),
        ("find_corners (the first, else the second)", ours),
    ):
        counts = [
            sum(finder(cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)) for image in images.values())
            for images in image_sets
        ]
        rows.append([label, *(f"{n} of {len(images)}" for n, images in zip(counts, image_sets, strict=True))])
    return rows


def _lens_row(label: str, checked: CheckedFit, reference: dict[str, Any], scale: float = 1.0) -> list[object]:
    """`scale`: the pictures' size over the published calibration's (fx, fy scale with it)."""
    fx, fy = checked.lens.intrinsics.fx / scale, checked.lens.intrinsics.fy / scale
    return [
        label,
        checked.lens.views,
        ", ".join(d.name for d in checked.dropped) or "none",
        f"{fx:.2f} ({100 * (fx / reference['fx'] - 1):+.2f} %)",
        f"{fy:.2f} ({100 * (fy / reference['fy'] - 1):+.2f} %)",
        f"{checked.lens.rms_px:.3f}",
    ]


def measure(quick: bool) -> Measured:
    b, reference = board(), published()["python_sample"]
    images = {path.name: read(path) for path in view_paths()}
    small = {name: as_esp32_cam_sends(image) for name, image in images.items()}
    corners: dict[str, FloatArray] = {}
    cpu_s = []
    for name, image in images.items():
        start = time.thread_time()
        found = find_corners(image, b)
        cpu_s.append(time.thread_time() - start)
        if found is not None:
            corners[name] = found
    ours = fit_dropping_outliers(list(corners.items()), b, 640, 480)
    lens = ours.lens.intrinsics
    fx_ok = abs(lens.fx / reference["fx"] - 1) <= FX_TOLERANCE
    fy_ok = abs(lens.fy / reference["fy"] - 1) <= FX_TOLERANCE
    rms_ok = abs(ours.lens.rms_px - reference["rms_px"]) <= RMS_TOLERANCE_PX
    every_view = len(corners) == len(images) and not ours.dropped
    rows = [_lens_row("cart2d (find_corners, the checks)", ours, reference)]
    sample = {
        name: _sample_corners(cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)) for name, image in images.items()
    }
    sample_views = [(name, c) for name, c in sample.items() if c is not None]
    sample_checked = fit_dropping_outliers(sample_views, b, 640, 480)
    rows.append(_lens_row("the C++ sample's corners, the checks", sample_checked, reference))
    # the pushed corner: column 4, row 2 of left03.jpg
    left03 = corners["left03.jpg"]
    spacing = float(np.linalg.norm(left03[1] - left03[0]))
    dented = find_corners(dent(images["left03.jpg"], left03[2 * b.cols + 4], DENT_SHIFT_PX, spacing / 3), b)
    dent_dropped: list[str] = []
    if dented is not None:
        with_dent = fit_dropping_outliers([*corners.items(), ("left03-dented.jpg", dented)], b, 640, 480)
        dent_dropped = [d.name for d in with_dent.dropped]
        rows.append(_lens_row("with left03-dented.jpg added", with_dent, reference))
    dent_ok = dent_dropped == ["left03-dented.jpg"]
    small_corners = [(name, c) for name, image in small.items() if (c := find_corners(image, b)) is not None]
    small_checked = fit_dropping_outliers(small_corners, b, 320, 240)
    rows.append(_lens_row("QVGA, JPEG 80 (fx, fy times 2)", small_checked, reference, 0.5))
    checks = [
        ("every usable view used", every_view),
        ("fx within 0.5 % of the published", fx_ok),
        ("fy within 0.5 % of the published", fy_ok),
        ("RMS within 0.1 px of the published", rms_ok),
        ("the view with a pushed corner dropped and named", dent_ok),
    ]

    unchecked_rms = calibrate_lens([c for _, c in sample_views], b, 640, 480).rms_px
    cpu_ms = 1000 * statistics.median(cpu_s)

    def verdict(ok: bool) -> str:
        return "met" if ok else "**MISSED**"

    markdown = (
        "### Real calibration\n\n"
        + table(
            ["finder", "640 x 480: board found in", "QVGA, JPEG 80"], _found_by_each_finder(images, small)
        )
        + "\n"
        + table(
            [
                "fit",
                "views kept",
                "dropped",
                "fx, px (vs 532.80)",
                "fy, px (vs 532.92)",
                "RMS, px (published 0.196)",
            ],
            rows,
        )
        + f"\nThe C++ sample's corners fitted as they are: RMS {unchecked_rms:.3f} px (published "
        f"{published()['cpp_sample']['rms_px']:.3f}). find_corners: {cpu_ms:.0f} ms of CPU per 640 x 480 "
        "view (median).\n\n" + table(["target", "result"], [[name, verdict(ok)] for name, ok in checks])
    )
    data = {
        "views": len(images),
        "found": len(corners),
        "fx": lens.fx,
        "fy": lens.fy,
        "cx": lens.cx,
        "cy": lens.cy,
        "rms_px": ours.lens.rms_px,
        "dropped": [d.name for d in ours.dropped],
        "published": {k: reference[k] for k in ("fx", "fy", "cx", "cy", "rms_px")},
        "cpp_sample_dropped": [d.name for d in sample_checked.dropped],
        "dent_dropped": dent_dropped,
        "cpp_sample_unchecked_rms_px": unchecked_rms,
        "find_corners_cpu_ms_median": cpu_ms,
        "targets": {name: ok for name, ok in checks},
    }
    return Measured(markdown, data, checks)


def add_to(section: Section, quick: bool) -> None:
    """This part into the "real photographs" section: its Markdown, its numbers, its targets."""
    part = measure(quick)
    section.markdown += "\n" + part.markdown
    section.data["calibration"] = part.data
    section.targets_met = section.targets_met and not missed(part.checks)


def run(out: Path, quick: bool) -> Section:
    section = Section(NAME, "")
    add_to(section, quick)
    return section


if __name__ == "__main__":
    sys.exit(section_main(run))

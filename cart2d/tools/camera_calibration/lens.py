"""The lens half of `cart2d camera calibrate`, the same for the real camera, the simulator and a
folder of pictures: the board found in each view (coverage said after each), the lens fitted,
views with a misplaced corner dropped by name and the lens fitted again, each kept view's own
error, and a fit above the limit refused (cart2d/perception/calibration_checks.py)."""

from __future__ import annotations

from collections.abc import Callable, Iterable

import numpy as np
import numpy.typing as npt

from cart2d.perception.calibration import MIN_VIEWS, Board, find_corners
from cart2d.perception.calibration_checks import (
    CheckedFit,
    Coverage,
    fit_dropping_outliers,
    refuse_above_limit,
)
from cart2d.perception.camera_model import FloatArray

Image = npt.NDArray[np.uint8]


def lens_from_views(
    views: Iterable[tuple[str, Image]], board: Board, say: Callable[[str], None] = print
) -> CheckedFit:
    """ValueError, with a sentence, when the board is in too few views, too many are dropped or
    the fit's error is above the limit."""
    found: list[tuple[str, FloatArray]] = []
    size: tuple[int, int] | None = None
    coverage: Coverage | None = None
    for name, image in views:
        shape = (image.shape[1], image.shape[0])
        if size is not None and shape != size:
            raise ValueError(f"{name} is {shape[0]} x {shape[1]}, the views before it {size[0]} x {size[1]}")
        size = shape
        coverage = coverage or Coverage(*shape)
        corners = find_corners(image, board)
        if corners is None:
            say(f"{name}: board NOT found, view skipped; {coverage.text()}")
            continue
        found.append((name, corners))
        coverage.add(corners)
        say(f"{name}: board found; {coverage.text()}")
    if size is None or len(found) < MIN_VIEWS:
        raise ValueError(f"the board was found in {len(found)} views: at least {MIN_VIEWS} are needed")
    checked = fit_dropping_outliers(found, board, *size)
    report(checked, say)
    kept = {e.name for e in checked.kept}
    final = Coverage(*size)
    for name, corners in found:
        if name in kept:
            final.add(corners)
    if final.missing():
        say(f"coverage of the views kept: {final.text()}; views there would pin the distortion down")
    refuse_above_limit(checked.lens)
    return checked


def report(checked: CheckedFit, say: Callable[[str], None]) -> None:
    for view in checked.dropped:
        say(f"DROPPED {view.name}: {view.reason}")
    for error in checked.kept:
        say(f"  {error.text()}")
    lens = checked.lens.intrinsics
    refit = f", fitted again without the {len(checked.dropped)} dropped" if checked.dropped else ""
    say(
        f"lens: fx {lens.fx:.1f} fy {lens.fy:.1f} cx {lens.cx:.1f} cy {lens.cy:.1f} px, "
        f"k1 {lens.dist[0]:.3f} k2 {lens.dist[1]:.3f}; RMS reprojection error {checked.lens.rms_px:.3f} px "
        f"over {checked.lens.views} views{refit}"
    )

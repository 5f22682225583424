"""What makes a lens calibration trustworthy: each view's own reprojection error, views with a
misplaced corner dropped by name (and the lens fitted again without them), a fit whose RMS error
is above MAX_RMS_PX refused with a sentence, and which part of the picture the board has not yet
covered while views are being collected.

A corner misplaced by the finder (a hand over the board, a glare, a search window that slid into
the next square) pulls the whole fit towards it; the fit's RMS over hundreds of good corners hides
it, the corner's own residual does not. Zhang's method needs the board in every part of the
picture to separate the distortion from the focal length: coverage says where it is missing.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from cart2d.perception.calibration import MIN_VIEWS, Board, LensFit, calibrate_lens
from cart2d.perception.camera_model import FloatArray

# The limit of a lens fit's RMS reprojection error, over the views kept. A good fit is well under
# 0.5 px; above 1 px a view is blurred, the board bent or the lens model wrong, and the floor a
# metre away is off by centimetres. docs/camera.md ("Calibration") says the same to the user.
MAX_RMS_PX = 1.0
# A corner further than this from where the fit puts it is misplaced: OUTLIER_RMS_FACTOR times the
# fit's RMS error and at least OUTLIER_MIN_PX. The worst corner of a good view is under 3 times it
# (OpenCV's real views 2.9, the simulator's 2.8); a corner a thumb or a glare moves is off by
# pixels (OpenCV's own C++ sample slid left02.jpg's by 6.3 px).
OUTLIER_RMS_FACTOR = 6.0
OUTLIER_MIN_PX = 1.0
COVERAGE_GRID = 3  # the picture cut into 3 x 3 parts for the coverage feedback
COVERAGE_NAMES = (
    ("top left", "top middle", "top right"),
    ("left middle", "middle", "right middle"),
    ("bottom left", "bottom middle", "bottom right"),
)


@dataclass(frozen=True)
class ViewError:
    """A view's own reprojection error: RMS over its corners and its worst corner, (col, row)."""

    name: str
    rms_px: float
    worst_px: float
    worst_corner: tuple[int, int]

    def text(self) -> str:
        return f"{self.name}: {self.rms_px:.3f} px RMS, worst corner {self.worst_px:.2f} px"


@dataclass(frozen=True)
class DroppedView:
    name: str
    reason: str


@dataclass
class CheckedFit:
    """The fit over the views kept, each kept view's error, and the views dropped and why."""

    lens: LensFit
    kept: list[ViewError]
    dropped: list[DroppedView] = field(default_factory=list)


def view_errors(fit: LensFit, names: Sequence[str], board: Board) -> list[ViewError]:
    errors = []
    for name, residual in zip(names, fit.residuals_px, strict=True):
        worst = int(np.argmax(residual))
        errors.append(
            ViewError(
                name,
                float(np.sqrt(np.mean(residual**2))),
                float(residual[worst]),
                (worst % board.cols, worst // board.cols),
            )
        )
    return errors


def outlier_limit_px(fit: LensFit) -> float:
    return max(OUTLIER_MIN_PX, OUTLIER_RMS_FACTOR * fit.rms_px)


def fit_dropping_outliers(
    views: Sequence[tuple[str, FloatArray]], board: Board, width: int, height: int
) -> CheckedFit:
    """The lens from the named views' corners; while a view has a corner further than
    outlier_limit_px from the fit, the worst such view is dropped and the lens fitted again.
    ValueError if fewer than MIN_VIEWS views are left."""
    kept = list(views)
    dropped: list[DroppedView] = []
    while True:
        fit = calibrate_lens([corners for _, corners in kept], board, width, height)
        errors = view_errors(fit, [name for name, _ in kept], board)
        limit = outlier_limit_px(fit)
        worst = max(errors, key=lambda e: e.worst_px)
        if worst.worst_px <= limit:
            return CheckedFit(fit, errors, dropped)
        col, row = worst.worst_corner
        dropped.append(
            DroppedView(
                worst.name,
                f"corner {col},{row} (column, row of the inner corners) is {worst.worst_px:.1f} px from "
                f"where the fit puts it, over the {limit:.2f} px a good corner stays within: "
                "misplaced (a hand, a glare or a bent board over it)",
            )
        )
        kept = [(name, corners) for name, corners in kept if name != worst.name]
        if len(kept) < MIN_VIEWS:
            how_many = "1 view" if len(dropped) == 1 else f"{len(dropped)} views"
            raise ValueError(
                f"{how_many} dropped for misplaced corners ({', '.join(d.name for d in dropped)}): "
                f"{len(kept)} are left, at least {MIN_VIEWS} are needed; take more views"
            )


def refuse_above_limit(fit: LensFit, limit_px: float = MAX_RMS_PX) -> None:
    """ValueError, with a sentence, if the fit's RMS reprojection error is above the limit."""
    if fit.rms_px > limit_px:
        raise ValueError(
            f"the lens fit's RMS reprojection error is {fit.rms_px:.2f} px, above the {limit_px:.1f} px a "
            "calibration may have: the views are blurred, the board is not flat or not the size given; "
            "nothing was saved, calibrate again"
        )


class Coverage:
    """Which of the picture's COVERAGE_GRID x COVERAGE_GRID parts a board's corner has fallen in."""

    def __init__(self, width: int, height: int) -> None:
        self.width, self.height = width, height
        self.hits = np.zeros((COVERAGE_GRID, COVERAGE_GRID), dtype=np.int64)

    def add(self, corners: FloatArray) -> None:
        pts = np.asarray(corners, dtype=np.float64).reshape(-1, 2)
        col = np.clip((pts[:, 0] * COVERAGE_GRID / self.width).astype(int), 0, COVERAGE_GRID - 1)
        row = np.clip((pts[:, 1] * COVERAGE_GRID / self.height).astype(int), 0, COVERAGE_GRID - 1)
        np.add.at(self.hits, (row, col), 1)

    def missing(self) -> list[str]:
        """The parts no board has reached yet, by name ("top left" ... "bottom right")."""
        return [
            COVERAGE_NAMES[r][c]
            for r in range(COVERAGE_GRID)
            for c in range(COVERAGE_GRID)
            if not self.hits[r, c]
        ]

    def text(self) -> str:
        empty = self.missing()
        if not empty:
            return "the board has been in every part of the picture"
        return f"no board yet in the picture's {', '.join(empty)}"

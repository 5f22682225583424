"""The arithmetic of Borenstein and Feng's UMBmark (`cart2d calibrate`): pure, no link, no simulator.

The cart drives a square of side L, n times clockwise and n times counter-clockwise, from a
corner and heading along the first side; at the end of every run the return error is the true
position minus the position the odometry computed (in simulation from ground truth, on a robot
measured by hand). Two systematic errors explain the centroids of the CW and CCW end points:

- E_d = D_R/D_L, the ratio of the true measuring-wheel diameters where the odometry assumes
  its own ratio: it bends every straight side by an angle beta;
- E_b, true over assumed wheelbase: every 90 degree corner turns alpha too little.

J. Borenstein, L. Feng, "Measurement and correction of systematic odometry errors in mobile
robots", IEEE Trans. Robotics and Automation 12(6), 1996 (eqs. 11-18). To first order in the
errors, in our frame (x forward along the first side, y to the left, theta counter-clockwise):

    CCW: error = 2L (beta - alpha) (1, -1)        CW: error = -2L (beta + alpha) (1, 1)

so alpha = -(x_cw + x_ccw)/4L = (y_ccw - y_cw)/4L and beta = (x_ccw - x_cw)/4L = -(y_cw + y_ccw)/4L
(Borenstein's equations, in the same frame). Then R = (L/2)/sin(beta/2), the radius the
"straight" sides actually curve on, E_d = (R + b/2)/(R - b/2), E_b = 90 deg/(90 deg - alpha); the
corrected radii are r_L * 2/(E_d + 1) and r_R * 2/(1/E_d + 1) (their mean kept) and the track
E_b * b. The formulas are first order: a second pass with the corrected values removes most of
what is left. UMBmark cannot see a common scale error of both radii (a square scaled up still
closes); the mean radius is kept and the track absorbs it in the turns.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from typing import Any, Literal

from cart2d.params import robot

Point = tuple[float, float]
Axes = Literal["x", "y", "xy"]


@dataclass(frozen=True)
class Geometry:
    """The measuring-wheel geometry the odometry uses (settings 15-17)."""

    radius_left_m: float
    radius_right_m: float
    track_m: float

    def text(self) -> str:
        return (
            f"r_left {self.radius_left_m * 1e3:.4f} mm, r_right {self.radius_right_m * 1e3:.4f} mm, "
            f"track {self.track_m * 1e3:.3f} mm"
        )


@dataclass(frozen=True)
class Corrections:
    """What one UMBmark pass found and the geometry it proposes."""

    alpha_rad: float  # every corner turned this much too little (same sign CW and CCW)
    beta_rad: float  # every straight side curved this much to the left
    radius_m: float  # R: the radius the straight sides curve on (inf: straight)
    e_d: float  # D_R/D_L: true diameter ratio relative to the one the odometry assumed
    e_b: float  # true over assumed wheelbase
    geometry: Geometry  # the corrected one


def centroid(points: Sequence[Point]) -> Point:
    if not points:
        raise ValueError("no end points")
    return (statistics.fmean(p[0] for p in points), statistics.fmean(p[1] for p in points))


def e_max_syst(cw: Sequence[Point], ccw: Sequence[Point]) -> float:
    """Borenstein's measure of systematic odometry error: the larger centroid distance."""
    return max(math.hypot(*centroid(cw)), math.hypot(*centroid(ccw)))


def umbmark_corrections(
    cw: Sequence[Point], ccw: Sequence[Point], side_m: float, geometry: Geometry, axes: Axes = "xy"
) -> Corrections:
    """The UMBmark arithmetic: return errors (true minus odometry, metres, in the start frame) of
    the clockwise and counter-clockwise runs -> alpha, beta, E_d, E_b and the corrected geometry.

    `axes` says which centroid coordinates give alpha and beta: Borenstein's x equations, the
    y equations, or (default) the mean of both, which halves the noise of a hand measurement."""
    if side_m <= 0:
        raise ValueError("the side of the square must be positive")
    (x_cw, y_cw), (x_ccw, y_ccw) = centroid(cw), centroid(ccw)
    four_l = 4.0 * side_m
    alpha_x, beta_x = -(x_cw + x_ccw) / four_l, (x_ccw - x_cw) / four_l
    alpha_y, beta_y = (y_ccw - y_cw) / four_l, -(y_cw + y_ccw) / four_l
    if axes == "x":
        alpha, beta = alpha_x, beta_x
    elif axes == "y":
        alpha, beta = alpha_y, beta_y
    else:
        alpha, beta = 0.5 * (alpha_x + alpha_y), 0.5 * (beta_x + beta_y)
    if not abs(alpha) < math.pi / 4 or not abs(beta) < math.pi / 2:
        raise ValueError(
            f"the end points are too far off for UMBmark (alpha {math.degrees(alpha):.1f} deg, "
            f"beta {math.degrees(beta):.1f} deg): check the measurements and their signs"
        )
    b = geometry.track_m
    sin_half = math.sin(beta / 2.0)
    radius = (side_m / 2.0) / sin_half if sin_half != 0.0 else math.inf
    # (R + b/2)/(R - b/2) with R = (L/2)/sin(beta/2), multiplied through by sin(beta/2): no
    # division by zero when the sides are straight.
    if not side_m > b * abs(sin_half):
        raise ValueError("the curvature found is tighter than the wheelbase: check the measurements")
    e_d = (side_m + b * sin_half) / (side_m - b * sin_half)
    e_b = (math.pi / 2.0) / (math.pi / 2.0 - alpha)
    corrected = Geometry(
        radius_left_m=geometry.radius_left_m * 2.0 / (e_d + 1.0),
        radius_right_m=geometry.radius_right_m * 2.0 / (1.0 / e_d + 1.0),
        track_m=geometry.track_m * e_b,
    )
    return Corrections(
        alpha_rad=alpha,
        beta_rad=beta,
        radius_m=radius,
        e_d=e_d,
        e_b=e_b,
        geometry=corrected,
    )


def square_corners(side_m: float, clockwise: bool) -> list[Point]:
    """The square in the frame of SET_POSE (0, 0, 0): along +x first, then right (CW) or left."""
    s = -side_m if clockwise else side_m
    return [(side_m, 0.0), (side_m, s), (0.0, s), (0.0, 0.0)]


def parse_position_mm(text: str) -> Point:
    """'12.5, -3' or '12.5 -3' (millimetres, x then y) -> metres. ValueError with a sentence."""
    parts = text.replace(",", " ").replace(";", " ").split()
    if len(parts) != 2:
        raise ValueError("type two numbers, x and y in millimetres, e.g. 12.5 -3")
    try:
        x_mm, y_mm = float(parts[0]), float(parts[1])
    except ValueError:
        raise ValueError(f"not numbers: {text.strip()!r}; e.g. 12.5 -3") from None
    if not (math.isfinite(x_mm) and math.isfinite(y_mm)) or max(abs(x_mm), abs(y_mm)) > 10_000:
        raise ValueError("each coordinate must be a finite number of millimetres, at most 10 m")
    return (x_mm / 1000.0, y_mm / 1000.0)


@dataclass
class Measurement:
    """The return errors of one UMBmark pass (m)."""

    geometry: Geometry  # what the odometry used
    cw: list[Point] = field(default_factory=list)
    ccw: list[Point] = field(default_factory=list)

    def e_max_syst_m(self) -> float:
        return e_max_syst(self.cw, self.ccw)

    def as_dict(self) -> dict[str, Any]:
        return {
            "geometry": asdict(self.geometry),
            "cw": [list(p) for p in self.cw],
            "ccw": [list(p) for p in self.ccw],
            "centroid_cw": list(centroid(self.cw)),
            "centroid_ccw": list(centroid(self.ccw)),
            "e_max_syst_m": self.e_max_syst_m(),
        }


@dataclass
class Calibration:
    side_m: float
    before: Geometry
    after: Geometry
    passes: list[tuple[Measurement, Corrections]]
    verification: Measurement | None = None
    saved: bool = False
    truth: Geometry | None = None  # simulation: the measuring wheels as the simulator has them
    faults: dict[str, float] = field(default_factory=dict)

    def first(self) -> Measurement:
        """The measurement with the geometry as it was."""
        if self.passes:
            return self.passes[0][0]
        if self.verification is None:
            raise ValueError("nothing was measured")
        return self.verification

    def e_max_before_m(self) -> float:
        return self.first().e_max_syst_m()

    def e_max_after_m(self) -> float | None:
        return None if self.verification is None or not self.passes else self.verification.e_max_syst_m()

    def identified_errors(self) -> tuple[float, float] | None:
        """Simulation: relative errors of what UMBmark can identify, the radius ratio r_R/r_L and
        the track in units of the mean radius, after calibration against the simulator's truth."""
        if self.truth is None:
            return None
        a, t = self.after, self.truth
        ratio = (a.radius_right_m / a.radius_left_m) / (t.radius_right_m / t.radius_left_m) - 1.0
        track = (a.track_m / (a.radius_left_m + a.radius_right_m)) / (
            t.track_m / (t.radius_left_m + t.radius_right_m)
        ) - 1.0
        return ratio, track

    def as_dict(self) -> dict[str, Any]:
        after = self.e_max_after_m()
        before = self.e_max_before_m()
        identified = self.identified_errors()
        return {
            "side_m": self.side_m,
            "before": asdict(self.before),
            "after": asdict(self.after),
            "passes": [
                {
                    "measurement": m.as_dict(),
                    "alpha_rad": c.alpha_rad,
                    "beta_rad": c.beta_rad,
                    "radius_m": c.radius_m if math.isfinite(c.radius_m) else None,
                    "e_d": c.e_d,
                    "e_b": c.e_b,
                    "corrected": asdict(c.geometry),
                }
                for m, c in self.passes
            ],
            "verification": None if self.verification is None else self.verification.as_dict(),
            "e_max_syst_before_m": before,
            "e_max_syst_after_m": after,
            "improvement": None if not after else before / after,
            "saved": self.saved,
            "faults": self.faults,
            "truth": None if self.truth is None else asdict(self.truth),
            "ratio_error": None if identified is None else identified[0],
            "track_per_radius_error": None if identified is None else identified[1],
        }


def sim_layout(side_m: float, step_m: float = 0.2) -> tuple[tuple[int, float], Point, Point]:
    """An arena that fits the square with room for the uncalibrated cart's detours: the grid
    (nodes, step) and the CCW and CW start corners."""
    margin = max(1.0, 0.5 * side_m)
    nodes = math.ceil((side_m + 2.0 * margin) / step_m - 1e-9) + 1
    return (nodes, step_m), (margin, margin), (margin, margin + side_m)


def true_geometry(faults: dict[str, float]) -> Geometry:
    """The simulator's measuring wheels under these faults."""
    enc = robot()["encoders"]
    return Geometry(
        enc["radius_m"] * faults.get("enc_radius_scale_l", 1.0),
        enc["radius_m"] * faults.get("enc_radius_scale_r", 1.0),
        enc["track_m"] + faults.get("enc_track_error_m", 0.0),
    )

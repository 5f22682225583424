"""Odometry calibration with Borenstein and Feng's UMBmark: `cart2d calibrate`.

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

The square is driven as UMBmark asks: each side a one-point path (WAIT_XY_ARRAY) that stops on
its corner, each corner a turn on the spot (VELOCITY with v = 0 until the odometry's heading is
90 degrees on; see turn_on_the_spot). In the simulator (`--sim`) the cart is placed at the start
for every run and the ground truth gives the error; on a robot (`--serial PORT`) the user puts
the cart back on the start mark and types where it ended. The corrected values are written with
PARAM_SET after every pass and saved with SAVE at the end. A restart of the MCU anywhere in
between (STATUS: a new boot count, or the uptime going backwards) stops the calibration: it
loses the run's path and the values set in RAM.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import statistics
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Literal, Protocol

from cart2d import cli_args
from cart2d import faults as fault_table
from cart2d.link import CommandRefused, Link, LinkError, firmware, path_stream
from cart2d.link.firmware import ControllerRestarted, ResetWatch
from cart2d.params import robot, setting_id
from cart2d.simulator import SimOptions, Simulator, SimulatorError

Point = tuple[float, float]
Axes = Literal["x", "y", "xy"]

SETTING_NAMES = ("enc_radius_left_m", "enc_radius_right_m", "enc_track_m")
SYSTEMATIC_FAULTS = ("enc_radius_scale_l", "enc_radius_scale_r", "enc_track_error_m")


# -- the arithmetic ---------------------------------------------------------------------------
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


# -- the hand-measured path (a real robot) ----------------------------------------------------
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


class Aborted(RuntimeError):
    """The user quit at a prompt."""


def ask_position(ask: Callable[[str], str], say: Callable[[str], None], prompt: str) -> Point:
    """Asks until the answer parses; 'q' aborts."""
    while True:
        answer = ask(prompt).strip()
        if answer.lower() in ("q", "quit"):
            raise Aborted("calibration aborted at the prompt")
        try:
            return parse_position_mm(answer)
        except ValueError as exc:
            say(f"  {exc}")


# -- driving the squares -----------------------------------------------------------------------
class RunError(RuntimeError):
    """A run did not end on its last corner."""


class Runner(Protocol):
    def drive(self, clockwise: bool, label: str, watch: ResetWatch | None = None) -> Point:
        """Drives one square; returns its return error (true minus odometry, m, start frame).
        With a watch, a restart of the MCU raises ControllerRestarted."""
        ...


def _wait_arrived(
    link: Link, expired: Callable[[], bool], poll_s: float, watch: ResetWatch | None = None
) -> None:
    status = firmware.wait_path_end(link, expired, poll_s, watch)
    if status is None:
        raise RunError("the square took too long: stopped")
    if status.path_outcome():
        raise RunError(f"the cart stopped before the corner ({', '.join(status.flags) or 'STOP'})")


def _wrap(angle: float) -> float:
    return math.remainder(angle, 2.0 * math.pi)


def turn_on_the_spot(
    link: Link,
    heading_rad: float,
    expired: Callable[[], bool],
    omega_max: float = 1.0,
    tolerance_rad: float = math.radians(0.3),
) -> None:
    """Turns to an odometry heading without moving (VELOCITY with v = 0, slowing down as the
    heading comes near), then STOP. The path follower cannot be asked for this: from a stop at
    a corner, the next corner lies 90 degrees off, and a few millimetres past the corner it
    counts as behind the cart, which then reverses down the side instead of turning."""
    while True:
        error = _wrap(heading_rad - link.call("POSE")[2])
        if abs(error) < tolerance_rad:
            break
        if expired():
            raise RunError("the turn took too long: stopped")
        omega = math.copysign(min(omega_max, max(0.05, 2.0 * abs(error))), error)
        link.call("VELOCITY", 0.0, omega)
    link.call("STOP")


def drive_square(
    link: Link,
    side_m: float,
    clockwise: bool,
    expired: Callable[[], bool],
    poll_s: float,
    watch: ResetWatch | None = None,
) -> Point:
    """From wherever the cart is: pose := (0, 0, 0); then each side is a one-point path
    (WAIT_XY_ARRAY) that ends stopped on its corner, and each corner a 90 degree turn on the spot
    (right for CW). Returns where the odometry ends (x, y). With a watch, STATUS is checked
    for a restart of the MCU before the run, at every corner and at the end (a restart loses the
    path and the settings not saved, and the pose may be wrong): ControllerRestarted."""

    def check() -> None:
        if watch is not None:
            watch.read(link)

    check()
    omega_max = min(1.0, 0.9 * link.call("MAX_SPEED_GET")[1])  # VELOCITY refuses more than w_max
    link.call("SET_POSE", 0.0, 0.0, 0.0)
    turn = -math.pi / 2 if clockwise else math.pi / 2
    try:
        for k, corner in enumerate(square_corners(side_m, clockwise)):
            if k:
                turn_on_the_spot(link, k * turn, expired, omega_max)
                check()
            path_stream.upload_path(link, [corner])
            _wait_arrived(link, expired, poll_s, watch)
        x, y, _ = link.call("POSE")
        check()
    except BaseException:  # Ctrl-C included: never leave the cart driving
        with contextlib.suppress(LinkError):
            link.call("STOP")
        raise
    return (x, y)


@dataclass
class SimRunner:
    """Runs in the simulator: placed at the start corner every time, judged by ground truth."""

    sim: Simulator
    link: Link
    side_m: float
    start_ccw: Point
    start_cw: Point

    def drive(self, clockwise: bool, label: str, watch: ResetWatch | None = None) -> Point:
        sx, sy = self.start_cw if clockwise else self.start_ccw
        self.sim.control("place", x=sx, y=sy, theta=0.0)
        start = self.sim.truth()
        deadline_t = start["t"] + 60.0 + 10.0 * self.side_m / 0.1
        expired = lambda: self.sim.truth()["t"] > deadline_t  # noqa: E731
        drive_square(self.link, self.side_m, clockwise, expired, 0.01, watch)
        side = self.sim.side
        assert side is not None
        side.wait_truth(lambda t: abs(t["v"]) < 1e-4 and abs(t["omega"]) < 1e-3, 30.0)  # at rest
        x_odo, y_odo, _ = self.link.call("POSE")
        end = self.sim.truth()
        c, s = math.cos(start["theta"]), math.sin(start["theta"])
        dx, dy = end["x"] - start["x"], end["y"] - start["y"]
        return (c * dx + s * dy - x_odo, -s * dx + c * dy - y_odo)


@dataclass
class SerialRunner:
    """Runs on a robot: the user places it and measures where it stopped."""

    link: Link
    side_m: float
    ask: Callable[[str], str] = input
    say: Callable[[str], None] = print
    timeout_s: float = 300.0

    def drive(self, clockwise: bool, label: str, watch: ResetWatch | None = None) -> Point:
        turn = "right" if clockwise else "left"
        answer = self.ask(
            f"{label}: put the cart on the start mark, facing along the first side "
            f"(it will turn {turn}); Enter drives, q quits: "
        )
        if answer.strip().lower() in ("q", "quit"):
            raise Aborted("calibration aborted at the prompt")
        t_end = time.monotonic() + self.timeout_s
        expired = lambda: time.monotonic() > t_end  # noqa: E731
        x_odo, y_odo = drive_square(self.link, self.side_m, clockwise, expired, 0.1, watch)
        self.say(f"  stopped; the odometry puts the cart at x {x_odo * 1e3:+.1f} mm, y {y_odo * 1e3:+.1f} mm")
        x, y = ask_position(
            self.ask,
            self.say,
            "  where is the wheel-axis centre now, relative to the start mark "
            "(x forward along the first side, y left; mm, e.g. 12 -3)? ",
        )
        return (x - x_odo, y - y_odo)


# -- the calibration --------------------------------------------------------------------------
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


def setting_ids() -> tuple[int, int, int]:
    left, right, track = (setting_id(name) for name in SETTING_NAMES)
    return left, right, track


def read_geometry(link: Link) -> Geometry:
    left, right, track = (firmware.read_setting(link, i) for i in setting_ids())
    return Geometry(left, right, track)


def write_geometry(link: Link, geometry: Geometry) -> Geometry:
    """PARAM_SET of the three values (RAM only); returns what the firmware keeps (float32)."""
    values = (geometry.radius_left_m, geometry.radius_right_m, geometry.track_m)
    kept = [firmware.write_setting(link, i, v) for i, v in zip(setting_ids(), values, strict=True)]
    return Geometry(*kept)


def save_settings(link: Link, timeout_s: float = 10.0) -> None:
    """SAVE, then wait until the firmware has written the EEPROM."""
    link.call("SAVE")
    deadline = time.monotonic() + timeout_s
    while firmware.read_status(link).eeprom_busy:
        if time.monotonic() > deadline:
            raise LinkError("the EEPROM write did not finish")
        time.sleep(0.02)


def measure(
    runner: Runner,
    geometry: Geometry,
    runs: int,
    say: Callable[[str], None],
    title: str,
    watch: ResetWatch | None = None,
) -> Measurement:
    """n runs each way, alternating CW and CCW."""
    m = Measurement(geometry)
    for i in range(runs):
        for clockwise, points in ((True, m.cw), (False, m.ccw)):
            label = f"{title}, {'CW' if clockwise else 'CCW'} run {i + 1}/{runs}"
            error = runner.drive(clockwise, label, watch)
            points.append(error)
            say(f"{label}: return error x {error[0] * 1e3:+7.1f} mm, y {error[1] * 1e3:+7.1f} mm")
    return m


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


def calibrate(
    runner: Runner,
    link: Link,
    side_m: float,
    runs: int,
    passes: int,
    verify: bool,
    say: Callable[[str], None] = print,
    axes: Axes = "xy",
    refine_runs: int | None = None,
    watch: ResetWatch | None = None,
) -> Calibration:
    """UMBmark passes, each followed by PARAM_SET of the corrected geometry; then, if asked, a
    last pass with the final values (with passes = 0: only that, a measurement). Passes after
    the first may use fewer runs (`refine_runs`). Nothing is saved here. A restart of the MCU
    at any point (the watch's baseline, else the first STATUS here, onwards) stops it with
    RunError: it ruins the run it happens in and loses the geometry set in RAM."""
    watch = watch or ResetWatch(firmware.read_status(link))
    try:
        return _calibrate(runner, link, side_m, runs, passes, verify, say, axes, refine_runs, watch)
    except ControllerRestarted as exc:
        raise RunError(ruined(exc)) from exc


def ruined(exc: ControllerRestarted) -> str:
    return (
        f"{exc}. That ruins the calibration: the run it happened in lost its path and maybe its pose, "
        "and the wheel geometry set since the last SAVE is gone; calibration stopped, nothing saved"
    )


def check_not_restarted(watch: ResetWatch, link: Link) -> None:
    """RunError if the MCU restarted since the watch last looked (before a SAVE)."""
    try:
        watch.read(link)
    except ControllerRestarted as exc:
        raise RunError(ruined(exc)) from exc


def _calibrate(
    runner: Runner,
    link: Link,
    side_m: float,
    runs: int,
    passes: int,
    verify: bool,
    say: Callable[[str], None],
    axes: Axes,
    refine_runs: int | None,
    watch: ResetWatch,
) -> Calibration:
    before = geometry = read_geometry(link)
    done: list[tuple[Measurement, Corrections]] = []
    for k in range(passes):
        n = runs if k == 0 or refine_runs is None else refine_runs
        m = measure(runner, geometry, n, say, f"pass {k + 1}/{passes}", watch)
        c = umbmark_corrections(m.cw, m.ccw, side_m, geometry, axes)
        say(
            f"pass {k + 1}: E_max,syst {m.e_max_syst_m() * 1e3:.1f} mm; "
            f"alpha {math.degrees(c.alpha_rad):+.3f} deg, beta {math.degrees(c.beta_rad):+.3f} deg "
            f"-> E_d {c.e_d:.5f}, E_b {c.e_b:.5f}"
        )
        geometry = write_geometry(link, c.geometry)
        say(f"  odometry now: {geometry.text()}")
        done.append((m, c))
    result = Calibration(side_m, before, geometry, done)
    if verify:
        result.verification = measure(runner, geometry, runs, say, "check" if passes else "UMBmark", watch)
    watch.read(link)
    return result


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


def calibrate_in_sim(
    faults: dict[str, float],
    side_m: float = 2.0,
    runs: int = 5,
    passes: int = 2,
    verify: bool = True,
    save: bool = True,
    eeprom: Path | None = None,
    speed: str = "max",
    seed: int = 1,
    say: Callable[[str], None] = print,
    refine_runs: int | None = None,
) -> Calibration:
    """UMBmark calibration in a simulator of its own, with these faults, judged by ground truth.
    The new values are saved (SAVE) unless the check found them worse than the old ones, which
    are then restored."""
    grid, start_ccw, start_cw = sim_layout(side_m)
    with tempfile.TemporaryDirectory() as tmp:
        options = SimOptions(
            speed=speed,
            seed=seed,
            eeprom=eeprom or Path(tmp) / "eeprom.bin",
            grid=grid,
            start=(*start_ccw, 0.0),
            quiet=True,
        )
        with Simulator(options) as sim, Link(sim.pty) as link:
            firmware.check_compatible(firmware.wait_for_version(link))
            if faults:
                sim.control("faults", **faults)
            runner = SimRunner(sim, link, side_m, start_ccw, start_cw)
            watch = ResetWatch(firmware.read_status(link))
            result = calibrate(
                runner, link, side_m, runs, passes, verify, say, refine_runs=refine_runs, watch=watch
            )
            result.truth, result.faults = true_geometry(faults), dict(faults)
            after = result.e_max_after_m()
            if after is not None and after > result.e_max_before_m():
                say("the check found the new values worse than the old: not saved, the old ones restored")
                write_geometry(link, result.before)
            elif save and passes:
                check_not_restarted(watch, link)
                save_settings(link)
                result.saved = True
    return result


# -- the command -------------------------------------------------------------------------------
def add_arguments(parser: argparse.ArgumentParser) -> None:
    where = parser.add_mutually_exclusive_group(required=True)
    where.add_argument("--sim", action="store_true", help="in the simulator, judged by ground truth")
    where.add_argument("--serial", metavar="PORT", help="a real cart; you measure where each run ends")
    parser.add_argument("--baud", type=int, default=115200)
    parser.add_argument("--side", type=float, default=2.0, help="side of the square, m (default 2)")
    parser.add_argument("--runs", type=int, default=5, help="runs each way per pass (default 5)")
    parser.add_argument(
        "--passes", type=int, help="passes, each correcting the last (default: 2 sim, 1 cart)"
    )
    parser.add_argument(
        "--no-check", action="store_true", help="sim: skip the last UMBmark with the new values"
    )
    parser.add_argument("--no-save", action="store_true", help="leave the new values in RAM (no SAVE)")
    parser.add_argument("--report", type=Path, help="write the numbers to this JSON file")
    sim = parser.add_argument_group("simulation")
    sim.add_argument("--eeprom", type=Path, help="the simulator's EEPROM file (default: a temporary one)")
    sim.add_argument("--faults", default="{}", help="simulator faults, JSON: sim/README.md")
    for key in SYSTEMATIC_FAULTS:
        sim.add_argument(f"--{key.replace('_', '-')}", type=float, dest=key, help=f"fault {key}")
    sim.add_argument(
        "--speed", type=cli_args.speed, default="max", help="simulated seconds per second, or 'max' (default)"
    )
    sim.add_argument("--seed", type=cli_args.seed, default=1)


def sim_faults(args: argparse.Namespace) -> dict[str, float]:
    """The faults of --faults and the fault options, checked (ValueError: every problem)."""
    try:
        faults = json.loads(args.faults)
    except json.JSONDecodeError as exc:
        raise ValueError(f"--faults is not JSON: {exc}") from None
    if not isinstance(faults, dict):
        raise ValueError('--faults takes a JSON object, such as {"enc_slip_l": 0.02}')
    for key in SYSTEMATIC_FAULTS:
        if getattr(args, key, None) is not None:
            faults[key] = getattr(args, key)
    problems = fault_table.problems(faults)
    if problems:
        raise ValueError("; ".join(problems))
    return faults


def saved_words(args: argparse.Namespace, saved: bool) -> str:
    """Where the new values went, in words."""
    if not saved:
        return "not saved: the values last set stay in RAM until a reset"
    if not args.sim:
        return "saved to EEPROM"
    if args.eeprom is None:
        return (
            "saved to the simulated EEPROM, a temporary file deleted with the simulator: nothing is kept "
            "(--eeprom FILE keeps it)"
        )
    return f"saved to the simulated EEPROM, kept in {args.eeprom}"


def _print_summary(result: Calibration, say: Callable[[str], None]) -> None:
    say(f"before: {result.before.text()}")
    say(f"after:  {result.after.text()}")
    if result.truth is not None:
        identified = result.identified_errors()
        assert identified is not None
        say(
            f"simulator truth: {result.truth.text()}; found r_R/r_L within {identified[0] * 1e6:+.0f} ppm, "
            f"track/mean radius within {identified[1] * 1e6:+.0f} ppm"
        )
    before = result.e_max_before_m()
    after = result.e_max_after_m()
    line = f"E_max,syst before {before * 1e3:.1f} mm"
    if after is not None:
        line += f", after {after * 1e3:.2f} mm ({before / max(after, 1e-12):.0f}x smaller)"
    say(line)


def _run_serial(args: argparse.Namespace, passes: int, say: Callable[[str], None]) -> Calibration:
    with Link(args.serial, args.baud) as link:
        firmware.check_compatible(firmware.wait_for_version(link))
        runner = SerialRunner(link, args.side, say=say)
        say(
            f"UMBmark: a {args.side:g} m square; per pass, {args.runs} run(s) clockwise and "
            f"{args.runs} counter-clockwise; {passes} pass(es). Mark the start: the wheel-axis centre "
            "and the heading. Run this again afterwards to see the new values' errors."
        )
        watch = ResetWatch(firmware.read_status(link))
        result = calibrate(runner, link, args.side, args.runs, passes, verify=False, say=say, watch=watch)
        if not args.no_save:
            check_not_restarted(watch, link)
            save_settings(link)
            result.saved = True
    return result


def option_problems(args: argparse.Namespace) -> tuple[dict[str, float], list[str]]:
    """The simulator's faults, and one line per bad option value (checked before anything runs)."""
    problems, faults = [], {}
    if not 0.2 <= args.side <= 20.0 or args.runs < 1 or (args.passes is not None and args.passes < 1):
        problems.append("--side from 0.2 to 20 m, --runs and --passes at least 1")
    if args.sim:
        try:
            faults = sim_faults(args)
        except ValueError as exc:
            problems.append(str(exc))
    if args.report is not None and not args.report.parent.is_dir():
        problems.append(f"--report {args.report}: its folder does not exist")
    return faults, problems


def main_calibrate(args: argparse.Namespace, say: Callable[[str], None] = print) -> int:
    """The `cart2d calibrate` command; exit status 2 for bad option values (nothing run), 1 if it
    failed or made things worse."""
    faults, problems = option_problems(args)
    for problem in problems:
        print(f"cart2d calibrate: {problem}", file=sys.stderr)
    if problems:
        return 2
    passes = args.passes if args.passes is not None else (2 if args.sim else 1)
    try:
        if args.sim:
            result = calibrate_in_sim(
                faults,
                args.side,
                args.runs,
                passes,
                verify=not args.no_check,
                save=not args.no_save,
                eeprom=args.eeprom,
                speed=args.speed,
                seed=args.seed,
                say=say,
            )
        else:
            result = _run_serial(args, passes, say)
    except (LinkError, CommandRefused, SimulatorError, RunError, Aborted, ValueError, OSError) as exc:
        print(f"cart2d calibrate: {exc}", file=sys.stderr)
        return 1
    _print_summary(result, say)
    say(saved_words(args, result.saved))
    if args.report is not None:
        args.report.write_text(json.dumps(result.as_dict(), indent=2) + "\n")
    after = result.e_max_after_m()
    return 0 if after is None or after <= result.e_max_before_m() else 1

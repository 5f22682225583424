"""Driving UMBmark's squares: on a cart (SerialRunner: the user places it and measures where it
stopped) or in the simulator (SimRunner: placed at the start, judged by ground truth).

The square is driven as UMBmark asks: each side a one-point path (WAIT_XY_ARRAY) that stops on
its corner, each corner a turn on the spot (VELOCITY with v = 0 until the odometry's heading is
90 degrees on; see turn_on_the_spot). In the simulator (`--sim`) the cart is placed at the start
for every run and the ground truth gives the error; on a robot (`--serial PORT`) the user puts
the cart back on the start mark and types where it ended.
"""

from __future__ import annotations

import contextlib
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

from cart2d.link import Link, LinkError, firmware, path_stream
from cart2d.link.firmware import ResetWatch
from cart2d.simulation.simulator import Simulator
from cart2d.tools.umbmark.arithmetic import Point, parse_position_mm, square_corners


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

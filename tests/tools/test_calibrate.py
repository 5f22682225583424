"""Odometry calibration (UMBmark, cart2d/tools/umbmark/): the arithmetic against a hand-computed
case and against a simple odometry model, the hand-measurement prompts with fake input, the
robot path with a fake link, and the whole command in the simulator judged by ground truth."""

from __future__ import annotations

import json
import math
import random
from collections.abc import Sequence
from pathlib import Path

import pytest

from cart2d.link import Link, Priority
from cart2d.link.firmware import ResetWatch
from cart2d.spec import load_spec
from cart2d.tools.cli import main
from cart2d.tools.umbmark.arithmetic import (
    Geometry,
    centroid,
    e_max_syst,
    parse_position_mm,
    sim_layout,
    square_corners,
    umbmark_corrections,
)
from cart2d.tools.umbmark.procedure import Schedule, calibrate, setting_ids
from cart2d.tools.umbmark.runners import Aborted, SerialRunner
from tests.support.sim import start_sim

NOMINAL = Geometry(0.021, 0.021, 0.305)
Point = tuple[float, float]


def end_error(side_m: float, clockwise: bool, true: Geometry, odometry: Geometry) -> Point:
    """The simple model: the odometry drives an exact square (straight sides, 90 degree turns
    on the spot) by its own geometry, while each wheel really rolls its count times its true
    radius and the body turns by the true track; both move on exact arcs. The odometry ends on
    the start, so the return error (true minus odometry) is where the cart really ends."""
    x = y = theta = 0.0

    def move(odo_left_m: float, odo_right_m: float) -> None:
        nonlocal x, y, theta
        left = odo_left_m * true.radius_left_m / odometry.radius_left_m
        right = odo_right_m * true.radius_right_m / odometry.radius_right_m
        ds, dtheta = 0.5 * (left + right), (right - left) / true.track_m
        if abs(dtheta) < 1e-12:
            x, y = x + ds * math.cos(theta), y + ds * math.sin(theta)
        else:
            r = ds / dtheta
            x += r * (math.sin(theta + dtheta) - math.sin(theta))
            y -= r * (math.cos(theta + dtheta) - math.cos(theta))
        theta += dtheta

    turn = -1.0 if clockwise else 1.0
    quarter = odometry.track_m * math.pi / 4  # each wheel's arc for 90 degrees, as the odometry sees it
    for k in range(4):
        move(side_m, side_m)
        if k < 3:
            move(-turn * quarter, turn * quarter)
    return (x, y)


def true_geometry(e_d: float, e_b: float, odometry: Geometry = NOMINAL) -> Geometry:
    """Wheels whose diameter ratio D_R/D_L is e_d (mean kept) and a wheelbase e_b times longer."""
    return Geometry(
        odometry.radius_left_m * 2 / (e_d + 1),
        odometry.radius_right_m * 2 / (1 / e_d + 1),
        odometry.track_m * e_b,
    )


# -- the arithmetic ---------------------------------------------------------------------------
def test_a_hand_computed_case() -> None:
    # L = 2 m, b = 0.3 m; corners 0.01 rad short (alpha), sides bent 0.02 rad left (beta).
    # First order: CCW error = 2L(beta - alpha)(1, -1) = (0.04, -0.04),
    #              CW error = -2L(beta + alpha)(1, 1) = (-0.12, -0.12); two runs each way around them.
    cw = [(-0.11, -0.125), (-0.13, -0.115)]
    ccw = [(0.045, -0.03), (0.035, -0.05)]
    c = umbmark_corrections(cw, ccw, 2.0, Geometry(0.021, 0.021, 0.3))
    assert centroid(cw) == pytest.approx((-0.12, -0.12))
    assert centroid(ccw) == pytest.approx((0.04, -0.04))
    # alpha = -(x_cw + x_ccw)/4L = 0.08/8; beta = (x_ccw - x_cw)/4L = 0.16/8 (and the same from y)
    assert c.alpha_rad == pytest.approx(0.01)
    assert c.beta_rad == pytest.approx(0.02)
    # R = (L/2)/sin(beta/2) = 1/0.0099998333 = 100.0017 m
    assert c.radius_m == pytest.approx(100.0017, abs=1e-4)
    # E_d = (R + b/2)/(R - b/2) = 100.1517/99.8517; E_b = 90/(90 - 0.5730 deg)
    assert c.e_d == pytest.approx(1.0030045, abs=1e-7)
    assert c.e_b == pytest.approx(1.0064070, abs=1e-7)
    # r_L * 2/(E_d + 1), r_R * 2/(1/E_d + 1), E_b * b
    assert c.geometry.radius_left_m == pytest.approx(0.02096850, abs=1e-8)
    assert c.geometry.radius_right_m == pytest.approx(0.02103150, abs=1e-8)
    assert c.geometry.track_m == pytest.approx(0.3019221, abs=1e-7)
    # E_max,syst: the CW centroid, 0.12 * sqrt(2)
    assert e_max_syst(cw, ccw) == pytest.approx(0.169706, abs=1e-6)
    # Borenstein's x equations and the y equations agree on first-order data.
    for axes in ("x", "y"):
        one = umbmark_corrections(cw, ccw, 2.0, Geometry(0.021, 0.021, 0.3), axes)
        assert (one.alpha_rad, one.beta_rad) == pytest.approx((0.01, 0.02))


def test_no_error_changes_nothing() -> None:
    c = umbmark_corrections([(0.0, 0.0)], [(0.0, 0.0)], 2.0, NOMINAL)
    assert (c.e_d, c.e_b, c.radius_m) == (1.0, 1.0, math.inf)
    assert c.geometry == NOMINAL


def test_signs_in_our_frame() -> None:
    """x forward, y left, theta counter-clockwise: a cart that turns too little has a longer
    wheelbase than its odometry thinks; one whose sides bend left has the larger right wheel."""
    wide = true_geometry(1.0, 1.02)
    c = umbmark_corrections(
        [end_error(2, True, wide, NOMINAL)], [end_error(2, False, wide, NOMINAL)], 2, NOMINAL
    )
    assert c.alpha_rad > 0 and c.e_b > 1 and c.geometry.track_m > NOMINAL.track_m
    big_right = true_geometry(1.01, 1.0)
    c = umbmark_corrections(
        [end_error(2, True, big_right, NOMINAL)], [end_error(2, False, big_right, NOMINAL)], 2, NOMINAL
    )
    assert c.beta_rad > 0 and c.e_d > 1
    assert c.geometry.radius_right_m > NOMINAL.radius_right_m > c.geometry.radius_left_m


def test_the_model_s_errors_are_recovered() -> None:
    """Property: end points from the odometry model with known E_d and E_b give them back, to
    first order: what is left is of second order in the errors (heading errors of up to ~0.3 rad
    accumulate over a 2 m square with 1 % errors), and the next pass removes it."""
    rng = random.Random(6)
    for _ in range(100):
        e_d, e_b = 1 + rng.uniform(-0.01, 0.01), 1 + rng.uniform(-0.01, 0.01)
        side = rng.choice([1.0, 1.6, 2.0])
        true = true_geometry(e_d, e_b)
        c = umbmark_corrections(
            [end_error(side, True, true, NOMINAL)], [end_error(side, False, true, NOMINAL)], side, NOMINAL
        )
        size = abs(e_d - 1) + abs(e_b - 1)
        assert abs(c.e_d - e_d) <= 0.02 * size and abs(c.e_b - e_b) <= 0.15 * size


def test_passes_converge_on_the_model() -> None:
    """Property: each pass feeds the corrected geometry back; the return errors shrink by orders
    of magnitude per pass, and the geometry converges on the true one."""
    rng = random.Random(7)
    for _ in range(20):
        true = true_geometry(1 + rng.uniform(-0.02, 0.02), 1 + rng.uniform(-0.02, 0.02))
        odometry, errors = NOMINAL, []
        for _ in range(3):
            cw, ccw = end_error(2, True, true, odometry), end_error(2, False, true, odometry)
            c = umbmark_corrections([cw], [ccw], 2, odometry)
            errors.append(e_max_syst([cw], [ccw]))
            odometry = c.geometry
        assert errors[1] < errors[0] / 8 and errors[2] < errors[0] / 1000
        assert odometry.radius_left_m == pytest.approx(true.radius_left_m, rel=1e-4)
        assert odometry.radius_right_m == pytest.approx(true.radius_right_m, rel=1e-4)
        assert odometry.track_m == pytest.approx(true.track_m, rel=1e-4)


def test_nonsense_is_refused() -> None:
    with pytest.raises(ValueError, match="no end points"):
        umbmark_corrections([], [(0.0, 0.0)], 2.0, NOMINAL)
    with pytest.raises(ValueError, match="too far off"):
        umbmark_corrections([(-10.0, 0.0)], [(-10.0, 0.0)], 2.0, NOMINAL)  # alpha ~ 72 degrees
    with pytest.raises(ValueError, match="positive"):
        umbmark_corrections([(0.0, 0.0)], [(0.0, 0.0)], 0.0, NOMINAL)


def test_the_square_turns_right_when_clockwise() -> None:
    for clockwise in (True, False):
        points = [(0.0, 0.0), *square_corners(1.5, clockwise)]
        assert points[-1] == (0.0, 0.0) and points[1] == (1.5, 0.0)
        for a, b, c in zip(points, points[1:], points[2:], strict=False):
            cross = (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0])
            assert (cross < 0) == clockwise


def test_the_simulated_arena_holds_both_squares() -> None:
    for side in (1.0, 2.0, 3.0):
        (nodes, step), ccw, cw = sim_layout(side)
        size = (nodes - 1) * step
        for (x, y), clockwise in ((ccw, False), (cw, True)):
            for cx, cy in square_corners(side, clockwise):
                assert 0.99 <= x + cx <= size - 0.99 and 0.99 <= y + cy <= size - 0.99


# -- hand measurements ------------------------------------------------------------------------
def test_typed_positions_parse_as_millimetres() -> None:
    assert parse_position_mm("12.5, -3") == pytest.approx((0.0125, -0.003))
    assert parse_position_mm("  12.5   -3 ") == pytest.approx((0.0125, -0.003))
    assert parse_position_mm("-1e1;2") == pytest.approx((-0.01, 0.002))
    for bad in ("", "12", "1 2 3", "a b", "nan 1", "1 inf", "20000 0"):
        with pytest.raises(ValueError):
            parse_position_mm(bad)


class Answers:
    """Fake input(): hands out the answers in order and records the prompts."""

    def __init__(self, answers: Sequence[str]) -> None:
        self.answers = list(answers)
        self.prompts: list[str] = []

    def __call__(self, prompt: str) -> str:
        self.prompts.append(prompt)
        return self.answers.pop(0)


class FakeCart(Link):
    """A Link whose firmware is a few lines: paths end exactly on their point (plus a fixed
    offset, as a stop within tolerance does), VELOCITY turns by omega * 0.1 s, settings are kept."""

    def __init__(self, stop_offset: Point = (0.0, 0.0)) -> None:
        super().__init__("fake")
        self.pose = [0.0, 0.0, 0.0]
        self.stop_offset = stop_offset
        self.settings = dict(zip(setting_ids(), (0.021, 0.021, 0.305), strict=True))
        self.commands: list[str] = []

    def call(
        self,
        command: str | int,
        *args: float,
        timeout_s: float | None = None,
        priority: Priority = Priority.COMMAND,
        token: int | None = None,
    ) -> tuple[float, ...]:
        name = str(command)
        self.commands.append(name)
        if name == "SET_POSE":
            self.pose = list(args)
        elif name == "WAIT_XY_ARRAY":
            self.pose[0], self.pose[1] = args[1] + self.stop_offset[0], args[2] + self.stop_offset[1]
            return (args[0], 0.0, 0.0)  # received (a whole one-point path), index, room
        elif name == "VELOCITY":
            self.pose[2] += 0.1 * args[1]
        elif name == "POSE":
            return tuple(self.pose)
        elif name == "STATUS":
            return (0.0, float(load_spec().flags["ARRIVED"]), *[0.0] * 14)  # IDLE, arrived
        elif name == "MAX_SPEED_GET":
            return (0.5, math.pi)
        elif name == "PARAM_GET":
            return (args[0], self.settings[int(args[0])], 0.0, 1.0)
        elif name == "PARAM_SET":
            self.settings[int(args[0])] = args[1]
            return args
        return ()


def test_a_cart_calibrated_from_typed_measurements() -> None:
    """The --serial path: the cart drives each square, the user types where it stopped (mm,
    relative to the start mark), the odometry's own end point is subtracted, and the pass
    writes the corrected geometry with PARAM_SET."""
    true = true_geometry(0.995, 1.01)
    cw, ccw = end_error(1.6, True, true, NOMINAL), end_error(1.6, False, true, NOMINAL)
    cart = FakeCart(stop_offset=(0.002, -0.001))  # the odometry ends 2 mm ahead, 1 mm right

    def typed(error: Point) -> str:  # what the user measures: the odometry's end plus the error
        return f"{(error[0] + 0.002) * 1000:.2f}, {(error[1] - 0.001) * 1000:.2f}"

    answers = Answers(["", "oops", typed(cw), "", typed(ccw), "", typed(cw), "", typed(ccw)])
    said: list[str] = []
    runner = SerialRunner(cart, 1.6, ask=answers, say=said.append)
    result = calibrate(runner, cart, Schedule(1.6, runs=2, passes=1, verify=False), said.append)

    assert not answers.answers
    assert "turn right" in answers.prompts[0] and "turn left" in answers.prompts[3]
    assert any("two numbers" in line for line in said)  # "oops" was asked again
    m, c = result.passes[0]
    assert m.cw[0] == pytest.approx(cw, abs=1e-5) and m.ccw[1] == pytest.approx(ccw, abs=1e-5)
    assert c.e_d == pytest.approx(0.995, abs=2e-4) and c.e_b == pytest.approx(1.01, abs=2e-3)
    left, right, track = (cart.settings[i] for i in setting_ids())
    assert (left, right, track) == (
        result.after.radius_left_m,
        result.after.radius_right_m,
        result.after.track_m,
    )
    assert right < 0.021 < left and track > 0.305
    # Every corner was a turn on the spot (VELOCITY) followed by a one-point path.
    assert cart.commands.count("WAIT_XY_ARRAY") == 4 * 4 and "STOP" in cart.commands


class ModelRunner:
    """Runs by the simple model (end_error) of a cart whose true geometry is `true`, for the
    geometry the fake cart's odometry has at the moment; counts the runs each way."""

    def __init__(self, cart: FakeCart, side_m: float, true: Geometry) -> None:
        self.cart, self.side_m, self.true = cart, side_m, true
        self.runs: list[str] = []

    def drive(self, clockwise: bool, label: str, watch: ResetWatch | None = None) -> Point:
        left, right, track = (self.cart.settings[i] for i in setting_ids())
        self.runs.append(label)
        return end_error(self.side_m, clockwise, self.true, Geometry(left, right, track))


def test_a_schedule_sets_the_runs_of_each_pass_and_the_check() -> None:
    """Schedule: `runs` each way in the first pass, `refine_runs` in the later ones, `runs` again
    in the check; the side and the axes reach the arithmetic (a wrong side leaves E_d off)."""
    true = true_geometry(0.995, 1.01)
    cart = FakeCart()
    runner = ModelRunner(cart, 1.6, true)
    schedule = Schedule(side_m=1.6, runs=3, passes=2, verify=True, axes="y", refine_runs=1)
    result = calibrate(runner, cart, schedule, say=lambda _: None)

    per_pass = [sum(label.startswith(f"pass {k}/2") for label in runner.runs) for k in (1, 2)]
    assert per_pass == [6, 2]
    assert sum(label.startswith("check") for label in runner.runs) == 6
    assert [len(m.cw) for m, _ in result.passes] == [3, 1]
    assert result.verification is not None and len(result.verification.ccw) == 3
    assert result.side_m == 1.6
    first = result.passes[0][1]
    assert first == umbmark_corrections(result.passes[0][0].cw, result.passes[0][0].ccw, 1.6, NOMINAL, "y")
    assert first.e_d == pytest.approx(0.995, abs=5e-4)  # y equations alone: first order
    after = result.e_max_after_m()
    assert after is not None and after < 0.1 * result.e_max_before_m()
    assert Schedule(runs=5, refine_runs=2).runs_in_pass(0) == 5
    assert Schedule(runs=5).runs_in_pass(1) == 5


def test_q_at_a_prompt_aborts() -> None:
    cart = FakeCart()
    runner = SerialRunner(cart, 1.0, ask=Answers(["", "q"]), say=lambda _: None)
    with pytest.raises(Aborted):
        runner.drive(True, "run")
    with pytest.raises(Aborted):
        SerialRunner(cart, 1.0, ask=Answers(["q"]), say=lambda _: None).drive(False, "run")


def test_the_command_refuses_bad_numbers(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["calibrate", "--sim", "--side", "0.1"]) == 2
    assert main(["calibrate", "--serial", "/dev/null", "--runs", "0"]) == 2
    assert "--side from 0.2 to 20 m" in capsys.readouterr().err
    for bad, words in [
        (["--faults", "[1]"], "JSON object"),
        (["--faults", "{not json"], "not JSON"),
        (["--faults", '{"enc_slip_l": 9}'], "enc_slip_l"),
        (["--enc-track-error-m", "9"], "enc_track_error_m"),
        (["--report", "/nonexistent/r.json"], "folder does not exist"),
    ]:
        assert main(["calibrate", "--sim", *bad]) == 2, bad  # bad option values: 2, as elsewhere
        assert words in capsys.readouterr().err


# -- in the simulator -------------------------------------------------------------------------
def test_calibration_in_the_simulator_removes_the_systematic_error(tmp_path: Path) -> None:
    """`cart2d calibrate --sim` with wrong wheel radii and track: the UMBmark error shrinks
    at least 5x, and the corrected settings are in the EEPROM after a simulator restart."""
    report = tmp_path / "report.json"
    code = main(
        [
            "calibrate",
            "--sim",
            "--enc-radius-scale-l=1.01",
            "--enc-radius-scale-r=0.995",
            "--enc-track-error-m=0.006",
            "--runs=1",
            f"--eeprom={tmp_path / 'eeprom.bin'}",
            f"--report={report}",
        ]
    )
    assert code == 0
    r = json.loads(report.read_text())
    assert r["saved"] and len(r["passes"]) == 2
    assert r["e_max_syst_before_m"] > 0.2  # the faults are large: the cart ends far from home
    assert r["e_max_syst_after_m"] * 5 <= r["e_max_syst_before_m"]
    # What UMBmark can identify, against the simulator's truth: r_R/r_L and track/mean radius.
    assert abs(r["ratio_error"]) < 1e-3 and abs(r["track_per_radius_error"]) < 1e-3

    sim = start_sim(tmp_path)  # the same EEPROM file
    try:
        with Link(sim.pty) as link:
            stored = [link.call("PARAM_GET", i)[1] for i in setting_ids()]
            assert link.call("STATUS")[8] == 0.0  # settings from the EEPROM
    finally:
        sim.stop()
    after = r["after"]
    assert stored == [after["radius_left_m"], after["radius_right_m"], after["track_m"]]
    assert stored != [0.021, 0.021, 0.305]

"""## Drivetrain: the firmware against the simulator's traction, backlash and caster physics.

Four manoeuvres with the real firmware in the simulator, each in exact simulated time (the
simulator starts paused; a command is written, then `run` advances a fixed span), ground truth
sampled at every physics step (4 kHz):

- **turn on the spot**: VELOCITY (0, 3 rad/s) from rest for 1.5 s, then VELOCITY (0, 0) for 1 s:
  the overshoot of the true yaw rate over 3 rad/s, the time to 90 %, how far the heading runs on
  after the stop command, and how far the axle centre wanders;
- **reversal**: VELOCITY (0.3 m/s, 0) for 1.5 s, then (-0.3 m/s, 0) for 1.5 s: the time from the
  reversal to -0.27 m/s, the largest heading change and yaw rate in the 1.5 s after it (the caster
  swinging round) and the caster angle before and after;
- **pushing a wall**: backing into the west wall (no switch there) with VELOCITY (-0.3 m/s, 0):
  the firmware's PI winds up to full PWM; in the last 0.2 s before the stall guard stops the
  motors, the duty, wheel speed, motor current, body speed and tyre slip, and when the guard tripped;
- **the bench square and circle** (bench/firmware.py's: 1.6 m legs at 0.5 m/s with turns on the
  spot; a 16-gon of radius 0.6 m): how far the tyres slid (the integral of |slip| over time)
  against the distance driven, the peak slip, and the largest sideways force on the tyres.

`python -m bench.drivetrain`; it reports, it has no targets (bench/missions.py holds the missions').
"""

from __future__ import annotations

import itertools
import math
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from bench.common import Section, section_main, table
from bench.firmware import SQUARE, circle_route
from cart2d.link import Link
from cart2d.link.path_stream import upload_path
from cart2d.params import robot
from cart2d.simulation.simulator import SimOptions, Simulator
from cart2d.spec import load_spec

NAME = "drivetrain"
STALLED = load_spec().flags["STALLED"]
TRUTH_HZ = 4000.0  # every physics step
MASS_KG = float(robot()["traction"]["mass_kg"])
Truth = dict[str, Any]


class Recorder:
    """Keeps every ground-truth message the simulator sends."""

    def __init__(self) -> None:
        self.samples: list[Truth] = []
        self._lock = threading.Lock()

    def __call__(self, message: Truth) -> None:
        with self._lock:
            self.samples.append(message)

    def between(self, t0: float, t1: float) -> list[Truth]:
        with self._lock:
            return [s for s in self.samples if t0 <= s["t"] <= t1]


def command_then_run(
    sim: Simulator, link: Link, seconds: float, command: str, *args: float
) -> tuple[float, tuple[float, ...]]:
    """With the simulator paused: sends one command, runs `seconds` of simulated time; returns the
    simulated time the run started at and the command's results. The reply comes while the
    simulator runs, so the request waits in a thread."""
    t0 = float(sim.truth()["t"])
    results: list[tuple[float, ...]] = []
    caller = threading.Thread(target=lambda: results.append(link.call(command, *args, timeout_s=30.0)))
    caller.start()
    time.sleep(0.05)  # the request's bytes are in the pty before the run starts
    sim.run_for(seconds)
    caller.join(timeout=30.0)
    return t0, results[0] if results else ()


def started(tmp: Path, start: tuple[float, float, float]) -> tuple[Simulator, Link, Recorder]:
    sim = Simulator(SimOptions(speed="max", eeprom=tmp / "eeprom.bin", start=start, paused=True, quiet=True))
    sim.start()
    link = Link(sim.pty, timeout_s=2.0).open()
    time.sleep(0.05)  # the simulator has seen the port open: the DTR reset, at t = 0 while paused
    sim.run_for(sim.boot_s() + 0.4)  # the reset's time-out and the boot (through Optiboot)
    recorder = Recorder()
    assert sim.side is not None
    sim.side.subscribe(recorder)
    sim.control("truth_rate", hz=TRUTH_HZ)
    command_then_run(sim, link, 0.1, "SET_POSE", *start)
    command_then_run(sim, link, 0.1, "PARAM_SET", 13, 10.0)  # manual timeout: the runs below are longer
    return sim, link, recorder


def first_time(samples: list[Truth], condition: Callable[[Truth], bool]) -> float:
    return next((float(s["t"]) for s in samples if condition(s)), math.nan)


def slip(s: Truth) -> float:
    """The larger tyre slip of a sample, m/s (0 from a simulator without the field)."""
    return max(abs(float(s.get("slip_l", 0.0))), abs(float(s.get("slip_r", 0.0))))


def slid_mm(samples: list[Truth]) -> float:
    """How far the tyres slid over the floor, both together: the integral of |slip| over time."""
    total = 0.0
    for a, b in itertools.pairwise(samples):
        total += (abs(float(b.get("slip_l", 0.0))) + abs(float(b.get("slip_r", 0.0)))) * (b["t"] - a["t"])
    return 1000.0 * total


def turn_on_the_spot(tmp: Path) -> dict[str, float]:
    sim, link, rec = started(tmp, (0.9, 0.9, 0.0))
    try:
        t_cmd, _ = command_then_run(sim, link, 1.5, "VELOCITY", 0.0, 3.0)
        t_stop, _ = command_then_run(sim, link, 1.0, "VELOCITY", 0.0, 0.0)
        turning = rec.between(t_cmd, t_stop)
        after = rec.between(t_stop, t_stop + 1.0)
        x0, y0 = turning[0]["x"], turning[0]["y"]
        theta_at_stop = after[0]["theta"]
        run_on = max(abs(math.remainder(s["theta"] - theta_at_stop, 2 * math.pi)) for s in after)
        peak = max(s["omega"] for s in turning)
        return {
            "omega peak, rad/s": peak,
            "overshoot, %": 100.0 * (peak / 3.0 - 1.0),
            "to 90 %, s": first_time(turning, lambda s: s["omega"] >= 2.7) - t_cmd,
            "run-on after stop, rad": run_on,
            "centre wander, mm": 1000.0 * max(math.hypot(s["x"] - x0, s["y"] - y0) for s in turning + after),
            "peak slip, m/s": max(slip(s) for s in turning + after),
            "slid, mm": slid_mm(turning + after),
        }
    finally:
        link.close()
        sim.stop()


def reversal(tmp: Path) -> dict[str, float]:
    sim, link, rec = started(tmp, (0.4, 0.9, 0.0))
    try:
        t_fwd, _ = command_then_run(sim, link, 1.5, "VELOCITY", 0.3, 0.0)
        t_rev, _ = command_then_run(sim, link, 1.5, "VELOCITY", -0.3, 0.0)
        command_then_run(sim, link, 0.5, "STOP")
        before = rec.between(t_fwd, t_rev)
        after = rec.between(t_rev, t_rev + 1.5)
        theta0 = before[-1]["theta"]
        return {
            "to -0.27 m/s, s": first_time(after, lambda s: s["v"] <= -0.27) - t_rev,
            "heading change, mrad": 1000.0
            * max(abs(math.remainder(s["theta"] - theta0, 2 * math.pi)) for s in after),
            "yaw rate peak, rad/s": max(abs(s["omega"]) for s in after),
            "caster before, rad": float(before[-1].get("caster", math.nan)),
            "caster after, rad": float(after[-1].get("caster", math.nan)),
            "peak slip, m/s": max(slip(s) for s in after),
            "slid, mm": slid_mm(before + after),
        }
    finally:
        link.close()
        sim.stop()


def push_wall(tmp: Path) -> dict[str, float]:
    sim, link, rec = started(tmp, (0.0, 0.9, 0.0))  # the west wall is 0.08 m behind the footprint
    try:
        t_cmd, _ = command_then_run(sim, link, 3.0, "VELOCITY", -0.3, 0.0)
        _, status = command_then_run(sim, link, 0.1, "STATUS")
        run = rec.between(t_cmd, t_cmd + 3.0)
        t_contact = first_time(run, lambda s: s["in_wall_contact"])
        t_off = first_time(run, lambda s: s["t"] > t_contact and s["duty_l"] == 0.0 and s["duty_r"] == 0.0)
        pushing = [s for s in run if t_off - 0.2 <= s["t"] < t_off]

        def mean(key: str) -> float:
            return sum(float(s.get(key, math.nan)) for s in pushing) / len(pushing)

        return {
            "STALLED": float(bool(int(status[1]) & STALLED)) if status else math.nan,
            "contact after, s": t_contact - t_cmd,
            "motors off after contact, s": t_off - t_contact,
            "duty": mean("duty_l"),
            "wheel, rad/s": mean("wheel_l"),
            "current, A": mean("current_l"),
            "body v, m/s": mean("v"),
            "slip, m/s": mean("slip_l"),
        }
    finally:
        link.close()
        sim.stop()


def route(
    tmp: Path, start: tuple[float, float, float], points: list[tuple[float, float]]
) -> dict[str, float]:
    """Drives a path with the firmware's path following; how far the tyres slid against the
    distance driven, and the largest sideways force the tyres carried (m·|v·ω|: they never slide
    sideways in this model)."""
    sim, link, rec = started(tmp, start)
    try:
        t0 = float(sim.truth()["t"])
        caller = threading.Thread(target=lambda: upload_path(link, points))
        caller.start()
        time.sleep(0.05)
        sim.run_for(16.0)
        caller.join(timeout=30.0)
        run = rec.between(t0, t0 + 16.0)
        driven = sum(math.hypot(b["x"] - a["x"], b["y"] - a["y"]) for a, b in itertools.pairwise(run))
        slid = slid_mm(run)
        return {
            "driven, m": driven,
            "slid, mm": slid,
            "slid / driven, ppm": 1000.0 * slid / driven,
            "peak slip, m/s": max(slip(s) for s in run),
            "time slipping, ms": 1000.0 * sum(1 for s in run if slip(s) > 0.0) / TRUTH_HZ,
            "peak sideways force, N": MASS_KG * max(abs(s["v"] * s["omega"]) for s in run),
        }
    finally:
        link.close()
        sim.stop()


def square(tmp: Path) -> dict[str, float]:
    return route(tmp, (0.0, 0.0, 0.0), SQUARE)


def circle(tmp: Path) -> dict[str, float]:
    lap = circle_route(0)
    return route(tmp, lap.start, lap.points)


def run(out: Path, quick: bool) -> Section:
    del quick  # one run each: the manoeuvres are deterministic
    results: dict[str, dict[str, float]] = {}
    for name, manoeuvre in (
        ("turn", turn_on_the_spot),
        ("reversal", reversal),
        ("wall", push_wall),
        ("square", square),
        ("circle", circle),
    ):
        with tempfile.TemporaryDirectory() as tmp:
            results[name] = manoeuvre(Path(tmp))
    titles = {
        "turn": "Turn on the spot, VELOCITY (0, 3 rad/s) for 1.5 s then (0, 0)",
        "reversal": "Reversal, VELOCITY (0.3 m/s, 0) then (-0.3 m/s, 0)",
        "wall": "Backing into the west wall, VELOCITY (-0.3 m/s, 0): the last 0.2 s before the motors stop",
        "square": "The bench square (1.6 m legs at 0.5 m/s, turns on the spot)",
        "circle": "The bench circle (a 16-gon of radius 0.6 m, driving while turning)",
    }
    md = ["## Drivetrain\n"]
    for name, values in results.items():
        md.append(f"{titles[name]}:\n")
        md.append(table(list(values), [[f"{v:.4g}" for v in values.values()]]))
    del out
    return Section(NAME, "\n".join(md), dict(results))


if __name__ == "__main__":
    raise SystemExit(section_main(run))

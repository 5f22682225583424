"""## Drivetrain: the firmware against the simulator's traction, backlash and caster physics.

Three manoeuvres with the real firmware in the simulator, each run in exact simulated time (the
simulator starts paused; a command is written, then `run` advances a fixed span), ground truth
sampled at 500 Hz:

- **turn on the spot**: VELOCITY (0, 3 rad/s) from rest for 1.5 s, then VELOCITY (0, 0) for 1 s:
  the overshoot of the true yaw rate over 3 rad/s, the time to 90 %, how far the heading runs on
  after the stop command, and how far the axle centre wanders (scrub);
- **reversal**: VELOCITY (0.3 m/s, 0) for 1.5 s, then (-0.3 m/s, 0) for 1.5 s: the time from the
  reversal to -0.27 m/s, the largest heading change and yaw rate in the 1.5 s after it (the caster
  swinging round) and the caster angle before and after;
- **pushing a wall**: backing into the west wall (no switch there) with VELOCITY (-0.3 m/s, 0):
  the firmware's PI winds up to full PWM; in the last 0.2 s before the stall guard stops the
  motors, the wheel speed, motor current and body speed, and when the guard tripped.

`python -m bench.drivetrain`; no targets (the missions' targets are in bench/missions.py).
"""

from __future__ import annotations

import math
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from bench.common import Section, section_main, table
from cart2d.link import Link
from cart2d.simulator import SimOptions, Simulator
from cart2d.spec import load_spec

NAME = "drivetrain"
STALLED = load_spec().flags["STALLED"]
TRUTH_HZ = 500.0
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
    sim.run_for(0.5)  # boot
    link = Link(sim.pty, timeout_s=2.0).open()
    recorder = Recorder()
    assert sim.side is not None
    sim.side.subscribe(recorder)
    sim.control("truth_rate", hz=TRUTH_HZ)
    command_then_run(sim, link, 0.1, "SET_POSE", *start)
    command_then_run(sim, link, 0.1, "PARAM_SET", 13, 10.0)  # manual timeout: the runs below are longer
    return sim, link, recorder


def first_time(samples: list[Truth], condition: Callable[[Truth], bool]) -> float:
    return next((float(s["t"]) for s in samples if condition(s)), math.nan)


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
        return {
            "omega_peak_radps": max(s["omega"] for s in turning),
            "overshoot_pct": 100.0 * (max(s["omega"] for s in turning) / 3.0 - 1.0),
            "t90_s": first_time(turning, lambda s: s["omega"] >= 2.7) - t_cmd,
            "heading_run_on_rad": run_on,
            "centre_wander_mm": 1000.0 * max(math.hypot(s["x"] - x0, s["y"] - y0) for s in turning + after),
            "max_slip_mps": max(
                max(abs(s.get("slip_l", 0.0)), abs(s.get("slip_r", 0.0))) for s in turning + after
            ),
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
            "t_to_reverse_speed_s": first_time(after, lambda s: s["v"] <= -0.27) - t_rev,
            "heading_change_max_mrad": 1000.0
            * max(abs(math.remainder(s["theta"] - theta0, 2 * math.pi)) for s in after),
            "omega_max_radps": max(abs(s["omega"]) for s in after),
            "caster_before_rad": float(before[-1].get("caster", math.nan)),
            "caster_after_rad": float(after[-1].get("caster", math.nan)),
            "max_slip_mps": max(max(abs(s.get("slip_l", 0.0)), abs(s.get("slip_r", 0.0))) for s in after),
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
            "stalled_flag": float(bool(int(status[1]) & STALLED)) if status else math.nan,
            "contact_after_s": t_contact - t_cmd,
            "motors_off_after_contact_s": t_off - t_contact,
            "duty": mean("duty_l"),
            "wheel_radps": mean("wheel_l"),
            "current_a": mean("current_l"),
            "body_v_mps": mean("v"),
            "slip_mps": mean("slip_l"),
        }
    finally:
        link.close()
        sim.stop()


def run(out: Path, quick: bool) -> Section:
    del quick  # one run each: the manoeuvres are deterministic
    with tempfile.TemporaryDirectory() as tmp:
        turn = turn_on_the_spot(Path(tmp))
    with tempfile.TemporaryDirectory() as tmp:
        rev = reversal(Path(tmp))
    with tempfile.TemporaryDirectory() as tmp:
        wall = push_wall(Path(tmp))
    md = ["## Drivetrain\n"]
    md.append("Turn on the spot, VELOCITY (0, 3 rad/s) then (0, 0):\n")
    md.append(table(list(turn), [[f"{v:.4g}" for v in turn.values()]]))
    md.append("\nReversal, VELOCITY (0.3 m/s, 0) then (-0.3 m/s, 0):\n")
    md.append(table(list(rev), [[f"{v:.4g}" for v in rev.values()]]))
    md.append(
        "\nBacking into the west wall, VELOCITY (-0.3 m/s, 0), the last 0.2 s before the motors stop:\n"
    )
    md.append(table(list(wall), [[f"{v:.4g}" for v in wall.values()]]))
    del out
    return Section(NAME, "\n".join(md), {"turn": turn, "reversal": rev, "wall": wall})


if __name__ == "__main__":
    raise SystemExit(section_main(run))

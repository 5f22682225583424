"""## Safety: what stops the motors, and how fast

Each way the firmware stops the motors, measured on the real AVR binary in the simulator, in
simulated time, from ground truth sampled every 0.5 ms (what the H-bridges are driven with, not
what the firmware says):

- **a main-loop hang** (the simulator's `hang`: the loop never continues, interrupts and the
  PWM hardware run on) while driving by hand at 0.3 m/s: the watchdog (64 ms, fed only after a
  completed control tick) resets the MCU, every pin floats and the LMD18200s' pull-downs turn
  the motors off. Timed from the moment the loop hung, at random phases of the control tick.
- **a front switch** closing while driving into the arena's wall by hand, at three speeds and
  three angles: the next control tick stops the motors (flag BUMPER). Timed from the first
  closed switch.
- **a link gone quiet** during manual driving: the manual timeout (`manual_timeout_s`, 0.5 s)
  after the last VELOCITY.

`python -m bench.safety [--quick]`.
"""

from __future__ import annotations

import math
import random
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt

from bench.common import Section, section_main, spread, table
from bench.firmware import Port, call, paused_sim
from cart2d.params import robot, settings_table
from cart2d.simulation.simulator import Simulator

NAME = "safety"
TRUTH_HZ = 2000.0
HANG_BUDGET_S = 0.1  # issue 10: "the motors must be off within ~0.1 s of a hang"
BUMPER_BUDGET_S = 2.0 / int(robot()["control"]["tick_hz"])  # two control ticks
MANUAL_TIMEOUT_S = next(s["default"] for s in settings_table() if s["name"] == "manual_timeout_s")
WALL_X_M = (int(robot()["sim"]["grid_nodes"]) - 1) * float(robot()["sim"]["grid_step_m"]) + float(
    robot()["sim"]["arena_margin_m"]
)


@dataclass
class Bench:
    """A paused simulator, its serial port and every ground-truth sample from now on."""

    sim: Simulator
    port: Port
    truth: list[dict[str, Any]]

    def run(self, seconds: float) -> None:
        self.sim.run_for(seconds)
        self.port.poll()

    def drive(self, v: float, omega: float, seconds: float, refresh_s: float = 0.1) -> None:
        """Manual driving for `seconds`, refreshed as the panel does."""
        t = 0.0
        while t < seconds - 1e-9:
            self.port.send("VELOCITY", v, omega)
            step = min(refresh_s, seconds - t)
            self.run(step)
            t += step

    def first(self, after_s: float, test: Callable[[dict[str, Any]], bool]) -> dict[str, Any] | None:
        return next((s for s in self.truth if s["t"] >= after_s and test(s)), None)


def open_bench(tmp: str, start: tuple[float, float, float], seed: int) -> Bench:
    sim = paused_sim(tmp)
    sim.options.start = start
    sim.options.seed = seed
    sim.start()
    port = Port(sim.pty, seed)
    samples: list[dict[str, Any]] = []
    assert sim.side is not None
    sim.side.subscribe(samples.append)
    sim.control("truth_rate", hz=TRUTH_HZ)
    bench = Bench(sim, port, samples)
    bench.run(sim.boot_s() + 0.3)  # the reset that opening the port causes, the boot through Optiboot
    call(sim, port, "SET_POSE", *start)
    return bench


def motors_off(s: dict[str, Any]) -> bool:
    return bool(s["duty_l"] == 0.0 and s["duty_r"] == 0.0)


def events(sim: Simulator, kind: str) -> list[dict[str, Any]]:
    assert sim.side is not None
    return [e for e in sim.side.events if e.get("event") == kind]


@dataclass
class Hang:
    to_off_s: float
    travel_m: float  # true distance driven from the hang to standstill


def hang_trial(seed: int) -> Hang:
    rng = random.Random(seed)
    with tempfile.TemporaryDirectory() as tmp:
        bench = open_bench(tmp, (0.3, 0.9, 0.0), seed)
        try:
            bench.drive(0.3, 0.0, 0.8 + rng.uniform(0.0, 0.008))  # up to speed, at a random tick phase
            bench.sim.control("hang")
            bench.run(0.3)
            (hang,) = events(bench.sim, "hang")
            off = bench.first(hang["t"], motors_off)
            start = bench.first(hang["t"], lambda s: True)
            still = bench.first(hang["t"] + 0.05, lambda s: abs(s["v"]) < 1e-3)
            assert off is not None and start is not None and still is not None, "no truth after the hang"
            resets = [e for e in events(bench.sim, "mcu_reset") if e["t"] >= hang["t"]]
            assert [e["cause"] for e in resets] == ["watchdog"], f"resets after the hang: {resets}"
            travel = math.hypot(still["x"] - start["x"], still["y"] - start["y"])
            return Hang(off["t"] - hang["t"], travel)
        finally:
            bench.port.close()
            bench.sim.stop()


@dataclass
class Contact:
    speed_mps: float
    angle_deg: float
    to_off_s: float
    push_m: float  # how far the cart moved on after the switch closed


def bumper_trial(speed: float, angle_deg: float, seed: int) -> Contact:
    theta = math.radians(angle_deg)
    with tempfile.TemporaryDirectory() as tmp:
        bench = open_bench(tmp, (WALL_X_M - 0.9, 0.9, theta), seed)
        try:
            bench.drive(speed, 0.0, 0.9 / speed + 1.0)
            contact = bench.first(0.0, lambda s: bool(s["switch_l"] or s["switch_r"]))
            assert contact is not None, f"no contact at {speed} m/s, {angle_deg} deg"
            off = bench.first(contact["t"], motors_off)
            assert off is not None
            rest = bench.truth[-1]
            return Contact(
                speed,
                angle_deg,
                off["t"] - contact["t"],
                math.hypot(rest["x"] - contact["x"], rest["y"] - contact["y"]),
            )
        finally:
            bench.port.close()
            bench.sim.stop()


def timeout_trial(seed: int) -> float:
    with tempfile.TemporaryDirectory() as tmp:
        bench = open_bench(tmp, (0.3, 0.9, 0.0), seed)
        try:
            bench.drive(0.3, 0.0, 0.6)
            bench.port.send("VELOCITY", 0.3, 0.0)  # the last one
            last = bench.sim.truth()["t"]
            bench.run(MANUAL_TIMEOUT_S + 0.2)
            off = bench.first(last, motors_off)
            assert off is not None, "the motors stayed on without VELOCITY"
            return float(off["t"] - last)
        finally:
            bench.port.close()
            bench.sim.stop()


def plot(hangs: list[Hang], contacts: list[Contact], path: Path) -> None:
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 3.6))
    left.hist([1000 * h.to_off_s for h in hangs], bins=10, color="tab:red")
    left.axvline(1000 * HANG_BUDGET_S, color="k", ls="--", label=f"target {1000 * HANG_BUDGET_S:.0f} ms")
    left.set_xlabel("main-loop hang → motors off (ms)")
    left.set_ylabel("trials")
    left.legend()
    for angle in sorted({c.angle_deg for c in contacts}):
        cs = [c for c in contacts if c.angle_deg == angle]
        right.plot([c.speed_mps for c in cs], [1000 * c.to_off_s for c in cs], "o-", label=f"{angle:+.0f}°")
    right.axhline(1000 * BUMPER_BUDGET_S, color="k", ls="--", label="two control ticks")
    right.set_xlabel("speed into the wall (m/s)")
    right.set_ylabel("switch closed → motors off (ms)")
    right.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def run(out: Path, quick: bool) -> Section:
    started = time.monotonic()
    hangs = [hang_trial(seed) for seed in range(3 if quick else 12)]
    speeds = (0.5,) if quick else (0.2, 0.35, 0.5)
    angles = (0.0,) if quick else (-15.0, 0.0, 15.0)
    contacts = [bumper_trial(v, a, 7) for v in speeds for a in angles]
    timeout = timeout_trial(3)
    plot(hangs, contacts, out / f"{NAME}_stops.png")

    hang_off = spread([1000 * h.to_off_s for h in hangs])
    contact_off = spread([1000 * c.to_off_s for c in contacts])
    ok_hang = hang_off.high <= 1000 * HANG_BUDGET_S
    ok_contact = contact_off.high <= 1000 * BUMPER_BUDGET_S
    ok_timeout = abs(timeout - MANUAL_TIMEOUT_S) <= 2.0 / int(robot()["control"]["tick_hz"])
    md = [__doc__.split("\n\n", 1)[0], ""]
    md.append(
        table(
            ["what stops the motors", "after", "measured (ms)", "target", "met"],
            [
                [
                    "watchdog reset (64 ms), pins float, bridge pull-downs",
                    f"a main-loop hang while driving at 0.3 m/s ({len(hangs)} phases)",
                    hang_off.text(".1f", ""),
                    f"≤ {1000 * HANG_BUDGET_S:.0f}",
                    "yes" if ok_hang else "**no**",
                ],
                [
                    "safe stop at the next control tick (BUMPER)",
                    f"a front switch closing against the wall ({len(contacts)} speeds and angles)",
                    contact_off.text(".1f", ""),
                    f"≤ {1000 * BUMPER_BUDGET_S:.0f}",
                    "yes" if ok_contact else "**no**",
                ],
                [
                    "the manual timeout (MANUAL_TIMEOUT)",
                    "the last VELOCITY while driving by hand",
                    f"{1000 * timeout:.0f}",
                    f"{1000 * MANUAL_TIMEOUT_S:.0f} ± 16",
                    "yes" if ok_timeout else "**no**",
                ],
            ],
        )
    )
    travel = spread([h.travel_m for h in hangs])
    push = spread([c.push_m for c in contacts])
    md.append(
        f"After a hang the cart rolled {travel.text('.3f', 'm')} in all (it was doing 0.3 m/s; "
        f"before the watchdog it drove on until it hit something); the firmware ran again 65 ms "
        f"after the reset (the chip's reset time-out), idle. "
        f"After a switch closed the cart moved on {1000 * push.median:.1f} mm (at most "
        f"{1000 * push.high:.1f} mm): the bumper's travel and the wheels' braking.\n"
    )
    md.append(f"![Hang and bumper stops]({NAME}_stops.png)\n")
    md.append(f"\n_{'quick' if quick else 'full'} mode, {time.monotonic() - started:.0f} s._\n")
    return Section(
        NAME,
        "\n".join(md),
        {
            "hang_to_off_ms": hang_off.as_dict(),
            "hang_travel_m": travel.as_dict(),
            "bumper_to_off_ms": contact_off.as_dict(),
            "bumper_push_m": push.as_dict(),
            "contacts": [c.__dict__ for c in contacts],
            "manual_timeout_to_off_s": timeout,
        },
        targets_met=ok_hang and ok_contact and ok_timeout,
    )


def main() -> int:
    return section_main(run)


if __name__ == "__main__":
    raise SystemExit(main())

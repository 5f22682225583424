"""make bench-sim: the simulator's real-time factor and the firmware's CPU use per tick.

Drives the square (0,0) -> (1.6,0) -> (1.6,1.6) -> (0,1.6) -> (0,0) at v_max = 0.5 m/s with
telemetry on at its default 25 Hz, twice:
- in fast mode (--speed max), for the real-time factor: simulated seconds per wall second;
- at 4x real time, polling STATUS at 10 Hz, for the firmware's CPU use per 8 ms control tick
  as simavr counts it: cycles from the tick interrupt to the loop going back to sleep (encoder
  interrupts at full speed included), mean and max over the drive, as a share of the 128 000
  cycles of a tick. (At 4x the end of the drive is noticed within 0.4 s of simulated time, so
  idle ticks barely dilute the mean, as they would in fast mode.)
Targets: real-time factor >= 10, CPU mean <= 15 %, max <= 30 %.
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

from cart2d.link import Link
from cart2d.simulator import SimOptions, Simulator

SQUARE = [(1.6, 0.0), (1.6, 1.6), (0.0, 1.6), (0.0, 0.0)]


def drive_square(sim: Simulator, link: Link, poll_s: float = 0.05) -> tuple[float, float]:
    """Drives the square from the origin; returns (simulated seconds, wall seconds)."""
    sim.control("stats", reset=True)
    t0_sim = sim.truth()["t"]
    t0_wall = time.monotonic()
    link.call("WAIT_XY_ARRAY", len(SQUARE), *[c for p in SQUARE for c in p])
    while int(link.call("STATUS")[0]) != 0:
        if time.monotonic() - t0_wall > 120:
            raise RuntimeError("the square was not finished in 120 s of wall time")
        time.sleep(poll_s)
    return sim.truth()["t"] - t0_sim, time.monotonic() - t0_wall


def main() -> int:
    with tempfile.TemporaryDirectory() as tmp:
        options = SimOptions(speed="max", eeprom=Path(tmp) / "eeprom.bin")
        with Simulator(options) as sim, Link(sim.pty) as link:
            sim_s, wall_s = drive_square(sim, link)
            sim.control("place", x=0.0, y=0.0, theta=0.0)  # back to the start, facing +x
            link.call("SET_POSE", 0.0, 0.0, 0.0)
            sim.control("speed", factor=4)
            drive_s, _ = drive_square(sim, link, poll_s=0.1)
            cpu = sim.control("stats")["stats"]["cpu"]
            truth = sim.truth()
    rtf = sim_s / wall_s
    mean_pct, max_pct = 100 * cpu["mean"], 100 * cpu["max"]
    print(f"sim real-time factor (fast mode, driving at 0.5 m/s): {rtf:.1f}x  (target >= 10x)")
    print(
        f"firmware CPU per 8 ms control tick while driving: mean {mean_pct:.1f} %, max {max_pct:.1f} % "
        f"({cpu['max_cycles']} of 128000 cycles) over {cpu['ticks']} ticks, {cpu['overruns']} overruns  "
        "(targets: mean <= 15 %, max <= 30 %)"
    )
    print(f"square: {drive_s:.2f} s simulated, ends at ({truth['x']:.4f}, {truth['y']:.4f}) m (true pose)")
    ok = rtf >= 10 and mean_pct <= 15 and max_pct <= 30 and cpu["overruns"] == 0
    print("targets:", "met" if ok else "MISSED")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())

"""The simulator's speed against the size of its world: simulated seconds per wall second in fast
mode (`--speed max`) while the real firmware drives the bench square (bench/firmware.py's
drive_square), and per CPU second of the simulator process (the figure that depends least on what
else the machine runs); medians and ranges, with 0, 100 and 5000 boxes in a 22 m x 22 m arena.
The boxes (0.1-0.3 m) are scattered at random but kept 0.25 m or more clear of the route, so the
cart passes close to many of them (the broad phase and the probes work) and touches none.

    python -m bench.sim_world [--runs 3] [--counts 0,100,5000]
"""

from __future__ import annotations

import argparse
import itertools
import math
import os
import random
import statistics
import tempfile
from pathlib import Path

from bench.firmware import SQUARE, drive_square
from cart2d.link import Link
from cart2d.maps.world import Box, World
from cart2d.simulation.simulator import SimOptions, Simulator

ARENA = (-10.0, -10.0, 12.0, 12.0)
ROUTE = [(0.0, 0.0), *SQUARE]
CLEARANCE_M = 0.25  # from the route to a box's outline: the cart's bumper ends reach 0.197 m


def _segment_distance(px: float, py: float, a: tuple[float, float], b: tuple[float, float]) -> float:
    (ax, ay), (bx, by) = a, b
    dx, dy = bx - ax, by - ay
    t = max(0.0, min(1.0, ((px - ax) * dx + (py - ay) * dy) / (dx * dx + dy * dy)))
    return math.hypot(px - ax - t * dx, py - ay - t * dy)


def scattered_boxes(count: int, seed: int = 1) -> tuple[Box, ...]:
    rng = random.Random(seed)
    boxes: list[Box] = []
    while len(boxes) < count:
        sx, sy = rng.uniform(0.1, 0.3), rng.uniform(0.1, 0.3)
        x, y = rng.uniform(ARENA[0] + 0.5, ARENA[2] - 0.5), rng.uniform(ARENA[1] + 0.5, ARENA[3] - 0.5)
        near = min(_segment_distance(x, y, a, b) for a, b in itertools.pairwise(ROUTE))
        if near - math.hypot(sx, sy) / 2 < CLEARANCE_M:
            continue
        boxes.append(Box(x, y, sx, sy, id=f"b{len(boxes)}"))
    return tuple(boxes)


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of a process (/proc/PID/stat, fields 14 and 15, in clock ticks)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def measure(count: int, runs: int) -> tuple[list[float], list[float], int]:
    """Simulated seconds per wall second and per CPU second of the simulator, over `runs` drives
    of the square, and the contacts seen (none expected)."""
    world = World(boxes=scattered_boxes(count), boundary=ARENA)
    per_wall, per_cpu, contacts = [], [], 0
    for _ in range(runs):
        with tempfile.TemporaryDirectory() as tmp:
            options = SimOptions(speed="max", eeprom=Path(tmp) / "eeprom.bin", quiet=True, world=world)
            with Simulator(options) as sim, Link(sim.pty) as link:
                assert sim.process is not None
                cpu0 = cpu_seconds(sim.process.pid)
                sim_s, wall_s = drive_square(sim, link)
                cpu_s = cpu_seconds(sim.process.pid) - cpu0
                contacts += sim.truth()["box_contacts"] + sim.truth()["wall_contacts"]
        per_wall.append(sim_s / wall_s)
        per_cpu.append(sim_s / cpu_s)
    return per_wall, per_cpu, contacts


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--counts", default="0,100,5000")
    args = parser.parse_args()
    print("| boxes | simulated s per wall s | per CPU s of the simulator | contacts |")
    print("|---|---|---|---|")
    for count in (int(c) for c in args.counts.split(",")):
        wall, cpu, contacts = measure(count, args.runs)

        def cell(values: list[float]) -> str:
            return f"{statistics.median(values):.1f} ({min(values):.1f}-{max(values):.1f})"

        print(f"| {count} | {cell(wall)} | {cell(cpu)} | {contacts} |", flush=True)


if __name__ == "__main__":
    main()

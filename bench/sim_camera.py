"""The simulated camera's cost: render and JPEG time per frame and the JPEG's size (the C++
benchmark build/sim/sim_camera_bench, QVGA and VGA, 5 boxes + arena walls + checkerboard, then
each named room of docs/examples/ at QVGA: materials, lamps, shadows, every camera effect), and
what watching it costs the simulator in fast mode: simulated seconds per wall second at
`--speed max` with the camera off, on, and on in the tiled kitchen (15 frames per simulated
second), the cart standing. Targets (issue 24): >= 10 x real time without the camera, >= 1 x
with it in the hardest room.

    python -m bench.sim_camera [--quick]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

from cart2d.maps.world import Box, World, arena_world
from cart2d.simulation.simulator import SimOptions, Simulator
from cart2d.simulation.world import world_file
from cart2d.spec import repo_file

BOXES = (Box(0.6, 0.2, 0.2, 0.2), Box(1.0, -0.3, 0.2, 0.2), Box(1.4, 0.5, 0.2, 0.2))
ROOMS = ("kitchen", "office", "carpet", "corridor")


def room_file(name: str) -> Path:
    return repo_file("docs", "examples", f"{name}.json")


def cpu_s(pid: int) -> float:
    """A process's CPU seconds so far (Linux /proc: user + system)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def sim_speed(camera: bool, sim_seconds: float, folder: Path, room: str | None = None) -> tuple[float, float]:
    """Simulated seconds per wall second and per second of the simulator's CPU over
    `sim_seconds` at --speed max (in a named room: its boxes and its look). The second is what
    the simulator would do on a core of its own, whatever else the machine runs."""
    boxes: tuple[Box, ...] = BOXES
    look = None
    if room is not None:
        found, look, problems = world_file(room_file(room))
        assert not problems, problems
        boxes = tuple(found)
    world = World(boxes=boxes, boundary=arena_world(10, 10, 0.2).boundary)
    options = SimOptions(speed="max", paused=True, world=world, start=(0.0, 0.0, 0.0), quiet=True, look=look)
    options.eeprom = folder / f"eeprom-{camera}-{room}.bin"
    with Simulator(options) as sim:
        if camera:
            sim.camera(True)
        assert sim.process is not None
        start, cpu = time.monotonic(), cpu_s(sim.process.pid)
        sim.run_for(sim_seconds, wall_timeout_s=600.0)
        return sim_seconds / (time.monotonic() - start), sim_seconds / (cpu_s(sim.process.pid) - cpu)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer frames and a shorter run")
    args = parser.parse_args()
    frames, seconds, runs = (20, 2.0, 1) if args.quick else (200, 10.0, 3)
    table = subprocess.run(
        [str(repo_file("build", "sim", "sim_camera_bench")), str(frames), *map(str, map(room_file, ROOMS))],
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    print(table, end="")
    with tempfile.TemporaryDirectory() as folder:
        for camera, room, target in ((False, None, 10.0), (True, None, 1.0), (True, "kitchen", 1.0)):
            rates = [sim_speed(camera, seconds, Path(folder), room) for _ in range(runs)]
            state = ("on " if camera else "off") + (f" in the {room}" if room else "")
            wall = statistics.median(r[0] for r in rates)
            cpu = statistics.median(r[1] for r in rates)
            verdict = "ok" if cpu >= target else "MISSED"
            print(
                f"simulator at --speed max, camera {state}: {wall:6.1f} sim s per wall s, "
                f"{cpu:6.1f} per CPU s (median of {runs}; target >= {target:g} per CPU s: {verdict})"
            )
        print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores while measuring")


if __name__ == "__main__":
    main()

"""The simulated camera's cost: render and JPEG time per frame and the JPEG's size (the C++
benchmark build/sim/sim_camera_bench, QVGA and VGA, 5 boxes + arena walls + checkerboard), and
what watching it costs the simulator in fast mode: simulated seconds per wall second at
`--speed max` with the camera off and on (15 frames per simulated second), the cart standing.

    python -m bench.sim_camera [--quick]
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

from cart2d.maps.world import Box, World, arena_world
from cart2d.simulation.simulator import SimOptions, Simulator
from cart2d.spec import repo_file

BOXES = (Box(0.6, 0.2, 0.2, 0.2), Box(1.0, -0.3, 0.2, 0.2), Box(1.4, 0.5, 0.2, 0.2))


def sim_speed(camera: bool, sim_seconds: float, folder: Path) -> float:
    """Simulated seconds per wall second over `sim_seconds` at --speed max."""
    world = World(boxes=BOXES, boundary=arena_world(10, 10, 0.2).boundary)
    options = SimOptions(speed="max", paused=True, world=world, start=(0.0, 0.0, 0.0), quiet=True)
    options.eeprom = folder / f"eeprom-{camera}.bin"
    with Simulator(options) as sim:
        if camera:
            sim.camera(True)
        start = time.monotonic()
        sim.run_for(sim_seconds, wall_timeout_s=600.0)
        return sim_seconds / (time.monotonic() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer frames and a shorter run")
    args = parser.parse_args()
    frames, seconds, runs = (20, 2.0, 1) if args.quick else (200, 10.0, 3)
    table = subprocess.run(
        [str(repo_file("build", "sim", "sim_camera_bench")), str(frames)],
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    print(table, end="")
    with tempfile.TemporaryDirectory() as folder:
        for camera in (False, True):
            rates = [sim_speed(camera, seconds, Path(folder)) for _ in range(runs)]
            state = "on " if camera else "off"
            rate = statistics.median(rates)
            print(
                f"simulator at --speed max, camera {state}: {rate:6.1f} sim s per wall s (median of {runs})"
            )


if __name__ == "__main__":
    main()

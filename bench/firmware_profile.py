"""Where the firmware's control-tick cycles go, measured exactly in simavr.

Drives the bench square (see firmware.py) with the simulator's cycle profile on, then
attributes every cycle spent inside control-tick windows to the innermost function (inlined
functions included, via avr-addr2line) and prints cycles per tick by function.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

from bench.firmware import by_function, drive_square
from cart2d.link import Link
from cart2d.simulation.simulator import SimOptions, Simulator


def main() -> int:
    with tempfile.TemporaryDirectory() as tmp:
        options = SimOptions(speed="max", eeprom=Path(tmp) / "eeprom.bin")
        with Simulator(options) as sim, Link(sim.pty) as link:
            sim.control("profile", enable=True)
            drive_square(sim, link)
            profile = sim.control("profile", enable=False)["profile"]
            ticks = sim.control("stats")["stats"]["cpu"]["ticks"]
    functions = by_function(options.firmware, profile)
    total = sum(functions.values())
    print(f"{ticks} control ticks, {total / ticks:.0f} cycles per tick on average (of 128000)")
    for name, cycles in functions.most_common(int(sys.argv[1]) if len(sys.argv) > 1 else 25):
        print(f"{cycles / ticks:9.0f} cycles/tick  {100 * cycles / total:5.1f} %  {name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

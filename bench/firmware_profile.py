"""Where the firmware's control-tick cycles go, measured exactly in simavr.

Drives the bench square (see firmware.py) with the simulator's cycle profile on, then
attributes every cycle spent inside control-tick windows to the innermost function (inlined
functions included, via avr-addr2line) and prints cycles per tick by function.
"""

from __future__ import annotations

import collections
import subprocess
import sys
import tempfile
from pathlib import Path

from bench.firmware import drive_square
from cart2d.link import Link
from cart2d.simulator import SimOptions, Simulator


def functions_of(elf: Path, addresses: list[int]) -> dict[int, str]:
    """Innermost (inlined) function for each address."""
    text = "\n".join(hex(a) for a in addresses)
    out = subprocess.run(
        ["avr-addr2line", "-f", "-i", "-C", "-a", "-e", str(elf)],
        input=text,
        capture_output=True,
        text=True,
        check=True,
    ).stdout.splitlines()
    names: dict[int, str] = {}
    current = None
    expect_name = False
    for line in out:
        if line.startswith("0x"):
            current = int(line, 16)
            expect_name = True
        elif expect_name and current is not None:
            names[current] = line.split("(")[0]
            expect_name = False
    return names


def main() -> int:
    with tempfile.TemporaryDirectory() as tmp:
        options = SimOptions(speed="max", eeprom=Path(tmp) / "eeprom.bin")
        with Simulator(options) as sim, Link(sim.pty) as link:
            sim.control("profile", enable=True)
            drive_square(sim, link)
            profile = sim.control("profile", enable=False)["profile"]
            ticks = sim.control("stats")["stats"]["cpu"]["ticks"]
    names = functions_of(options.firmware, [a for a, _ in profile])
    by_function: collections.Counter[str] = collections.Counter()
    for address, cycles in profile:
        by_function[names.get(address, "?")] += cycles
    total = sum(by_function.values())
    print(f"{ticks} control ticks, {total / ticks:.0f} cycles per tick on average (of 128000)")
    for name, cycles in by_function.most_common(int(sys.argv[1]) if len(sys.argv) > 1 else 25):
        print(f"{cycles / ticks:9.0f} cycles/tick  {100 * cycles / total:5.1f} %  {name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

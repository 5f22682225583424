#!/usr/bin/env python3
"""Print the firmware's flash and static RAM use against the budgets (from avr-size)."""

from __future__ import annotations

import subprocess
import sys

CHIP_FLASH = 32 * 1024  # the ATmega328P's
# 24 KiB of the 32: the watchdog, the bumper stop, retained pose and reset causes, and two EEPROM
# records took the image past the first budget of 16 KiB; 8 KiB stay for growth and Optiboot (0.5 KiB).
FLASH_BUDGET = 24 * 1024
RAM_BUDGET = 1024  # data + bss + noinit; the other 1 KiB of the 2 KiB is for the stack
RAM_TOTAL = 2048


def sections(elf: str) -> dict[str, int]:
    out = subprocess.run(["avr-size", "-A", elf], check=True, capture_output=True, text=True).stdout
    sizes = {}
    for line in out.splitlines():
        parts = line.split()
        if len(parts) >= 2 and parts[0].startswith(".") and parts[1].isdigit():
            sizes[parts[0]] = int(parts[1])
    return sizes


def usage(sizes: dict[str, int]) -> tuple[int, int]:
    """(flash, static RAM) in bytes from the section sizes: .text + .data (the initial values of
    .data are stored in the flash), .data + .bss + .noinit (RAM the C runtime leaves alone)."""
    ram = sizes.get(".data", 0) + sizes.get(".bss", 0) + sizes.get(".noinit", 0)
    return sizes.get(".text", 0) + sizes.get(".data", 0), ram


def main() -> int:
    s = sections(sys.argv[1])
    flash, ram = usage(s)
    ok = flash <= FLASH_BUDGET and ram <= RAM_BUDGET
    share = 100 * flash / FLASH_BUDGET
    print(f"firmware flash: {flash} B of {FLASH_BUDGET} B budget ({share:.0f} %), {CHIP_FLASH} B chip")
    print(
        f"firmware RAM:   {ram} B static (data {s.get('.data', 0)} + bss {s.get('.bss', 0)} + noinit "
        f"{s.get('.noinit', 0)}) of "
        f"{RAM_BUDGET} B budget ({100 * ram / RAM_BUDGET:.0f} %); {RAM_TOTAL - ram} B left for the stack"
    )
    print("budgets:", "met" if ok else "EXCEEDED")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())

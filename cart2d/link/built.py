"""Where `make` puts what it builds (build/): the firmware, the simulator (whose reader also checks
a firmware file, firmware_files.py) and Optiboot; each overridden by an environment variable."""

from __future__ import annotations

import os
from pathlib import Path

from cart2d.spec import repo_file


def default_binary() -> Path:
    return Path(os.environ.get("CART2D_SIM", repo_file("build", "sim", "cart2d-sim")))


def default_firmware() -> Path:
    return Path(os.environ.get("CART2D_FIRMWARE", repo_file("build", "firmware", "cart2d-nano.elf")))


def default_bootloader() -> Path:
    """Optiboot as `make sim` builds it from Debian's source (sim/CMakeLists.txt)."""
    built = repo_file("build", "sim", "optiboot", "optiboot_atmega328.hex")
    return Path(os.environ.get("CART2D_BOOTLOADER", built))

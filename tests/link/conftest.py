"""Fixtures of the link's tests: a firmware that drives and never answers, to flash."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest


@pytest.fixture(scope="module")
def half_duty_hex(tmp_path_factory: pytest.TempPathFactory) -> bytes:
    """tests/link/avr/half_duty.c as Intel HEX: both motors forward at 50 %, not a word of protocol."""
    gcc, objcopy = shutil.which("avr-gcc"), shutil.which("avr-objcopy")
    if gcc is None or objcopy is None:
        pytest.fail("avr-gcc and avr-objcopy are needed (Debian gcc-avr, binutils-avr: make deps)")
    out = tmp_path_factory.mktemp("half-duty")
    source = Path(__file__).parent / "avr" / "half_duty.c"
    flags = ["-mmcu=atmega328p", "-Os", "-Wall", "-Wextra", "-Werror"]
    subprocess.run([gcc, *flags, "-o", str(out / "half.elf"), str(source)], check=True)
    elf, hex_file = out / "half.elf", out / "half.hex"
    subprocess.run([objcopy, "-O", "ihex", "-R", ".eeprom", str(elf), str(hex_file)], check=True)
    return hex_file.read_bytes()

"""The flasher's bootloader port (cart2d/link/bootloader.py): the flasher asks it, not a
simulator, what to flash through and which firmware the robot runs and falls back to. A fake
port: no avrdude, no simulator."""

from __future__ import annotations

import contextlib
from contextlib import AbstractContextManager
from pathlib import Path

import pytest

from cart2d.link import Link
from cart2d.link.bootloader import SerialBootloader, UpdateRefused
from cart2d.link.flashing import Flasher


class FakePort:
    def __init__(self, running: Path | None, built: Path, refusal: str = "") -> None:
        self.running, self.built, self.refusal = running, built, refusal
        self.flashed_files: list[Path] = []

    def avrdude_port(self) -> str:
        if self.refusal:
            raise UpdateRefused(self.refusal)
        return "/dev/fake"

    def programming(self) -> AbstractContextManager[object]:
        return contextlib.nullcontext()

    def running_firmware(self) -> Path | None:
        return self.running

    def built_firmware(self) -> Path:
        return self.built

    def flashed(self, path: Path) -> None:
        self.flashed_files.append(path)


def test_the_firmware_the_port_runs_becomes_the_good_one_once_it_answers(tmp_path: Path) -> None:
    running, built = tmp_path / "running.elf", tmp_path / "built.elf"
    running.write_bytes(b"\x7fELF running")
    built.write_bytes(b"\x7fELF built")
    flasher = Flasher(Link("unopened"), tmp_path / "gateway", FakePort(running, built))
    assert flasher.good_firmware() == built  # nothing answered yet: the built one
    flasher.answered()
    good = flasher.good_firmware()
    assert good is not None and good != running and good.read_bytes() == running.read_bytes()


def test_nothing_known_and_nothing_built_leaves_no_firmware_to_roll_back_to(tmp_path: Path) -> None:
    flasher = Flasher(Link("unopened"), tmp_path / "gateway", FakePort(None, tmp_path / "absent.hex"))
    flasher.answered()
    assert flasher.current is None and flasher.good_firmware() is None


def test_an_update_the_port_cannot_take_is_refused_before_anything_starts(tmp_path: Path) -> None:
    port = FakePort(None, tmp_path / "absent.hex", refusal="no bootloader here: start it with one")
    flasher = Flasher(Link("unopened"), tmp_path / "gateway", port)
    with pytest.raises(UpdateRefused, match="no bootloader here"):
        flasher.start(b":00000001FF\n")
    assert flasher.job.state == "idle" and port.flashed_files == []


def test_a_real_carts_port_is_the_links_and_its_fallback_the_built_hex(tmp_path: Path) -> None:
    assert SerialBootloader(Link("/dev/ttyUSB0")).avrdude_port() == "/dev/ttyUSB0"
    assert SerialBootloader(Link("socket://cart.local:4000")).avrdude_port() == "net:cart.local:4000"
    assert SerialBootloader(Link("/dev/ttyUSB0")).built_firmware().suffix == ".hex"
    flasher = Flasher(Link("rfc2217://cart.local:4000"), tmp_path / "gateway")  # the default port
    with pytest.raises(UpdateRefused, match="RFC 2217"):
        flasher.refusal()

"""What the flasher (flashing.py) needs of the robot's bootloader: a port avrdude can open, the
MCU put into its bootloader while avrdude has it, and which firmware files it runs and falls back
to. The real cart's is its serial port (SerialBootloader: opening the port resets the Nano into
Optiboot, DTR through its auto-reset capacitor); the simulator's is the simulation package's
(cart2d/simulation/bootloader.py), which runs Optiboot as every Nano does."""

from __future__ import annotations

from contextlib import AbstractContextManager
from pathlib import Path
from typing import Protocol
from urllib.parse import urlsplit

from cart2d.link.built import default_firmware
from cart2d.link.transport import Link


class UpdateRefused(RuntimeError):
    """No update can be made on this link (nothing started); the sentence says what to do."""


class BootloaderPort(Protocol):
    def avrdude_port(self) -> str:
        """avrdude's -P; UpdateRefused, in a sentence saying what to do, if nothing can flash."""
        ...

    def programming(self) -> AbstractContextManager[object]:
        """Held while avrdude runs: the port is avrdude's and the MCU in its bootloader."""
        ...

    def running_firmware(self) -> Path | None:
        """The file the robot runs, when it is known before anything was flashed."""
        ...

    def built_firmware(self) -> Path:
        """What a rollback flashes when no file is known to have answered."""
        ...

    def flashed(self, path: Path) -> None:
        """`path` is in the MCU's flash now."""
        ...


class SerialBootloader:
    """The real cart's: avrdude opens the link's port, which the link lends it."""

    def __init__(self, link: Link) -> None:
        self.link = link

    def avrdude_port(self) -> str:
        return avrdude_port(self.link.port)

    def programming(self) -> AbstractContextManager[object]:
        return self.link.released()

    def running_firmware(self) -> Path | None:
        return None

    def built_firmware(self) -> Path:
        return default_firmware().with_suffix(".hex")

    def flashed(self, path: Path) -> None:
        pass


def avrdude_port(port: str) -> str:
    """avrdude's -P for the link's port: a device path as it is, `socket://HOST:PORT` as
    `net:HOST:PORT` (avrdude's raw TCP; what resets the Nano is the bridge opening its serial
    device). UpdateRefused, in one sentence saying what to do, for a port avrdude cannot use."""
    if "://" not in port:
        return port
    parts = urlsplit(port)
    if parts.scheme == "socket" and parts.hostname and parts.port:
        return f"net:{parts.hostname}:{parts.port}"
    if parts.scheme == "rfc2217":
        raise UpdateRefused(
            f"avrdude cannot flash through {port} because it does not speak RFC 2217: give the bridge a raw "
            "TCP port (ser2net's tcp accepter, ESPHome's stream_server), connect the gateway to it with "
            "socket://HOST:PORT and update again"
        )
    raise UpdateRefused(
        f"avrdude cannot flash through {port}: connect the gateway with a serial device path or a raw TCP "
        "bridge (socket://HOST:PORT) and update again"
    )

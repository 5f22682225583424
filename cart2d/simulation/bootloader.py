"""The simulator's bootloader port for the flasher (cart2d/link/bootloader.py): the simulated
Nano runs Optiboot (SimOptions.bootloader) and resets into it when avrdude opens its pty, as a
Nano does when DTR falls. Its flash is the simulator's firmware file: a restart of the simulator
(a power cycle) comes back with what was flashed last."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from contextlib import AbstractContextManager
from pathlib import Path

from cart2d.link import Link
from cart2d.link.bootloader import UpdateRefused, avrdude_port
from cart2d.link.built import default_firmware
from cart2d.simulation.simulator import Simulator


class SimulatedBootloader:
    def __init__(self, sim: Simulator, link: Link) -> None:
        self.sim = sim
        self.link = link

    def avrdude_port(self) -> str:
        if self.sim.options.bootloader is None:
            raise UpdateRefused(
                "the simulator runs without a bootloader (cart2d sim --no-bootloader), so nothing can flash "
                "it: start it without --no-bootloader to update its firmware"
            )
        return avrdude_port(self.link.port)

    def programming(self) -> AbstractContextManager[object]:
        stack = contextlib.ExitStack()
        stack.enter_context(self.link.released())
        stack.enter_context(self._real_time())
        return stack

    def running_firmware(self) -> Path | None:
        return self.sim.options.firmware

    def built_firmware(self) -> Path:
        return default_firmware()

    def flashed(self, path: Path) -> None:
        self.sim.options.firmware = path

    @contextlib.contextmanager
    def _real_time(self) -> Iterator[None]:
        """A simulator runs in real time while avrdude talks to it: avrdude's waits are wall-clock
        times, and Optiboot's wait for the programmer (1 s after a reset) is simulated time."""
        if self.sim.options.speed == "1":
            yield
            return
        self.sim.control("speed", factor=1)
        try:
            yield
        finally:
            speed = self.sim.options.speed
            self.sim.control("speed", factor=speed if speed == "max" else float(speed))

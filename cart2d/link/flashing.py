"""Firmware updates: an uploaded Intel HEX file, checked, then flashed with avrdude on a real
port (the link lends it the port) or loaded by restarting the simulator. Runs as a background
job whose state and log the panel polls."""

from __future__ import annotations

import contextlib
import io
import shutil
import subprocess
import threading
import time
from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass, field
from pathlib import Path

from intelhex import IntelHex, IntelHexError

from cart2d.link.transport import Link
from cart2d.simulator import Simulator

# ATmega328P: 32 KiB of flash, the top 512 bytes hold the Optiboot bootloader.
APPLICATION_BYTES = 32768 - 512
# Its interrupt vector table: 26 vectors of 4 bytes at address 0, each a jump: JMP (0x940C), or
# RJMP (0xCxxx) where the linker relaxed it. A file without it is not an ATmega328P program and
# would leave the MCU lost (in simulation, a fuzzer's random HEX did exactly that).
VECTORS = 26


def _is_jump(low: int, high: int) -> bool:
    return (low, high) == (0x0C, 0x94) or (high & 0xF0) == 0xC0


def check_hex(data: bytes) -> int:
    """The size of the program in an Intel HEX file; ValueError with the reason otherwise."""
    try:
        image = IntelHex(io.StringIO(data.decode("ascii")))
    except (UnicodeDecodeError, IntelHexError, ValueError) as exc:
        raise ValueError(f"not a valid Intel HEX file: {exc}") from exc
    segments = image.segments()
    if not segments:
        raise ValueError("the HEX file holds no program")
    end = max(stop for _, stop in segments)
    if end > APPLICATION_BYTES:
        raise ValueError(
            f"the program ends at byte {end}, beyond the {APPLICATION_BYTES} bytes below the bootloader"
        )
    if not all(_is_jump(image[4 * v], image[4 * v + 1]) for v in range(VECTORS)):
        raise ValueError(
            "not an ATmega328P program: it does not start with the interrupt vector table's 26 jumps "
            "(build it with make firmware)"
        )
    return sum(stop - start for start, stop in segments)


@dataclass
class UpdateJob:
    state: str = "idle"  # idle | running | done | failed
    log: list[str] = field(default_factory=list)
    started_s: float = 0.0
    ended_s: float = 0.0

    def view(self) -> dict[str, object]:
        return {
            "state": self.state,
            "log": self.log[-50:],
            "elapsed_s": round((self.ended_s or time.monotonic()) - self.started_s, 1)
            if self.started_s
            else 0.0,
        }


class Flasher:
    """One firmware update at a time, in a background thread."""

    def __init__(
        self,
        link: Link,
        directory: Path,
        sim: Simulator | None = None,
        baud: int = 115200,
        after: Callable[[], object] | None = None,
        resetting: Callable[[], AbstractContextManager[object]] | None = None,
    ) -> None:
        self.link = link
        self.after = after  # e.g. the gateway's firmware check; an exception fails the job
        # Held around the update: the MCU restarts on purpose in it (the gateway's restart watch).
        self.resetting = resetting or contextlib.nullcontext
        self.directory = directory
        self.sim = sim
        self.baud = baud
        self.job = UpdateJob()
        self._lock = threading.Lock()

    def start(self, data: bytes) -> UpdateJob:
        """Checks the file now (ValueError if bad, nothing started) and flashes it in the background."""
        size = check_hex(data)
        with self._lock:
            if self.job.state == "running":
                raise RuntimeError("a firmware update is already running")
            self.directory.mkdir(parents=True, exist_ok=True)
            path = self.directory / "uploaded-firmware.hex"
            path.write_bytes(data)
            self.job = UpdateJob(
                state="running", log=[f"checked: {size} bytes of program"], started_s=time.monotonic()
            )
            threading.Thread(target=self._run, args=(path,), name="firmware update", daemon=True).start()
            return self.job

    def _run(self, path: Path) -> None:
        job = self.job
        try:
            with self.resetting():
                if self.sim is not None:
                    self._reload_simulator(path, job)
                else:
                    self._avrdude(path, job)
                    if self.after is not None:
                        job.log.append("checking the new firmware")
                        self.after()
            job.log.append("done")
            job.state = "done"
        except Exception as exc:  # the job reports any failure instead of dying silently
            job.log.append(f"failed: {exc}")
            job.state = "failed"
        finally:
            job.ended_s = time.monotonic()

    def _reload_simulator(self, path: Path, job: UpdateJob) -> None:
        """Restarts the simulator on the new file; if that firmware does not pass the check,
        restarts it on the previous one again (a real chip would need reflashing)."""
        assert self.sim is not None
        previous = self.sim.options.firmware
        job.log.append("restarting the simulator with the new firmware")
        self.sim.restart(path)
        try:
            if not self.link.connected.wait(10.0):
                raise RuntimeError("the simulator did not come back")
            if self.after is not None:
                job.log.append("checking the new firmware")
                self.after()
        except Exception as exc:
            job.log.append(f"the new firmware does not answer ({exc}): restoring the previous one")
            self.sim.restart(previous)
            if self.after is not None:
                self.after()
            raise RuntimeError("the new firmware was rejected; the previous firmware runs again") from exc

    def _avrdude(self, path: Path, job: UpdateJob) -> None:
        avrdude = shutil.which("avrdude")
        if avrdude is None:
            raise RuntimeError("avrdude is not installed (Debian package avrdude)")
        cmd = [avrdude, "-p", "m328p", "-c", "arduino", "-P", self.link.port, "-b", str(self.baud), "-D"]
        cmd += ["-U", f"flash:w:{path}:i"]
        job.log.append(" ".join(cmd))
        with self.link.released():
            done = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
        job.log += [line for line in done.stderr.splitlines() if line.strip()][-20:]
        if done.returncode != 0:
            raise RuntimeError(f"avrdude exited with {done.returncode}")

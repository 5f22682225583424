"""Firmware updates: an uploaded Intel HEX file, checked (cart2d/link/firmware_files.py), then
flashed with avrdude through the Nano's bootloader, reached by a bootloader port (bootloader.py):
the real cart's serial port, or the simulator's, which runs Optiboot as every Nano does
(cart2d/simulation/bootloader.py): one code path for both. Runs as a background job whose state
and log the panel polls.

The robot is never left on a program that does not speak the protocol: after flashing, the new
firmware must answer VERSION (and be compatible) within CHECK_S; if it does not, or a stop comes
first (hurry(): a cart moving under a program that does not answer is the reason to press it),
the last firmware that answered is flashed back (kept by content, so it is that program and no
later upload), and checked in turn.

avrdude takes a device path or `net:HOST:PORT` (raw TCP): a link on `socket://HOST:PORT` is
flashed through `net:HOST:PORT`; one on `rfc2217://` cannot be (avrdude 7.1 has no RFC 2217),
and an update is refused before anything starts (docs/firmware.md, "Flashing over a network
link")."""

from __future__ import annotations

import contextlib
import shutil
import subprocess
import threading
import time
from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass, field
from pathlib import Path

from cart2d.link.bootloader import BootloaderPort, SerialBootloader
from cart2d.link.firmware_files import FirmwareArchive, check_hex, copy_into
from cart2d.link.transport import Link

# How long a new firmware has to answer once the link has its port back. Opening the port resets
# the Nano again (DTR) and Optiboot waits in its bootloader: about 0.5 s when requests come at once
# (its first non-STK500 byte ends the wait), 1.5 s at most (LED flashes and its 1 s watchdog,
# docs/firmware.md, "Start-up time after a reset"); the rest is the link's retries.
CHECK_S = 5.0
AVRDUDE_TIMEOUT_S = 120.0
HURRIED_CHECK_S = 1.0  # after a stop: the last chance to answer before the rollback

# Checks that the robot runs a compatible firmware: (wait_s, hurried) -> None or an exception.
FirmwareCheck = Callable[[float, Callable[[], bool]], object]


@dataclass
class UpdateJob:
    state: str = "idle"  # idle | running | done | failed
    log: list[str] = field(default_factory=list)
    started_s: float = 0.0
    ended_s: float = 0.0
    error: str = ""  # why it failed, a sentence without a label (the log's last line has one)

    def view(self) -> dict[str, object]:
        return {
            "state": self.state,
            "error": self.error,
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
        bootloader: BootloaderPort | None = None,
        baud: int = 115200,
        check: FirmwareCheck | None = None,
        resetting: Callable[[], AbstractContextManager[object]] | None = None,
    ) -> None:
        self.link = link
        self.check = check  # e.g. the gateway's firmware check; an exception fails the job
        # Held around the update: the MCU restarts on purpose in it (the gateway's restart watch).
        self.resetting = resetting or contextlib.nullcontext
        self.directory = directory
        self.archive = FirmwareArchive(directory / "firmware")
        self.bootloader: BootloaderPort = bootloader or SerialBootloader(link)
        self.baud = baud
        self.job = UpdateJob()
        self._lock = threading.Lock()
        self._thread: threading.Thread | None = None
        self._hurry = threading.Event()
        # The file the robot runs, by content, when the gateway knows it: the simulator's, or
        # the last one flashed. It becomes the one to roll back to once it has answered.
        running = self.bootloader.running_firmware()
        self.current = copy_into(self.archive, running) if running is not None else None

    # -- what the gateway tells and asks ----------------------------------------------------------
    def answered(self) -> None:
        """The robot's firmware answered the protocol: the file it runs becomes the good one."""
        if self.current is not None:
            self.archive.mark_good(self.current)

    def good_firmware(self) -> Path | None:
        """What a rollback flashes: the last file that answered, else the built firmware."""
        good = self.archive.good()
        if good is not None:
            return good
        built = self.bootloader.built_firmware()
        return built if built.exists() else None

    def running(self) -> bool:
        return self.job.state == "running"

    def refusal(self) -> None:
        """Raises UpdateRefused if avrdude cannot reach the robot's bootloader from here."""
        self.bootloader.avrdude_port()

    def hurry(self) -> None:
        """A stop: a new firmware that has not answered yet gets HURRIED_CHECK_S more, then it
        is rolled back."""
        if self.running():
            self._hurry.set()

    def wait(self, timeout_s: float) -> bool:
        """Waits until no update runs; False if one still runs after timeout_s."""
        thread = self._thread
        if thread is not None:
            thread.join(timeout_s)
        return not self.running()

    # -- the job ---------------------------------------------------------------------------------
    def start(self, data: bytes) -> UpdateJob:
        """Checks the file now (ValueError if bad, nothing started) and flashes it in the background.
        UpdateRefused if nothing can flash the robot on this link."""
        self.refusal()
        size = check_hex(data)
        with self._lock:
            if self.running():
                raise RuntimeError("a firmware update is already running")
            path = self.archive.keep(data, ".hex")
            self._hurry.clear()
            self.job = UpdateJob(
                state="running", log=[f"checked: {size} bytes of program"], started_s=time.monotonic()
            )
            self._thread = threading.Thread(
                target=self._run, args=(path,), name="firmware update", daemon=True
            )
            self._thread.start()
            return self.job

    def _run(self, path: Path) -> None:
        job = self.job
        try:
            with self.resetting():
                self._install(path, job)
            job.log.append("done")
            job.state = "done"
        except Exception as exc:  # the job reports any failure instead of dying silently
            job.error = str(exc)
            job.log.append(f"failed: {exc}")
            job.state = "failed"
        finally:
            job.ended_s = time.monotonic()

    def _install(self, path: Path, job: UpdateJob) -> None:
        """Flashes `path` and checks it; else flashes the good firmware back and checks that."""
        good = self.good_firmware()
        try:
            self._flash(path, job)
            self._check(job, CHECK_S)
        except Exception as exc:
            if good is None:
                raise RuntimeError(
                    f"the new firmware does not answer ({exc}) and no firmware that answered is known to "
                    "restore: flash one (make flash)"
                ) from exc
            job.log.append(f"the new firmware does not answer ({exc}): restoring the previous one")
            self._hurry.clear()  # the previous firmware answered before: give it its full time
            self._flash(good, job)
            self._check(job, CHECK_S)
            raise RuntimeError("the new firmware was rejected; the previous firmware runs again") from exc

    def _flash(self, path: Path, job: UpdateJob) -> None:
        self.current = None  # unknown until avrdude has written it
        self._avrdude(path, job)
        self.current = path
        self.bootloader.flashed(path)

    def _check(self, job: UpdateJob, wait_s: float) -> None:
        if self.check is not None:
            job.log.append("checking that it answers")
            self.check(wait_s, self._hurry.is_set)

    def _avrdude(self, path: Path, job: UpdateJob) -> None:
        avrdude = shutil.which("avrdude")
        if avrdude is None:
            raise RuntimeError("avrdude is not installed (Debian package avrdude)")
        cmd = avrdude_command(avrdude, self.bootloader.avrdude_port(), self.baud, path)
        job.log.append(" ".join(cmd))
        with self.bootloader.programming():
            done = run_avrdude(cmd, job.log.append)
        job.log += [line for line in done.stderr.splitlines() if line.strip()][-20:]
        if done.returncode != 0:
            raise RuntimeError(f"avrdude exited with {done.returncode}")


def avrdude_command(avrdude: str, port: str, baud: int, path: Path) -> list[str]:
    """`make flash`'s command: STK500v1 to Optiboot, -D (Optiboot erases each page as it writes
    it), write then verify. On a pseudo-terminal (the simulator's) avrdude's DTR/RTS ioctls fail
    with a warning and it goes on: the simulator resets the MCU when the port opens instead, as
    the Nano's auto-reset capacitor does when DTR falls. An upload is Intel HEX (`:i`); the
    firmware a simulator was started on, which a rollback may write back, can be the ELF (`:e`)."""
    flash = f"flash:w:{path}:{'e' if is_elf(path) else 'i'}"
    return [avrdude, "-p", "m328p", "-c", "arduino", "-P", port, "-b", str(baud), "-D", "-U", flash]


def is_elf(path: Path) -> bool:
    try:
        with path.open("rb") as f:
            return f.read(4) == b"\x7fELF"
    except OSError:
        return False


# What avrdude 7.1 says when it never got in sync with the bootloader: the arduino programmer
# syncs while it opens the port ("unable to open programmer arduino on port ..."), other
# programmers while they initialise.
NEVER_IN_SYNC = ("unable to open programmer", "initialization failed")


def run_avrdude(cmd: list[str], note: Callable[[str], object]) -> subprocess.CompletedProcess[str]:
    """Runs avrdude, and once more if it never got in sync with the bootloader (nothing written):
    its first GET_SYNCs race Optiboot's start after the reset (wall-clock drains of 250 ms against
    the LED flashes), which a Nano loses now and then and a simulator that falls behind real time
    (a loaded machine) more often."""
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=AVRDUDE_TIMEOUT_S, check=False)
    if (
        done.returncode != 0
        and any(words in done.stderr for words in NEVER_IN_SYNC)
        and "bytes of flash" not in done.stderr
    ):
        note("avrdude could not get in sync with the bootloader: once more")
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=AVRDUDE_TIMEOUT_S, check=False)
    return done

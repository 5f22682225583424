"""`cart2d` in a process of its own with its own CART2D_HOME, and what it says on stderr."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

from tests.support.sockets import free_port


def cart2d(home: Path, *args: str, timeout_s: float = 60.0) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "cart2d.tools.cli", *args],
        env={**os.environ, "CART2D_HOME": str(home)},
        capture_output=True,
        text=True,
        timeout=timeout_s,
    )


class Running:
    """A `cart2d` process started by running_cart2d()."""

    def __init__(self, process: subprocess.Popen[str]) -> None:
        self.process = process
        self.err = ""  # stderr, when kept

    def stop(self, sig: int = signal.SIGTERM) -> str:
        """Ends it as a user would (SIGTERM, or SIGINT: Ctrl-C); what it printed on stdout."""
        self.process.send_signal(sig)
        out, err = self.process.communicate(timeout=30)
        self.err = err or ""
        return out or ""


@contextlib.contextmanager
def running_cart2d(home: Path, *args: str, keep_stderr: bool = False) -> Iterator[Running]:
    """`cart2d ARGS` running in its own process with its own CART2D_HOME, killed at the end if
    still running; stderr (its log) is dropped unless kept."""
    process = subprocess.Popen(
        [sys.executable, "-m", "cart2d.tools.cli", *args],
        env={**os.environ, "CART2D_HOME": str(home)},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE if keep_stderr else subprocess.DEVNULL,
        text=True,
    )
    try:
        yield Running(process)
    finally:
        process.kill()
        process.communicate()


def one_sentence(stderr: str) -> str:
    """stderr holds one line and no traceback; the line."""
    lines = [line for line in stderr.splitlines() if line.strip()]
    assert "Traceback" not in stderr and len(lines) == 1, stderr
    return lines[0]


def fake_ports_and_serve(tmp_path: Path, serial_port: str) -> subprocess.CompletedProcess[str]:
    """`cart2d serve --serial PORT` where pyserial sees two USB serial ports."""
    program = f"""
import sys
from serial.tools import list_ports, list_ports_common
def comports(include_links=False):
    found = []
    for device, what in (("/dev/ttyUSB7", "FT232R USB UART"), ("/dev/ttyACM3", "USB2.0-Serial")):
        port = list_ports_common.ListPortInfo(device, skip_link_detection=True)
        port.description = what
        found.append(port)
    return found
list_ports.comports = comports
from cart2d.tools.cli import main
sys.exit(main(["serve", "--serial", {serial_port!r}, "--port", "{free_port()}"]))
"""
    return subprocess.run(
        [sys.executable, "-c", program],
        env={**os.environ, "CART2D_HOME": str(tmp_path)},
        capture_output=True,
        text=True,
        timeout=30,  # the old gateway retried for ever
    )

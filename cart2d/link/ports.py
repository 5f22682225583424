"""The serial ports this machine has, for a sentence when the one asked for is not there
(`cart2d serve --serial`): pyserial's list_ports, which reads what the kernel lists of USB and
on-board serial devices (on Linux, /sys/class/tty)."""

from __future__ import annotations

import os

from serial.tools import list_ports


def visible_ports() -> list[str]:
    """Each serial port pyserial sees: its device, with what it is where it says ("/dev/ttyUSB0
    (FT232R USB UART)")."""
    found = []
    for port in sorted(list_ports.comports(), key=lambda p: p.device):
        what = port.description if port.description and port.description not in ("n/a", port.device) else ""
        found.append(f"{port.device} ({what})" if what else port.device)
    return found


def ports_sentence() -> str:
    ports = visible_ports()
    if not ports:
        return "no serial port is visible on this machine (is the cart's USB cable plugged in?)"
    return "the serial ports here: " + ", ".join(ports)


def port_problem(port: str) -> str | None:
    """Why `port` cannot be the cart's serial port, before trying to open it; None if it may be.
    A pyserial URL (socket://, rfc2217://, loop://) is left to pyserial."""
    if "://" in port:
        return None
    if not os.path.exists(port):
        return f"there is no serial port {port}"
    if not os.access(port, os.R_OK | os.W_OK):
        return (
            f"{port} may not be opened by this user (permission denied): add yourself to its group "
            "(on Debian and Ubuntu: sudo usermod -aG dialout $USER, then log in again)"
        )
    return None

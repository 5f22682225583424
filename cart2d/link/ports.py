"""The cart's serial port: a device path or any pyserial URL (docs/network-link.md), opened
with serial_for_url: `socket://host:port` (raw TCP, e.g. ESPHome's stream_server or ser2net's
tcp accepter), `rfc2217://host:port` (Telnet COM port control, e.g. ser2net's telnet(rfc2217)
accepter). For a sentence when a device asked for is not there (`cart2d serve
--serial`): pyserial's list_ports, which reads what the kernel lists of USB and on-board serial
devices (on Linux, /sys/class/tty)."""

from __future__ import annotations

import os
from urllib.parse import urlsplit

import serial
from serial.tools import list_ports

# A write to a raw TCP bridge waits at most this long for room in the socket's buffer (a stalled
# peer fills it): then SerialTimeoutException, and the link reopens. pyserial's rfc2217 client
# has no write timeout; its socket keeps the 5 s of its connect timeout.
NETWORK_WRITE_TIMEOUT_S = 1.0


def is_url(port: str) -> bool:
    return "://" in port


def open_port(port: str, baud: int, read_timeout_s: float) -> serial.Serial:
    """The port open: a device path, or a pyserial URL."""
    if not is_url(port):
        return serial.Serial(port, baud, timeout=read_timeout_s)
    if port.startswith("rfc2217://"):
        return serial.serial_for_url(with_option(port, "ign_set_control"), baud, timeout=read_timeout_s)
    return serial.serial_for_url(port, baud, timeout=read_timeout_s, write_timeout=NETWORK_WRITE_TIMEOUT_S)


def with_option(url: str, option: str) -> str:
    """`url` with a pyserial URL option (`?a&b`) added, unless it has it. The link needs
    ign_set_control on rfc2217: ser2net does not confirm the DTR/RTS settings pyserial sends on
    open when its device cannot take them (a pseudo-terminal, an adapter without the lines), and
    pyserial then gives up the connection ("timeout while waiting for option 'control'"); the
    link never reads the control lines back."""
    parts = urlsplit(url)
    options = [o for o in parts.query.split("&") if o]
    if any(o.split("=", 1)[0] == option for o in options):
        return url
    return parts._replace(query="&".join([*options, option])).geturl()


def url_problem(port: str, error: str) -> str:
    """One sentence for a network port that could not be opened."""
    where = urlsplit(port).netloc or port
    if "refused" in error.lower():
        return (
            f"nothing accepts connections at {where} ({port}): is the serial bridge (ser2net, ESPHome's "
            "stream_server, esp-link) running there, on that port?"
        )
    return f"cannot connect to {port}: {error}"


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

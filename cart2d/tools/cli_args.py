"""The command line's argument types and parser: a bad value is one sentence in argparse's words
(`cart2d sim: error: argument --port: ...`), exit status 2, checked before anything starts."""

from __future__ import annotations

import argparse
import math
from typing import NoReturn
from urllib.parse import urlsplit

from cart2d import __version__
from cart2d.spec import load_spec
from cart2d.store import address_or_host_name

SEED_MAX = 2**64 - 1  # the simulator's --seed is an unsigned 64-bit integer


class Parser(argparse.ArgumentParser):
    """argparse's parser, whose errors are one line: what is wrong, and where the help is."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message} ({self.prog} --help lists the options)\n")


def _number(text: str) -> float:
    """The number typed, NaN if it is none (a range check then refuses it with its sentence)."""
    try:
        return float(text)
    except ValueError:
        return math.nan


def port_number(text: str) -> int:
    try:
        port = int(text)
    except ValueError:
        port = -1
    if not 1 <= port <= 65535:
        raise argparse.ArgumentTypeError(f"{text!r} is not a port: give a whole number from 1 to 65535")
    return port


def camera_port_number(text: str) -> int:
    """A port P for the simulated ESP32-CAM, whose stream takes P + 1 as the stock sketch's does."""
    port = port_number(text)
    if port == 65535:
        raise argparse.ArgumentTypeError(
            "65535 leaves no port for the camera's stream (the next one): give 1 to 65534"
        )
    return port


def host(text: str) -> str:
    try:
        return address_or_host_name(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"{text!r}: {exc}") from None


def speed(text: str) -> str:
    """'max', or a positive factor of real time, kept as typed (the simulator's --speed)."""
    if text == "max":
        return text
    factor = _number(text)
    if not (math.isfinite(factor) and factor > 0.0):
        raise argparse.ArgumentTypeError(
            f"{text!r} is not a speed: give simulated seconds per second (a number above 0, such as "
            "1 or 10) or 'max'"
        )
    return text


def replay_speed(text: str) -> float:
    """A positive factor of the recorded pace (`cart2d replay --speed`)."""
    factor = _number(text)
    if not (math.isfinite(factor) and 0.0 < factor <= 1000.0):
        raise argparse.ArgumentTypeError(
            f"{text!r} is not a replay speed: give recorded seconds per second, above 0 and at most 1000"
        )
    return factor


def camera_fps(text: str) -> float:
    """The camera frames a second a recording keeps (`--record-camera-fps`): 0 for none."""
    fps = _number(text)
    if not (math.isfinite(fps) and 0.0 <= fps <= 60.0):
        raise argparse.ArgumentTypeError(
            f"{text!r} is not a frame rate: give frames a second from 0 (no camera frames) to 60"
        )
    return fps


def seed(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = -1
    if not 0 <= value <= SEED_MAX:
        raise argparse.ArgumentTypeError(f"{text!r} is not a seed: give a whole number from 0 to 2^64 - 1")
    return value


def camera_url(text: str) -> str:
    """The camera's base URL (http://HOST[:PORT]), checked as its stream's URL is made from it."""
    from cart2d.gateway.camera import stream_url_for

    try:
        stream_url_for(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text


def camera_stream_url(text: str) -> str:
    parts = urlsplit(text)
    if parts.scheme != "http" or not parts.hostname:
        raise argparse.ArgumentTypeError(f"the camera's stream must be an http:// URL, got {text!r}")
    return text


def version_text() -> str:
    spec = load_spec()
    table = f"{spec.dictionary_hash:#06x}"
    return f"cart2d {__version__} (firmware protocol {spec.version}, command table {table})"

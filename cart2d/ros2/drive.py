"""cmd_vel into the panel's manual-drive path (Gateway.drive): the firmware's manual timeout
stops the cart 0.5 s after the last command (robot.toml, manual_timeout_s), the speeds are
clamped to the firmware's limits as the panel's joystick clamps them, and a stop wins.

A stream of cmd_vel (commands less than the timeout apart) belongs to the stop generation of its
first command (Link.motion_token): a stop on the API, the panel or the `stop` service cancels the
rest of the stream, however fast teleop keeps sending; the next stream, after a silence as long
as the timeout, drives again. Commands are coalesced: the driver sends the newest, never a queue
of old ones (a slow link must not replay the past)."""

from __future__ import annotations

import logging
import math
import threading
from collections.abc import Callable
from dataclasses import dataclass

from cart2d.link import CommandRefused, LinkError, MotionCancelled
from cart2d.params import settings_table

log = logging.getLogger(__name__)


def _default(name: str) -> float:
    return float(next(entry["default"] for entry in settings_table() if entry["name"] == name))


SILENCE_S = _default("manual_timeout_s")  # a new stream after this long without a command


@dataclass(frozen=True)
class DriveCommand:
    v_mps: float
    omega_radps: float
    token: int  # the stop generation of the command's stream


def speed_limits(settings: list[dict[str, object]]) -> tuple[float, float]:
    """v_max_mps and w_max_radps from the firmware's settings (the defaults where missing)."""
    values = {str(e.get("name")): e.get("value") for e in settings}
    out = []
    for name in ("v_max_mps", "w_max_radps"):
        value = values.get(name)
        out.append(float(value) if isinstance(value, int | float) and value > 0 else _default(name))
    return out[0], out[1]


def _clamped(value: float, limit: float) -> float:
    return max(-limit, min(limit, value))


class CmdVelGate:
    """Admits cmd_vel samples: finite, clamped, with their stream's token."""

    def __init__(
        self,
        motion_token: Callable[[], int],
        limits: Callable[[], tuple[float, float]],
        clock: Callable[[], float],
        silence_s: float = SILENCE_S,
    ) -> None:
        self._motion_token = motion_token
        self._limits = limits
        self._clock = clock
        self._silence_s = silence_s
        self._last_s: float | None = None
        self._token = 0

    def admit(self, v_mps: float, omega_radps: float) -> DriveCommand | None:
        """The command to send, or None (logged) for a sample that is not a speed."""
        if not (math.isfinite(v_mps) and math.isfinite(omega_radps)):
            log.warning("cmd_vel dropped: its speeds are not finite (v %r, omega %r)", v_mps, omega_radps)
            return None
        now = self._clock()
        if self._last_s is None or now - self._last_s >= self._silence_s:
            self._token = self._motion_token()  # a new stream
        self._last_s = now
        v_max, w_max = self._limits()
        return DriveCommand(_clamped(v_mps, v_max), _clamped(omega_radps, w_max), self._token)


class Driver:
    """Sends the newest admitted command with Gateway.drive on a thread of its own."""

    def __init__(self, drive: Callable[[float, float, int], None]) -> None:
        self._drive = drive
        self._newest: DriveCommand | None = None
        self._wake = threading.Condition()
        self._closed = False
        self._cancelled_token: int | None = None
        self._sending = False
        self.sent = 0
        self.skipped = 0  # commands of a stream a stop cancelled, not sent
        self.cancelled = 0  # commands the link refused for a stop after their stream began
        self._thread = threading.Thread(target=self._run, name="ros2 cmd_vel", daemon=True)

    def start(self) -> Driver:
        self._thread.start()
        return self

    @property
    def busy(self) -> bool:
        """A command waits or is being sent."""
        with self._wake:
            return self._newest is not None or self._sending

    def offer(self, command: DriveCommand) -> None:
        with self._wake:
            self._newest = command
            self._wake.notify()

    def close(self) -> None:
        with self._wake:
            self._closed = True
            self._wake.notify()
        self._thread.join(timeout=5.0)

    def _run(self) -> None:
        while True:
            with self._wake:
                while self._newest is None and not self._closed:
                    self._wake.wait()
                if self._closed:
                    return
                command, self._newest = self._newest, None
                self._sending = True
            assert command is not None
            if command.token == self._cancelled_token:
                self.skipped += 1  # the rest of a stream a stop cancelled
            else:
                self._send(command)
            with self._wake:
                self._sending = False

    def _send(self, command: DriveCommand) -> None:
        try:
            self._drive(command.v_mps, command.omega_radps, command.token)
            self.sent += 1
        except MotionCancelled:
            self.cancelled += 1
            self._cancelled_token = command.token
            log.warning("cmd_vel ignored after a stop until it pauses for %.1f s", SILENCE_S)
        except CommandRefused as exc:
            log.info("cmd_vel refused by the firmware: %s", exc)
        except LinkError as exc:
            log.warning("cmd_vel not sent: %s", exc)
        except Exception:  # the driver must outlive a command the gateway could not take
            log.exception("cmd_vel not sent")

"""The STATUS monitor: a thread that reads STATUS a few times a second, also when nothing runs
(that is how restarts are noticed: restarts.py sees every STATUS), and hands each one to what it
follows (the mission, the reset routine) so they are ended when the firmware shows their end.

What it follows says what it was running when the STATUS was asked for (before_status): a path
or routine started while the STATUS was on its way is not ended by the stale answer."""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any, Protocol

from cart2d.gateway.bus import Closing, EventBus
from cart2d.gateway.state import BUSY_POLL_S, STATUS_POLL_S
from cart2d.link import CommandRefused, Link, LinkError, firmware


class Followed(Protocol):
    """A service whose end the monitor watches for in STATUS."""

    def busy(self) -> bool:
        """Whether it runs now (STATUS is read more often then)."""
        ...

    def before_status(self) -> Any:
        """What runs now, as handed back to after_status with the STATUS asked for after this."""
        ...

    def after_status(self, status: firmware.Status, running: Any) -> None: ...


class Monitor:
    def __init__(
        self,
        link: Link,
        bus: EventBus,
        read_status: Callable[[], firmware.Status],
        read_pose: Callable[[], object],
        telemetry_age_s: Callable[[], float],
    ) -> None:
        """`read_status`: STATUS through the restart watch; `read_pose`: POSE, for /api/status
        while telemetry is off (`telemetry_age_s`: since the last frame)."""
        self.link = link
        self._read_status = read_status
        self._read_pose = read_pose
        self._telemetry_age_s = telemetry_age_s
        self._followed: list[Followed] = []
        self._stop = threading.Event()
        self.woken = threading.Event()  # look at STATUS now, not at the next poll
        self._last_tick: int | None = None
        self._thread = threading.Thread(target=self._watch, name="gateway monitor", daemon=True)
        self._bus = bus

    def follow(self, followed: Followed) -> None:
        """Hands `followed` every STATUS from now on, after those added before it."""
        self._followed.append(followed)

    def wake(self) -> None:
        self.woken.set()

    def on_tick(self, tick: int) -> None:
        """Telemetry's 16-bit TICK: going backwards (not its wrap), the MCU may have restarted."""
        last, self._last_tick = self._last_tick, tick
        if last is not None and (tick - last) % 65536 > 32768:
            self.woken.set()

    def start(self) -> None:
        """Starts the thread, which the gateway's Closing ends."""
        self._bus.subscribe(Closing, lambda _: self.close())
        self._thread.start()

    def close(self) -> None:
        self._stop.set()
        if self._thread.ident is not None:
            self._thread.join(timeout=2.0)

    def _watch(self) -> None:
        while not self._stop.is_set():
            busy = any(f.busy() for f in self._followed)
            self.woken.wait(BUSY_POLL_S if busy else STATUS_POLL_S)
            self.woken.clear()
            if self._stop.is_set() or not self.link.connected.is_set():
                continue
            try:
                self.look()
            except (LinkError, CommandRefused):
                continue  # the link is reconnecting: the firmware keeps driving on its own

    def look(self) -> firmware.Status:
        """One round: STATUS, handed to what is followed; LinkError / CommandRefused as read."""
        running = [f.before_status() for f in self._followed]
        status = self._read_status()
        for followed, was in zip(self._followed, running, strict=True):
            followed.after_status(status, was)
        if self._telemetry_age_s() > 2 * BUSY_POLL_S:  # telemetry is off
            self._read_pose()  # for /api/status, which reads none itself (status_cache.py)
        return status

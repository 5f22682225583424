"""The firmware's speed limits for cmd_vel, known before a command needs them.

Reading the settings can take a round trip per setting (~100 ms at 1x for the whole table, the
gateway's SettingsCache fills after any change). That read was on the cmd_vel path: the first
command of a run, and the first after any settings change, waited for it. Here the gate takes
the limits last read at once, and a thread of its own reads them again when asked (at start,
after each command): a change reaches the gate one command late, and the firmware refuses
(OUT_OF_RANGE) a speed beyond its own limits meanwhile, so a stale limit never drives faster."""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable

from cart2d.ros2.drive import speed_limits

log = logging.getLogger(__name__)


class KnownLimits:
    """(v_max_mps, w_max_radps) as last read (the defaults until then); refresh() reads them,
    wake() asks the refreshing thread to, without waiting."""

    def __init__(self, read_settings: Callable[[], list[dict[str, object]]]) -> None:
        self._read_settings = read_settings
        self._limits = speed_limits([])
        self._wanted = threading.Event()
        self._closed = False
        self._thread = threading.Thread(target=self._run, name="ros2 speed limits", daemon=True)

    def __call__(self) -> tuple[float, float]:
        return self._limits  # one reference, swapped whole: no lock needed to read it

    def refresh(self) -> None:
        try:
            self._limits = speed_limits(self._read_settings())
        except Exception as exc:  # the link down: the limits last read stand
            log.info("the speed limits were not read again: %s", exc)

    def start(self) -> KnownLimits:
        self._thread.start()
        self.wake()  # read before the first command comes
        return self

    def wake(self) -> None:
        self._wanted.set()

    def close(self) -> None:
        self._closed = True
        self._wanted.set()
        if self._thread.is_alive():
            self._thread.join(timeout=5.0)

    def _run(self) -> None:
        while True:
            self._wanted.wait()
            self._wanted.clear()
            if self._closed:
                return
            self.refresh()

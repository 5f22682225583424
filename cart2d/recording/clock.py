"""A session's time axis, in ns: the log time of every message and the timestamp of its header.

One file has one time axis (the Foxglove app matches the frame tree and the poses by their
times). On a real cart it is the wall clock. In simulation it is the simulator's time, from its
truth messages (the SDK takes an explicit log_time), placed at the session's wall-clock start so
that the file shows a real date: a mission run at `--speed max` is then recorded, and replayed, at
the pace the cart really moved. Messages between two truth messages (telemetry, events) take the
time of the latest one (50 Hz: 20 ms apart). The axis never goes back: a wall clock stepped back
(NTP) or a simulator restarted at t = 0 continues from the last time given.
"""

from __future__ import annotations

import threading
import time


class SessionClock:
    def __init__(self, simulated: bool) -> None:
        self.simulated = simulated
        self._lock = threading.Lock()
        self._last_ns = time.time_ns()
        self._offset_ns = self._last_ns  # simulated time 0, on the wall clock
        self._sim_t_ns: int | None = None

    def now_ns(self) -> int:
        """The time of a message handed over now."""
        with self._lock:
            if not self.simulated:
                self._last_ns = max(time.time_ns(), self._last_ns)
            return self._last_ns

    def truth_ns(self, sim_t_s: float) -> int:
        """The time of a truth message of the simulator's time sim_t_s (s)."""
        with self._lock:
            if not self.simulated:
                self._last_ns = max(time.time_ns(), self._last_ns)
                return self._last_ns
            t_ns = round(sim_t_s * 1e9)
            if self._sim_t_ns is not None and t_ns < self._sim_t_ns:  # a new simulator: go on from here
                self._offset_ns = self._last_ns - t_ns
            self._sim_t_ns = t_ns
            self._last_ns = max(self._offset_ns + t_ns, self._last_ns)
            return self._last_ns

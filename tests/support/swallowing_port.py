"""A serial port that answers nothing and records what the link wrote to it, and when."""

from __future__ import annotations

import os
import select
import threading
import time


# -- a fake port that swallows every request ---------------------------------------------------
class SwallowingPort:
    """A pseudo-terminal the link opens as its serial port; every byte it writes is recorded
    with the time it arrived, and nothing is ever answered."""

    def __init__(self) -> None:
        self._master, self._slave = os.openpty()
        self.name = os.ttyname(self._slave)
        self.chunks: list[tuple[float, bytes]] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._read, daemon=True)
        self._thread.start()

    def _read(self) -> None:
        while not self._stop.is_set():
            ready, _, _ = select.select([self._master], [], [], 0.01)
            if ready:
                self.chunks.append((time.monotonic(), os.read(self._master, 4096)))

    def requests(self, size: int) -> list[tuple[float, bytes]]:
        """The requests written, each with the arrival time of its first byte."""
        out: list[tuple[float, bytes]] = []
        data = b""
        for t, chunk in self.chunks:
            for b in chunk:
                if not data:
                    start = t
                data += bytes([b])
                if len(data) == size:
                    out.append((start, data))
                    data = b""
        return out

    def close(self) -> None:
        self._stop.set()
        self._thread.join()
        os.close(self._master)
        os.close(self._slave)

"""A fake clock for logic timed by a `Callable[[], float]`: it reads `t`, which the test moves."""

from __future__ import annotations


class FakeClock:
    def __init__(self, t: float = 100.0) -> None:
        self.t = t

    def __call__(self) -> float:
        return self.t

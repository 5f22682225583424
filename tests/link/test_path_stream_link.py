"""The path stream over a link that loses requests and replies (issue 22, "a slightly noisy link
ends missions"): a firmware fake that keeps the waypoint window as docs/protocol.md says, and a
link that fails the calls it is told to. No physics is needed: the cart's progress is a few
waypoints per STATUS read, and outages are counted in calls, not seconds."""

from __future__ import annotations

from typing import Any

import pytest

from cart2d.link import CommandRefused, LinkTimeout, path_stream
from cart2d.link.protocol import Reply
from cart2d.spec import load_spec

WINDOW = 32
STEP = 3
PATH_MODE = next(code for code, name in load_spec().modes.items() if name == "PATH")
IDLE_MODE = next(code for code, name in load_spec().modes.items() if name == "IDLE")


class FakeLine:
    def __init__(self, byte_error_rate: float) -> None:
        self.rate = byte_error_rate

    def byte_error_rate(self) -> float:
        return self.rate


class WindowFirmware:
    """The firmware's path window behind a link whose calls fail on demand: `outage` calls in a
    row raise LinkTimeout unexecuted, and `lose_reply` names commands whose next reply is lost
    after they were executed (LinkTimeout all the same). Each STATUS moves the cart STEP
    waypoints on, as far as the points received allow."""

    def __init__(self, byte_error_rate: float = 0.0) -> None:
        self.line = FakeLine(byte_error_rate)
        self.telemetry_count = 0
        self.telemetry = None
        self.count = self.received = self.index = 0
        self.driving = False
        self.outage = 0
        self.lose_reply: set[str] = set()
        self.frames: list[tuple[str, int]] = []  # (command, points it carried), as executed
        self.calls = 0

    def motion_token(self) -> int:
        return 0

    def call(self, command: str, *args: float, **options: Any) -> tuple[float, ...]:
        self.calls += 1
        if self.outage > 0:
            self.outage -= 1
            raise LinkTimeout(f"no reply to COMMAND_{command} (an outage)")
        results: tuple[float, ...] = getattr(self, command.lower())(*args)
        if command in self.lose_reply:
            self.lose_reply.discard(command)
            raise LinkTimeout(f"no reply to COMMAND_{command} (its reply was lost)")
        return results

    def _room(self) -> int:
        return max(0, min(self.count, max(self.index - 1, 0) + WINDOW) - self.received)

    def _pacing(self) -> tuple[float, ...]:
        return (float(self.received), float(self.index), float(self._room()))

    def wait_xy_array(self, n: float, *xy: float) -> tuple[float, ...]:
        self.count, self.received, self.index, self.driving = int(n), len(xy) // 2, 0, True
        self.frames.append(("WAIT_XY_ARRAY", len(xy) // 2))
        return self._pacing()

    def xy_append(self, index: float, *xy: float) -> tuple[float, ...]:
        points = len(xy) // 2
        if int(index) != self.received or points > self._room():
            raise CommandRefused(Reply(0, 1, 20, (10.0,)))
        self.received += points
        self.frames.append(("XY_APPEND", points))
        return self._pacing()

    def status(self) -> tuple[float, ...]:
        if self.driving:
            self.index = min(self.index + STEP, self.received, self.count)
            self.driving = self.index < self.count
        mode = PATH_MODE if self.driving else IDLE_MODE
        return (mode, 0, self.index, self.count, 0, 0, 0, 0, 0, 0, 1.0, 0, 0, 1, 0, self.received)

    def version(self) -> tuple[float, ...]:
        return (1.0, 100.0, 0.0, 1.0, float(WINDOW), 30.0)


POINTS = [(0.01 * k, 0.0) for k in range(120)]


def drive_to_the_end(link: WindowFirmware) -> path_stream.PathStream:
    stream = path_stream.upload_path(link, POINTS)  # type: ignore[arg-type]
    assert stream.join(30.0)
    return stream


def test_a_link_that_recovers_costs_the_stream_nothing() -> None:
    # Each lost reply or outage ended the stream ("the link failed while streaming the path") and
    # with it the mission, with the cart stopped at the end of the points it had.
    link = WindowFirmware()
    link.outage = 3  # the first WAIT_XY_ARRAY and its resends are lost
    link.lose_reply = {"XY_APPEND"}  # one append arrives, its reply does not
    stream = path_stream.upload_path(link, POINTS)  # type: ignore[arg-type]
    link.outage = 25  # then 25 calls in a row fail: STATUS and appends
    assert stream.join(30.0)
    assert not stream.failure and stream.sent == link.received == len(POINTS)
    assert [points for command, points in link.frames if command == "WAIT_XY_ARRAY"] == [15]


def test_a_lost_reply_to_a_path_that_arrived_does_not_send_it_twice() -> None:
    link = WindowFirmware()
    link.lose_reply = {"WAIT_XY_ARRAY"}
    stream = drive_to_the_end(link)
    assert not stream.failure and stream.sent == len(POINTS)
    assert [command for command, _ in link.frames].count("WAIT_XY_ARRAY") == 1  # STATUS said it arrived
    assert link.received == len(POINTS) and stream.window == WINDOW


def test_a_link_that_stays_down_ends_the_stream_with_a_sentence(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(path_stream, "LINK_GRACE_S", 0.3)
    link = WindowFirmware()
    stream = path_stream.upload_path(link, POINTS)  # type: ignore[arg-type]
    link.outage = 1_000_000
    assert stream.join(30.0)
    assert stream.failure.startswith("the link failed while streaming the path: no answer for ")


@pytest.mark.parametrize(("byte_error_rate", "most"), [(0.0, 15), (0.01, 12), (0.05, 2)])
def test_frames_carry_as_many_points_as_the_lines_error_rate_makes_worth_it(
    byte_error_rate: float, most: int
) -> None:
    # Every frame carried 15 points: at 5 % of bytes lost, a 131-byte WAIT_XY_ARRAY and its reply
    # arrive whole once in 2 500 tries, and no mission started.
    assert path_stream.frame_points(byte_error_rate) == most
    link = WindowFirmware(byte_error_rate)
    stream = drive_to_the_end(link)
    assert not stream.failure and link.received == len(POINTS)
    assert max(points for _, points in link.frames) == most

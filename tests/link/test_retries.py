"""The link's retries on a line that loses replies (issue 22, "a slightly noisy link ends
missions"): a lost reply costs a retry, not a request; a STOP is resent fastest; a read waiting
for its reply gives way to a STOP and is asked again after it. Against a firmware fake on a
pseudo-terminal that answers as the firmware does (a repeated SEQ and CRC from memory) and loses
the replies it is told to (tests/support/pty_firmware.py). No assertion on the wall clock:
counts, orders and ratios."""

from __future__ import annotations

import os
import random
import threading
from collections.abc import Callable, Iterator

import pytest

from cart2d.link import Link, LinkTimeout
from cart2d.link.protocol import Packet, encode_reply, encode_request
from cart2d.link.transport import RETRANSMIT_WINDOW_S
from cart2d.spec import load_spec
from tests.support.pty_firmware import FakeFirmware
from tests.support.swallowing_port import SwallowingPort

SPEC = load_spec()


@pytest.fixture
def swallowing() -> Iterator[SwallowingPort]:
    port = SwallowingPort()
    yield port
    port.close()


@pytest.fixture
def fake_factory() -> Iterator[Callable[[Callable[[str, int], bool]], FakeFirmware]]:
    made: list[FakeFirmware] = []

    def make(answers: Callable[[str, int], bool]) -> FakeFirmware:
        made.append(FakeFirmware(answers))
        return made[-1]

    yield make
    for fake in made:
        fake.close()


def test_a_lost_reply_costs_a_retry_not_the_request(
    fake_factory: Callable[[Callable[[str, int], bool]], FakeFirmware],
) -> None:
    # Half the replies lost: with 5 tries a request failed once in 32 (at 1 % of bytes lost both
    # ways, STATUS's exchange is lost about as often), and every failure ended a mission.
    rng = random.Random(22)
    fake = fake_factory(lambda name, n: rng.random() < 0.5)
    with Link(fake.name).open() as link:
        for _ in range(60):
            link.call("PARAM_SET", 1.0, 0.5)
            link.call("STATUS")
        assert link.retransmissions > 30  # replies were lost, and resent for
    # Retransmissions were answered from memory: each PARAM_SET was executed once.
    assert fake.executed.count("PARAM_SET") == 60


def test_a_stop_is_resent_far_sooner_than_an_ordinary_request(swallowing: SwallowingPort) -> None:
    # A lost STOP was resent only after the 250 ms a reply may take: the cart drove on for it.
    # Side by side on one line that answers nothing: tries of a STOP and of a read in the same
    # retransmission window (1.5 s).
    size = len(encode_request(0, SPEC.code("STOP")))  # STATUS's request is as long
    with Link(swallowing.name).open() as link:
        with pytest.raises(LinkTimeout):
            link.stop()
        stops = len(swallowing.requests(size))
        with pytest.raises(LinkTimeout):
            link.call("STATUS")
        reads = len(swallowing.requests(size)) - stops
    assert reads >= 2
    assert stops >= 3 * reads  # 25 ms against 250 ms: ten times as many on an idle machine


def test_a_read_waiting_for_its_reply_gives_way_to_a_stop_and_is_answered_after_it(
    fake_factory: Callable[[Callable[[str, int], bool]], FakeFirmware],
) -> None:
    # A read held the link for its whole wait (here 5 s), and a stop waited behind it; a read
    # that had waited through a stop failed ("it gave way to a STOP").
    stopped = threading.Event()

    def answers(name: str, n: int) -> bool:
        if name == "STOP":
            stopped.set()
        return name == "STOP" or stopped.is_set()

    fake = fake_factory(answers)
    with Link(fake.name, timeout_s=5.0).open() as link:
        results: list[object] = []
        reader = threading.Thread(target=lambda: results.append(link.call("STATUS")))
        reader.start()
        while "STATUS" not in fake.received:
            threading.Event().wait(0.005)
        assert link.stop().ok
        reader.join(10.0)
    assert fake.received == ["STATUS", "STOP", "STATUS"]  # cut short, stopped, asked again
    assert len(results) == 1 and isinstance(results[0], tuple)


class LateFirmware(FakeFirmware):
    """Answers a request's first SEQ only, and only `delay_s` later: a host whose reader decodes
    the reply long after it came (a busy machine), or a line with a long queue."""

    def __init__(self, delay_s: float) -> None:
        self.delay_s = delay_s
        self.first_seq: int | None = None
        super().__init__(lambda name, n: False)

    def _handle(self, packet: Packet) -> None:
        super()._handle(packet)
        if self.first_seq is None:
            self.first_seq = packet.seq
            reply = encode_reply(packet.seq, 0, packet.body[0], [0.0] * 16)
            threading.Timer(self.delay_s, os.write, (self._master, reply)).start()


def test_a_reply_later_than_the_retransmission_window_still_answers_its_request() -> None:
    # A STOP answered 147 times without one reply in 6.5 s on a busy machine: each reply reached
    # the reader after its round (1.5 s) had ended and a new SEQ was waited for.
    fake = LateFirmware(delay_s=RETRANSMIT_WINDOW_S + 0.3)
    try:
        with Link(fake.name).open() as link:
            reply = link.request("STATUS")
    finally:
        fake.close()
    assert reply.seq == fake.first_seq
    assert fake.received.count("STATUS") > 1  # a second round with a new SEQ began before it came

"""The link's two rules about time (docs/protocol.md): a partial packet is dropped once it has
waited longer than its line time plus 50 ms ("Host receiving"), and a request is retransmitted
only within 1.5 s of its first transmission ("Retransmission and duplicates")."""

from __future__ import annotations

import os
import select
import threading
import time
from collections.abc import Iterator, Sequence
from pathlib import Path

import pytest
import serial

from cart2d.link import Link, LinkTimeout
from cart2d.link.protocol import (
    PARTIAL_MARGIN_S,
    Decoder,
    Packet,
    Telemetry,
    encode_reply,
    encode_request,
    encode_telemetry,
)
from cart2d.link.transport import RETRANSMIT_WINDOW_S
from cart2d.spec import load_spec, load_vectors
from tests.support.sim import start_sim
from tests.support.swallowing_port import SwallowingPort

BYTE_S = 10 / 115200  # one byte on the line, 8N1
BOGUS_HEADER = b"\x7e\x7f"  # a start byte and a corrupted LEN that promises 127 bytes of body
BOGUS_DEADLINE_S = (127 + 5) * BYTE_S + PARTIAL_MARGIN_S


def reply(seq: int) -> bytes:
    return encode_reply(seq, 0, 12, [0.005])  # TOL_GET's reply, 12 bytes


def seqs(items: Sequence[Packet | Telemetry]) -> list[int]:
    return [p.seq for p in items if isinstance(p, Packet)]


# -- the decoder, fed timestamped chunks --------------------------------------------------------
def test_a_corrupted_length_holds_the_next_replies_only_until_its_time_is_up() -> None:
    decoder = Decoder()
    assert decoder.feed(BOGUS_HEADER, 0.0) == []
    assert decoder.feed(reply(1), 0.001) == []  # held: it may still be the bogus packet's body
    assert decoder.feed(b"", BOGUS_DEADLINE_S - 1e-6) == []
    assert seqs(decoder.feed(b"", BOGUS_DEADLINE_S + 1e-6)) == [1]  # the start byte dropped, rescanned
    assert decoder.expired == 1 and decoder.errors == 1
    assert seqs(decoder.feed(reply(2), BOGUS_DEADLINE_S + 0.002)) == [2]  # nothing held any more


def test_replies_every_10_ms_after_a_corrupted_length_are_each_late_by_at_most_the_deadline() -> None:
    """The issue's case: one reply with a corrupted LEN held back the next 16 replies, until
    enough bytes had arrived to fill the promised length."""
    decoder = Decoder()
    corrupted = bytearray(encode_reply(0, 0, 19, [0.0] * 15))  # a STATUS reply, 68 bytes
    corrupted[1] = 0x7F
    delivered: dict[int, float] = {}
    t = 0.0
    for data in [bytes(corrupted)] + [reply(k) for k in range(1, 17)]:
        for item in decoder.feed(data, t):
            delivered[seqs([item])[0]] = t
        t += 0.010
        for item in decoder.feed(b"", t - 0.005):  # the reader's empty reads in between
            delivered[seqs([item])[0]] = t - 0.005
    assert sorted(delivered) == list(range(1, 17))
    for seq, at in delivered.items():
        sent = 0.010 * seq
        assert at <= max(sent, BOGUS_DEADLINE_S + 0.005) + 1e-9, (seq, at)


def test_a_packet_trickling_in_at_line_speed_or_with_latency_is_kept() -> None:
    data = reply(3)
    decoder = Decoder()
    found = [i for k, b in enumerate(data) for i in decoder.feed(bytes([b]), k * BYTE_S)]
    assert seqs(found) == [3]
    decoder = Decoder()  # a USB adapter holds the second half back for 40 ms
    assert decoder.feed(data[:5], 0.0) == []
    assert decoder.feed(b"", 0.045) == []
    assert seqs(decoder.feed(data[5:], 0.045)) == [3] and decoder.errors == 0


def test_an_incomplete_telemetry_frame_and_a_lone_start_byte_expire_too() -> None:
    frame = encode_telemetry([0.0] * 16, 7)
    decoder = Decoder()
    assert decoder.feed(frame[:30], 0.0) == []
    assert seqs(decoder.feed(reply(4), 0.001)) == []
    deadline = len(frame) * BYTE_S + PARTIAL_MARGIN_S
    assert seqs(decoder.feed(b"", deadline + 1e-6)) == [4]
    decoder = Decoder()
    assert decoder.feed(b"\x7e", 0.0) == []  # LEN never came: waits for the shortest packet
    assert decoder.feed(b"", 7 * BYTE_S + PARTIAL_MARGIN_S + 1e-6) == [] and decoder.expired == 1


def test_the_stream_vectors_still_decode_without_timestamps() -> None:
    # feed() without a time stamps with time.monotonic(): a stream fed at once is complete
    streams = [v for v in load_vectors() if v.kind == "stream"]
    assert streams
    for v in streams:
        assert seqs(Decoder().feed(v.data)) == [int(s) for s in v.fields["seqs"].split(",")]


@pytest.fixture
def swallowing() -> Iterator[SwallowingPort]:
    port = SwallowingPort()
    yield port
    port.close()


def test_a_request_is_retransmitted_only_within_1_5_s_of_its_first_transmission(
    swallowing: SwallowingPort,
) -> None:
    link = Link(swallowing.name, timeout_s=0.2, retries=20).open()  # 20 retries would take 4.2 s
    try:
        started = time.monotonic()
        with pytest.raises(LinkTimeout, match="no reply to COMMAND_GOTO"):
            link.call("GOTO", 1.0, 0.5)
        gave_up_s = time.monotonic() - started
        time.sleep(0.5)  # a retransmission after the give-up would show here
    finally:
        link.close()
    size = len(encode_request(0, load_spec().code("GOTO"), [1.0, 0.5]))
    attempts = swallowing.requests(size)
    assert len(attempts) >= 4  # it did retransmit, every 0.2 s
    assert all(data == attempts[0][1] for _, data in attempts)  # the identical bytes: same SEQ
    first, last = attempts[0][0], attempts[-1][0]
    # The link checks the window just before it writes; the pty adds well under 0.1 s.
    assert last - first <= RETRANSMIT_WINDOW_S + 0.1
    assert len(attempts) <= 1 + RETRANSMIT_WINDOW_S / 0.2 + 1
    assert link.retransmissions == len(attempts) - 1
    assert gave_up_s < RETRANSMIT_WINDOW_S + 0.2 + 1.0  # the last wait, and a loaded machine


# -- end to end: the real firmware's replies behind a corrupted length --------------------------
class Splice:
    """Stands between the link and the simulator's pty, passing bytes both ways, and can slip
    bytes of its own into the stream towards the host."""

    def __init__(self, sim_pty: str) -> None:
        self._master, self._slave = os.openpty()
        self.name = os.ttyname(self._slave)
        self._sim = serial.Serial(sim_pty, 115200, timeout=0.01)
        self._lock = threading.Lock()  # one writer towards the host at a time
        self._stop = threading.Event()
        self._threads = [
            threading.Thread(target=self._to_sim, daemon=True),
            threading.Thread(target=self._to_host, daemon=True),
        ]
        for thread in self._threads:
            thread.start()

    def _to_sim(self) -> None:
        while not self._stop.is_set():
            ready, _, _ = select.select([self._master], [], [], 0.01)
            if ready:
                self._sim.write(os.read(self._master, 4096))

    def _to_host(self) -> None:
        while not self._stop.is_set():
            data = self._sim.read(4096)
            if data:
                with self._lock:
                    os.write(self._master, data)

    def inject(self, data: bytes) -> None:
        with self._lock:
            os.write(self._master, data)

    def close(self) -> None:
        self._stop.set()
        for thread in self._threads:
            thread.join()
        self._sim.close()
        os.close(self._master)
        os.close(self._slave)


def test_the_next_reply_is_not_held_back_by_a_corrupted_length_from_the_firmware(tmp_path: Path) -> None:
    sim = start_sim(tmp_path)
    splice = Splice(sim.pty)
    # A generous per-try timeout: the reply must come in the first try, not by retransmission.
    link = Link(splice.name, timeout_s=1.0, retries=4).open()
    try:
        link.call("TELEMETRY", 0.0)  # quiet between replies: only a retry's reply could fill the gap
        time.sleep(0.1)  # the last frame already on its way
        # Opening the port reset the MCU (DTR): a request during its start-up may have needed a
        # retry, and a partial frame of the start-up (the reset cuts the frame being sent short)
        # reaches the link when the splice relays it after the link has opened (on a busy
        # machine 9 runs in 15 counted 6 partials, not 5). Everything before TELEMETRY's reply
        # has been decoded or dropped by the time it came (the decoder keeps the stream's order):
        # count from here.
        link.retransmissions = 0
        partials_before = link.partials_dropped
        for k in range(5):
            splice.inject(BOGUS_HEADER)
            assert link.call("TOL_SET", 0.01 + 0.001 * k)[0] == pytest.approx(0.01 + 0.001 * k)
            assert link.call("TOL_GET")[0] == pytest.approx(0.01 + 0.001 * k)
        assert link.retransmissions == 0
        assert link.partials_dropped - partials_before == 5
    finally:
        link.close()
        splice.close()
        sim.stop()

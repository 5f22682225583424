"""bench/firmware.py's Port: the serial port of a paused simulator stepped from Python. A reply
spans many steps, so its bytes are read over many polls, however long the host takes between
them (a busy machine): a run must not depend on the wall clock."""

from __future__ import annotations

import os
from collections.abc import Iterator

import pytest

from bench.firmware import Port
from cart2d.link.protocol import PARTIAL_MARGIN_S, encode_reply
from cart2d.spec import load_spec


@pytest.fixture
def pty_pair() -> Iterator[tuple[int, str]]:
    """The simulator's end (a file descriptor to write to) and the host's end (a path)."""
    sim_end, host_end = os.openpty()
    try:
        yield sim_end, os.ttyname(host_end)
    finally:
        os.close(sim_end)
        os.close(host_end)


def test_a_reply_read_over_polls_far_apart_in_wall_time_is_decoded(
    pty_pair: tuple[int, str], monkeypatch: pytest.MonkeyPatch
) -> None:
    sim_end, host_path = pty_pair
    wall = [1000.0]  # a fake wall clock: the host is slow, the line is not
    monkeypatch.setattr("cart2d.link.protocol.time.monotonic", lambda: wall[0])
    port = Port(host_path, seed=0)
    try:
        seq = port.send("STATUS")
        reply = encode_reply(seq, 0, load_spec().code("STATUS"), [float(i) for i in range(16)])
        for k in range(0, len(reply), 2):  # the bytes of 0.1 ms steps, two at a time
            os.write(sim_end, reply[k : k + 2])
            port.poll()
            wall[0] += 2 * PARTIAL_MARGIN_S  # the host's work between two steps
        assert seq in port.replies
        assert port.replies[seq].results == tuple(float(i) for i in range(16))
    finally:
        port.close()

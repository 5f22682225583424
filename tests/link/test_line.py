"""How long the link waits for a reply (cart2d/link/line.py), as pure arithmetic on what it
measured: the line's latency, its error rate, and back-off sized to that rate."""

from __future__ import annotations

import random

import pytest

from cart2d.link.line import MIN_WAIT_S, STOP_RESEND_S, LineStats

STATUS = (7, 72)  # bytes of a STATUS request and of its reply
CEILING_S = 0.25


def timed_line(latency_s: float = 0.003) -> LineStats:
    line = LineStats(115200, CEILING_S)
    for _ in range(20):
        line.answered_at_once(line.line_time(*STATUS) + latency_s, *STATUS)
        line.tried(True, True, sum(STATUS))
    return line


def test_until_a_round_trip_is_timed_every_wait_is_the_ceiling_but_a_stops() -> None:
    line = LineStats(115200, CEILING_S)
    assert line.wait_s(*STATUS) == CEILING_S
    assert line.wait_s(7, 8, stop=True) == STOP_RESEND_S


def test_a_timed_line_waits_for_the_bytes_and_its_latency() -> None:
    line = timed_line(0.003)
    assert line.wait_s(*STATUS) == pytest.approx(max(MIN_WAIT_S, line.line_time(*STATUS) + 0.003 * 1.25))
    assert timed_line(0.1).wait_s(*STATUS) == pytest.approx(line.line_time(*STATUS) + 0.125)


def test_a_clean_line_backs_off_from_the_first_timeout() -> None:
    line = timed_line()
    base = line.wait_s(*STATUS)
    assert [line.wait_s(*STATUS, unanswered=k) for k in range(4)] == pytest.approx(
        [base, 2 * base, 4 * base, 8 * base]
    )
    assert line.wait_s(*STATUS, unanswered=20) == CEILING_S


def test_a_line_that_loses_half_its_tries_to_noise_resends_at_the_base_wait_first() -> None:
    line = timed_line()
    for k in range(200):
        line.tried(k % 2 == 0, True, sum(STATUS))
    base = line.wait_s(*STATUS)
    # 0.5^7 < 1 %: seven losses in a row are noise, the eighth is not
    assert line.losses_explained(sum(STATUS)) == 7
    assert [line.wait_s(*STATUS, unanswered=k) for k in range(8)] == pytest.approx([base] * 8)
    assert line.wait_s(*STATUS, unanswered=8) == pytest.approx(2 * base)


@pytest.mark.parametrize("error_rate", [0.01, 0.05])
def test_the_byte_error_rate_is_learnt_from_the_tries(error_rate: float) -> None:
    rng = random.Random(4)
    line = timed_line()
    sizes = [sum(STATUS), 7 + 20, 27 + 20, 131 + 20]
    for k in range(4000):
        size = sizes[k % len(sizes)]
        line.tried(all(rng.random() >= error_rate for _ in range(size)), True, size)
    assert line.byte_error_rate() == pytest.approx(error_rate, rel=0.35)


def test_silence_teaches_nothing_about_noise() -> None:
    line = timed_line()
    for _ in range(50):
        line.tried(False, False, sum(STATUS))  # a Nano in its bootloader: nothing comes at all
    assert line.byte_error_rate() == 0.0
    assert line.timeouts == 50

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


def request_tries(line: LineStats, reply_after_s: float) -> tuple[int, float]:
    """One request to a peer whose reply comes `reply_after_s` after a try, on a live line: the
    tries until a wait was long enough, and the time they took (what transport._send does)."""
    spent = 0.0
    for unanswered in range(1000):
        wait = line.wait_s(*STATUS, unanswered=unanswered)
        if wait >= reply_after_s:
            if unanswered == 0:
                line.answered_at_once(reply_after_s, *STATUS)
            else:
                line.answered_late(unanswered, *STATUS)
            line.tried(True, True, sum(STATUS))
            return unanswered + 1, spent + reply_after_s
        line.tried(False, True, sum(STATUS))  # bytes came (telemetry): the line is alive
        spent += wait
    raise AssertionError("never answered")


def test_a_peer_slower_than_the_base_wait_is_waited_for_though_its_losses_look_like_noise() -> None:
    """Replies that come after the wait are lost tries: the error rate they teach climbs to 100 %
    and explained any run of losses, so the link resent at the base wait for ever (the noisy-line
    bench: 299 tries in 6 s, no reply, on a busy machine)."""
    rng = random.Random(5)
    line = timed_line(0.003)
    for _ in range(400):  # 5 % of the bytes lost: three STATUS tries in four are, by noise
        line.tried(all(rng.random() >= 0.05 for _ in range(sum(STATUS))), True, sum(STATUS))
    slow = 6 * line.wait_s(*STATUS)  # then the host gets busy: every reply comes after six base waits
    tries, spent = request_tries(line, slow)
    assert tries > 1 and spent < 1.5  # answered within one round of retransmissions (RETRANSMIT_WINDOW_S)
    # the next request waits as long at its first try, is answered at once, and times the line
    assert request_tries(line, slow)[0] == 1
    assert line.wait_s(*STATUS) >= slow


def test_a_noisy_line_still_resends_at_the_base_wait_after_the_first_try() -> None:
    line = timed_line()
    for k in range(200):
        line.tried(k % 2 == 0, True, sum(STATUS))
    line.answered_late(12, *STATUS)  # the last request needed a backed-off try
    base = line.wait_s(*STATUS, unanswered=1)
    assert line.wait_s(*STATUS) == pytest.approx(min(CEILING_S, base * 2 ** (12 - 7)))
    assert [line.wait_s(*STATUS, unanswered=k) for k in range(1, 8)] == pytest.approx([base] * 7)

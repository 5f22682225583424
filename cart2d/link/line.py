"""What the link measures of its line, and how long it waits for a reply because of it.

Every try of a request is an exchange of known sizes: the request's bytes, and its reply's from
the command's results (docs/protocol.md). From the replies that came at the first try (Karn's
rule: a reply to a retransmitted request may answer any of its tries) the link learns the line's
latency beyond the bytes' own time on the wire, as TCP does (RFC 6298: a smoothed round trip and
its variation). Until then every wait is the ceiling, longer than any round trip the link can
work with, so a reply after a retransmission answers the last try, and is timed from it. From
every try on a line that is alive (bytes came: telemetry, garbled replies) it learns how many
tries are lost, and from that the share of bytes that arrive damaged or not at all. A silent
line teaches nothing about noise: a Nano in its bootloader, a stalled bridge.

- **The wait for a reply**: the exchange's time on the wire, plus the smoothed latency and four
  times its variation (at least a quarter of the latency: a network's delays wander); at least
  MIN_WAIT_S, at most the link's ceiling (0.25 s on a serial port, 0.5 s over a network), which
  is also the wait until a reply has been timed.
- **Back-off**, sized to the measured error rate: the wait doubles after each unanswered try
  beyond the run of losses that the line's noise explains (with 99 % probability, for an
  exchange of this size). A clean line backs off from the first timeout (a silence there means
  a slow peer: a bootloader, a busy bridge); a line losing half its STATUS exchanges to noise
  resends at the base wait eight times first, since resending at once is what gets through.
- **A STOP** is resent after at most STOP_RESEND_S: it is answered from the firmware's memory
  if the first one arrived, and only its own resends stop a cart whose STOP was lost.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass

from cart2d.link.protocol import BITS_PER_BYTE

MIN_WAIT_S = 0.02  # the firmware's busiest moment: a tick's wait (8 ms) behind a telemetry frame (6.3 ms)
EXPLAINED = 0.01  # a run of losses whose probability under the line's noise is below this is not noise
STOP_RESEND_S = 0.025  # a STOP (15 bytes both ways, 1.3 ms of line) unanswered this long is sent again
RTT_GAIN = 1 / 8  # RFC 6298's alpha and beta
RTT_VAR_GAIN = 1 / 4
LOSS_GAIN = 0.05  # the loss rate follows about the last 20 tries (the mean of all, until there are 20)
# A line that sent a byte this recently is alive: telemetry comes every 40 ms, but a busy host's
# reader may not look for a few hundred (a Nano in its bootloader is silent for 0.5 to 1.5 s).
ALIVE_S = 1.0
REPLY_OVERHEAD = 8  # a reply's bytes besides its results: 0x7E, LEN, SEQ, STATUS, CMD, ARGC, CRC


def reply_size(results: int) -> int:
    return REPLY_OVERHEAD + 4 * results


@dataclass(frozen=True)
class LineView:
    """The line's figures at one moment (for /api/status, benchmarks and logs)."""

    tries: int
    answered: int
    timeouts: int
    loss_rate: float  # of tries on a live line, lately
    byte_error_rate: float  # estimated share of bytes damaged or lost, either way
    latency_s: float | None  # smoothed round trip beyond the bytes' time on the wire
    wait_s: float  # the wait for a STATUS reply now


class LineStats:
    """The line's latency and losses, as measured by one link's requests."""

    def __init__(self, baud: int, ceiling_s: float) -> None:
        self.byte_s = BITS_PER_BYTE / baud
        self.ceiling_s = ceiling_s
        self._lock = threading.Lock()
        self._srtt: float | None = None
        self._rttvar = 0.0
        self._answered_share = 1.0  # EWMA of tries answered, on a live line
        self._bytes = 80.0  # EWMA of the bytes an exchange moves (a STATUS)
        self._counted = 0  # tries the two averages have seen
        self.tries = 0
        self.answered = 0
        self.timeouts = 0

    def line_time(self, request_bytes: int, reply_bytes: int) -> float:
        return (request_bytes + reply_bytes) * self.byte_s

    def wait_s(self, request_bytes: int, reply_bytes: int, unanswered: int = 0, stop: bool = False) -> float:
        """How long to wait for the reply to a try, after `unanswered` tries of the same request."""
        with self._lock:
            srtt, rttvar = self._srtt, self._rttvar
        wait = self.ceiling_s
        if srtt is not None:
            latency = srtt + max(4 * rttvar, srtt / 4)
            wait = max(self.line_time(request_bytes, reply_bytes) + latency, MIN_WAIT_S)
            beyond_noise = unanswered - self.losses_explained(request_bytes + reply_bytes)
            if beyond_noise > 0:
                wait *= 2.0 ** min(beyond_noise, 16)
            wait = min(wait, self.ceiling_s)
        return min(wait, STOP_RESEND_S) if stop else wait

    def losses_explained(self, exchange_bytes: int) -> int:
        """How many tries of an exchange of this size in a row the line's noise loses with a
        probability of at least EXPLAINED (0 on a clean line)."""
        lost = 1.0 - math.pow(1.0 - self.byte_error_rate(), exchange_bytes)
        if lost <= EXPLAINED:
            return 0
        if lost >= 1.0 - 1e-9:
            return 1 << 16
        return math.ceil(math.log(EXPLAINED) / math.log(lost))

    def timed(self) -> bool:
        """Whether a round trip has been timed (until then, replies to retransmissions count)."""
        with self._lock:
            return self._srtt is not None

    def answered_at_once(self, round_trip_s: float, request_bytes: int, reply_bytes: int) -> None:
        """A reply that answered a try `round_trip_s` after it was written."""
        sample = max(0.0, round_trip_s - self.line_time(request_bytes, reply_bytes))
        with self._lock:
            if self._srtt is None:
                self._srtt, self._rttvar = sample, sample / 2
            else:
                self._rttvar += RTT_VAR_GAIN * (abs(self._srtt - sample) - self._rttvar)
                self._srtt += RTT_GAIN * (sample - self._srtt)

    def tried(self, answered: bool, alive: bool, exchange_bytes: int) -> None:
        """One try's outcome; `alive`: the line sent something lately (else it says nothing of noise)."""
        with self._lock:
            self.tries += 1
            if answered:
                self.answered += 1
            else:
                self.timeouts += 1
            if answered or alive:
                self._counted += 1
                gain = max(LOSS_GAIN, 1.0 / self._counted)
                self._answered_share += gain * (float(answered) - self._answered_share)
                self._bytes += gain * (exchange_bytes - self._bytes)

    def byte_error_rate(self) -> float:
        """The share of bytes damaged or lost that explains the tries lost: 1 - s^(1/bytes)."""
        with self._lock:
            share, size = self._answered_share, self._bytes
        return 1.0 - math.pow(max(share, 1e-6), 1.0 / max(size, 1.0))

    def view(self, status_request: int, status_reply: int) -> LineView:
        with self._lock:
            latency = self._srtt
            loss = 1.0 - self._answered_share
            tries, answered, timeouts = self.tries, self.answered, self.timeouts
        return LineView(
            tries=tries,
            answered=answered,
            timeouts=timeouts,
            loss_rate=loss,
            byte_error_rate=self.byte_error_rate(),
            latency_s=latency,
            wait_s=self.wait_s(status_request, status_reply),
        )

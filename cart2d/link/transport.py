"""The serial link to the firmware: requests with retries, telemetry, reconnection.

One request is outstanding at a time (docs/protocol.md, "Retransmission and duplicates"): a
request that gets no reply within its wait is retransmitted with the same sequence number,
which the firmware answers from memory instead of executing it twice; it remembers a request
for 2 s, so a request is retransmitted only within RETRANSMIT_WINDOW_S of its first
transmission. The wait is measured from the line (line.py: its latency, and back-off sized to
the tries it loses), so a lost reply costs a retry of a few tens of milliseconds, not a mission;
a request that can be executed twice without harm (commands.py, REPEATABLE) goes on as a new
one after the window while the line is alive, for up to PATIENCE_S (and a late reply to one of
its earlier SEQs answers it: a busy host's reader may decode it seconds late). A reader thread decodes
everything the firmware sends, and drops a partial packet that waited too long (protocol.py,
Decoder). If the port disappears (USB unplugged, simulator restarted, a network bridge's
connection dropped) the link reopens it in the background; requests in the meantime fail with
LinkDown. The port may be a pyserial URL (ports.py): a network connection that stays silent
while a request waits is dropped and reopened too (STALL_S), and a bridge that refuses
connections is retried with back-off.
Over ~500 lines for a reason: the retransmission, the reader and the reopening share one
request slot and one stop generation, whose rules are easiest checked in one place.

A STOP is the last word the motors hear (cart2d/link/commands.py says which commands are
motion). Requests wait for the link in order of priority, then arrival, and STOP comes first: it
waits at most for the exchange on the wire, never behind queued commands or reads (and cuts
short the wait for a read's or a motion command's reply), and is resent after at most
line.STOP_RESEND_S. Each STOP
starts a new stop generation; a motion command belongs to the generation it was asked for in
(a token, taken when the request arrived) and is refused with MotionCancelled, unsent, once a
STOP came after it, however long it waited; one asked for while a STOP is on its way belongs to
none. So no motion asked for before a STOP's answer follows that STOP. Telemetry listeners run
in a thread of their own (they never hold up the replies the reader decodes).

Over ~500 lines for a reason: the request queue, the stop's priority and generations, the
retransmission and the reader share one lock and one port, and their invariant (no motion
after a STOP's answer) is read in one place.
"""

from __future__ import annotations

import contextlib
import heapq
import itertools
import logging
import math
import random
import threading
import time
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from enum import IntEnum

import serial

from cart2d.link import commands, ports
from cart2d.link.line import ALIVE_S, STOP_RESEND_S, LineStats, reply_size
from cart2d.link.protocol import (
    Decoder,
    Packet,
    ProtocolError,
    Reply,
    Telemetry,
    decode_reply,
    encode_request,
)
from cart2d.spec import load_spec

log = logging.getLogger(__name__)

# The firmware answers a retransmission from memory for 2 s after it executed the original; a
# host retransmits only within 1.5 s of the first transmission, so that no retransmission
# reaches the firmware after it forgot the original and would execute it again (the 0.5 s
# between covers the line, a USB adapter's latency and the firmware's busiest tick).
RETRANSMIT_WINDOW_S = 1.5
READ_TIMEOUT_S = 0.05  # how long the reader waits for a byte before it checks the decoder's time-outs
# A network link that has not sent one byte for STALL_S since a request went unanswered is
# stalled (a bridge that lost its Wi-Fi, a peer gone without closing): dropped and reopened. The
# firmware sends telemetry (25 Hz) and answers within milliseconds; a Nano's bootloader after a
# reset keeps the line silent for at most ~1.6 s (the old ATmegaBOOT; Optiboot ~1 s).
STALL_S = 3.0
# Opening a Nano's port resets it into its bootloader, which takes what comes in the first second
# as STK500 commands: a request's bytes there can hold it in a page write for as long as requests
# keep coming (every byte feeds its watchdog) while the firmware never starts. The link sends
# nothing after an open until the line speaks (the firmware's telemetry) or this long has passed.
BOOT_QUIET_S = 1.6
# The longest wait for a reply before the request is retransmitted (a direct line: ~8 ms round
# trip); the wait is measured from the line below that (line.py).
TIMEOUT_S = 0.25
# Over a network the round trip grows by the network's (tens to hundreds of ms over Wi-Fi): waiting
# longer spares retransmissions. The retransmission window still holds while one way takes less
# than the 0.5 s between RETRANSMIT_WINDOW_S and the firmware's 2 s.
NETWORK_TIMEOUT_S = 0.5
REOPEN_DELAY_S = 0.2  # between attempts to reopen a device path (an open is cheap and local)
REOPEN_MAX_DELAY_S = 3.2  # a network bridge is retried after 0.2, 0.4 ... then every 3.2 s
# A repeatable request (a read, STOP, a setting's write) unanswered in its window goes on as a
# new request while the line is alive, this long from its first transmission: a link that
# recovers within a few seconds (a noisy stretch, a bridge's hiccup) costs retries, not a mission.
PATIENCE_S = 5.0
STATUS_SIZES = (len(encode_request(0, load_spec().code("STATUS"))), reply_size(16))  # bytes each way


class LinkError(RuntimeError):
    """The firmware could not be reached."""


class LinkDown(LinkError):
    """The port is closed or gone; the link is trying to reopen it."""


class LinkTimeout(LinkError):
    """No reply after every retry."""


class MotionCancelled(RuntimeError):
    """A motion command refused unsent: a STOP came after it was asked for."""


class CommandRefused(RuntimeError):
    """The firmware answered CONTROL_ERROR or CONTROL_INVALID_COM."""

    def __init__(self, reply: Reply) -> None:
        super().__init__(reply.describe_error())
        self.reply = reply


TelemetryListener = Callable[[Telemetry], None]
TELEMETRY_BACKLOG = 64  # frames kept for slow telemetry listeners (2.5 s at 25 Hz); older ones are dropped
NO_TOKEN = -1  # the motion token asked for while a STOP is on its way: valid in no generation


class Priority(IntEnum):
    """Who gets the link first when several requests wait (lower first; equal: first come)."""

    STOP = 0
    COMMAND = 1
    BACKGROUND = 2  # reads that can wait for everything else (filling the settings cache)


class Turnstile:
    """One holder at a time; waiters are let in by priority, then in order of arrival."""

    def __init__(self) -> None:
        self._cond = threading.Condition()
        self._held = False
        self._waiting: list[tuple[int, int]] = []  # a heap of (priority, arrival)
        self._arrivals = itertools.count()

    @contextlib.contextmanager
    def hold(self, priority: Priority) -> Iterator[None]:
        ticket = (int(priority), next(self._arrivals))
        with self._cond:
            heapq.heappush(self._waiting, ticket)
            while self._held or self._waiting[0] != ticket:
                self._cond.wait()
            heapq.heappop(self._waiting)
            self._held = True
        try:
            yield
        finally:
            with self._cond:
                self._held = False
                self._cond.notify_all()

    def waiting(self, priority: Priority) -> bool:
        """Whether a request of this priority or a more urgent one waits."""
        with self._cond:
            return bool(self._waiting) and self._waiting[0][0] <= priority


class Link:
    def __init__(
        self, port: str, baud: int = 115200, timeout_s: float | None = None, retries: int | None = None
    ) -> None:
        """`timeout_s`: a fixed wait for every reply (None: measured from the line, at most
        TIMEOUT_S, NETWORK_TIMEOUT_S over a network); `retries`: at most this many
        retransmissions of a request (None: as many as its window holds)."""
        self.port = port
        self.baud = baud
        self.timeout_s = timeout_s
        self.retries = retries
        self.line = LineStats(baud, NETWORK_TIMEOUT_S if ports.is_url(port) else TIMEOUT_S)
        self._stop_code = load_spec().code("STOP")
        self._stops_queued = 0  # STOPs waiting for the turnstile
        self._last_rx = -math.inf  # when the reader last got a byte (time.monotonic())
        self.fresh_starts = 0  # repeatable requests asked again as new ones after their window
        self._serial: serial.Serial | None = None
        self._seq = random.randrange(256)  # a restarted host must not repeat the last SEQ
        self._turnstile = Turnstile()
        self._stop_lock = threading.Lock()
        self._stop_generation = 0  # STOPs asked for so far
        self._stops_under_way = 0
        self._epochs = itertools.count(1)  # next() on a count is atomic: several threads bump it
        self.settings_epoch = 0  # changes whenever the firmware's settings may have changed
        self._reply_lock = threading.Condition()
        self._pending_seqs: tuple[int, ...] = ()  # the SEQs of the request waiting, every round's
        self._reply: Reply | None = None
        self._listeners: list[TelemetryListener] = []
        self._telemetry_queue: deque[Telemetry] = deque(maxlen=TELEMETRY_BACKLOG)
        self._telemetry_ready = threading.Condition()
        self._dispatcher: threading.Thread | None = None
        self._closing = threading.Event()
        self._released = threading.Event()  # the port is lent out (e.g. to avrdude)
        self._reader: threading.Thread | None = None
        self.telemetry: Telemetry | None = None
        self.telemetry_count = 0
        self.retransmissions = 0
        self.decode_errors = 0
        self.partials_dropped = 0  # partial packets that waited too long (since the port opened)
        self.connected = threading.Event()
        self.opens = 0  # times the port was opened (a Nano resets at each)
        self.open_error = ""  # why the port could not be opened, the last time it could not
        self.lost = 0  # times an open port was lost (closed under the link, stalled)
        self.lost_reason = ""  # why, the last time
        self._unanswered_since: float | None = None  # a request went unanswered, no byte since

    # -- lifecycle -----------------------------------------------------------------------
    def open(self, wait_s: float = 5.0) -> Link:
        if self._reader is not None and self._reader.is_alive():
            return self
        self._closing.clear()
        self._reader = threading.Thread(target=self._run, name=f"link {self.port}", daemon=True)
        self._reader.start()
        self._dispatcher = threading.Thread(
            target=self._dispatch_telemetry, name=f"telemetry {self.port}", daemon=True
        )
        self._dispatcher.start()
        if not self.connected.wait(wait_s):
            raise LinkDown(f"cannot open {self.port}" + (f": {self.open_error}" if self.open_error else ""))
        return self

    def close(self) -> None:
        """Stops the reader thread, which owns the port and closes it (within its read timeout)."""
        self._closing.set()
        with self._telemetry_ready:
            self._telemetry_ready.notify_all()
        for thread in (self._reader, self._dispatcher):
            if thread is not None:
                thread.join(timeout=2.0)
        self._reader = self._dispatcher = None

    def __enter__(self) -> Link:
        return self.open()

    def __exit__(self, *exc: object) -> None:
        self.close()

    @contextlib.contextmanager
    def released(self, wait_s: float = 5.0) -> Iterator[None]:
        """Closes the port and keeps it closed inside the block (for avrdude), then reopens it."""
        self._released.set()
        deadline = time.monotonic() + wait_s
        while self.connected.is_set() and time.monotonic() < deadline:
            time.sleep(0.02)
        try:
            yield
        finally:
            self._released.clear()
            self.connected.wait(wait_s)

    def down_reason(self) -> str:
        """Why the link is down, in words: how the port was lost and why it does not open."""
        why = [f"lost: {self.lost_reason}"] if self.lost_reason else []
        if self.open_error:
            why.append(f"reopening: {self.open_error}")
        return "; ".join(why) or f"{self.port} is not open yet"

    def subscribe(self, listener: TelemetryListener) -> None:
        self._listeners.append(listener)

    # -- requests ------------------------------------------------------------------------
    def motion_token(self) -> int:
        """The stop generation a motion command asked for now belongs to (NO_TOKEN while a STOP
        is on its way). Take it when the command arrives and pass it with every request the
        command makes: once a STOP follows, they are refused."""
        with self._stop_lock:
            return NO_TOKEN if self._stops_under_way else self._stop_generation

    def stopped_since(self, token: int) -> bool:
        """Whether a STOP was asked for since `token` was taken (or was on its way then)."""
        with self._stop_lock:
            return token == NO_TOKEN or token != self._stop_generation

    @contextlib.contextmanager
    def stopping(self) -> Iterator[None]:
        """A stop under way: the stop generation moves on (every motion token taken before is
        stale from now on), and a token taken inside the block is valid in no generation."""
        with self._stop_lock:
            self._stop_generation += 1
            self._stops_under_way += 1
        try:
            yield
        finally:
            with self._stop_lock:
                self._stops_under_way -= 1

    def stop(self, timeout_s: float | None = None) -> Reply:
        """STOP, ahead of every waiting request; every motion command asked for before it
        (queued, or between retransmissions) is refused from now on."""
        with self.stopping():
            return self.request("STOP", (), timeout_s, priority=Priority.STOP)

    def settings_may_change(self) -> None:
        """Something outside the link's sight may have changed the firmware's settings (an MCU
        restart): what was read of them is stale."""
        self.settings_epoch = next(self._epochs)

    def request(
        self,
        command: str | int,
        args: Sequence[float] = (),
        timeout_s: float | None = None,
        *,
        priority: Priority = Priority.COMMAND,
        token: int | None = None,
    ) -> Reply:
        """Send one request and return its reply (any status). Without a reply within the wait
        (line.py: measured from the line, or `timeout_s` / the link's timeout_s when given) the
        request is retransmitted, only within RETRANSMIT_WINDOW_S of its first transmission (and
        at most `retries` times when set); then LinkTimeout, except that a repeatable request
        (commands.py) goes on as a new one while the line is alive, for up to PATIENCE_S. A
        motion command belongs to `token` (default: the generation now) and raises
        MotionCancelled, unsent or cut short, once a STOP came after it; a repeatable request
        waiting for its reply gives way to a STOP and is asked again after it."""
        code = command if isinstance(command, int) else load_spec().code(command)
        motion = commands.is_motion(code)
        if motion and token is None:
            token = self.motion_token()
        changes_settings = not commands.keeps_settings(code)
        first_sent: list[float] = []  # when it was first written (its patience counts from then)
        while True:
            with self._queued(priority):
                if motion and token is not None:
                    self._refuse_if_stopped(code, token)
                if changes_settings:
                    self.settings_may_change()
                try:
                    reply = self._send(code, args, timeout_s, token if motion else None, first_sent)
                finally:
                    if changes_settings:
                        self.settings_may_change()
            if reply is not None:
                return reply  # else it gave way to a STOP: asked again behind it

    @contextlib.contextmanager
    def _queued(self, priority: Priority) -> Iterator[None]:
        """Holds the turnstile; a STOP waiting for it cuts short the wait of the exchange on
        the wire (of a repeatable or motion request)."""
        urgent = priority == Priority.STOP
        if urgent:
            with self._reply_lock:
                self._stops_queued += 1
                self._reply_lock.notify_all()
        try:
            with self._turnstile.hold(priority):
                if urgent:
                    with self._reply_lock:
                        self._stops_queued -= 1
                    urgent = False
                yield
        finally:
            if urgent:
                with self._reply_lock:
                    self._stops_queued -= 1

    def _send(
        self,
        code: int,
        args: Sequence[float],
        timeout_s: float | None,
        token: int | None,
        first_sent: list[float],
    ) -> Reply | None:
        """Tries until a reply comes; None if it gave way to a waiting STOP (a repeatable request)."""
        stop = code == self._stop_code
        repeatable = commands.is_repeatable(code)
        interruptible = not stop and (repeatable or token is not None)
        reply_bytes = reply_size(commands.reply_results(code))
        fixed = self.timeout_s if timeout_s is None else timeout_s
        all_tries = 0
        rounds: list[int] = []  # a late reply to an earlier round answers the request too
        while True:  # each round a new SEQ: the firmware answers a round's retransmissions from memory
            self._seq = (self._seq + 1) & 0xFF
            rounds.append(self._seq)
            data = encode_request(self._seq, code, list(args))
            round_began = time.monotonic()
            if not first_sent:
                first_sent.append(round_began)
            tries = 0
            while True:
                if fixed is None:
                    wait = self.line.wait_s(len(data), reply_bytes, tries, stop)
                else:
                    wait = min(fixed, STOP_RESEND_S) if stop else fixed
                written = time.monotonic()
                reply = self._exchange(data, tuple(rounds), wait, interruptible)
                tries += 1
                all_tries += 1
                self.line.tried(reply is not None, self.alive(), len(data) + reply_bytes)
                if reply is not None:
                    if reply.seq == rounds[-1] and (tries == 1 or not self.line.timed()):
                        self.line.answered_at_once(time.monotonic() - written, len(data), reply_bytes)
                    return reply
                if token is not None:
                    self._refuse_if_stopped(code, token, cut_short=True)  # never retransmitted after a STOP
                if interruptible and self._stop_queued():
                    return None
                late = time.monotonic() - round_began > RETRANSMIT_WINDOW_S
                if late or (self.retries is not None and tries > self.retries):
                    break
                self.retransmissions += 1
            waited_s = time.monotonic() - first_sent[0]
            patient = repeatable and self.retries is None and self.alive() and waited_s < PATIENCE_S
            if not patient:
                raise LinkTimeout(self._no_reply(code, all_tries, waited_s))
            self.fresh_starts += 1

    def _no_reply(self, code: int, tries: int, waited_s: float) -> str:
        line = self.line.view(*STATUS_SIZES)
        words = f"no reply to {load_spec().name_of(code)} after {tries} tries in {waited_s:.1f} s"
        if not self.alive():
            return f"{words}: the line has been silent for {ALIVE_S:g} s"
        return f"{words}; the line lost {line.loss_rate:.0%} of tries lately"

    def alive(self) -> bool:
        """Whether the line sent a byte within line.ALIVE_S (telemetry, replies, garbled ones)."""
        return time.monotonic() - self._last_rx < ALIVE_S

    def _stop_queued(self) -> bool:
        with self._reply_lock:
            return self._stops_queued > 0

    def _refuse_if_stopped(self, code: int, token: int, cut_short: bool = False) -> None:
        if self.stopped_since(token):
            what = "its reply was not waited for" if cut_short else "was not sent"
            raise MotionCancelled(
                f"{load_spec().name_of(code).removeprefix('COMMAND_')} {what}: a stop came after it"
            )

    def call(
        self,
        command: str | int,
        *args: float,
        timeout_s: float | None = None,
        priority: Priority = Priority.COMMAND,
        token: int | None = None,
    ) -> tuple[float, ...]:
        """Send a request; return its results, or raise CommandRefused."""
        reply = self.request(command, args, timeout_s, priority=priority, token=token)
        if not reply.ok:
            raise CommandRefused(reply)
        return reply.results

    def _exchange(
        self, data: bytes, seqs: tuple[int, ...], timeout_s: float, interruptible: bool
    ) -> Reply | None:
        port = self._serial
        if port is None or not self.connected.is_set():
            raise LinkDown(f"{self.port} is not open")
        with self._reply_lock:
            self._pending_seqs = seqs
            self._reply = None
        try:
            port.write(data)
        except (serial.SerialException, OSError) as exc:
            raise LinkDown(str(exc)) from exc
        deadline = time.monotonic() + timeout_s
        with self._reply_lock:
            while self._reply is None:
                left = deadline - time.monotonic()
                if left <= 0 or not self.connected.is_set() or (interruptible and self._stops_queued):
                    break
                self._reply_lock.wait(left)
            reply, self._reply, self._pending_seqs = self._reply, None, ()
            if reply is None and self._unanswered_since is None:
                self._unanswered_since = deadline - timeout_s
        return reply

    # -- reader thread -------------------------------------------------------------------
    def _run(self) -> None:
        delay_s = REOPEN_DELAY_S
        while not self._closing.is_set():
            if self._released.is_set():
                time.sleep(0.05)
                continue
            try:
                self._serial = ports.open_port(self.port, self.baud, READ_TIMEOUT_S)
                self._serial.reset_input_buffer()  # bytes queued while nobody listened
            except (serial.SerialException, OSError) as exc:
                if str(exc) != self.open_error:
                    log.info("cannot open %s: %s", self.port, exc)
                self.open_error = str(exc)
                self._closing.wait(delay_s)
                if ports.is_url(self.port):  # a bridge rebooting or out of reach: back off
                    delay_s = min(2 * delay_s, REOPEN_MAX_DELAY_S)
                continue
            delay_s = REOPEN_DELAY_S
            self.open_error = ""
            log.info("link open on %s", self.port)
            self.opens += 1
            self.settings_may_change()  # opening a Nano's port resets it
            with self._reply_lock:
                self._unanswered_since = None
            self._quiet_while_booting(self._serial)
            self.connected.set()
            why = self._read_until_gone(self._serial)
            self.connected.clear()
            with self._reply_lock:
                self._reply_lock.notify_all()
            with contextlib.suppress(serial.SerialException, OSError):
                self._serial.close()
            if not self._closing.is_set() and not self._released.is_set():
                self.lost += 1
                self.lost_reason = why
                log.warning("link to %s lost (%s); reopening", self.port, why)
                self._closing.wait(REOPEN_DELAY_S)

    def _quiet_while_booting(self, port: serial.Serial) -> None:
        """Until the line speaks or BOOT_QUIET_S passed (the bytes stay for the reader)."""
        deadline = time.monotonic() + BOOT_QUIET_S
        with contextlib.suppress(serial.SerialException, OSError, TypeError):
            while not port.in_waiting and time.monotonic() < deadline and not self._closing.is_set():
                self._closing.wait(0.01)

    def _read_until_gone(self, port: serial.Serial) -> str:
        """Decodes what the port sends until it is gone, closing or released; why it ended."""
        decoder = Decoder(self.baud)
        stalls = ports.is_url(self.port)
        while not self._closing.is_set() and not self._released.is_set():
            try:
                data = port.read(max(1, port.in_waiting))  # b"" after READ_TIMEOUT_S of silence
            except (serial.SerialException, OSError, TypeError) as exc:
                if not self._closing.is_set():
                    log.warning("reading %s failed: %s", self.port, exc)
                return str(exc) or type(exc).__name__
            now = time.monotonic()
            with self._reply_lock:
                if data:
                    self._unanswered_since = None
                    self._last_rx = now
                elif stalls and self._unanswered_since is not None and now - self._unanswered_since > STALL_S:
                    return f"nothing came for {STALL_S:g} s although a request waited: the connection stalled"
            # Fed even when empty: a partial packet expires while nothing arrives as well.
            for item in decoder.feed(data, now):
                self._handle(item)
            self.decode_errors = decoder.errors
            self.partials_dropped = decoder.expired
        return "closed"

    def _handle(self, item: Packet | Telemetry) -> None:
        if isinstance(item, Telemetry):
            self.telemetry = item
            self.telemetry_count += 1
            with self._telemetry_ready:
                self._telemetry_queue.append(item)
                self._telemetry_ready.notify()
            return
        try:
            reply = decode_reply(item)
        except ProtocolError:
            return
        with self._reply_lock:
            if reply.seq in self._pending_seqs:
                self._reply = reply
                self._reply_lock.notify_all()

    def _dispatch_telemetry(self) -> None:
        """Hands telemetry to the listeners, away from the reader: however slow they are, the
        reader keeps decoding replies (a slow listener loses old frames, TELEMETRY_BACKLOG)."""
        while not self._closing.is_set():
            with self._telemetry_ready:
                while not self._telemetry_queue and not self._closing.is_set():
                    self._telemetry_ready.wait()
                frames = list(self._telemetry_queue)
                self._telemetry_queue.clear()
            for frame in frames:
                for listener in list(self._listeners):
                    listener(frame)

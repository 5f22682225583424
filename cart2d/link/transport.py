"""The serial link to the firmware: requests with retries, telemetry, reconnection.

One request is outstanding at a time (docs/protocol.md, "Retransmission and duplicates"): a
request that gets no reply within the timeout is retransmitted with the same sequence number,
which the firmware answers from memory instead of executing it twice; it remembers a request
for 2 s, so a request is retransmitted only within RETRANSMIT_WINDOW_S of its first
transmission. A reader thread decodes everything the firmware sends, and drops a partial
packet that waited too long (protocol.py, Decoder). If the port disappears (USB
unplugged, simulator restarted) the link reopens it in the background; requests in the
meantime fail with LinkDown.
"""

from __future__ import annotations

import contextlib
import logging
import random
import threading
import time
from collections.abc import Callable, Iterator, Sequence

import serial

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


class LinkError(RuntimeError):
    """The firmware could not be reached."""


class LinkDown(LinkError):
    """The port is closed or gone; the link is trying to reopen it."""


class LinkTimeout(LinkError):
    """No reply after every retry."""


class CommandRefused(RuntimeError):
    """The firmware answered CONTROL_ERROR or CONTROL_INVALID_COM."""

    def __init__(self, reply: Reply) -> None:
        super().__init__(reply.describe_error())
        self.reply = reply


TelemetryListener = Callable[[Telemetry], None]


class Link:
    def __init__(self, port: str, baud: int = 115200, timeout_s: float = 0.25, retries: int = 4) -> None:
        self.port = port
        self.baud = baud
        self.timeout_s = timeout_s
        self.retries = retries
        self._serial: serial.Serial | None = None
        self._seq = random.randrange(256)  # a restarted host must not repeat the last SEQ
        self._request_lock = threading.Lock()
        self._reply_lock = threading.Condition()
        self._pending_seq: int | None = None
        self._reply: Reply | None = None
        self._listeners: list[TelemetryListener] = []
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

    # -- lifecycle -----------------------------------------------------------------------
    def open(self, wait_s: float = 5.0) -> Link:
        if self._reader is not None and self._reader.is_alive():
            return self
        self._closing.clear()
        self._reader = threading.Thread(target=self._run, name=f"link {self.port}", daemon=True)
        self._reader.start()
        if not self.connected.wait(wait_s):
            raise LinkDown(f"cannot open {self.port}")
        return self

    def close(self) -> None:
        """Stops the reader thread, which owns the port and closes it (within its read timeout)."""
        self._closing.set()
        if self._reader is not None:
            self._reader.join(timeout=2.0)
            self._reader = None

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

    def subscribe(self, listener: TelemetryListener) -> None:
        self._listeners.append(listener)

    # -- requests ------------------------------------------------------------------------
    def request(
        self, command: str | int, args: Sequence[float] = (), timeout_s: float | None = None
    ) -> Reply:
        """Send one request and return its reply (any status). Without a reply within the
        timeout the request is retransmitted, at most `retries` times and only within
        RETRANSMIT_WINDOW_S of its first transmission; then LinkTimeout."""
        code = command if isinstance(command, int) else load_spec().code(command)
        timeout = self.timeout_s if timeout_s is None else timeout_s
        with self._request_lock:
            self._seq = (self._seq + 1) & 0xFF
            data = encode_request(self._seq, code, list(args))
            first_sent = time.monotonic()
            tries = 0
            while True:
                reply = self._exchange(data, self._seq, timeout)
                tries += 1
                if reply is not None:
                    return reply
                late = time.monotonic() - first_sent > RETRANSMIT_WINDOW_S
                if tries > self.retries or late:
                    break
                self.retransmissions += 1
            waited_s = time.monotonic() - first_sent
            raise LinkTimeout(
                f"no reply to {load_spec().name_of(code)} after {tries} tries in {waited_s:.1f} s"
            )

    def call(self, command: str | int, *args: float, timeout_s: float | None = None) -> tuple[float, ...]:
        """Send a request; return its results, or raise CommandRefused."""
        reply = self.request(command, args, timeout_s)
        if not reply.ok:
            raise CommandRefused(reply)
        return reply.results

    def _exchange(self, data: bytes, seq: int, timeout_s: float) -> Reply | None:
        port = self._serial
        if port is None or not self.connected.is_set():
            raise LinkDown(f"{self.port} is not open")
        with self._reply_lock:
            self._pending_seq = seq
            self._reply = None
        try:
            port.write(data)
        except (serial.SerialException, OSError) as exc:
            raise LinkDown(str(exc)) from exc
        deadline = time.monotonic() + timeout_s
        with self._reply_lock:
            while self._reply is None:
                left = deadline - time.monotonic()
                if left <= 0 or not self.connected.is_set():
                    break
                self._reply_lock.wait(left)
            reply, self._reply, self._pending_seq = self._reply, None, None
        return reply

    # -- reader thread -------------------------------------------------------------------
    def _run(self) -> None:
        while not self._closing.is_set():
            if self._released.is_set():
                time.sleep(0.05)
                continue
            try:
                self._serial = serial.Serial(self.port, self.baud, timeout=READ_TIMEOUT_S)
                self._serial.reset_input_buffer()  # bytes queued while nobody listened
            except (serial.SerialException, OSError):
                time.sleep(0.2)
                continue
            log.info("link open on %s", self.port)
            self.opens += 1
            self.connected.set()
            self._read_until_gone(self._serial)
            self.connected.clear()
            with self._reply_lock:
                self._reply_lock.notify_all()
            self._serial.close()
            if not self._closing.is_set() and not self._released.is_set():
                log.warning("link to %s lost; reopening", self.port)
                time.sleep(0.2)

    def _read_until_gone(self, port: serial.Serial) -> None:
        decoder = Decoder(self.baud)
        while not self._closing.is_set() and not self._released.is_set():
            try:
                data = port.read(max(1, port.in_waiting))  # b"" after READ_TIMEOUT_S of silence
            except (serial.SerialException, OSError, TypeError) as exc:
                if not self._closing.is_set():
                    log.warning("reading %s failed: %s", self.port, exc)
                return
            # Fed even when empty: a partial packet expires while nothing arrives as well.
            for item in decoder.feed(data, time.monotonic()):
                self._handle(item)
            self.decode_errors = decoder.errors
            self.partials_dropped = decoder.expired

    def _handle(self, item: Packet | Telemetry) -> None:
        if isinstance(item, Telemetry):
            self.telemetry = item
            self.telemetry_count += 1
            for listener in self._listeners:
                listener(item)
            return
        try:
            reply = decode_reply(item)
        except ProtocolError:
            return
        with self._reply_lock:
            if reply.seq == self._pending_seq:
                self._reply = reply
                self._reply_lock.notify_all()

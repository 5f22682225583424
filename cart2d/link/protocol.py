"""Encoding and decoding of the serial protocol (docs/protocol.md), without any I/O.

`Decoder` turns the byte stream from the firmware into replies and telemetry frames, dropping
anything that fails its length or CRC check, or stays incomplete for too long, and
resynchronising on the next start byte.
"""

from __future__ import annotations

import math
import struct
import time
from dataclasses import dataclass

import numpy as np

from cart2d.spec import crc16_mcrf4xx, load_spec

SYNC = 0x7E
MIN_BODY = 2
MAX_BODY = 127
MAX_ARGS = (MAX_BODY - 2) // 4
TELEMETRY_SYNC = b"\xaa\xbb"
TELEMETRY_CHANNELS = 16
TELEMETRY_PAYLOAD = 4 * TELEMETRY_CHANNELS + 4
TELEMETRY_SIZE = 3 + TELEMETRY_PAYLOAD + 1

CONTROL_OK = 0
CONTROL_ERROR = 1
CONTROL_INVALID_COM = 2


class ProtocolError(ValueError):
    """Bytes that are not a valid packet or frame."""


def frame(seq: int, body: bytes) -> bytes:
    if not MIN_BODY <= len(body) <= MAX_BODY:
        raise ProtocolError(f"body of {len(body)} bytes (allowed {MIN_BODY}..{MAX_BODY})")
    core = bytes([len(body), seq & 0xFF]) + body
    return bytes([SYNC]) + core + struct.pack("<H", crc16_mcrf4xx(core))


def _floats(values: list[float] | tuple[float, ...]) -> bytes:
    return b"".join(struct.pack("<f", v) for v in values)


def shortest_float32(value: float) -> float:
    """The float32 nearest `value` as the double with the fewest significant digits that is the
    same float32: 0.005 for the float32 nearest 0.005, which widens to 0.004999999888241291.
    Every number the firmware sends is a float32; this keeps the widening's noise out of replies,
    the API and logs, and packing the result gives back the same four bytes. numpy prints a
    float32 as the shortest decimal that reads back as it (Steele & White / Dragon4, "unique")."""
    return float(str(np.float32(value))) if math.isfinite(value) else value


def _unpack_floats(data: bytes) -> tuple[float, ...]:
    """Little-endian float32s, each as shortest_float32 gives it (about 1 us a number)."""
    return tuple(float(text) for text in np.frombuffer(data, "<f4").astype("U32"))


def encode_request(seq: int, cmd: int, args: list[float] | tuple[float, ...] = ()) -> bytes:
    if len(args) > MAX_ARGS:
        raise ProtocolError(f"{len(args)} arguments (at most {MAX_ARGS})")
    return frame(seq, bytes([cmd, len(args)]) + _floats(args))


def encode_reply(seq: int, status: int, cmd: int, results: list[float] | tuple[float, ...] = ()) -> bytes:
    return frame(seq, bytes([status, cmd, len(results)]) + _floats(results))


@dataclass(frozen=True)
class Packet:
    seq: int
    body: bytes
    crc: int


@dataclass(frozen=True)
class Reply:
    seq: int
    status: int
    cmd: int
    results: tuple[float, ...]

    @property
    def ok(self) -> bool:
        return self.status == CONTROL_OK

    def describe_error(self) -> str:
        """A sentence for a person: why the firmware refused the request."""
        spec = load_spec()
        name = spec.name_of(self.cmd)
        if self.status == CONTROL_INVALID_COM:
            return f"the firmware does not know command {self.cmd}"
        if self.status == CONTROL_ERROR and self.results:
            reason = spec.reasons.get(int(self.results[0]), f"reason {self.results[0]:g}")
            return f"{name} refused: {REASON_TEXT.get(reason, reason)}"
        return f"{name} refused"


REASON_TEXT = {
    "ARG_COUNT": "wrong number of arguments",
    "NOT_FINITE": "an argument is NaN or infinite",
    "OUT_OF_RANGE": "an argument is out of range",
    "OVER_CAPACITY": "more waypoints than a path holds",
    "BAD_STATE": "not possible in the current state",
    "EEPROM_INVALID": "no valid settings stored in EEPROM",
    "MALFORMED": "malformed request",
    "BLOCKED": "a front switch is closed: the cart may only back away from what it touches",
    "WINDOW_FULL": "the waypoint window has no room for these points yet",
    "OUT_OF_ORDER": "the points do not continue the path where it stands",
}


def decode_reply(packet: Packet) -> Reply:
    body = packet.body
    if len(body) < 3 or len(body) != 3 + 4 * body[2]:
        raise ProtocolError("reply length does not match its result count")
    return Reply(packet.seq, body[0], body[1], _unpack_floats(body[3:]))


def decode_request(packet: Packet) -> tuple[int, tuple[float, ...]]:
    body = packet.body
    if len(body) != 2 + 4 * body[1]:
        raise ProtocolError("request length does not match its argument count")
    return body[0], struct.unpack(f"<{body[1]}f", body[2:])


@dataclass(frozen=True)
class Telemetry:
    """One telemetry frame; field order is the channel order of docs/protocol.md."""

    x: float
    y: float
    theta: float
    v_left: float
    v_right: float
    v_left_target: float
    v_right_target: float
    pwm_left: float
    pwm_right: float
    v: float
    omega: float
    v_target: float
    omega_target: float
    distance_to_waypoint: float
    waypoint_index: float
    state: float
    tick: int

    @property
    def mode(self) -> int:
        return int(self.state) & 0x0F

    @property
    def flags(self) -> int:
        return int(self.state) >> 4


TELEMETRY_FIELDS = tuple(f for f in Telemetry.__dataclass_fields__ if f != "tick")


def encode_telemetry(values: list[float] | tuple[float, ...], tick: int) -> bytes:
    if len(values) != TELEMETRY_CHANNELS:
        raise ProtocolError(f"telemetry needs {TELEMETRY_CHANNELS} values")
    data = _floats(values) + struct.pack("<H", tick & 0xFFFF)
    payload = data + struct.pack("<H", crc16_mcrf4xx(data))
    return TELEMETRY_SYNC + bytes([TELEMETRY_PAYLOAD]) + payload + bytes([sum(payload) & 0xFF])


def decode_telemetry(data: bytes) -> Telemetry:
    if len(data) != TELEMETRY_SIZE or data[:2] != TELEMETRY_SYNC or data[2] != TELEMETRY_PAYLOAD:
        raise ProtocolError("not a telemetry frame")
    payload = data[3:-1]
    if sum(payload) & 0xFF != data[-1]:
        raise ProtocolError("telemetry checksum")
    (tick, crc) = struct.unpack("<HH", payload[-4:])
    if crc != crc16_mcrf4xx(payload[:-2]):
        raise ProtocolError("telemetry CRC")
    values = _unpack_floats(payload[: 4 * TELEMETRY_CHANNELS])
    if not all(math.isfinite(v) for v in values):
        raise ProtocolError("telemetry value not finite")
    return Telemetry(**dict(zip(TELEMETRY_FIELDS, values, strict=True)), tick=tick)


# How long past its line time a host waits for the rest of a partial packet (docs/protocol.md,
# "Host receiving"): the firmware writes every packet whole, so only the link's latency (a USB
# adapter's buffering, the reader thread's scheduling) separates its bytes.
PARTIAL_MARGIN_S = 0.05
BITS_PER_BYTE = 10  # 8N1: start bit, 8 data bits, stop bit


class Decoder:
    """Splits a byte stream into packets and telemetry frames; garbage is skipped.

    Each byte is stamped with the time it was fed. A partial packet or frame whose start byte
    has waited longer than its line time plus `margin_s` is dropped like a corrupt one (its
    start byte goes, the bytes after it are scanned again): a corrupted LEN would otherwise
    hold back everything that follows until enough bytes arrived to fill the length it promised.
    feed(b"", now) applies the rule when no byte arrives."""

    def __init__(self, baud: int = 115200, margin_s: float = PARTIAL_MARGIN_S) -> None:
        self._buf = bytearray()
        self._arrived: list[float] = []  # when each byte of _buf was fed (s, the caller's clock)
        self._byte_s = BITS_PER_BYTE / baud
        self.margin_s = margin_s
        self.errors = 0  # starts dropped: bad length, CRC or checksum, or expired
        self.expired = 0  # of which: partial packets that waited too long

    def feed(self, data: bytes, now: float | None = None) -> list[Packet | Telemetry]:
        """The packets and frames completed by `data`, which arrived at `now` (time.monotonic()
        when not given)."""
        now = time.monotonic() if now is None else now
        self._buf += data
        self._arrived += [now] * len(data)
        out: list[Packet | Telemetry] = []
        while self._buf:
            start = self._next_start(0)
            if start < 0:
                self._drop(len(self._buf))
                break
            self._drop(start)
            item, used = self._try_parse()
            if used == 0:
                if now <= self._deadline():
                    break  # need more bytes, and they may still come
                self.expired += 1
            if item is None:
                self.errors += 1
                self._drop(1)  # drop this start byte and rescan after it
                continue
            out.append(item)
            self._drop(used)
        return out

    def _drop(self, count: int) -> None:
        del self._buf[:count]
        del self._arrived[:count]

    def _deadline(self) -> float:
        """When the partial packet at the start of the buffer stops being worth waiting for:
        its start byte's arrival, plus the line time of the whole packet (as far as its LEN
        tells), plus the margin."""
        if self._buf[0] == SYNC:
            length = self._buf[1] if len(self._buf) > 1 else MIN_BODY
            total = length + 5
        else:
            total = TELEMETRY_SIZE
        return self._arrived[0] + total * self._byte_s + self.margin_s

    def _next_start(self, frm: int) -> int:
        for i in range(frm, len(self._buf)):
            b = self._buf[i]
            if b == SYNC or (b == 0xAA and bytes(self._buf[i + 1 : i + 2]) in (b"", b"\xbb")):
                return i
        return -1

    def _try_parse(self) -> tuple[Packet | Telemetry | None, int]:
        """(item, bytes used); (None, n > 0) = invalid here; (None, 0) = incomplete."""
        buf = self._buf
        if buf[0] == SYNC:
            if len(buf) < 2:
                return None, 0
            length = buf[1]
            if not MIN_BODY <= length <= MAX_BODY:
                return None, 1
            total = length + 5
            if len(buf) < total:
                return None, 0
            crc = buf[total - 2] | (buf[total - 1] << 8)
            if crc != crc16_mcrf4xx(bytes(buf[1 : total - 2])):
                return None, 1
            return Packet(buf[2], bytes(buf[3 : total - 2]), crc), total
        if len(buf) < TELEMETRY_SIZE:
            return None, 0
        try:
            return decode_telemetry(bytes(buf[:TELEMETRY_SIZE])), TELEMETRY_SIZE
        except ProtocolError:
            return None, 1

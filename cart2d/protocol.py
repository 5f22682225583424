"""Encoding and decoding of the serial protocol (docs/protocol.md), without any I/O.

`Decoder` turns the byte stream from the firmware into replies and telemetry frames, dropping
anything that fails its length or CRC check and resynchronising on the next start byte.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass

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
    "OVER_CAPACITY": "more waypoints than the firmware can hold",
    "BAD_STATE": "not possible in the current state",
    "EEPROM_INVALID": "no valid settings stored in EEPROM",
    "MALFORMED": "malformed request",
}


def decode_reply(packet: Packet) -> Reply:
    body = packet.body
    if len(body) < 3 or len(body) != 3 + 4 * body[2]:
        raise ProtocolError("reply length does not match its result count")
    results = struct.unpack(f"<{body[2]}f", body[3:])
    return Reply(packet.seq, body[0], body[1], results)


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
    values = struct.unpack(f"<{TELEMETRY_CHANNELS}f", payload[: 4 * TELEMETRY_CHANNELS])
    if not all(math.isfinite(v) for v in values):
        raise ProtocolError("telemetry value not finite")
    return Telemetry(**dict(zip(TELEMETRY_FIELDS, values, strict=True)), tick=tick)


class Decoder:
    """Splits a byte stream into packets and telemetry frames; garbage is skipped."""

    def __init__(self) -> None:
        self._buf = bytearray()
        self.errors = 0

    def feed(self, data: bytes) -> list[Packet | Telemetry]:
        self._buf += data
        out: list[Packet | Telemetry] = []
        while self._buf:
            start = self._next_start(0)
            if start < 0:
                # Keep a trailing 0xAA: it may be the first half of a telemetry sync.
                self._buf = self._buf[-1:] if self._buf[-1:] == b"\xaa" else bytearray()
                break
            del self._buf[:start]
            item, used = self._try_parse()
            if used == 0:
                break  # need more bytes
            if item is None:
                self.errors += 1
                del self._buf[:1]  # drop this start byte and rescan after it
                continue
            out.append(item)
            del self._buf[:used]
        return out

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

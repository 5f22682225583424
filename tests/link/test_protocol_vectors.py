"""The hex test vectors of docs/protocol.md, checked by the Python codec and, for the
`exchange` ones, by the real firmware running in the simulator."""

from __future__ import annotations

import math
import struct
from pathlib import Path

import pytest
import serial

from cart2d.link.protocol import (
    Decoder,
    Packet,
    Telemetry,
    decode_reply,
    decode_request,
    decode_telemetry,
    encode_reply,
    encode_request,
    encode_telemetry,
)
from cart2d.spec import Vector, crc16_mcrf4xx, load_spec, load_vectors
from tests.support.sim import start_sim

VECTORS = load_vectors()


def of_kind(kind: str) -> list[pytest.ParameterSet]:
    return [pytest.param(v, id=v.name) for v in VECTORS if v.kind == kind]


def floats(text: str) -> list[float]:
    return [float(x) for x in text.split(",")] if text else []


def same(a: float, b: float) -> bool:
    return (math.isnan(a) and math.isnan(b)) or struct.pack("<f", a) == struct.pack("<f", b)


def packets(data: bytes) -> list[Packet]:
    return [item for item in Decoder().feed(data) if isinstance(item, Packet)]


def test_every_kind_is_present() -> None:
    assert {v.kind for v in VECTORS} == {
        "crc",
        "request",
        "reply",
        "telemetry",
        "reject",
        "stream",
        "exchange",
    }


@pytest.mark.parametrize("v", of_kind("crc"))
def test_crc(v: Vector) -> None:
    assert crc16_mcrf4xx(v.data) == int(v.fields["crc"], 16)


@pytest.mark.parametrize("v", of_kind("request"))
def test_request(v: Vector) -> None:
    (packet,) = packets(v.data)
    cmd, args = decode_request(packet)
    expected = floats(v.fields["args"])
    assert packet.seq == int(v.fields["seq"]) and cmd == int(v.fields["cmd"])
    assert len(args) == len(expected) and all(same(a, b) for a, b in zip(args, expected, strict=True))
    assert encode_request(packet.seq, cmd, expected) == v.data


@pytest.mark.parametrize("v", of_kind("reply"))
def test_reply(v: Vector) -> None:
    (packet,) = packets(v.data)
    reply = decode_reply(packet)
    expected = floats(v.fields["args"])
    assert (reply.seq, reply.status, reply.cmd) == (
        int(v.fields["seq"]),
        int(v.fields["status"]),
        int(v.fields["cmd"]),
    )
    assert all(same(a, b) for a, b in zip(reply.results, expected, strict=True))
    assert encode_reply(reply.seq, reply.status, reply.cmd, expected) == v.data


@pytest.mark.parametrize("v", of_kind("telemetry"))
def test_telemetry(v: Vector) -> None:
    frame = decode_telemetry(v.data)
    values = floats(v.fields["values"])
    assert frame.tick == int(v.fields["tick"])
    assert encode_telemetry(values, frame.tick) == v.data
    assert [item for item in Decoder().feed(b"\x00\x01" + v.data) if isinstance(item, Telemetry)] == [frame]


@pytest.mark.parametrize("v", of_kind("reject"))
def test_reject(v: Vector) -> None:
    assert packets(v.data) == []


@pytest.mark.parametrize("v", of_kind("stream"))
def test_stream(v: Vector) -> None:
    assert [p.seq for p in packets(v.data)] == [int(s) for s in v.fields["seqs"].split(",")]


def test_stream_fed_byte_by_byte_gives_the_same_packets() -> None:
    for v in VECTORS:
        if v.kind != "stream":
            continue
        decoder = Decoder()
        found = [item for b in v.data for item in decoder.feed(bytes([b]))]
        assert [p.seq for p in found if isinstance(p, Packet)] == [
            int(s) for s in v.fields["seqs"].split(",")
        ]


def test_exchanges_with_the_real_firmware(tmp_path: Path) -> None:
    """Each exchange vector against a freshly reset firmware with a blank EEPROM: its requests,
    sent back to back, yield its replies in order. A power-on reset: Optiboot 4.4 starts the
    firmware at once without EXTRF, where after the button it would take the bytes itself."""
    sim = start_sim(tmp_path)
    try:
        with serial.Serial(sim.pty, 115200, timeout=0.05) as port:
            for v in (v for v in VECTORS if v.kind == "exchange"):
                expected = packets(v.reply)
                assert len(packets(v.data)) == len(expected), f"{v.name}: one reply per request"
                sim.reset("power")  # returns after the reset time-out, when the firmware listens again
                port.reset_input_buffer()
                port.write(v.data)
                replies: list[Packet] = []
                decoder = Decoder()
                for _ in range(100):
                    replies += [i for i in decoder.feed(port.read(256)) if isinstance(i, Packet)]
                    if len(replies) >= len(expected):
                        break
                assert len(replies) == len(expected), f"{v.name}: {len(replies)} replies"
                encoded = b"".join(
                    encode_reply(got.seq, got.body[0], got.body[1], decode_reply(got).results)
                    for got in replies
                )
                assert encoded == v.reply, f"{v.name}: {encoded.hex(' ')} != {v.reply.hex(' ')}"
    finally:
        sim.stop()


def test_spec_tables_match_what_the_firmware_reports(tmp_path: Path) -> None:
    from cart2d.link import Link

    spec = load_spec()
    sim = start_sim(tmp_path)
    try:
        with Link(sim.pty) as link:
            version, _firmware, dictionary, *_ = link.call("VERSION")
        assert int(version) == spec.version
        assert int(dictionary) == spec.dictionary_hash
    finally:
        sim.stop()

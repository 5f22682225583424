"""Firmware updates: HEX checks, refusal of bad files, and a reload in the simulator."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from cart2d.link.flashing import APPLICATION_BYTES, check_hex
from cart2d.simulator import default_firmware
from tests.conftest import wait_for
from tests.test_server import OCTETS, Rig

HEX = default_firmware().with_suffix(".hex")


def record(address: int, data: bytes, kind: int = 0) -> str:
    body = bytes([len(data), address >> 8, address & 0xFF, kind]) + data
    return ":" + (body + bytes([(-sum(body)) & 0xFF])).hex().upper()


# 26 vectors: a JMP (0C 94 ..) and an RJMP (.. C0 + NOP), as avr-gcc writes them with -mrelax.
VECTOR_TABLE = (
    "\n".join(record(16 * k, (b"\x0c\x94\x34\x00" + b"\x09\xc1\x00\x00") * 2) for k in range(6))
    + "\n"
    + record(96, b"\x0c\x94\x34\x00" * 2)
    + "\n"
    + record(0, b"", 1)
)


def test_the_built_firmware_passes_the_check() -> None:
    size = check_hex(HEX.read_bytes())
    assert 10_000 < size < APPLICATION_BYTES


@pytest.mark.parametrize(
    ("text", "fragment"),
    [
        ("", "no program"),
        (VECTOR_TABLE, ""),  # valid: must not raise
        (record(0, b"\x0c\x94" * 2) + "\n" + record(0, b"", 1), "vector table"),  # too short
        (record(0, b"\x00" * 16) + "\n" + record(0, b"", 1), "vector table"),  # no jumps: not a program
        (record(0, b"\x0c\x94")[:-2] + "00\n" + record(0, b"", 1), "Intel HEX"),  # bad checksum
        ("hello, world\n", "Intel HEX"),
        (record(0x7F00, b"\x00" * 16) + "\n" + record(0, b"", 1), "bootloader"),
        ("\xff\xfe", "Intel HEX"),
    ],
)
def test_hex_files_are_checked(text: str, fragment: str) -> None:
    data = text.encode("latin-1")
    if not fragment:
        assert check_hex(data) == 104
        return
    with pytest.raises(ValueError, match=fragment):
        check_hex(data)


@pytest.fixture
def rig(tmp_path: Path) -> Iterator[Rig]:
    r = Rig(tmp_path)
    yield r
    r.close()


def test_a_bad_file_is_refused_and_nothing_starts(rig: Rig) -> None:
    response = rig.client.post("/api/firmware/update", content=b"not a hex file", headers=OCTETS)
    assert response.status_code == 422 and "Intel HEX" in response.json()["detail"]
    assert rig.client.get("/api/firmware/update").json()["state"] == "idle"


def test_uploading_a_hex_restarts_the_simulator_on_it_and_keeps_the_eeprom(rig: Rig) -> None:
    rig.client.post("/api/command", json={"name": "SET_POSE", "args": [1.0, 1.0, 0.0]})
    rig.client.put("/api/firmware/settings", json={"id": 4, "value": 0.02})  # tol_final_m
    rig.client.post("/api/firmware/save")
    wait_for(lambda: rig.client.get("/api/status").json()["status"]["eeprom_busy"] is False)
    response = rig.client.post("/api/firmware/update", content=HEX.read_bytes(), headers=OCTETS)
    assert response.status_code == 202 and response.json()["state"] == "running"
    wait_for(lambda: rig.client.get("/api/firmware/update").json()["state"] != "running", 30)
    job = rig.client.get("/api/firmware/update").json()
    assert job["state"] == "done", job["log"]
    status = rig.client.get("/api/status").json()
    assert status["link"]["state"] == "connected" and status["firmware"]["firmware"] == "0.1.0"
    assert status["pose"] == {"x": 0.0, "y": 0.0, "theta": 0.0}  # a freshly started MCU
    settings = {s["name"]: s["value"] for s in rig.client.get("/api/firmware/settings").json()}
    assert settings["tol_final_m"] == pytest.approx(0.02)  # loaded from the kept EEPROM


def test_a_firmware_that_does_not_answer_is_rolled_back_in_simulation(rig: Rig) -> None:
    response = rig.client.post("/api/firmware/update", content=VECTOR_TABLE.encode(), headers=OCTETS)
    assert response.status_code == 202  # it looks like an AVR program...
    wait_for(lambda: rig.client.get("/api/firmware/update").json()["state"] != "running", 60)
    job = rig.client.get("/api/firmware/update").json()
    assert job["state"] == "failed" and "previous firmware runs again" in job["log"][-1]
    status = rig.client.get("/api/status").json()  # ...but the robot answers again
    assert status["link"]["state"] == "connected" and status["firmware"]["firmware"] == "0.1.0"
    assert rig.client.post("/api/command", json={"name": "POSE", "args": []}).json()["status"] == "CONTROL_OK"

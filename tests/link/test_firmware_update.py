"""Firmware updates: HEX checks, refusal of bad files, avrdude through the simulated Nano's
Optiboot (the real cart's path), and the rollback to the last firmware that answered (issue 11,
finding 3)."""

from __future__ import annotations

import math
import subprocess
from pathlib import Path
from typing import Any

import pytest

from cart2d.link.built import default_binary, default_firmware
from cart2d.link.firmware_files import check_hex
from cart2d.simulation.side_channel import SimulatorError
from tests.support.server import OCTETS, Rig
from tests.support.sim import run_for
from tests.support.waiting import wait_for

HEX = default_firmware().with_suffix(".hex")
APPLICATION_BYTES = 32768 - 512  # below the Nano's bootloader


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
        ("", "empty file"),
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


def test_a_bad_file_is_refused_and_nothing_starts(rig: Rig) -> None:
    response = rig.client.post("/api/firmware/update", content=b"not a hex file", headers=OCTETS)
    assert response.status_code == 422 and "Intel HEX" in response.json()["detail"]
    assert rig.client.get("/api/firmware/update").json()["state"] == "idle"


def test_a_simulator_without_a_bootloader_refuses_an_update_with_what_to_do(tmp_path: Path) -> None:
    """The bare chip (`cart2d sim --no-bootloader`): nothing can flash it, so nothing starts."""
    bare = Rig(tmp_path, bootloader=None)
    try:
        response = bare.client.post("/api/firmware/update", content=HEX.read_bytes(), headers=OCTETS)
        assert response.status_code == 409, response.text
        assert response.json()["detail"] == (
            "the simulator runs without a bootloader (cart2d sim --no-bootloader), so nothing can flash it: "
            "start it without --no-bootloader to update its firmware"
        )
        assert update_state(bare)["state"] == "idle"
    finally:
        bare.close()


def test_uploading_a_hex_flashes_it_through_avrdude_in_place_and_keeps_the_eeprom(rig: Rig) -> None:
    rig.client.post("/api/command", json={"name": "SET_POSE", "args": [1.0, 1.0, 0.0]})
    rig.client.put("/api/firmware/settings", json={"id": 4, "value": 0.02})  # tol_final_m
    rig.client.post("/api/firmware/save")
    wait_for(lambda: rig.gateway.read_status().eeprom_busy is False)  # read now, after the SAVE
    assert rig.sim.process is not None
    pid = rig.sim.process.pid
    response = rig.client.post("/api/firmware/update", content=HEX.read_bytes(), headers=OCTETS)
    assert response.status_code == 202 and response.json()["state"] == "running"
    job = wait_update(rig)
    assert job["state"] == "done", job["log"]
    assert any("avrdude" in line and "-c arduino" in line and "-D" in line for line in job["log"]), job["log"]
    assert any("bytes of flash verified" in line for line in job["log"]), job["log"]
    assert rig.sim.process.pid == pid  # flashed through the bootloader, not a new simulator
    status = rig.client.get("/api/status").json()
    assert status["link"]["state"] == "connected" and status["firmware"]["firmware"] == "0.1.0"
    # Another program may have been flashed, and the cart moved meanwhile: whatever pose the
    # firmware kept in RAM, the gateway plans from none until the user says where the cart is.
    assert status["pose_trust"]["trusted"] is False
    assert status["reset"]["last"]["caused_by"] == "a firmware update"
    settings = {s["name"]: s["value"] for s in rig.client.get("/api/firmware/settings").json()}
    assert settings["tol_final_m"] == pytest.approx(0.02)  # -D: avrdude leaves the EEPROM alone


# -- the same reader as the simulator's, and the rollback (issue 11, finding 3) ---------------------
EOF_RECORD = record(0, b"", 1)
TABLE = VECTOR_TABLE.removesuffix(EOF_RECORD)  # the vector table's records, each with its newline

# Files the gateway used to take and the simulator refuses, with the words of the refusal.
REFUSED = {
    "junk after the end": (VECTOR_TABLE + "\njunk\n", "line 9: more text after the end-of-file record"),
    "no end record": (TABLE, "no end-of-file record"),
    "an end record mid-file": (
        TABLE + EOF_RECORD + "\n" + record(0x200, b"\x01\x02") + "\n" + EOF_RECORD + "\n",
        "line 9: more text after the end-of-file record",
    ),
    "a 160-byte record": (
        TABLE + record(0x200, bytes(160)) + "\n" + EOF_RECORD + "\n",
        "longer than the 126 characters",
    ),
    "leading blank lines": ("\n\n" + VECTOR_TABLE + "\n", "line 1: empty line before the end-of-file record"),
    "a type-02 segment simavr misreads": (
        TABLE + record(0, b"\x00\x01", 2) + "\n" + record(0x70, b"\x01\x02") + "\n" + EOF_RECORD + "\n",
        "ORs extended segment addresses",
    ),
}


def upload(client: Any, data: bytes) -> Any:
    return client.post("/api/firmware/update", content=data, headers=OCTETS)


def update_state(rig: Rig) -> dict[str, Any]:
    state: dict[str, Any] = rig.client.get("/api/firmware/update").json()
    return state


def wait_update(rig: Rig, wall_timeout_s: float = 120.0) -> dict[str, Any]:
    wait_for(lambda: update_state(rig)["state"] != "running", wall_timeout_s)
    return update_state(rig)


def motors(rig: Rig) -> tuple[float, float]:
    """The duties the H-bridges see (NaN while the simulator is between two processes)."""
    try:
        truth = rig.sim.truth()
    except SimulatorError:
        return math.nan, math.nan
    return float(truth["duty_l"]), float(truth["duty_r"])


@pytest.mark.parametrize("name", list(REFUSED))
def test_a_file_the_simulator_refuses_is_refused_with_its_words_and_nothing_changes(
    rig: Rig, tmp_path: Path, name: str
) -> None:
    text, words = REFUSED[name]
    assert rig.sim.process is not None
    pid, running = rig.sim.process.pid, rig.sim.options.firmware
    response = upload(rig.client, text.encode())
    assert response.status_code == 422, response.text
    assert words in response.json()["detail"]
    assert update_state(rig)["state"] == "idle"
    assert rig.sim.process.pid == pid and rig.sim.options.firmware == running  # nothing restarted
    assert rig.client.post("/api/command", json={"name": "POSE", "args": []}).json()["status"] == "CONTROL_OK"
    # One reader: the simulator, given the file, refuses it with the same words.
    path = tmp_path / "refused.hex"
    path.write_text(text)
    sim = [str(default_binary()), "--firmware", str(path), "--eeprom", str(tmp_path / "e.bin")]
    done = subprocess.run(sim, capture_output=True, text=True, timeout=30, check=False)
    assert done.returncode == 1 and words in done.stderr, done.stderr


def test_the_cart_is_stoppable_throughout_an_update_and_a_rollback(rig: Rig, half_duty_hex: bytes) -> None:
    """A stop during a good update waits for it and stops the new firmware; a stop while a
    firmware that does not answer drives the cart rolls it back at once to the last firmware
    that answered (the good upload, not the built file): after its answer the motors are off
    and the previous firmware runs. (A rollback without a stop, after the check's full time:
    tests/link/test_flash_optiboot.py.)"""
    assert upload(rig.client, HEX.read_bytes()).status_code == 202
    assert rig.client.post("/api/stop").status_code == 200
    assert update_state(rig)["state"] == "done"  # a good firmware answers in its time, and stays
    assert upload(rig.client, half_duty_hex).status_code == 202
    wait_for(lambda: min(motors(rig)) > 0.45, 30)
    stop = rig.client.post("/api/stop")
    assert stop.status_code == 200, stop.text
    run_for(rig.sim, 0.008)  # the firmware sets the motors at its next control tick
    assert motors(rig) == (0.0, 0.0)
    job = update_state(rig)
    assert job["state"] == "failed" and "the previous firmware runs again" in job["log"][-1], job["log"]
    # the reason alone, for "The update failed: ..." (not "The update failed: failed: ...")
    assert (
        job["error"].startswith("the new firmware was rejected")
        and job["log"][-1] == f"failed: {job['error']}"
    )
    # The file that answered before, byte for byte: not the path the bad upload went to.
    assert rig.sim.options.firmware.read_bytes() == HEX.read_bytes()
    status = rig.client.get("/api/status").json()
    assert status["link"]["state"] == "connected" and status["firmware"]["firmware"] == "0.1.0"
    for _ in range(3):  # and again, on the firmware that answers
        assert rig.client.post("/api/stop").status_code == 200
        run_for(rig.sim, 0.05)
        assert motors(rig) == (0.0, 0.0)

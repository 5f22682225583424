"""What the gateway and the command line say, checked against what is true: numbers from the
firmware without float32 noise, the soft reset's words against the firmware's pose, where
`cart2d calibrate --sim` saved its values."""

from __future__ import annotations

import random
import struct

import pytest

from cart2d.link.protocol import Decoder, Packet, decode_reply, encode_reply, shortest_float32
from cart2d.tools.cli import main
from tests.support.server import Rig
from tests.support.sim import run_for
from tests.support.waiting import wait_for


def test_numbers_from_the_firmware_carry_no_float32_noise(rig: Rig) -> None:
    """tol_final_m is 0.005 (config/robot.toml): as a float32 widened to a double it would read
    0.004999999888241291."""
    tol = rig.client.post("/api/command", json={"name": "TOL_GET", "args": []}).json()
    assert tol["results"] == [0.005]
    param = rig.client.post("/api/command", json={"name": "PARAM_GET", "args": [4]}).json()
    assert param["results"] == [4.0, 0.005, 0.001, 0.5]
    settings = {s["name"]: s["value"] for s in rig.client.get("/api/firmware/settings").json()}
    assert settings["tol_final_m"] == 0.005 and settings["v_max_mps"] == 0.5
    assert rig.client.put("/api/firmware/settings", json={"id": 6, "value": 0.3}).json() == {"value": 0.3}


def test_shortest_float32_keeps_every_float32_and_drops_the_noise() -> None:
    assert shortest_float32(struct.unpack("<f", struct.pack("<f", 0.005))[0]) == 0.005
    assert shortest_float32(0.004999999888241291) == 0.005
    generator = random.Random(12)
    for _ in range(20000):
        raw = generator.getrandbits(32).to_bytes(4, "little")
        (value,) = struct.unpack("<f", raw)
        short = shortest_float32(value)
        if value == value:  # NaN stays NaN
            assert struct.pack("<f", short) == raw  # the same float32
            assert len(repr(short)) <= len(repr(value))
    # a reply decodes to the short numbers, and encodes back to the same bytes
    data = encode_reply(7, 0, 12, [0.005, 0.1, 1e-3])
    (packet,) = Decoder().feed(data)
    assert isinstance(packet, Packet)
    reply = decode_reply(packet)
    assert reply.results == (0.005, 0.1, 0.001) and encode_reply(7, 0, 12, reply.results) == data


def test_the_soft_reset_says_what_the_firmware_did_with_its_pose(rig: Rig) -> None:
    """A soft reset keeps the RAM: the firmware restores its pose from it (retained.cpp), and
    the words say so with that pose. A power cut loses it: the pose restarts at (0, 0, 0)."""
    assert rig.client.post("/api/goto", json={"x": 0.6, "y": 0.4}).status_code == 200
    run_for(rig.sim, 4.0)
    before = rig.pose_now()
    assert before["x"] > 0.5
    report = rig.client.post("/api/reset").json()["reset"]
    after = rig.pose_now()
    assert report["pose_restored"] and after == before
    assert rig.client.get("/api/status").json()["pose"] == after  # what the gateway read at the restart
    where = f"({after['x']:.3f} m, {after['y']:.3f} m,"
    assert f"restored its pose from RAM, {where}" in report["message"]
    assert "(0, 0, 0)" not in report["message"]

    noticed = rig.gateway.resets_noticed
    rig.sim.reset("power", off_s=0.5)
    run_for(rig.sim, 0.5)
    wait_for(lambda: rig.gateway.resets_noticed > noticed, 10)  # the monitor notices the restart
    last = rig.client.get("/api/status").json()["reset"]["last"]
    assert not last["pose_restored"] and "Its pose restarted at (0, 0, 0)." in last["message"]
    assert rig.client.get("/api/status").json()["pose"] == {"x": 0.0, "y": 0.0, "theta": 0.0}


def test_calibrate_in_the_simulator_says_a_temporary_eeprom_keeps_nothing(
    capsys: pytest.CaptureFixture[str],
) -> None:
    code = main(["calibrate", "--sim", "--side=0.5", "--runs=1", "--passes=1", "--no-check"])
    said = capsys.readouterr().out
    assert code == 0, said
    assert "saved to EEPROM" not in said
    assert "saved to the simulated EEPROM, a temporary file deleted with the simulator" in said

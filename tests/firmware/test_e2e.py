"""End-to-end behaviour of the real firmware ELF in the simulator, judged by ground truth."""

from __future__ import annotations

import math
import time
from pathlib import Path

import serial

from cart2d.link import Link
from cart2d.link.firmware import read_status
from cart2d.link.protocol import encode_request
from cart2d.simulation.simulator import Simulator
from cart2d.spec import load_spec
from tests.support.sim import run_for, start_sim, wait_idle
from tests.support.waiting import wait_for

SPEC = load_spec()
FLAGS = SPEC.flags
# One encoder count of a measuring wheel: 2 pi 0.021 m / 2000 = 0.066 mm.
COUNT_M = 2 * math.pi * 0.021 / 2000


def truth_pose(sim: Simulator) -> tuple[float, float, float]:
    t = sim.truth()
    return t["x"], t["y"], t["theta"]


def angle_diff(a: float, b: float) -> float:
    return math.remainder(a - b, 2 * math.pi)


def test_straight_drive_odometry_agrees_with_truth(sim: Simulator, link: Link) -> None:
    link.call("GOTO", 1.5, 0.0)
    status = wait_idle(link)
    x, y, theta = link.call("POSE")
    tx, ty, ttheta = truth_pose(sim)
    assert int(status[1]) & FLAGS["ARRIVED"]
    # No injected errors: odometry and truth differ only by count quantisation.
    assert math.hypot(x - tx, y - ty) < 5 * COUNT_M
    assert abs(angle_diff(theta, ttheta)) < 0.002
    assert math.hypot(tx - 1.5, ty) < 0.01


def test_turn_in_place_odometry_agrees_with_truth(tmp_path: Path) -> None:
    sim = start_sim(tmp_path, speed="1", start=(0.9, 0.9, 0.0))
    try:
        with Link(sim.pty) as link:
            link.call("SET_POSE", 0.9, 0.9, 0.0)
            t_end = time.monotonic() + 1.5
            while time.monotonic() < t_end:  # refresh faster than the 0.5 s manual timeout
                link.call("VELOCITY", 0.0, 1.5)
                time.sleep(0.1)
            link.call("STOP")
            run_for(sim, 0.3)
            x, y, theta = link.call("POSE")
            tx, ty, ttheta = truth_pose(sim)
        assert abs(angle_diff(ttheta, 0.0)) > 1.5  # it really turned (1.5 rad/s for ~1.5 s)
        assert abs(angle_diff(theta, ttheta)) < 0.002
        assert math.hypot(x - tx, y - ty) < 0.002
        assert math.hypot(tx - 0.9, ty - 0.9) < 0.02  # on the spot
    finally:
        sim.stop()


def test_goto_stops_within_the_final_tolerance_in_ground_truth(sim: Simulator, link: Link) -> None:
    tol = link.call("TOL_GET")[0]
    link.call("GOTO", 1.2, 0.8)
    status = wait_idle(link)
    tx, ty, _ = truth_pose(sim)
    assert int(status[1]) & FLAGS["ARRIVED"]
    assert math.hypot(tx - 1.2, ty - 0.8) < tol + 5 * COUNT_M
    assert sim.truth()["collisions"] == 0 and sim.truth()["wall_contacts"] == 0


def test_goto_behind_drives_backwards(sim: Simulator, link: Link) -> None:
    link.call("SET_POSE", 0.0, 0.0, 0.0)
    sim.control("place", x=1.0, y=0.9, theta=0.0)
    link.call("SET_POSE", 1.0, 0.9, 0.0)
    link.call("GOTO", 0.5, 0.9)
    wait_for(lambda: link.telemetry is not None and link.telemetry.v < -0.05)
    wait_idle(link)
    tx, ty, ttheta = truth_pose(sim)
    assert math.hypot(tx - 0.5, ty - 0.9) < 0.01
    assert abs(angle_diff(ttheta, 0.0)) < 0.05  # it never turned round


def test_waypoint_path_in_several_frames(sim: Simulator, link: Link) -> None:
    # A 20-point zig-zag: more than one frame holds (15 points), so XY_APPEND carries the rest.
    points = [(0.1 * (i + 1), 0.2 * (i % 2) + 0.4) for i in range(16)] + [
        (1.6, 1.0),
        (1.2, 1.4),
        (0.8, 1.4),
        (0.4, 1.0),
    ]
    flat = [c for p in points for c in p]
    assert link.call("WAIT_XY_ARRAY", len(points), *flat[:30]) == (15.0, 0.0, 5.0)  # received, index, room
    received, _index, room = link.call("XY_APPEND", 15, *flat[30:])
    assert (received, room) == (20.0, 0.0)
    status = wait_idle(link)
    tx, ty, _ = truth_pose(sim)
    assert int(status[1]) & FLAGS["ARRIVED"]
    assert int(status[2]) == 20 and int(status[3]) == 20  # every waypoint consumed
    assert math.hypot(tx - 0.4, ty - 1.0) < 0.01
    assert sim.truth()["wall_contacts"] == 0


def test_path_over_capacity_is_refused_and_the_cart_keeps_its_path(sim: Simulator, link: Link) -> None:
    link.call("WAIT_XY_ARRAY", 2, 1.0, 0.0, 1.0, 1.0)
    refused = link.request("WAIT_XY_ARRAY", [65536.0])  # a path holds at most 65 535 points
    assert refused.status == 1 and "more waypoints" in refused.describe_error()
    status = wait_idle(link)
    tx, ty, _ = truth_pose(sim)
    assert int(status[3]) == 2
    assert math.hypot(tx - 1.0, ty - 1.0) < 0.01


def test_reset_routine_squares_up_against_the_wall(tmp_path: Path) -> None:
    # Placed askew (0.2 rad) 0.6 m from the east wall; the routine must end flat against it.
    sim = start_sim(tmp_path, start=(1.2, 0.9, 0.2))
    try:
        with Link(sim.pty) as link:
            link.call("PARAM_SET", 11, 0.9)  # reset_y_m: where we placed it
            link.call("RESET_ROUTINE")
            status = wait_idle(link)
            x, y, theta = link.call("POSE")
            truth = sim.truth()
        assert not int(status[1]) & FLAGS["ROUTINE_FAILED"]
        assert truth["switch_l"] and truth["switch_r"]
        assert abs(angle_diff(truth["theta"], 0.0)) < 0.01  # square to the wall
        assert abs(truth["x"] - 1.88) < 0.005  # bumper (0.17 m) on the wall at 2.05 m
        assert (x, y, theta) == (1.88000005, 0.9, 0.0) or (abs(x - 1.88) < 1e-6 and abs(y - 0.9) < 1e-6)
        assert theta == 0.0
    finally:
        sim.stop()


def test_save_survives_an_mcu_reset_and_load_restores_it(sim: Simulator, link: Link) -> None:
    link.call("TOL_SET", 0.02)
    link.call("PARAM_SET", 8, 0.75)
    link.call("SAVE")
    wait_for(lambda: link.call("STATUS")[9] == 0.0)  # eeprom_busy
    before = read_status(link)
    sim.reset()  # returns once the reset time-out is over: requests sent before would be lost
    # A RAM-keeping reset shows as a new boot count. Not the uptime going backwards: Optiboot
    # swallows the first request after the reset, and at max speed its 0.2 s wait for a reply is
    # ~14 s simulated, enough for the restarted MCU's uptime to overtake the old one.
    wait_for(lambda: read_status(link).restarted_since(before))
    assert read_status(link).boot_count == before.boot_count + 1
    assert link.call("TOL_GET") == (0.02,)  # the float32 nearest 0.02, in its shortest digits
    assert link.call("PARAM_GET", 8)[1] == 0.75
    assert link.call("STATUS")[8] == 0.0  # settings from EEPROM, not defaults
    link.call("TOL_SET", 0.03)
    link.call("LOAD")
    assert abs(link.call("TOL_GET")[0] - 0.02) < 1e-9


def test_eeprom_persists_across_simulator_restarts(tmp_path: Path) -> None:
    for run in range(2):
        sim = start_sim(tmp_path)
        try:
            with Link(sim.pty) as link:
                if run == 0:
                    link.call("MAX_SPEED_SET", 0.3, 2.0)
                    link.call("SAVE")
                    wait_for(lambda: link.call("STATUS")[9] == 0.0)
                else:
                    assert link.call("MAX_SPEED_GET") == (0.3, 2.0)
        finally:
            sim.stop()


def test_corrupt_and_dropped_uart_bytes_do_not_derail_the_link(sim: Simulator, link: Link) -> None:
    sim.control("faults", uart_rx_corrupt=0.01, uart_rx_drop=0.005, uart_tx_corrupt=0.01, uart_tx_drop=0.005)
    # At 1.5 % of bytes lost or flipped each way, STATUS (7 bytes out, 68 back) gets through on
    # about a third of tries; 10 retries gave up about once in 300 calls. A request is
    # retransmitted only within 1.5 s of its first transmission: tries 50 ms apart (a reply
    # here takes a few ms) make about 30 of them, and 0.68^30 is about 1 in 10^5.
    link.timeout_s = 0.05
    link.retries = 40
    for i in range(60):
        value = 0.01 + 0.001 * i
        assert struct_f32(link.call("TOL_SET", value)[0]) == struct_f32(value)  # the same float32
        assert struct_f32(link.call("TOL_GET")[0]) == struct_f32(value)
    assert link.retransmissions > 0  # faults really happened
    link.call("GOTO", 0.8, 0.4)
    wait_idle(link)
    tx, ty, _ = truth_pose(sim)
    assert math.hypot(tx - 0.8, ty - 0.4) < 0.05  # the last TOL_SET (0.069 m) applies
    status = link.call("STATUS")
    assert status[7] > 0  # the firmware counted the corrupt packets it dropped


def wait_for_event(sim: Simulator, name: str) -> None:
    side = sim.side
    assert side is not None
    wait_for(lambda: any(e.get("event") == name for e in side.events), 10)


def struct_f32(value: float) -> float:
    import struct

    return float(struct.unpack("<f", struct.pack("<f", value))[0])


def test_manual_drive_stops_without_refresh(tmp_path: Path) -> None:
    sim = start_sim(tmp_path, speed="1", start=(0.2, 0.9, 0.0))
    try:
        with Link(sim.pty) as link:
            for _ in range(8):  # 0.8 s of refreshed driving
                link.call("VELOCITY", 0.3, 0.0)
                time.sleep(0.1)
            assert abs(sim.truth()["duty_l"]) > 0.05  # driving
            run_for(sim, 0.7)  # no refresh for longer than the 0.5 s timeout
            status = link.call("STATUS")
            truth = sim.truth()
        assert int(status[0]) == 0 and int(status[1]) & FLAGS["MANUAL_TIMEOUT"]
        assert truth["duty_l"] == 0.0 and truth["duty_r"] == 0.0
    finally:
        sim.stop()


def test_same_seed_and_inputs_give_the_same_trajectory(tmp_path: Path) -> None:
    """Deterministic: both runs start paused, open the port (which resets the MCU, as on a
    Nano), boot through Optiboot for 1.6 s, get the command queued while paused, and run
    exactly 6 s more of simulated time; seeded faults included."""
    endings = []
    for run in range(2):
        sim = start_sim(tmp_path / str(run), seed=7, paused=True)
        try:
            sim.control("faults", enc_miss_prob=0.001, enc_radius_scale_l=1.01)
            with serial.Serial(sim.pty, 115200) as port:
                wait_for_event(sim, "host_open")
                # Boot: the reset time-out, Optiboot's LED flashes and 1 s wait, its watchdog reset
                # (~1.53 s); a byte sent before would end Optiboot's wait, and be lost with it.
                sim.run_for(1.6)
                port.write(encode_request(1, SPEC.code("GOTO"), [1.0, 0.5]))
                port.flush()
                time.sleep(0.1)  # the simulator has read the bytes before it runs
                endings.append(sim.run_for(6.0))
        finally:
            sim.stop()
    a, b = endings
    assert a["t"] == b["t"] and abs(a["t"] - 7.6) < 1e-6  # to the instruction
    assert (a["x"], a["y"], a["theta"]) == (b["x"], b["y"], b["theta"])
    assert math.hypot(a["x"] - 1.0, a["y"] - 0.5) < 0.05  # and it did drive there

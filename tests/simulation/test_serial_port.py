"""The simulated Nano's serial port as a host sees it: opening it resets the MCU (a Nano's DTR
line pulses RESET through 100 nF), what the MCU sends while nobody has it open is lost, and the
host's end of the line (baud rate, USB delays) is set on the command line or by the `link`
message (sim/README.md)."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import pytest

from cart2d.link import Link, LinkTimeout
from cart2d.params import robot
from cart2d.simulation.side_channel import SimulatorError
from cart2d.simulation.simulator import Simulator
from tests.support.sim import events, run_for, start_sim
from tests.support.waiting import wait_for


@dataclass(frozen=True)
class Reopen:
    """HEARTBEAT's uptime 1.2 s after the port opened (over 1 s whatever the boot took: the DTR
    reset's 65 ms time-out and the start-up), then right after closing and reopening it; and, in
    simulated time, when the first answer had come (read after it), when the port reopened and
    when the second answer had come. The simulator runs on (`speed max`) while the host reads
    an answer and asks for the time: those times bound an answer from above, never date it."""

    before: float
    after: float
    first_answered_by: float
    reopened_at: float
    second_answered_by: float


def uptimes_across_a_reopen(sim: Simulator) -> Reopen:
    with Link(sim.pty, timeout_s=0.2) as link:
        run_for(sim, 1.2)
        before = link.call("HEARTBEAT")[0]
        first_answered_by = sim.truth()["t"]
    with Link(sim.pty, timeout_s=0.2) as link:
        after = link.call("HEARTBEAT")[0]
        second_answered_by = sim.truth()["t"]
    reopened_at = [e["t"] for e in events(sim, "host_open") if e["opens"] == 2]
    assert reopened_at, events(sim, "host_open")  # sent before the answer that followed it
    return Reopen(before, after, first_answered_by, reopened_at[0], second_answered_by)


def test_opening_the_port_resets_the_mcu(tmp_path: Path) -> None:
    sim = start_sim(tmp_path)
    try:
        sim.control("stats")  # the side channel is served: no event can pass it by
        reopen = uptimes_across_a_reopen(sim)
        assert reopen.before >= 1.0
        # The MCU restarted when the port reopened: its uptime is shorter than the time since.
        # (A request written the moment the port opens reaches an MCU still booting and is lost,
        # as on a Nano; the link resends it.)
        assert reopen.after < reopen.second_answered_by - reopen.reopened_at
        opens = events(sim, "host_open")
        assert [e["opens"] for e in opens] == [1, 2]
        assert all(e["reset"] for e in opens)
        wait_for(lambda: len(events(sim, "host_close")) == 2, 10)
        assert sim.control("stats")["stats"]["uart"]["host_opens"] == 2
    finally:
        sim.stop()


def test_no_auto_reset_keeps_the_mcu_running_across_opens(tmp_path: Path) -> None:
    sim = start_sim(tmp_path, auto_reset=False)
    try:
        sim.control("stats")  # the side channel is served: no event can pass it by
        reopen = uptimes_across_a_reopen(sim)
        # Its uptime went on at least from the first answer to the reopening (the first answered
        # before first_answered_by, the second after reopened_at): with a reset it would be below
        # `before` (over 1 s). Uptime counts whole control ticks: one tick of slack.
        tick_s = 1.0 / robot()["control"]["tick_hz"]
        assert reopen.after - reopen.before >= reopen.reopened_at - reopen.first_answered_by - tick_s
        assert [e["reset"] for e in events(sim, "host_open")] == [False, False]
    finally:
        sim.stop()


def read_available(fd: int) -> bytes:
    try:
        return os.read(fd, 65536)
    except BlockingIOError:
        return b""


def test_output_while_no_host_listens_is_lost_not_queued(tmp_path: Path) -> None:
    sim = start_sim(tmp_path, paused=True, auto_reset=False)
    try:
        sim.run_for(1.0)  # telemetry at 25 Hz with nobody listening
        dropped = sim.control("stats")["stats"]["uart"]["tx_no_host"]
        assert dropped > 1000
        # A plain open, not pyserial's, which flushes its input on opening and would hide a queue.
        fd = os.open(sim.pty, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        try:
            wait_for(lambda: bool(events(sim, "host_open")), 10)
            assert read_available(fd) == b""  # nothing from before the open
            sim.run_for(0.1)
            wait_for(lambda: len(read_available(fd)) > 0, 10)  # what the MCU sends now arrives
        finally:
            os.close(fd)
        assert sim.control("stats")["stats"]["uart"]["tx_no_host"] == dropped
    finally:
        sim.stop()


def test_host_baud_out_of_range_garbles_requests_and_back_in_range_works(tmp_path: Path) -> None:
    sim = start_sim(tmp_path)
    try:
        with Link(sim.pty) as link:
            # Booted: the request written as the port opens is lost in the reset, and the resends
            # are in wall time (with both cores busy, two tries in 0.4 s were not always enough).
            link.call("HEARTBEAT")
            ack = sim.control("link", host_baud=105000)  # 89 % of the Nano's 117 647 baud
            assert ack["link"]["host_baud"] == 105000
            assert ack["link"]["mcu_baud"] == pytest.approx(117647.06)
            patient, link.retries = link.retries, 1
            with pytest.raises(LinkTimeout):
                link.call("HEARTBEAT", timeout_s=0.2)
            link.retries = patient
            uart = sim.control("stats")["stats"]["uart"]
            assert uart["rx_frame_errors"] > 0
            sim.control("link", host_baud=115200)
            link.call("HEARTBEAT")
    finally:
        sim.stop()


def test_link_settings_from_the_command_line_and_rejected_updates(tmp_path: Path) -> None:
    sim = start_sim(tmp_path, host_baud=116000.0, usb_latency_ms=(1.0, 2.0), ftdi_latency_timer_ms=16.0)
    try:
        settings = sim.control("stats")["stats"]["link"]
        assert settings["host_baud"] == 116000
        assert settings["usb_latency_ms"] == [1, 2]
        assert settings["ftdi_latency_timer_ms"] == 16
        assert settings["auto_reset"] is True
        for bad in (
            {"host_baud": 10},
            {"usb_latency_ms": [1, -1]},
            {"auto_reset": 1},
            {"ftdi_latency_timer_ms": 300},
        ):
            with pytest.raises(SimulatorError):
                sim.control("link", **bad)
        now = sim.control("link")["link"]
        assert {k: now[k] for k in settings if k != "mcu_baud"} == {
            **{k: settings[k] for k in settings if k != "mcu_baud"},
            "host_open": False,
        }
        with Link(sim.pty, timeout_s=0.5) as link:  # a CH340-like delay and an FTDI timer still work
            assert link.call("HEARTBEAT")[0] >= 0.0
    finally:
        sim.stop()

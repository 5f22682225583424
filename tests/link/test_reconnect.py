"""The link survives its port disappearing and coming back (here: the simulator killed and
restarted on the same stable port name, as a USB cable unplugged and plugged in). Each open
resets the simulated Nano, which answers once through Optiboot: about 0.5 s of simulated time,
any amount of wall time on a busy machine, so the test waits for its VERSION as the gateway does
(it asked within 0.3 s of wall time, and failed 3 runs in 12 with both cores busy)."""

from __future__ import annotations

from pathlib import Path

import pytest

from cart2d.link import Link, LinkDown
from cart2d.link.firmware import wait_for_version
from tests.support.sim import start_sim
from tests.support.waiting import wait_for


def test_link_reconnects_after_the_simulator_is_killed_and_restarted(tmp_path: Path) -> None:
    port = tmp_path / "cart2d-tty"
    sim = start_sim(tmp_path, pty_link=port)
    link = Link(str(port)).open()
    try:
        wait_for_version(link)
        link.call("SET_POSE", 0.5, 0.25, 0.0)
        sim.kill()
        wait_for(lambda: not link.connected.is_set(), wall_timeout_s=5)
        with pytest.raises(LinkDown):
            link.call("POSE")
        sim = start_sim(tmp_path, pty_link=port)  # a new process, a new pty, the same name
        wait_for(link.connected.is_set, wall_timeout_s=10)
        wait_for_version(link)
        assert link.call("POSE") == (0.0, 0.0, 0.0)  # a freshly booted MCU answers
        assert link.call("TOL_GET")[0] == pytest.approx(0.005)
    finally:
        link.close()
        sim.stop()

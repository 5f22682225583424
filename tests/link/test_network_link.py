"""The link over a network (issue 15): the gateway opens pyserial URLs, and Debian's ser2net in
front of the simulator's pseudo-terminal stands for the bridge (docs/network-link.md): a mission
through it, a bridge killed and restored mid-mission, a stalled connection, a slow network.

What resets the board: ser2net opens its serial device when a connection comes in, which on a
Nano's USB port raises DTR and resets it (the simulator's auto_reset); an ESP32 bridge on the
Nano's TX/RX pins has no DTR (auto_reset off here)."""

from __future__ import annotations

import math
import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from cart2d.link import Link, LinkError, LinkTimeout
from cart2d.link.transport import STALL_S, STATUS_SIZES
from cart2d.simulation.simulator import Simulator
from tests.support.cli import fake_ports_and_serve, one_sentence
from tests.support.network_link import NetRig
from tests.support.ser2net import DelayRelay, Ser2net
from tests.support.sim import start_sim
from tests.support.waiting import wait_for

GOAL = (1.2, 0.6)


@pytest.fixture(params=[True, False], ids=["rfc2217", "socket"])
def net(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[NetRig]:
    rig = NetRig(tmp_path, rfc2217=request.param)
    yield rig
    rig.close()


def at_goal(sim: Simulator) -> bool:
    truth = sim.truth()
    return math.hypot(truth["x"] - GOAL[0], truth["y"] - GOAL[1]) < 0.01


def test_a_mission_through_ser2net_reaches_its_goal(net: NetRig) -> None:
    net.gateway.go_to(*GOAL)
    wait_for(lambda: net.mission()["state"] != "driving", 60)
    assert net.mission()["state"] == "arrived", net.mission()["reason"]
    assert at_goal(net.sim)
    assert net.link.lost == 0 and net.link.opens == 1


def kill_and_restore_mid_mission(rig: NetRig) -> None:
    rig.gateway.go_to(*GOAL)
    wait_for(lambda: rig.sim.truth()["v"] > 0.2, 30)
    rig.bridge.kill()
    wait_for(lambda: not rig.link.connected.is_set(), 10)
    wait_for(lambda: "refused" in rig.link.open_error, 10)
    link = rig.gateway.status_view()["link"]
    assert link["state"] == "reconnecting" and "refused" in link["error"], link
    rig.bridge.start()
    wait_for(rig.link.connected.is_set, 15)


def test_a_bridge_that_resets_the_board_ends_the_mission_with_the_reason(tmp_path: Path) -> None:
    """ser2net in front of a Nano's USB port: the reconnection opens the port again, DTR resets
    the MCU, the firmware forgets its path; the gateway notices, says why, and the cart stays."""
    rig = NetRig(tmp_path, rfc2217=True)
    try:
        kill_and_restore_mid_mission(rig)
        wait_for(lambda: rig.mission()["state"] != "driving", 30)
        mission = rig.mission()
        assert mission["state"] == "failed"
        assert "the controller restarted" in mission["reason"]
        assert "the link to the robot was lost and its port reopened" in mission["reason"]
        assert rig.link.lost == 1 and rig.link.opens == 2
        assert not rig.gateway.pose_trust.trusted  # the pose restarted: no plan from it
        assert not at_goal(rig.sim)
        truth_v = rig.sim.truth()["v"]
        assert abs(truth_v) < 0.01
    finally:
        rig.close()


def test_a_bridge_without_dtr_lets_the_mission_drive_on_to_its_goal(tmp_path: Path) -> None:
    """An ESP32 on the Nano's TX/RX pins: no DTR, no reset. The firmware drives the path it has
    while the link is down; the gateway reconnects, follows it again and the mission arrives."""
    rig = NetRig(tmp_path, rfc2217=False, auto_reset=False)
    try:
        kill_and_restore_mid_mission(rig)
        wait_for(lambda: rig.mission()["state"] != "driving", 60)
        assert rig.mission()["state"] == "arrived", rig.mission()["reason"]
        assert at_goal(rig.sim)
        assert rig.link.lost == 1 and rig.link.opens == 2
        assert rig.gateway.resets_noticed == 0
    finally:
        rig.close()


class SilentServer:
    """A TCP peer that accepts and then never answers: a bridge whose serial side or Wi-Fi
    stalled while the connection stays up."""

    def __init__(self) -> None:
        self.sock = socket.create_server(("127.0.0.1", 0))
        self.port = self.sock.getsockname()[1]
        self.accepted: list[socket.socket] = []
        threading.Thread(target=self._accept, daemon=True).start()

    def _accept(self) -> None:
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return
            self.accepted.append(conn)

    def close(self) -> None:
        self.sock.close()
        for conn in self.accepted:
            conn.close()


def test_a_stalled_connection_times_requests_out_and_is_reopened() -> None:
    server = SilentServer()
    link = Link(f"socket://127.0.0.1:{server.port}").open()
    try:
        started = time.monotonic()
        with pytest.raises(LinkTimeout):
            link.call("HEARTBEAT")
        assert time.monotonic() - started < 2.0  # the retransmission window, not a wedged read
        with pytest.raises(LinkError):  # timed out, or the link dropped the stalled connection
            link.stop()  # a STOP is not held up behind it either
        wait_for(lambda: link.lost == 1, STALL_S + 5)
        assert "stalled" in link.lost_reason
        wait_for(lambda: len(server.accepted) == 2, 5)  # a new connection
    finally:
        link.close()
        server.close()


def test_serve_with_a_url_nobody_listens_on_says_so_in_one_sentence(tmp_path: Path) -> None:
    # A port bound but not listening refuses connections and cannot be taken meanwhile (once, a
    # free port given back was the one the gateway then listened on for its panel: it answered)
    with socket.socket() as held:
        held.bind(("127.0.0.1", 0))
        url = f"socket://127.0.0.1:{held.getsockname()[1]}"
        done = fake_ports_and_serve(tmp_path, url)
    assert done.returncode == 1
    line = one_sentence(done.stderr)
    assert "nothing accepts connections at 127.0.0.1:" in line and "serial bridge" in line
    assert "/dev/ttyUSB7" not in line  # a device list says nothing about a network bridge


def test_a_slow_network_needs_no_retransmission_and_executes_each_command_once(tmp_path: Path) -> None:
    """150 ms each way (a poor Wi-Fi): the per-try wait over a network covers the round trip, so
    nothing is sent twice while replies come within it (a busy machine may hold one back longer:
    then, and only then, a retransmission is right); the retransmission window still closes 0.5 s
    before the firmware forgets a request (docs/protocol.md)."""
    tty = tmp_path / "robot-tty"
    sim = start_sim(tmp_path, pty_link=tty, speed="1", auto_reset=False)
    bridge = Ser2net(tmp_path, str(tty), rfc2217=False)
    relay = DelayRelay(bridge.port, 0.15)
    try:
        with Link(relay.url).open(wait_s=10) as link:
            link.call("HEARTBEAT")
            link.retransmissions = 0
            late = 0  # calls answered only after the per-try wait the line had set
            for k in range(5):
                tolerance = 0.01 + 0.001 * k
                calls: tuple[tuple[str, tuple[float, ...]], ...] = (("TOL_SET", (tolerance,)), ("STATUS", ()))
                for name, args in calls:
                    before, wait_s = link.retransmissions, link.line.wait_s(*STATUS_SIZES)
                    began = time.monotonic()
                    reply = link.call(name, *args)
                    late += time.monotonic() - began > wait_s
                    if link.retransmissions > before:  # sent twice: the reply was not within the wait
                        assert time.monotonic() - began > wait_s, (name, wait_s)
                    if name == "TOL_SET":
                        assert reply[0] == pytest.approx(tolerance)
            assert wait_s > 0.3  # the round trip is covered
            assert link.retransmissions <= late
            assert link.lost == 0
    finally:
        relay.close()
        bridge.stop()
        sim.stop()

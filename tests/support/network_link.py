"""The simulator, Debian's ser2net in front of its pseudo-terminal, and a gateway on the
ser2net URL."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from cart2d.link import Link
from cart2d.simulation.simulator import Simulator
from cart2d.simulation.wiring import simulated_gateway
from cart2d.store import Store
from tests.support.ser2net import Ser2net
from tests.support.sim import start_sim


class NetRig:
    """The simulator, ser2net in front of its pty, and a gateway on the ser2net URL."""

    def __init__(self, tmp_path: Path, rfc2217: bool, **sim_options: Any) -> None:
        tty = tmp_path / "robot-tty"
        self.sim: Simulator = start_sim(tmp_path, pty_link=tty, speed="1", **sim_options)
        self.bridge = Ser2net(tmp_path, str(tty), rfc2217=rfc2217)
        self.link = Link(self.bridge.url).open(wait_s=10)
        self.simulation = simulated_gateway(
            self.link, Store(tmp_path / "gateway"), Store(tmp_path / "gateway").load(), self.sim
        )
        self.gateway = self.simulation.gateway
        self.gateway.wait_for_firmware(10.0, 0.1)
        self.gateway.start()

    def mission(self) -> dict[str, Any]:
        view: dict[str, Any] = self.gateway.mission_view()
        return view

    def close(self) -> None:
        self.gateway.close()
        self.link.close()
        self.bridge.stop()
        self.sim.stop()

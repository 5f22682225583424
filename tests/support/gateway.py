"""A Gateway on the real firmware in the simulator without the HTTP layer, the wider grid the
live-map tests use, and the least a Seeing needs of a gateway."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from cart2d.link import Link
from cart2d.simulation.simulator import Simulator
from cart2d.simulation.wiring import simulated_gateway
from cart2d.store import GatewaySettings, MapSettings, Store
from tests.support.sim import start_sim
from tests.support.waiting import wait_for


class GatewayRig:
    def __init__(self, tmp_path: Path, settings: GatewaySettings, **sim_options: Any) -> None:
        self.sim: Simulator = start_sim(tmp_path, **sim_options)
        self.link = Link(self.sim.pty, timeout_s=0.2).open()
        self.store = Store(tmp_path / "gateway")
        self.simulation = simulated_gateway(self.link, self.store, settings, self.sim)
        self.gateway = self.simulation.gateway
        self.gateway.check_firmware()
        self.gateway.start()
        self.messages: list[dict[str, Any]] = []
        self.gateway.subscribe(self.messages.append)

    def close(self) -> None:
        self.gateway.close()
        self.link.close()
        self.sim.stop()

    def wait_end(self) -> dict[str, Any]:
        wait_for(lambda: self.gateway.mission_view()["state"] != "driving", 60.0)
        return self.gateway.mission_view()


WIDE = GatewaySettings(map=MapSettings(cols=20, rows=10, step_m=0.2))  # 3.8 x 1.8 m, 20 x 10 nodes


class QuietGateway:
    """What a Seeing needs of a gateway to be made: a subscription that never calls."""

    def subscribe(self, listener: object) -> Callable[[], None]:
        return lambda: None

"""The gateway's app on the real firmware in the simulator, served by a TestClient, and the
headers and bases a browser on this machine sends."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from fastapi.testclient import TestClient

from cart2d.link import Link
from cart2d.server import create_app
from cart2d.simulation.wiring import simulated_gateway
from cart2d.store import Store
from tests.support.sim import start_sim

JSON = {"content-type": "application/json"}


OCTETS = {"content-type": "application/octet-stream"}  # a firmware upload


BASE_URL = "http://127.0.0.1:8080"  # the Host a browser on this machine sends


WS_BASE = "ws://127.0.0.1:8080"


class Rig:
    def __init__(
        self, tmp_path: Path, bind_host: str = "127.0.0.1", token: str | None = None, **sim_options: Any
    ) -> None:
        # pty_link: a name that survives restarts
        self.sim = start_sim(tmp_path, pty_link=tmp_path / "robot-tty", **sim_options)
        self.link = Link(self.sim.pty, timeout_s=0.2).open()
        self.store = Store(tmp_path / "gateway")
        self.simulation = simulated_gateway(self.link, self.store, self.store.load(), self.sim)
        self.gateway = self.simulation.gateway
        # Opening the port reset the Nano into Optiboot: the firmware answers once it has left it.
        self.gateway.wait_for_firmware(10.0, 0.1)
        self.gateway.start()
        # What the panel sends: its own Host, and every change as JSON (the guards refuse others).
        self.client = TestClient(
            create_app(self.gateway, bind_host, token, simulation=self.simulation.add_routes),
            base_url=BASE_URL,
            headers=JSON,
        )

    def close(self) -> None:
        self.gateway.close()
        self.link.close()
        self.sim.stop()

    def mission_state(self) -> str:
        state: str = self.client.get("/api/mission").json()["state"]
        return state

    def pose_now(self) -> dict[str, float]:
        """The firmware's pose now: POSE through the generic command form (/api/status gives
        the pose as the gateway last read it)."""
        results = self.client.post("/api/command", json={"name": "POSE", "args": []}).json()["results"]
        return dict(zip(("x", "y", "theta"), results, strict=True))

"""A gateway on a simulator, wired in one place for `cart2d sim`, `cart2d mission` and the tests'
rigs: the gateway is given the simulator's ground truth, its world, its reset button and its
bootloader port (cart2d/gateway/collaborators.py), the supervisor restarts the simulator when it
exits on its own, and `add_routes` puts the simulation's routes in the app (create_app's
`simulation`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from fastapi import FastAPI
from fastapi.params import Depends

from cart2d.gateway import Gateway
from cart2d.link import Link, LinkError
from cart2d.simulation.bootloader import SimulatedBootloader
from cart2d.simulation.routes import add_simulation_routes
from cart2d.simulation.side_channel import SimulatorError
from cart2d.simulation.simulator import Simulator
from cart2d.simulation.supervisor import Supervisor
from cart2d.simulation.world import SimWorld
from cart2d.store import GatewaySettings, Store


class TruthFeed:
    """The simulator's ground truth for the gateway (collaborators.GroundTruth): its time is the
    cart's clock, its messages go to the gateway's viewers; across restarts of the simulator."""

    def __init__(self, sim: Simulator) -> None:
        self._t: float | None = None
        self._listeners: list[Callable[[dict[str, Any]], None]] = []
        sim.subscribe_truth(self._on_truth)

    def time_s(self) -> float | None:
        return self._t

    def subscribe(self, listener: Callable[[dict[str, Any]], None]) -> None:
        self._listeners.append(listener)

    def _on_truth(self, truth: dict[str, Any]) -> None:
        self._t = truth.get("t")
        for listener in self._listeners:
            listener(truth)


def reset_button(sim: Simulator) -> Callable[[], None]:
    """The simulated Nano's reset button, as the restart watch presses it (LinkError if not)."""

    def press() -> None:
        try:
            sim.control("reset")
        except SimulatorError as exc:
            raise LinkError(f"the simulator did not reset the MCU: {exc}") from exc

    return press


@dataclass
class Simulation:
    sim: Simulator
    gateway: Gateway
    world: SimWorld
    supervisor: Supervisor

    def add_routes(self, app: FastAPI, guarded: Depends) -> None:
        """The simulation's routes (routes.py): its world's boxes and its faults."""
        add_simulation_routes(app, self.sim, self.world, guarded)


def simulated_gateway(link: Link, store: Store, settings: GatewaySettings, sim: Simulator) -> Simulation:
    """A Gateway on `link`, the pty of `sim`, with everything of the simulator it may use."""
    world = SimWorld(sim)
    gateway = Gateway(
        link,
        store,
        settings,
        truth=TruthFeed(sim),
        world=world,
        reset_button=reset_button(sim),
        bootloader=SimulatedBootloader(sim, link),
    )
    world.tell(gateway.bus)
    return Simulation(sim, gateway, world, Supervisor(sim, gateway))

"""The fleet manager and VDA 5050 vehicles over a real mosquitto, the carts fakes that reach a
node as soon as they are sent there: a cart killed mid-order leaves its last will, keeps the
nodes it held, and the other cart's goal is routed round them."""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Sequence

from cart2d.fleet.broker import Mosquitto
from cart2d.fleet.lattice import Lattice
from cart2d.fleet.manager import FleetManager
from cart2d.fleet.vehicle import Vehicle
from tests.support.vda5050 import Master
from tests.support.waiting import wait_for


class ArrivingCart:
    """Reaches each node it is sent to at once (its mission's end comes from another thread, as
    the gateway's bus does); `frozen`: it is sent but never arrives."""

    def __init__(self, x: float, y: float) -> None:
        self.pose = (x, y, 0.0, 0.0, 0.0)
        self.vehicle: Vehicle | None = None
        self.frozen = False

    def go_to(self, x: float, y: float) -> None:
        if not self.frozen:
            threading.Timer(0.01, self._arrive, ((x, y),)).start()

    def go_through(self, points: Sequence[tuple[float, float]]) -> None:
        self.go_to(*points[-1])  # one mission, to the last point

    def passed(self, x: float, y: float) -> None:
        pass

    def _arrive(self, goal: tuple[float, float]) -> None:
        self.pose = (goal[0], goal[1], 0.0, 0.0, 0.0)
        assert self.vehicle is not None
        self.vehicle.mission_ended(goal, True, "")

    def pose_now(self) -> tuple[float, float, float, float, float]:
        return self.pose

    def stop(self, reason: str) -> None:
        pass

    def set_pose(self, x: float, y: float, theta: float) -> None:
        pass


def test_a_killed_cart_keeps_its_nodes_and_the_other_goes_round() -> None:
    lattice = Lattice((0.25, 0.25), 0.5, frozenset((i, j) for i in range(5) for j in range(5)))
    with contextlib.ExitStack() as stack:
        broker = stack.enter_context(Mosquitto()).broker
        master = Master(broker)  # checks every message against the schemas
        stack.callback(master.close)
        manager = FleetManager(lattice, broker).start()
        stack.callback(manager.close)
        vehicles: dict[str, tuple[Vehicle, ArrivingCart]] = {}
        for name, cell in {"a": (2, 0), "b": (0, 2)}.items():
            cart = ArrivingCart(*lattice.position(cell))
            vehicle = Vehicle(broker, name, cart, cart.pose_now, lambda: True).start()
            cart.vehicle, vehicles[name] = vehicle, (vehicle, cart)
            stack.callback(vehicle.close)
        wait_for(lambda: len(manager.traffic.standing) == 2, 20)
        vehicles["a"][1].frozen = True  # a drives off and never reaches its next node
        manager.add_goal(*lattice.position((2, 4)), cart="a")  # straight up through (2, 2)
        wait_for(
            lambda: bool(manager.traffic.journeys.get("a")) and manager.traffic.journeys["a"].released >= 3,
            20,
        )
        killed = vehicles["a"][0].connection._client
        killed.loop_stop()  # killed: no DISCONNECT, the broker sends its last will
        sock = killed.socket()
        assert sock is not None
        sock.close()
        master.wait_for("a", "connection", lambda m: m["connectionState"] == "CONNECTIONBROKEN")
        wait_for(lambda: "a" in manager.traffic.offline, 10)
        held = {c for c, h in manager.traffic.holds.items() if h == "a"}
        assert {(2, 0), (2, 1), (2, 2)} <= held
        goal = manager.add_goal(*lattice.position((4, 2)), cart="b")  # straight across through (2, 2)
        wait_for(lambda: goal.status == "reached", 20)
        route = next(j.route for c, j in manager.traffic.finished if c == "b")
        assert not held & set(route), f"b drove over a's nodes: {route}"
        assert {c for c, h in manager.traffic.holds.items() if h == "a"} == held
        assert not master.invalid, master.invalid

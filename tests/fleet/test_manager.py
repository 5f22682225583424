"""The fleet manager with fake vehicles on a fake clock (no broker, no simulator): each vehicle
is the real order Executor over a cart that reaches the node it is sent to at the next tick;
the manager's orders and the vehicles' states are checked against the VDA 5050 schemas."""

from __future__ import annotations

import random
from collections.abc import Sequence
from typing import Any

from cart2d.fleet import vda5050
from cart2d.fleet.lattice import Lattice
from cart2d.fleet.manager import FleetManager
from cart2d.fleet.order import Executor
from tests.support.vda5050 import check


class InstantCart:
    def __init__(self, x: float, y: float) -> None:
        self.pose = (x, y, 0.0)
        self.route: list[tuple[float, float]] = []  # the points it drives through, one a tick
        self.stops = 0

    def go_through(self, points: Sequence[tuple[float, float]]) -> None:
        self.route = list(points)

    def passed(self, x: float, y: float) -> None:
        pass

    def stop(self, reason: str) -> None:
        self.route = []
        self.stops += 1

    def set_pose(self, x: float, y: float, theta: float) -> None:
        self.pose = (x, y, theta)


class Fleet:
    def __init__(self, lattice: Lattice, starts: dict[str, tuple[int, int]]) -> None:
        self.now = 0.0
        self.outbox: list[tuple[str, dict[str, Any]]] = []
        self.manager = FleetManager(lattice, clock=lambda: self.now, publish=self._sent)
        self.carts: dict[str, InstantCart] = {}
        self.vehicles: dict[str, Executor] = {}
        self.headers: dict[str, vda5050.Headers] = {}
        for name, cell in starts.items():
            self.add(name, *lattice.position(cell))

    def add(self, name: str, x: float, y: float) -> None:
        """A cart that comes on line at (x, y), not necessarily on a node."""
        cart = InstantCart(x, y)
        self.carts[name], self.vehicles[name] = cart, Executor(cart, pose=cart.pose)
        self.headers[name] = vda5050.Headers(name)
        self._say(name, "connection", {"connectionState": "ONLINE"})
        self._report(name)

    def _sent(self, topic: str, message: dict[str, Any]) -> None:
        where = vda5050.vehicle_of(topic)
        assert where is not None
        check(where[1], message)
        self.outbox.append((topic, message))

    def _say(self, name: str, kind: str, body: dict[str, Any]) -> None:
        message = {**self.headers[name].header(kind), **body}
        check(kind, message)
        self.manager.heard(vda5050.topic(name, kind), message)

    def _report(self, name: str) -> None:
        x, y, theta = self.carts[name].pose
        position = {"x": x, "y": y, "theta": theta, "mapId": "arena", "positionInitialized": True}
        self._say(
            name,
            "state",
            {
                **self.vehicles[name].state_fields(),
                "agvPosition": position,
                "operatingMode": "AUTOMATIC",
                "batteryState": {"batteryCharge": 0.0, "charging": False},
                "safetyState": {"eStop": "NONE", "fieldViolation": False},
            },
        )

    def tick(self) -> None:
        self.now += 0.5
        self.manager.step()
        for topic, message in self.outbox:
            where = vda5050.vehicle_of(topic)
            assert where is not None
            vehicle = self.vehicles[where[0]]
            if where[1] == "order":
                vehicle.order(message)
                assert vehicle.errors == [], vehicle.errors
            else:
                vehicle.instant_actions(message)
        self.outbox.clear()
        for name, cart in self.carts.items():
            vehicle = self.vehicles[name]
            if cart.route:  # on to its next node: passed on the way, or its mission's end
                point = cart.route.pop(0)
                cart.pose = (*point, 0.0)
                vehicle.moved(cart.pose)
                if not cart.route:
                    vehicle.mission_ended(point, True, "")
            self._report(name)
        places = [c.pose[:2] for c in self.carts.values()]
        assert len(set(places)) == len(places), f"two carts on one node: {places}"


def test_ten_random_goals_for_three_carts_are_all_reached_without_meeting() -> None:
    lattice = Lattice((0.25, 0.25), 0.5, frozenset((i, j) for i in range(6) for j in range(6)))
    fleet = Fleet(lattice, {"c1": (0, 0), "c2": (5, 0), "c3": (0, 5)})
    rng = random.Random(7)
    for _ in range(10):
        cell = rng.choice(sorted(lattice.free))
        fleet.manager.add_goal(*lattice.position(cell))
    for _ in range(400):
        fleet.tick()
        if all(g.status in ("reached", "cancelled") for g in fleet.manager.goals):
            break
    assert [g.status for g in fleet.manager.goals] == ["reached"] * 10
    assert {g.cart for g in fleet.manager.goals if g.status == "reached"} == {"c1", "c2", "c3"}


def test_a_named_cart_takes_the_goal_and_stop_all_cancels_every_order() -> None:
    lattice = Lattice((0.25, 0.25), 0.5, frozenset((i, 0) for i in range(8)))
    fleet = Fleet(lattice, {"c1": (0, 0), "c2": (7, 0)})
    goal = fleet.manager.add_goal(*lattice.position((3, 0)), cart="c2")  # c1 is nearer
    fleet.tick()
    fleet.tick()
    assert goal.cart == "c2" and goal.status == "driving"
    fleet.manager.stop_all()
    fleet.tick()
    assert [g.status for g in fleet.manager.goals] == ["cancelled"]  # (mypy narrowed goal.status)
    assert all(v.nodes == [] for v in fleet.vehicles.values())
    assert fleet.carts["c2"].stops == 1
    try:
        fleet.manager.add_goal(1.0, 1.0, cart="c9")
    except ValueError as exc:
        assert "no cart 'c9'" in str(exc)
    else:
        raise AssertionError("a goal for an unknown cart was taken")


def test_two_idle_carts_swap_places() -> None:
    lattice = Lattice((0.25, 0.25), 0.5, frozenset((i, j) for i in range(4) for j in range(3)))
    fleet = Fleet(lattice, {"c1": (0, 1), "c2": (3, 1)})
    fleet.manager.add_goal(*lattice.position((3, 1)), cart="c1")  # each goal where the other stands
    fleet.manager.add_goal(*lattice.position((0, 1)), cart="c2")
    for _ in range(60):
        fleet.tick()
    assert [g.status for g in fleet.manager.goals] == ["reached", "reached"]
    assert fleet.carts["c1"].pose[:2] == lattice.position((3, 1))


def test_at_every_connection_the_manager_asks_each_cart_for_its_state() -> None:
    lattice = Lattice((0.25, 0.25), 0.5, frozenset((i, 0) for i in range(4)))
    fleet = Fleet(lattice, {"c1": (0, 0), "c2": (3, 0)})
    fleet.manager.ask_states()  # what its broker connection calls when it (re)connects
    asked = [(t.split("/")[3], m["actions"][0]["actionType"]) for t, m in fleet.outbox]
    assert sorted(asked) == [("c1", "stateRequest"), ("c2", "stateRequest")]


def test_a_cart_cancelled_between_two_nodes_takes_its_next_goal_from_the_node_it_is_nearest() -> None:
    lattice = Lattice((0.25, 0.25), 0.5, frozenset((i, j) for i in range(8) for j in range(2)))
    fleet = Fleet(lattice, {"c1": (0, 0), "c2": (7, 1)})
    fleet.manager.add_goal(*lattice.position((6, 0)), cart="c1")
    while fleet.manager.traffic.standing["c1"] != (2, 0):
        fleet.tick()
    fleet.manager.cancel("c1")
    fleet.tick()
    # it stopped 0.4 m past the node it last reported, nearer the next one of its base
    fleet.carts["c1"].pose = (lattice.position((2, 0))[0] + 0.4, 0.25, 0.0)
    fleet.vehicles["c1"].moved(fleet.carts["c1"].pose)
    fleet._report("c1")
    goal = fleet.manager.add_goal(*lattice.position((3, 1)), cart="c1")
    for _ in range(20):
        fleet.tick()
    assert goal.status == "reached", fleet.vehicles["c1"].errors


def gone_offline(fleet: Fleet, name: str) -> None:
    """The cart's connection breaks and it is carried off: its reservations stay."""
    fleet._say(name, "connection", {"connectionState": "CONNECTIONBROKEN"})
    del fleet.carts[name], fleet.vehicles[name]


def test_a_cart_nearest_a_node_another_holds_joins_at_a_free_node_within_reach() -> None:
    lattice = Lattice((0.25, 0.25), 0.5, frozenset((i, j) for i in range(6) for j in range(2)))
    fleet = Fleet(lattice, {"c1": (0, 0), "c2": (3, 0)})
    gone_offline(fleet, "c2")
    fleet.add("c3", 1.75, 0.48)  # 0.23 m from c2's node (3, 0), 0.27 m from (3, 1)
    assert fleet.manager.traffic.standing["c3"] == (3, 1)
    goal = fleet.manager.add_goal(*lattice.position((5, 0)), cart="c3")
    for _ in range(20):
        fleet.tick()
    assert goal.status == "reached", (goal.reason, fleet.vehicles["c3"].errors)
    assert fleet.manager.traffic.holds[(3, 0)] == "c2"  # its reservation held all along


def test_a_cart_that_cannot_join_and_its_goal_say_why_until_the_holder_is_removed() -> None:
    lattice = Lattice((0.25, 0.25), 0.5, frozenset((i, 0) for i in range(6)))
    fleet = Fleet(lattice, {"c1": (0, 0), "c2": (3, 0)})
    gone_offline(fleet, "c2")
    fleet.add("c3", 1.8, 0.25)  # where c2 stood: no other node within 0.3 m
    goal = fleet.manager.add_goal(*lattice.position((5, 0)), cart="c3")
    fleet.tick()
    (c3,) = [c for c in fleet.manager.view().carts if c.name == "c3"]
    assert c3.off_traffic is not None and "nearest node n3_0, which c2 holds" in c3.off_traffic
    (view,) = fleet.manager.view().goals
    assert view.status == "waiting" and view.reason is not None and "c3 is off the traffic" in view.reason
    fleet.manager.remove("c2")
    for _ in range(20):
        fleet.tick()
    assert goal.status == "reached" and goal.reason is None
    assert [c.off_traffic for c in fleet.manager.view().carts] == [None, None]


def test_a_goal_waiting_for_a_busy_cart_or_a_held_node_says_so() -> None:
    lattice = Lattice((0.25, 0.25), 0.5, frozenset((i, 0) for i in range(6)))
    fleet = Fleet(lattice, {"c1": (0, 0), "c2": (5, 0)})
    first = fleet.manager.add_goal(*lattice.position((2, 0)), cart="c1")
    second = fleet.manager.add_goal(*lattice.position((1, 0)), cart="c1")
    blocked = fleet.manager.add_goal(*lattice.position((5, 0)), cart="c1")  # where c2 is parked
    fleet.tick()
    assert first.status == "driving" and first.reason is None
    assert second.reason == "c1 is busy with another goal"
    for _ in range(20):
        fleet.tick()
    assert (first.status, second.status) == ("reached", "reached")
    assert blocked.status == "waiting"
    assert blocked.reason is not None and "held by c2, which is not going anywhere" in blocked.reason

"""A VDA 5050 vehicle (cart2d/fleet/vehicle.py) on a real mosquitto, driving a fake cart whose
missions end when the test says so: every message both sides send is checked against the
official schemas (tests/support/vda5050.py)."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Iterator
from typing import Any

import pytest

from cart2d.fleet.broker import Mosquitto
from cart2d.fleet.vehicle import Vehicle
from tests.support.fleet_cart import RecordingCart
from tests.support.vda5050 import Master, instant, order_body

SERIAL = "c1"


@pytest.fixture
def broker() -> Iterator[Mosquitto]:
    with Mosquitto() as mosquitto:
        yield mosquitto


@pytest.fixture
def cart() -> RecordingCart:
    return RecordingCart()


@pytest.fixture
def vehicle(broker: Mosquitto, cart: RecordingCart, master: Master) -> Iterator[Vehicle]:
    """Started after the master, which hears its first state."""
    v = Vehicle(broker.broker, SERIAL, cart, lambda: cart.pose, lambda: True).start()
    yield v
    v.close()


@pytest.fixture
def master(broker: Mosquitto) -> Iterator[Master]:
    m = Master(broker.broker)
    yield m
    assert not m.invalid, m.invalid
    m.close()


def arrive(vehicle: Vehicle, cart: RecordingCart, goal: tuple[float, float]) -> None:
    """The cart's mission to `goal` ends there."""
    wait_until(lambda: goal in cart.goals, f"the cart was never sent to {goal}")
    cart.pose = (goal[0], goal[1], 0.0, 0.0, 0.0)
    vehicle.mission_ended(goal, True, "")


def wait_until(condition: Any, what: str, timeout_s: float = 10.0) -> None:
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, what
        time.sleep(0.01)


def state_with(master: Master, **fields: Any) -> dict[str, Any]:
    return master.wait_for(SERIAL, "state", lambda s: all(s.get(k) == v for k, v in fields.items()))


POINTS = [("a", 0.25, 0.25), ("b", 0.75, 0.25), ("c", 1.25, 0.25), ("d", 1.75, 0.25)]


def test_connection_factsheet_state_and_visualization(vehicle: Vehicle, master: Master) -> None:
    master.wait_for(SERIAL, "connection", lambda m: m["connectionState"] == "ONLINE")
    factsheet = master.wait_for(SERIAL, "factsheet", lambda m: True)
    assert factsheet["typeSpecification"]["agvKinematic"] == "DIFF"
    state = master.wait_for(SERIAL, "state", lambda m: True)
    assert state["version"] == "2.1.0" and state["agvPosition"]["positionInitialized"]
    master.wait_for(SERIAL, "visualization", lambda m: m["headerId"] >= 3)  # 5 Hz: several already


def test_an_order_is_driven_through_its_base_reported_node_by_node_and_extended_by_its_update(
    vehicle: Vehicle, cart: RecordingCart, master: Master
) -> None:
    master.wait_for(SERIAL, "connection", lambda m: True)
    master.send(SERIAL, "order", order_body("o1", 0, POINTS, released=3))
    assert state_with(master, orderId="o1", driving=True)["lastNodeId"] == "a"
    assert cart.routes == [[(0.75, 0.25), (1.25, 0.25)]]  # one path through b, ending at the base's end
    cart.pose = (0.8, 0.25, 0.0, 0.5, 0.0)  # past b, driving on
    vehicle.moved()
    passed = state_with(master, lastNodeId="b", driving=True)
    assert [(n["nodeId"], n["released"]) for n in passed["nodeStates"]] == [("c", True), ("d", False)]
    assert [e["edgeId"] for e in passed["edgeStates"]] == ["b-c", "c-d"]
    # the update starts at the base's last node and releases the rest: the path is replaced at
    # speed by one through c to d, before the cart gets to c
    master.send(SERIAL, "order", order_body("o1", 1, POINTS[2:], first_seq=4))
    state_with(master, orderUpdateId=1, driving=True)
    assert cart.routes[-1] == [(1.25, 0.25), (1.75, 0.25)] and cart.passed_points == [(0.75, 0.25)]
    arrive(vehicle, cart, (1.75, 0.25))
    done = state_with(master, lastNodeId="d", orderUpdateId=1, driving=False)
    assert done["nodeStates"] == [] and done["edgeStates"] == [] and done["errors"] == []
    assert cart.goals == [(1.25, 0.25), (1.75, 0.25)]


def test_what_the_vehicle_refuses_is_an_error_that_changes_nothing(
    vehicle: Vehicle, cart: RecordingCart, master: Master
) -> None:
    master.wait_for(SERIAL, "connection", lambda m: True)
    master.send(SERIAL, "order", order_body("far", 0, [("x", 3.0, 3.0), ("y", 3.5, 3.0)]))
    refused = master.wait_for(SERIAL, "state", lambda s: bool(s["errors"]))
    assert refused["errors"][0]["errorType"] == "noRouteError" and refused["orderId"] == ""
    master.send(SERIAL, "order", order_body("o1", 0, POINTS[:3]))
    state_with(master, orderId="o1", driving=True)
    master.send(SERIAL, "order", order_body("o2", 0, POINTS[:2]))  # o1 still driving
    busy = master.wait_for(
        SERIAL, "state", lambda s: any(e["errorType"] == "orderError" for e in s["errors"])
    )
    assert busy["orderId"] == "o1"
    master.send(SERIAL, "order", order_body("o1", 1, POINTS[1:], first_seq=2))  # not where the base ends
    master.wait_for(SERIAL, "state", lambda s: any(e["errorType"] == "orderUpdateError" for e in s["errors"]))
    master.send(SERIAL, "instantActions", instant("i1", "dance"))
    failed = master.wait_for(SERIAL, "state", lambda s: any(a["actionId"] == "i1" for a in s["actionStates"]))
    assert failed["actionStates"][-1]["actionStatus"] == "FAILED"
    assert cart.goals == [(1.25, 0.25)]


def test_instant_actions(vehicle: Vehicle, cart: RecordingCart, master: Master) -> None:
    master.wait_for(SERIAL, "connection", lambda m: True)
    master.send(SERIAL, "order", order_body("o1", 0, POINTS[:3]))
    state_with(master, orderId="o1", driving=True)
    master.send(SERIAL, "instantActions", instant("p1", "startPause"))
    state_with(master, paused=True, driving=False)
    assert cart.stops == ["paused by the fleet"]
    vehicle.mission_ended((1.25, 0.25), False, "paused by the fleet")  # what the stop ends
    master.send(SERIAL, "instantActions", instant("p2", "stopPause"))
    state_with(master, paused=False, driving=True)
    assert cart.routes == [[(0.75, 0.25), (1.25, 0.25)]] * 2  # on again through the same nodes
    master.send(SERIAL, "instantActions", instant("c1", "cancelOrder"))
    cancelled = state_with(master, driving=False, nodeStates=[])
    assert cancelled["errors"] == [] and cart.stops[-1] == "the order was cancelled"
    master.send(SERIAL, "instantActions", instant("c2", "cancelOrder"))
    master.wait_for(SERIAL, "state", lambda s: any(e["errorType"] == "noOrderToCancel" for e in s["errors"]))
    master.send(
        SERIAL,
        "instantActions",
        instant("i1", "initPosition", x=1.0, y=2.0, theta=0.5, mapId="arena", lastNodeId="b"),
    )
    state_with(master, lastNodeId="b")
    assert cart.poses_set == [(1.0, 2.0, 0.5)]
    master.forget()
    master.send(SERIAL, "instantActions", instant("f1", "factsheetRequest"))
    master.wait_for(SERIAL, "factsheet", lambda m: True)
    master.send(SERIAL, "instantActions", instant("s1", "stateRequest"))
    master.wait_for(SERIAL, "state", lambda s: any(a["actionId"] == "s1" for a in s["actionStates"]))


def test_a_broker_restart_mid_order_loses_nothing(
    broker: Mosquitto, vehicle: Vehicle, cart: RecordingCart, master: Master
) -> None:
    master.wait_for(SERIAL, "connection", lambda m: True)
    master.send(SERIAL, "order", order_body("o1", 0, POINTS, released=2))
    state_with(master, orderId="o1", driving=True)
    broker.stop()
    arrive(vehicle, cart, (0.75, 0.25))  # while the broker is away (the base ends at b)
    wait_until(lambda: not vehicle.connection.connected.is_set(), "the vehicle never saw the broker go")
    master.forget()
    broker.start()
    assert master.connection.wait(10) and vehicle.connection.wait(10)
    master.wait_for(SERIAL, "connection", lambda m: m["connectionState"] == "ONLINE")  # retained again
    # the state the vehicle sent as it came back may have gone before the master was back: ask
    master.send(SERIAL, "instantActions", instant("s1", "stateRequest"))
    state_with(master, lastNodeId="b", driving=False)
    master.send(SERIAL, "order", order_body("o1", 1, POINTS[1:], first_seq=2))
    arrive(vehicle, cart, (1.75, 0.25))  # through c
    state_with(master, lastNodeId="d", driving=False)


def test_a_killed_vehicle_leaves_its_last_will(vehicle: Vehicle, master: Master) -> None:
    master.wait_for(SERIAL, "connection", lambda m: m["connectionState"] == "ONLINE")
    client = vehicle.connection._client
    client.loop_stop()  # no DISCONNECT: the process is gone as far as the broker knows
    socket = client.socket()
    assert socket is not None
    socket.close()
    master.wait_for(SERIAL, "connection", lambda m: m["connectionState"] == "CONNECTIONBROKEN")


def test_a_vehicle_closed_in_order_says_offline(
    broker: Mosquitto, cart: RecordingCart, master: Master
) -> None:
    v = Vehicle(broker.broker, "c2", cart, lambda: cart.pose, lambda: True).start()
    master.wait_for("c2", "connection", lambda m: m["connectionState"] == "ONLINE")
    v.close()
    master.wait_for("c2", "connection", lambda m: m["connectionState"] == "OFFLINE")


def test_a_failed_mission_waits_for_the_master(vehicle: Vehicle, cart: RecordingCart, master: Master) -> None:
    master.wait_for(SERIAL, "connection", lambda m: True)
    master.send(SERIAL, "order", order_body("o1", 0, POINTS[:3]))
    state_with(master, orderId="o1", driving=True)
    vehicle.mission_ended((1.25, 0.25), False, "a front switch closed")
    stuck = master.wait_for(
        SERIAL, "state", lambda s: any(e["errorType"] == "navigationError" for e in s["errors"])
    )
    assert not stuck["driving"] and cart.goals == [(1.25, 0.25)]  # not driven into it again by itself
    assert stuck["errors"][0]["errorReferences"][0]["referenceValue"] == "b"  # the node not reached
    master.send(SERIAL, "instantActions", instant("p1", "stopPause"))
    state_with(master, driving=True)
    assert cart.goals == [(1.25, 0.25), (1.25, 0.25)]


def test_a_broker_with_users_lets_in_only_the_vehicle_with_its_password(cart: RecordingCart) -> None:
    with Mosquitto(users={"cart7": "s3cret", "master": "m"}) as locked:
        master = Master(dataclasses.replace(locked.broker, username="master", password="m"))
        try:
            wrong = Vehicle(
                dataclasses.replace(locked.broker, username="cart7", password="no"),
                "c7",
                cart,
                lambda: cart.pose,
                lambda: True,
            )
            wrong.start()
            right = Vehicle(
                dataclasses.replace(locked.broker, username="cart7", password="s3cret"),
                "c8",
                cart,
                lambda: cart.pose,
                lambda: True,
            )
            right.start()
            master.wait_for("c8", "connection", lambda m: m["connectionState"] == "ONLINE")
            assert not wrong.connection.connected.is_set() and master.last("c7", "connection") is None
            right.close()
            wrong.close()
        finally:
            master.close()

"""A gateway on the real firmware in the simulator as a VDA 5050 vehicle (join_fleet): an order
driven through its missions service and reported node by node, every message checked against the
schemas."""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path

import pytest

from cart2d.fleet.broker import Mosquitto
from cart2d.fleet.gateway_vehicle import join_fleet
from cart2d.fleet.vehicle import factsheet_body
from cart2d.store import GatewaySettings, MapSettings
from tests.support.gateway import GatewayRig
from tests.support.sim import high_rate_truth
from tests.support.vda5050 import Master, order_body

SQUARE = GatewaySettings(map=MapSettings(cols=20, rows=20, step_m=0.2))  # 3.8 m


@pytest.fixture
def rig(tmp_path: Path) -> Iterator[GatewayRig]:
    r = GatewayRig(tmp_path, SQUARE)
    yield r
    r.close()


def test_the_simulated_cart_drives_an_order_node_by_node(rig: GatewayRig) -> None:
    with Mosquitto() as broker:
        master = Master(broker.broker)  # first: it hears the vehicle's first state
        vehicle = join_fleet(rig.gateway, broker.broker, "sim1")
        try:
            first = master.wait_for("sim1", "state", lambda s: s["agvPosition"]["positionInitialized"], 30)
            x, y = first["agvPosition"]["x"], first["agvPosition"]["y"]
            points = [("n0", x, y), ("n1", x + 0.6, y), ("n2", x + 0.6, y + 0.6)]
            master.send("sim1", "order", order_body("o1", 0, points))
            passed = master.wait_for("sim1", "state", lambda s: s["lastNodeId"] == "n1", 60)
            assert [n["nodeId"] for n in passed["nodeStates"]] == ["n2"]
            done = master.wait_for(
                "sim1", "state", lambda s: s["lastNodeId"] == "n2" and not s["driving"], 60
            )
            assert done["errors"] == [] and done["nodeStates"] == []
            truth = rig.sim.truth()  # where the simulated cart really stands
            assert math.dist((truth["x"], truth["y"]), (x + 0.6, y + 0.6)) < 0.1
            assert not master.invalid, master.invalid
        finally:
            master.close()
            vehicle.close()


def test_the_simulated_cart_keeps_its_speed_through_a_node_on_the_way(rig: GatewayRig) -> None:
    """A straight base of three nodes is one path (issue 27): at the middle node the cart's
    true speed (the simulator's ground truth, in simulated time) stays near its top speed, and
    the middle node is reported passed while the cart drives on."""
    v_max = float(factsheet_body()["physicalParameters"]["speedMax"])
    with Mosquitto() as broker:
        master = Master(broker.broker)
        vehicle = join_fleet(rig.gateway, broker.broker, "sim1")
        try:
            first = master.wait_for("sim1", "state", lambda s: s["agvPosition"]["positionInitialized"], 30)
            x, y = first["agvPosition"]["x"], first["agvPosition"]["y"]
            truth = high_rate_truth(rig.sim, hz=100.0)
            middle = (x + 0.5, y + 0.5)  # a diagonal: the arena's corner leaves no room along an edge
            points = [("n0", x, y), ("n1", *middle), ("n2", x + 1.0, y + 1.0)]
            master.send("sim1", "order", order_body("o1", 0, points))
            passed = master.wait_for("sim1", "state", lambda s: s["lastNodeId"] == "n1", 60)
            assert passed["driving"] and [n["nodeId"] for n in passed["nodeStates"]] == ["n2"]
            master.wait_for("sim1", "state", lambda s: s["lastNodeId"] == "n2" and not s["driving"], 60)
            assert not master.invalid, master.invalid
        finally:
            master.close()
            vehicle.close()
    at_middle = min(truth, key=lambda s: math.dist((s["x"], s["y"]), middle))
    assert math.dist((at_middle["x"], at_middle["y"]), middle) < 0.05
    assert at_middle["v"] > 0.7 * v_max, f"{at_middle['v']:.3f} m/s at the middle node (top {v_max} m/s)"

"""The order's executor (cart2d/fleet/order.py) on a fake cart, no broker: a cancelled order
takes with it the navigation error its stop left (STOP ALL stops each cart, then cancels its
order: the page showed the cart in error until its next order)."""

from __future__ import annotations

from cart2d.fleet.order import Executor
from tests.support.fleet_cart import RecordingCart
from tests.support.vda5050 import instant, order_body

POINTS = [("a", 0.25, 0.25), ("b", 0.75, 0.25), ("c", 1.25, 0.25)]


def test_a_cancelled_order_clears_the_error_of_the_stop_that_ended_it() -> None:
    cart = RecordingCart()
    executor = Executor(cart, pose=(0.25, 0.25, 0.0))
    executor.order(order_body("o1", 0, POINTS))
    assert cart.goals == [(1.25, 0.25)]  # one path through b to c
    executor.mission_ended((1.25, 0.25), False, "STOP ALL from the fleet")  # the gateway's own stop
    assert [e["errorType"] for e in executor.errors] == ["navigationError"]
    executor.instant_actions(instant("c1", "cancelOrder"))
    state = executor.state_fields()
    assert state["errors"] == [] and state["nodeStates"] == [] and not state["driving"]
    assert state["actionStates"][0]["actionStatus"] == "FINISHED"
    executor.order(order_body("o2", 0, [("b", 0.3, 0.25), ("c", 1.25, 0.25)]))  # not stuck
    assert cart.goals[-1] == (1.25, 0.25) and executor.errors == []


def test_a_cancel_with_no_order_is_an_error_of_its_own() -> None:
    executor = Executor(RecordingCart())
    executor.instant_actions(instant("c1", "cancelOrder"))
    assert [e["errorType"] for e in executor.errors] == ["noOrderToCancel"]

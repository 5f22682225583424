"""The released base driven as one path (cart2d/fleet/order.py, issue 27): the cart is sent
through the base's nodes at once, each node reported traversed as the cart crosses it, an
update that extends the base replaces the path before the cart gets to its end, and no node
that is not released is ever in the path. A fake cart, no broker."""

from __future__ import annotations

from collections.abc import Sequence

from cart2d.fleet.order import Executor, Refused
from tests.support.fleet_cart import RecordingCart
from tests.support.vda5050 import instant, order_body

POINTS = [("a", 0.25, 0.25), ("b", 0.75, 0.25), ("c", 1.25, 0.25), ("d", 1.75, 0.25), ("e", 1.75, 0.75)]


def started(released: int) -> tuple[Executor, RecordingCart]:
    cart = RecordingCart()
    executor = Executor(cart, pose=(0.25, 0.25, 0.0))
    executor.order(order_body("o1", 0, POINTS, released=released))
    return executor, cart


def remaining(executor: Executor) -> list[str]:
    return [n["nodeId"] for n in executor.state_fields()["nodeStates"]]


def test_the_base_is_one_path_and_each_node_is_traversed_as_the_cart_crosses_it() -> None:
    executor, cart = started(released=3)
    assert cart.routes == [[(0.75, 0.25), (1.25, 0.25)]]  # through b, stopping only at c
    executor.moved((0.70, 0.26, 0.0))  # short of b
    assert executor.last_node_id == "a" and remaining(executor) == ["b", "c", "d", "e"]
    executor.moved((0.76, 0.25, 0.0))  # across the line through b
    state = executor.state_fields()
    assert (state["lastNodeId"], state["lastNodeSequenceId"]) == ("b", 2)
    assert remaining(executor) == ["c", "d", "e"] and next(e["edgeId"] for e in state["edgeStates"]) == "b-c"
    assert state["driving"] and cart.passed_points == [(0.75, 0.25)]
    executor.moved((1.30, 0.25, 0.0))  # c is the path's end: its mission's arrival says so
    assert executor.last_node_id == "b"
    executor.mission_ended((1.25, 0.25), True, "")
    assert executor.last_node_id == "c" and not executor.state_fields()["driving"]
    assert cart.routes == [[(0.75, 0.25), (1.25, 0.25)]]  # d is not released: it waits at c


def test_poses_far_apart_still_see_the_node_crossed_but_not_a_detour_beyond_its_deviation() -> None:
    executor, _ = started(released=3)
    executor.moved((0.55, 0.25, 0.0))
    executor.moved((0.95, 0.27, 0.0))  # one look before b, the next 0.2 m past it
    assert executor.last_node_id == "b"
    executor, _ = started(released=3)
    executor.moved((0.55, 0.70, 0.0))
    executor.moved((0.95, 0.70, 0.0))  # beyond b's line, but 0.45 m off it (allowedDeviationXY 0.3)
    assert executor.last_node_id == "a"


def test_an_update_before_the_base_end_replaces_the_path_and_a_later_one_starts_it_again() -> None:
    executor, cart = started(released=3)
    executor.moved((0.80, 0.25, 0.0))  # b passed
    executor.order(order_body("o1", 1, POINTS[2:4], first_seq=4))  # c..d: d released
    assert cart.routes[-1] == [(1.25, 0.25), (1.75, 0.25)]  # from where it is, through c to d
    executor.moved((1.30, 0.25, 0.0))
    assert executor.last_node_id == "c"
    executor.mission_ended((1.25, 0.25), True, "")  # the replaced path's end: stale
    assert executor.state_fields()["driving"] and executor.last_node_id == "c"
    executor.mission_ended((1.75, 0.25), True, "")
    assert executor.last_node_id == "d" and not executor.state_fields()["driving"]
    executor.order(order_body("o1", 2, POINTS[3:], first_seq=6))  # at rest at d: e released
    assert cart.routes[-1] == [(1.75, 0.75)] and executor.state_fields()["driving"]


def test_no_path_ever_holds_a_node_that_is_not_released() -> None:
    for released in range(2, len(POINTS) + 1):
        executor, cart = started(released)
        allowed = {(x, y) for _, x, y in POINTS[:released]}
        assert cart.routes and set(cart.routes[-1]) <= allowed, (released, cart.routes)
        executor.mission_ended(cart.routes[-1][-1], True, "")
        assert executor.last_node_id == POINTS[released - 1][0]


def test_a_pause_stops_and_the_resume_drives_on_through_the_nodes_left() -> None:
    executor, cart = started(released=4)
    executor.moved((0.80, 0.25, 0.0))  # b passed
    executor.instant_actions(instant("p1", "startPause"))
    assert cart.stops == ["paused by the fleet"] and not executor.state_fields()["driving"]
    executor.mission_ended((1.75, 0.25), False, "paused by the fleet")
    executor.instant_actions(instant("p2", "stopPause"))
    assert cart.routes[-1] == [(1.25, 0.25), (1.75, 0.25)] and executor.errors == []
    executor.instant_actions(instant("c1", "cancelOrder"))
    executor.moved((1.30, 0.25, 0.0))  # a cancelled order reports nothing more
    assert executor.last_node_id == "b" and remaining(executor) == []


class RefusingCart(RecordingCart):
    def go_through(self, points: Sequence[tuple[float, float]]) -> None:
        if len(self.routes) >= 1:
            raise Refused("no route")
        super().go_through(points)


def test_a_refused_extension_leaves_the_cart_on_its_path_to_the_old_base_end() -> None:
    cart = RefusingCart()
    executor = Executor(cart, pose=(0.25, 0.25, 0.0))
    executor.order(order_body("o1", 0, POINTS, released=3))
    executor.order(order_body("o1", 1, POINTS[2:4], first_seq=4))
    assert [e["errorType"] for e in executor.errors] == ["noRouteError"]
    assert executor.state_fields()["driving"]  # still on its way to c
    executor.mission_ended((1.25, 0.25), True, "")  # there; tried again from rest, refused
    assert executor.last_node_id == "c" and executor.stuck

"""Traffic control with fake carts on a fake clock: each tick every cart moves at most one node,
and only onto a node it holds; no two carts ever stand on one node or swap over one edge."""

from __future__ import annotations

from cart2d.fleet.lattice import Cell, Lattice
from cart2d.fleet.traffic import Journey, Traffic


def lattice(cells: set[Cell]) -> Lattice:
    return Lattice((0.25, 0.25), 0.5, frozenset(cells))


def open_square(n: int) -> set[Cell]:
    return {(i, j) for i in range(n) for j in range(n)}


def drive(traffic: Traffic, ticks: int, frozen: frozenset[str] = frozenset()) -> int:
    """Moves the carts until every journey has ended (returns the ticks it took) or `ticks`."""
    for tick in range(ticks):
        if not traffic.journeys:
            return tick
        traffic.step(float(tick))
        before = dict(traffic.standing)
        for cart, journey in list(traffic.journeys.items()):
            if cart in frozen or journey.passed + 1 >= journey.released:
                continue
            nxt = journey.route[journey.passed + 1]
            assert traffic.holds[nxt] == cart, f"{cart} drove onto {nxt}, which it does not hold"
            traffic.reached(cart, journey.passed + 1)
        places = list(traffic.standing.values())
        assert len(places) == len(set(places)), f"two carts on one node at tick {tick}: {traffic.standing}"
        for a, cell in traffic.standing.items():
            for b, other in traffic.standing.items():
                assert not (a != b and before[a] == other and before[b] == cell), f"{a} and {b} swapped"
    return ticks


def test_two_carts_pass_in_a_corridor_through_its_bay() -> None:
    corridor = {(i, 0) for i in range(7)} | {(3, 1)}  # one passing bay half-way
    traffic = Traffic(lattice(corridor))
    traffic.join("a", (0, 0))
    traffic.join("b", (6, 0))
    traffic.send("a", (5, 0))
    traffic.send("b", (0, 0))  # where a stands now: a is on its way
    ticks = drive(traffic, 60)
    assert ticks < 60, f"still driving: {traffic.journeys}"
    assert traffic.standing == {"a": (5, 0), "b": (0, 0)}
    waited = sum(j.waited_s for _, j in traffic.finished)
    assert waited > 0  # one waited in (or for) the bay while the other passed


def test_four_carts_round_a_block_deadlock_is_resolved() -> None:
    traffic = Traffic(lattice(open_square(5)))
    # each wants the node the next one stands on: a circle of waits from the first step
    routes = {
        "a": [(1, 1), (2, 1), (3, 1)],
        "b": [(2, 1), (2, 2), (2, 3)],
        "c": [(2, 2), (1, 2), (0, 2)],
        "d": [(1, 2), (1, 1), (1, 0)],
    }
    for cart, route in routes.items():
        traffic.join(cart, route[0])
        traffic.journeys[cart] = Journey(list(route))
    ticks = drive(traffic, 40)
    assert ticks < 40, f"still driving: {traffic.journeys}"
    assert traffic.deadlocks >= 1
    assert {cart: traffic.standing[cart] for cart in routes} == {c: r[-1] for c, r in routes.items()}
    assert sum(j.reroutes for _, j in traffic.finished) >= 1


def test_an_offline_cart_keeps_its_node_and_the_other_routes_round_it() -> None:
    traffic = Traffic(lattice(open_square(5)))
    traffic.join("a", (0, 2))
    traffic.join("b", (2, 0))
    traffic.send("b", (2, 4))  # straight up through (2, 2)
    traffic.step(0.0)
    traffic.set_online("b", False)  # lost before it moved: it holds (1, 0) and what it released
    held_by_b = {c for c, h in traffic.holds.items() if h == "b"}
    traffic.send("a", (4, 2))  # its straight way through (2, 2) is b's
    drive(traffic, 20, frozen=frozenset({"b"}))
    assert traffic.standing["a"] == (4, 2)
    assert {c for c, h in traffic.holds.items() if h == "b"} == held_by_b
    finished = dict(traffic.finished)
    assert not held_by_b & set(finished["a"].route)


def test_a_goal_on_a_parked_cart_is_refused() -> None:
    traffic = Traffic(lattice(open_square(3)))
    traffic.join("a", (0, 0))
    traffic.join("b", (2, 2))
    try:
        traffic.send("a", (2, 2))
    except ValueError as exc:
        assert "held by b" in str(exc)
    else:
        raise AssertionError("a goal on another cart's node was taken")
    assert "a" not in traffic.journeys

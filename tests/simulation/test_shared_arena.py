"""The shared arena's bookkeeping on fake simulators: contacts between carts counted disc to
disc from their truth (once per contact), each simulator given the other carts as boxes."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, cast

from cart2d.params import footprint_radius_m
from cart2d.simulation.shared_arena import SharedArena
from cart2d.simulation.simulator import Simulator


class FakeSim:
    def __init__(self) -> None:
        self.listeners: list[Callable[[dict[str, Any]], None]] = []

    def subscribe_truth(self, listener: Callable[[dict[str, Any]], None]) -> None:
        self.listeners.append(listener)

    def at(self, x: float, y: float, t: float = 0.0) -> None:
        for listener in self.listeners:
            listener({"t": t, "x": x, "y": y, "theta": 0.0})


def test_contacts_between_carts_and_the_boxes_each_simulator_gets() -> None:
    sims = {"a": FakeSim(), "b": FakeSim()}
    arena = SharedArena(cast(dict[str, Simulator], sims))
    reach = 2 * footprint_radius_m()
    sims["a"].at(1.0, 1.0)
    sims["b"].at(1.0 + reach + 0.01, 1.0)
    assert arena.cart_contacts == 0
    [box] = arena.boxes_for("a")
    assert (box.id, box.x, box.sx) == ("cart:b", 1.0 + reach + 0.01, reach)
    sims["b"].at(1.0 + reach - 0.001, 1.0, 1.0)  # touching
    sims["b"].at(1.0 + reach - 0.002, 1.0, 1.1)  # still the same contact
    assert arena.cart_contacts == 1 and arena.view()["touching"] == [["a", "b"]]
    sims["b"].at(1.0 + reach + 0.01, 1.0, 1.2)  # apart
    sims["a"].at(1.0 + 0.02, 1.0, 1.3)  # and again
    assert arena.cart_contacts == 2
    assert arena.contact_log[0]["carts"] == ["a", "b"]

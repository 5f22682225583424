"""Two simulated carts (the real firmware each, coupled in one arena) sent head-on through one
corridor by the fleet manager over a real mosquitto: both arrive, and the carts never touch
(their discs, from the simulators' truth) nor anything else."""

from __future__ import annotations

import contextlib
from pathlib import Path

from cart2d.fleet.arena import FLEET_MAP, map_lattice
from cart2d.fleet.broker import Mosquitto
from cart2d.fleet.manager import FleetManager
from cart2d.maps.world import Box
from cart2d.simulation.shared_arena import CartStart
from cart2d.tools.fleet import SimFleet
from tests.support.sim import require_builds
from tests.support.waiting import wait_for

# a corridor along y = 1.75 between two long boxes; its ends open at x = 0.25 and x = 3.75
CORRIDOR = [Box(2.0, 1.2, 2.5, 0.6, id="south"), Box(2.0, 2.3, 2.5, 0.6, id="north")]


def test_two_carts_pass_through_one_corridor_without_contact(tmp_path: Path) -> None:
    require_builds()
    lattice = map_lattice(FLEET_MAP, CORRIDOR)
    assert lattice.nearest(2.0, 1.25) == lattice.nearest(2.0, 1.75)  # no node beside the corridor
    # beside each end, off the other's way: both plan through the corridor and meet in it
    starts = [CartStart(id="west", x=0.25, y=2.25), CartStart(id="east", x=3.75, y=1.25)]
    with contextlib.ExitStack() as stack:
        broker = stack.enter_context(Mosquitto()).broker
        fleet = SimFleet.start(starts, "2", CORRIDOR, broker, stack, tmp_path)
        manager = FleetManager(lattice, broker).start()
        stack.callback(manager.close)
        wait_for(lambda: len(manager.traffic.standing) == 2, 30)
        manager.add_goal(3.75, 2.25, cart="west")
        manager.add_goal(0.25, 1.25, cart="east")
        try:
            wait_for(lambda: all(g.status == "reached" for g in manager.goals), 120)
        except AssertionError as exc:
            raise AssertionError(f"{exc}: {manager.view().carts}, {fleet.arena.view()}") from None
        truth = fleet.arena.view()
        assert truth["cart_contacts"] == 0, fleet.arena.contact_log
        for name, cart in truth["carts"].items():
            assert cart["wall_contacts"] == 0 and cart["box_contacts"] == 0, (name, cart)
        assert manager.traffic.deadlocks + sum(j.waited_s > 0 for _, j in manager.traffic.finished) >= 1
        # each simulator's world holds the other cart (what its bumpers and its camera meet)
        west_world = fleet.carts[0].sim.control("world_get")["world"]
        assert [b["id"] for b in west_world["boxes"] if b["id"].startswith("cart:")] == ["cart:east"]

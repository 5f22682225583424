"""`cart2d fleet sim --map FILE.yaml` (issue 27): a floor plan as the fleet's arena. Its lattice
keeps off its walls and goes round a partition through its doorway; the simulators stand its
walls, so a cart sent across drives round the partition without touching it; a map that cannot
be read is one sentence before anything starts."""

from __future__ import annotations

import contextlib
import math
from pathlib import Path

import numpy as np
import pytest

from cart2d.fleet.arena import map_lattice
from cart2d.fleet.broker import Mosquitto
from cart2d.fleet.manager import FleetManager
from cart2d.maps.occupancy import FREE, OCCUPIED, OccupancyMap
from cart2d.maps.ros import load_ros_map, save_ros_map
from cart2d.simulation.shared_arena import CartStart
from cart2d.tools.cli import main
from cart2d.tools.fleet import SimFleet, fleet_map
from tests.support.sim import require_builds
from tests.support.waiting import wait_for

RESOLUTION_M = 0.05
PARTITION_X = (1.45, 1.55)  # from the south wall up to y = 1.25; the doorway above it


def two_rooms() -> OccupancyMap:
    """3 m x 2.5 m, walls 10 cm thick, a partition across the lower half at x = 1.5 m."""
    cells = np.full((50, 60), FREE, dtype=np.int8)  # rows are y, columns x
    cells[:2, :] = cells[-2:, :] = OCCUPIED
    cells[:, :2] = cells[:, -2:] = OCCUPIED
    cells[:25, 29:31] = OCCUPIED
    return OccupancyMap((0.0, 0.0), RESOLUTION_M, cells)


def test_the_lattice_of_a_floor_plan_keeps_off_its_walls_and_goes_through_the_doorway() -> None:
    plan = two_rooms()
    lattice = map_lattice(fleet_map(plan, "two rooms"))
    occupied = np.argwhere(plan.cells == OCCUPIED)[:, ::-1] * RESOLUTION_M + RESOLUTION_M / 2
    for cell in lattice.free:
        x, y = lattice.position(cell)
        assert np.min(np.hypot(occupied[:, 0] - x, occupied[:, 1] - y)) > 0.2, (cell, x, y)
    west, east = lattice.nearest(0.5, 0.5), lattice.nearest(2.5, 0.5)
    route = lattice.route(west, east)
    assert route is not None
    positions = [lattice.position(c) for c in route]
    crossing = [(x, y) for x, y in positions if PARTITION_X[0] < x < PARTITION_X[1]]
    assert crossing and all(y > 1.25 for _, y in crossing)  # through the doorway, not the partition


def test_a_map_that_cannot_be_read_is_one_sentence(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["fleet", "sim", "--carts", "1", "--map", str(tmp_path / "none.yaml")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("cart2d fleet sim: --map ") and "cannot be read" in err and "Traceback" not in err


def test_a_cart_crosses_the_floor_plan_round_its_partition(tmp_path: Path) -> None:
    require_builds()
    save_ros_map(two_rooms(), tmp_path / "rooms.yaml")  # as `cart2d map save` writes it
    arena_map = fleet_map(load_ros_map(tmp_path / "rooms.yaml"), "rooms")  # as --map reads it
    lattice = map_lattice(arena_map)
    start, goal = lattice.position(lattice.nearest(0.5, 0.5)), lattice.position(lattice.nearest(2.5, 0.5))
    with contextlib.ExitStack() as stack:
        broker = stack.enter_context(Mosquitto()).broker
        fleet = SimFleet.start(
            [CartStart(id="a", x=start[0], y=start[1])], "max", [], broker, stack, tmp_path, arena_map
        )
        assert len(fleet.carts[0].sim.control("world_get")["world"]["walls"]) > 4  # the partition too
        manager = FleetManager(lattice, broker).start()
        stack.callback(manager.close)
        wait_for(lambda: len(manager.traffic.standing) == 1, 30)
        manager.add_goal(*goal)
        wait_for(lambda: all(g.status == "reached" for g in manager.goals), 120)
        truth = fleet.arena.view()["carts"]["a"]
    assert truth["wall_contacts"] == 0, truth
    assert math.dist((truth["x"], truth["y"]), goal) < 0.1, truth

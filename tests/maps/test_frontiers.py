"""Frontiers between seen-free and unseen floor, and the choice among them: gain against the
way there, an unreachable one set aside with its reason."""

from __future__ import annotations

import numpy as np

from cart2d.maps.frontiers import Frontier, choose, frontiers
from cart2d.maps.occupancy import FREE, OCCUPIED, UNKNOWN, OccupancyMap


def room() -> OccupancyMap:
    """20 x 20 cells of 0.1 m: free on the left half, unknown on the right; a wall along the
    bottom row, and a free pocket of 2 cells in the unknown (too small to count)."""
    cells = np.full((20, 20), UNKNOWN, dtype=np.int8)
    cells[:, :10] = FREE
    cells[0, :] = OCCUPIED
    cells[5, 15:17] = FREE
    return OccupancyMap((0.0, 0.0), 0.1, cells)


def test_the_frontier_is_the_free_edge_next_to_the_unknown() -> None:
    (f,) = frontiers(room())
    assert f.cells == 19  # column 9, rows 1 to 19 (row 0 is the wall)
    assert abs(f.centre[0] - 0.95) < 1e-9 and 0.9 < f.centre[1] < 1.2


def test_a_map_with_no_unknown_floor_has_no_frontier() -> None:
    cells = np.full((10, 10), FREE, dtype=np.int8)
    assert frontiers(OccupancyMap((0.0, 0.0), 0.1, cells)) == []


def test_the_choice_weighs_gain_against_the_way_and_blacklists_the_unreachable() -> None:
    near_small, far_big, cut_off = (
        Frontier((1.0, 0.0), 5),
        Frontier((4.0, 0.0), 40),
        Frontier((2.0, 2.0), 100),
    )
    lengths = {near_small.centre: 1.0, far_big.centre: 4.0, cut_off.centre: None}
    blacklist: dict[tuple[float, float], str] = {}
    chosen = choose([near_small, far_big, cut_off], 0.1, lengths.__getitem__, blacklist)
    assert chosen == far_big  # 4 m of edge for 4.5 m against 0.5 m for 1.5 m
    assert blacklist == {cut_off.centre: "no path to the frontier at (2.00, 2.00)"}
    assert choose([cut_off, near_small], 0.1, lengths.__getitem__, blacklist) == near_small


def test_a_frontier_whose_way_is_not_safe_yet_is_left_out_of_this_choice_only() -> None:
    near, far = Frontier((1.0, 0.0), 10), Frontier((3.0, 0.0), 10)
    lengths = {near.centre: float("inf"), far.centre: 3.0}
    blacklist: dict[tuple[float, float], str] = {}
    assert choose([near, far], 0.1, lengths.get, blacklist) == far
    assert blacklist == {}  # not set aside: the next choice looks at it again
    lengths[near.centre] = 1.0
    assert choose([near, far], 0.1, lengths.get, blacklist) == near

"""The map on a finer grid (cart2d/planning/refine.py, live_map.layout_for): it blocks exactly the
floor the map's own grid blocks, reaches whatever the map's grid reaches by a path no longer, and
keeps the user's obstacles where they were on a floor plan too."""

from __future__ import annotations

import random

import numpy as np
import pytest

from cart2d.gateway.live_map import FINE_PLANNING_NODES, layout_for, planner_for
from cart2d.maps import OCCUPIED, OccupancyMap
from cart2d.params import planning_radius_m
from cart2d.planning import EPS, PlanError, point_square_distance
from cart2d.planning.refine import odd_factor, refined_cells
from cart2d.store import FloorPlan, MapSettings

STEP = 0.2


def test_the_factor_is_odd_fine_enough_and_within_the_node_budget() -> None:
    assert odd_factor(0.2, 0.05, 10, 10, FINE_PLANNING_NODES) == 5  # 4 rounded up to odd
    assert odd_factor(0.1, 0.05, 41, 41, FINE_PLANNING_NODES) == 3
    assert odd_factor(0.2, 0.2, 10, 10, FINE_PLANNING_NODES) == 1
    assert odd_factor(0.2, 0.3, 10, 10, FINE_PLANNING_NODES) == 1
    # 1000 x 1000 nodes: already over the budget at 3, so the map's own grid
    assert odd_factor(0.2, 0.05, 1000, 1000, FINE_PLANNING_NODES) == 1
    assert odd_factor(0.2, 0.05, 120, 120, 120 * 120 * 9) == 3  # 5 would be 354k nodes


def test_refined_cells_cover_each_coarse_cell_exactly() -> None:
    cells = np.zeros((3, 4), dtype=np.bool_)
    cells[1, 2] = True
    fine = refined_cells(cells, 5)
    assert fine.shape == (11, 16)
    rows, cols = fine.nonzero()
    # node (2, 1) is fine node (10, 5); its cell is fine cells 8..12 x 3..7
    assert (rows.min(), rows.max(), cols.min(), cols.max()) == (3, 7, 8, 12)
    assert fine.sum() == 25


def random_map(seed: int) -> MapSettings:
    rng = random.Random(seed)
    obstacles = sorted({(rng.randrange(10), rng.randrange(10)) for _ in range(rng.randrange(3, 9))})
    return MapSettings(cols=10, rows=10, step_m=STEP, obstacles=obstacles)


@pytest.mark.parametrize("seed", range(12))
def test_the_finer_grid_blocks_exactly_the_floor_the_maps_grid_blocks(seed: int) -> None:
    m = random_map(seed)
    fine = layout_for(m, 0.05).planner()
    assert fine.grid.step_m == pytest.approx(STEP / 5) and fine.grid.cols == 46
    r = planning_radius_m()
    free = fine.graph.free.reshape(fine.grid.rows, fine.grid.cols)
    for j in range(fine.grid.rows):
        for i in range(fine.grid.cols):
            p = fine.grid.node_xy(i, j)
            clear = all(
                point_square_distance(p, (oi * STEP, oj * STEP), STEP / 2) > r + EPS for oi, oj in m.obstacles
            )
            near = any(
                abs(point_square_distance(p, (oi * STEP, oj * STEP), STEP / 2) - r) < 1e-6
                for oi, oj in m.obstacles
            )
            if not near:  # exactly touching is up to rounding
                assert free[j, i] == clear, (i, j)


@pytest.mark.parametrize("seed", range(12))
def test_the_finer_grid_reaches_what_the_maps_grid_reaches_by_a_path_no_longer(seed: int) -> None:
    m = random_map(seed)
    coarse, fine = planner_for(m), layout_for(m, 0.05).planner()
    rng = random.Random(100 + seed)
    compared = 0
    for _ in range(80):
        start = (rng.uniform(0.0, 1.8), rng.uniform(0.0, 1.8))
        goal = (rng.uniform(0.0, 1.8), rng.uniform(0.0, 1.8))
        try:
            on_map = coarse.plan(start, goal)
        except PlanError:
            continue
        on_fine = fine.plan(start, goal)  # never PlanError where the map's grid has a path
        # The driven paths: each within 4 % of the true shortest (the simplification's bound;
        # the grid paths themselves differ by how their ends join the nodes, within √2 steps)
        assert on_fine.length_m <= on_map.length_m * 1.04  # the shortest is no longer than on_map
        compared += 1
    assert compared >= 5


def test_on_a_floor_plan_the_finer_grid_keeps_its_walls_and_the_users_obstacles() -> None:
    cells = np.zeros((40, 60), dtype=np.int8)  # 3 x 2 m at 5 cm
    cells[0, :] = cells[-1, :] = cells[:, 0] = cells[:, -1] = OCCUPIED
    plan = FloorPlan.of(OccupancyMap((0.0, 0.0), 0.05, cells), "room")
    m = MapSettings.model_validate({"floor_plan": plan, "planning_step_m": 0.2, "obstacles": [(7, 4)]})
    coarse, fine = layout_for(m), layout_for(m, 0.05)
    assert coarse.grid.step_m == pytest.approx(0.2) and fine.grid.step_m == pytest.approx(0.05)
    assert fine.obstacles == () and fine.outside_blocked
    assert fine.blocked is not None
    # the user's obstacle (7, 4): the 4 x 4 floor cells of that 0.2 m block, x 1.4-1.6, y 0.8-1.0
    expected = cells == OCCUPIED
    expected[16:20, 28:32] = True
    assert np.array_equal(fine.blocked, expected)


def test_on_the_finer_grid_the_cart_may_stray_off_the_map_as_far_as_on_the_maps_grid() -> None:
    # The cart at an edge node drifts 1.3 cm outside the node rectangle while turning on the spot:
    # within half of the map's 0.2 m step, though more than half of the finer grid's 2.2 cm
    m = MapSettings()
    coarse, fine = planner_for(m), layout_for(m, 0.025).planner()
    assert fine.grid.step_m < 0.026
    for planner in (coarse, fine):
        plan = planner.plan((-0.013, 0.25), (1.6, 1.6))
        # from where it is, or on the finer grid the nearest point of the map
        assert plan.start in ((-0.013, 0.25), (0.0, 0.25))
        with pytest.raises(PlanError, match="off the map"):
            planner.plan((-0.11, 0.25), (1.6, 1.6))

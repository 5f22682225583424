"""The log-odds occupancy grid: hits raise cells, rays of free floor lower the cells they cross,
clamped; the pose places a detection in the map."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from cart2d.perception.detection import Detection
from cart2d.perception.occupancy import LogOddsGrid

MIN_RANGE_M = 0.25


def detection(hits: list[tuple[float, float]], clear_ends: tuple[tuple[float, float], ...] = ()) -> Detection:
    """A detection in base_link with its rays from the lens's foot at (0.1, 0)."""
    hit_array = np.array(hits, dtype=np.float64).reshape(-1, 2)
    ends = np.concatenate([hit_array, np.array(clear_ends, dtype=np.float64).reshape(-1, 2)])
    return Detection(
        floor_mask=np.ones((2, 2), bool),
        lowest_row=np.zeros(0, np.int32),
        lowest_px=np.zeros((0, 2)),
        hits=hit_array,
        free=ends,
        origin=np.array([0.1, 0.0]),
        min_range_m=MIN_RANGE_M,
        is_hit=np.zeros(0, bool),
    )


def grid() -> LogOddsGrid:
    return LogOddsGrid((-2.0, -2.0), 0.05, 80, 80)  # 4 m x 4 m round the start


def p_at(g: LogOddsGrid, x: float, y: float) -> float:
    i, j = int((x - g.origin[0]) / g.resolution_m), int((y - g.origin[1]) / g.resolution_m)
    return float(g.probability()[j, i])


def test_repeated_hits_converge_to_occupied_and_are_clamped() -> None:
    g = grid()
    seen = [p_at(g, 1.01, 0.01)]
    for _ in range(10):
        g.integrate((0.0, 0.0, 0.0), detection([(1.01, 0.01)]))
        seen.append(p_at(g, 1.01, 0.01))
    assert seen[0] == 0.5
    assert all(b > a for a, b in itertools.pairwise(seen[:5]))  # each hit raises it...
    assert seen[-1] == pytest.approx(1 / (1 + math.exp(-g.max_log_odds)), abs=1e-6)  # ...up to the clamp
    (cell,) = g.cells(0.9)
    assert cell[:2] == pytest.approx((1.025, 0.025))  # the cell's centre


def test_the_ray_to_a_hit_clears_the_floor_before_it_but_not_the_blind_zone() -> None:
    g = grid()
    g.integrate((0.0, 0.0, 0.0), detection([(1.01, 0.01)]))
    assert p_at(g, 0.7, 0.0) < 0.5  # crossed by the ray
    assert p_at(g, 0.2, 0.0) == 0.5  # nearer than the min range: the camera does not see it
    assert p_at(g, 1.3, 0.0) == 0.5  # behind the hit: unknown
    assert p_at(g, 0.7, 0.5) == 0.5  # beside the ray


def test_free_evidence_clears_a_cell_wrongly_marked() -> None:
    g = grid()
    for _ in range(3):
        g.integrate((0.0, 0.0, 0.0), detection([(0.81, 0.01)]))  # a false obstacle
    ((x, y, _),) = g.cells()
    assert (x, y) == pytest.approx((0.825, 0.025))
    for _ in range(12):  # then the floor is seen clear through it, up to max range
        g.integrate((0.0, 0.0, 0.0), detection([], ((1.6, 0.03),)))
    assert p_at(g, 0.81, 0.01) < 0.5
    assert g.cells() == []


def test_a_cell_hit_in_a_frame_is_not_cleared_by_its_neighbours_rays() -> None:
    g = grid()
    # one ray ends on the hit, another passes right over it to max range
    g.integrate((0.0, 0.0, 0.0), detection([(1.01, 0.01)], ((1.6, 0.016),)))
    assert p_at(g, 1.01, 0.01) > 0.5


def test_the_pose_places_the_detection_in_the_map() -> None:
    g = grid()
    # facing +y from (0.5, -1.0): a hit 1 m ahead of base_link is at (0.5, 0.0) in the map
    g.integrate((0.5, -1.0, math.pi / 2), detection([(1.0, 0.0)]))
    ((x, y, _),) = g.cells()
    assert (x, y) == pytest.approx((0.525, 0.025))
    assert p_at(g, 0.51, -0.4) < 0.5  # the ray runs along +y


def test_rays_and_hits_off_the_grid_are_ignored() -> None:
    g = grid()
    g.integrate((10.0, 10.0, 0.0), detection([(1.0, 0.0)], ((1.5, 0.3),)))  # wholly outside
    assert np.all(g.log_odds == 0.0)
    g.integrate((1.0, 0.0, 0.0), detection([(1.5, 0.0)], ((1.6, 0.4),)))  # leaves the grid at x = 2
    assert g.cells() == []  # the hit at x = 2.5 is off the grid
    assert p_at(g, 1.9, 0.0) < 0.5  # the part inside is cleared


def test_clear_forgets_everything() -> None:
    g = grid()
    g.integrate((0.0, 0.0, 0.0), detection([(1.01, 0.01)]))
    g.clear()
    assert np.all(g.probability() == 0.5) and g.cells() == []

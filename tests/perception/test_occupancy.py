"""The log-odds occupancy grid: hits raise cells, rays of free floor lower the cells they cross,
clamped; the pose places a detection in the map; an obstacle seen by its face is taken as deep
as told behind that face, along its normal, hand-computed."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from cart2d.perception.detection import Detection
from cart2d.perception.occupancy import LogOddsGrid, _reach, run_lengths

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


def test_a_turning_frame_clears_no_floor_beyond_a_hit_within_its_heading_uncertainty() -> None:
    # A ray 3 degrees beside a face's hit, on to 1.6 m: with the heading certain it clears the
    # floor behind the face's end; uncertain by 0.1 rad (2.6 rad/s, 40 ms) the floor behind is
    # left as it was, and before the hit it is cleared still. 10 degrees off, it is cleared.
    beside = (1.6 * math.cos(math.radians(3)), 1.6 * math.sin(math.radians(3)))
    wide = (1.6 * math.cos(math.radians(10)), 1.6 * math.sin(math.radians(10)))
    for sigma, behind_cleared in ((0.0, True), (0.1, False)):
        g = grid()
        g.integrate((0.0, 0.0, 0.0), detection([(1.01, 0.0)], (beside, wide)), heading_sigma=sigma)
        assert (p_at(g, 1.3, 0.066) < 0.5) is behind_cleared
        assert p_at(g, 0.7, 0.033) < 0.5  # nearer than the hit
        assert p_at(g, 1.3, 0.22) < 0.5  # the ray outside the band


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


def face(x0: float, y0: float, x1: float, y1: float, n: int = 21) -> np.ndarray:
    """n hits evenly along the segment, in scan-line order."""
    return np.column_stack([np.linspace(x0, x1, n), np.linspace(y0, y1, n)])


def deep(depth_m: float = 0.1) -> LogOddsGrid:
    return LogOddsGrid((-2.0, -2.0), 0.05, 80, 80, hit_depth_m=depth_m)


def test_a_face_seen_at_a_slant_is_taken_deep_behind_it_not_along_the_rays() -> None:
    # the face x = 1.0, y in [0, 0.1], seen from (0.1, -0.8): the rays run up and to the right at
    # about 45 degrees; the obstacle's assumed body is the strip x in [1.0, 1.1] behind the face
    hits = face(1.0, 0.0, 1.0, 0.1)
    behind = deep()._behind(np.array([0.1, -0.8]), hits)
    assert behind[:, 0].min() == pytest.approx(1.0) and behind[:, 0].max() == pytest.approx(1.1)
    assert behind[:, 1].min() == pytest.approx(0.0) and behind[:, 1].max() == pytest.approx(0.1)


def test_the_depth_goes_away_from_the_camera_whichever_side_it_is_on() -> None:
    hits = face(0.0, 1.0, 0.2, 1.2)  # a face at 45 degrees: into it is up-left seen from below-right
    for origin, sign in (((0.5, 0.0), -1.0), ((-0.5, 2.0), 1.0)):
        behind = deep()._behind(np.array(origin), hits)
        step = behind.reshape(len(hits), -1, 2)[:, -1] - hits  # each hit's deepest point
        assert step == pytest.approx(
            np.tile(sign * 0.1 * np.array([math.sqrt(0.5), -math.sqrt(0.5)]), (21, 1))
        )


def test_a_hit_too_short_a_run_to_show_its_face_is_only_its_cell() -> None:
    # a single hit, and a run of 2 cm (a thin pole, a face's end at the picture's side)
    for hits in (np.array([[1.0, 0.0]]), face(1.0, 0.0, 1.0, 0.02, 5)):
        behind = deep()._behind(np.array([0.0, 0.0]), hits)
        assert np.allclose(np.unique(behind, axis=0), np.unique(hits, axis=0))


def test_two_obstacles_side_by_side_each_keep_their_own_face() -> None:
    # a face along y (x = 1.0) and, 0.3 m away, one along x (y = 0.5), in one detection
    hits = np.concatenate([face(1.0, -0.1, 1.0, 0.1), face(0.8, 0.5, 1.0, 0.5)])
    behind = deep()._behind(np.array([0.0, 0.0]), hits).reshape(len(hits), -1, 2)[:, -1] - hits
    assert behind[:21] == pytest.approx(np.tile([0.1, 0.0], (21, 1)), abs=1e-9)
    assert behind[21:] == pytest.approx(np.tile([0.0, 0.1], (21, 1)), abs=1e-9)


def test_no_depth_is_taken_unless_told() -> None:
    hits = face(1.0, 0.0, 1.0, 0.1)
    assert np.array_equal(LogOddsGrid((-2.0, -2.0), 0.05, 80, 80)._behind(np.zeros(2), hits), hits)


def test_the_assumed_depth_is_marked_occupied_behind_a_slanted_face() -> None:
    g = deep()
    # base_link, the lens's foot at (0.1, 0): the face x = 0.86 at y 0.455 to 0.595 (0.14 m long),
    # seen about 30 degrees left; 0.1 m behind it are the cells up to x = 0.96, on the same rows
    # (along the rays the depth would reach y = 0.65, a row more)
    hits = face(0.86, 0.455, 0.86, 0.595)
    g.integrate((0.0, 0.0, 0.0), detection([tuple(h) for h in hits]))
    occupied = {(round(x, 3), round(y, 3)) for x, y, _ in g.cells()}
    assert occupied == {(x, y) for x in (0.875, 0.925, 0.975) for y in (0.475, 0.525, 0.575)}


def test_an_obstacle_is_taken_as_deep_as_its_face_is_wide_up_to_the_most_told() -> None:
    # a narrow box's face (6 cm) and a wall's (0.5 m), seen straight on from the origin
    narrow, wall = face(1.0, -0.03, 1.0, 0.03, 13), face(1.0, 0.5, 1.0, 1.0, 41)
    for hits, depth in ((narrow, 0.06), (wall, 0.2)):
        behind = deep(0.2)._behind(np.array([0.0, 0.0]), hits)
        assert behind[:, 0].max() == pytest.approx(1.0 + depth, abs=0.0125)  # sampled every 2.5 cm
        assert behind[:, 0].min() == pytest.approx(1.0)


def test_runs_of_hits_end_where_the_next_hit_is_off_by_more_than_a_gap() -> None:
    hits = np.array([[1.0, 0.0], [1.0, 0.01], [1.0, 0.03], [1.3, 0.05], [1.3, 0.08], [0.5, 0.5]])
    assert run_lengths(hits) == pytest.approx([0.03, 0.03, 0.03, 0.03, 0.03, 0.0])
    assert len(run_lengths(np.zeros((0, 2)))) == 0


def test_depth_assumed_behind_a_face_is_cleared_by_the_floor_seen_behind_it_and_stays_cleared() -> None:
    # a thin board: its face x = 1.0, y in [-0.1, 0.1], seen straight on ten times, takes the 0.2 m
    # behind it as the board's body; then the cart, round the side, sees floor right through that
    # strip (rays along y at x = 1.125 and 1.175) six times each; then it sees the face again
    g = deep(0.2)
    front = detection([tuple(h) for h in face(1.0, -0.1, 1.0, 0.1)])
    for _ in range(10):
        g.integrate((0.0, 0.0, 0.0), front)
    assert p_at(g, 1.12, 0.01) > 0.8 and p_at(g, 1.17, 0.01) > 0.8  # assumed: the planner keeps off
    ahead = detection([], ((2.1, 0.0),))  # floor seen 2 m straight ahead
    for _ in range(6):
        for x in (1.125, 1.175):
            g.integrate((x, -0.6, math.pi / 2), ahead)  # facing +y: the ray x = const, y -0.5 to 1.5
    for _ in range(3):
        g.integrate((0.0, 0.0, 0.0), front)
    assert p_at(g, 1.12, 0.01) < 0.5 and p_at(g, 1.17, 0.01) < 0.5  # floor seen beats an assumption
    assert p_at(g, 1.01, 0.01) > 0.9  # the face itself, seen, stays


@pytest.mark.parametrize("heading", [0.0, math.pi - 0.1, -math.pi + 0.05])
def test_the_reach_beside_hits_matches_every_pair_compared(heading: float) -> None:
    """_reach's bisection against the all-pairs rule it stands for, for views across the +-pi
    seam too: the nearest hit within the angle of each ray's bearing."""
    rng = np.random.default_rng(5)
    origin = np.array([0.3, -0.2])

    def points(n: int) -> np.ndarray:
        a, d = heading + rng.uniform(-0.5, 0.5, n), rng.uniform(0.2, 2.0, n)
        return origin + np.column_stack([d * np.cos(a), d * np.sin(a)])

    for _ in range(20):
        ends, hits, sigma = points(200), points(int(rng.integers(1, 200))), float(rng.uniform(0.0, 0.2))
        rays, faces = ends - origin, hits - origin
        apart = np.arctan2(rays[:, 1], rays[:, 0])[:, None] - np.arctan2(faces[:, 1], faces[:, 0])[None, :]
        apart = np.remainder(apart + math.pi, math.tau) - math.pi
        expected = np.where(np.abs(apart) <= sigma, np.hypot(faces[:, 0], faces[:, 1])[None, :], np.inf).min(
            axis=1
        )
        assert np.array_equal(_reach(origin, ends, hits, sigma), expected)

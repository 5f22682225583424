"""In the simulator, with markers at the foot of the arena's walls: goals driven with the left
measuring wheel slipping (its odometry drifts by decimetres) end with the gateway's pose at the
truth, and a cart whose firmware pose is wrong and untrusted (carried) is found at its first
marker and then driven to its goal. Real time (the camera sees in wall-clock time): short runs."""

from __future__ import annotations

import math

from cart2d.localisation.markers import arena_markers
from cart2d.tools.localised_run import Run, arena_bounds, run_goals
from tests.support.sim import require_builds

GRID = (10, 10, 0.2)
MARKERS = arena_markers(arena_bounds(GRID), spacing_m=0.6)


def test_goals_with_wheel_slip_end_with_the_pose_at_the_truth() -> None:
    require_builds()
    report = run_goals(
        Run([(0.3, 1.0), (1.5, 1.0)], (1.0, 1.0, math.pi), MARKERS, {"enc_slip_l": 0.05}, GRID)
    )
    goals = report["goals"]
    assert all(g["reached"] for g in goals), goals
    assert goals[-1]["odometry_error_m"] > 0.08  # the slip is real: odometry alone is off by this
    for g in goals:
        # The heading at a goal is the last fix's (under 1 degree at rest) plus 2.5 % of what the
        # cart turned since (the slipping wheel): at most 4.5 degrees for the half turn a route
        # re-sent at its goal can make. A correction of under 3 cm there no longer re-sends it
        # (cart2d/gateway/correction_resend.py): 0.4 to 2.1 degrees in 8 runs on a loaded
        # machine, where 0.2 to 2.4 were measured before, 3.0 unloaded and 5.1 on CI.
        assert g["pose_error_m"] < 0.03 and g["heading_error_deg"] < 5.0, g
        assert g["goal_error_m"] < 0.05, g
    assert report["collisions"] == 0


def test_a_carried_cart_is_found_at_its_first_marker_and_driven() -> None:
    require_builds()
    run = Run([(1.0, 1.0)], (0.4, 0.7, math.pi), MARKERS, {}, GRID, start_believed=(1.5, 1.5, 0.0))
    report = run_goals(run)
    (goal,) = report["goals"]
    assert goal["reached"], goal
    assert goal["pose_error_m"] < 0.05 and goal["goal_error_m"] < 0.06, goal
    # the firmware still counts from where it believed it was, facing the other way
    assert abs(report["localisation"]["map_to_odom"]["theta"]) > math.radians(170)

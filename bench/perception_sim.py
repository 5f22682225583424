"""The perception section's measurements on the SIMULATED camera (bench/perception.py prints them):
`cart2d camera calibrate --sim`'s procedure against the real simulator binary, whose lens is
known (config/robot.toml [camera] + [sim.camera]: cart2d.tools.camera_calibration.simulated.simulated_lens).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Any

from cart2d.perception.calibration import Board, CameraCalibration, GroundBoard
from cart2d.perception.camera_model import Intrinsics, Mount
from cart2d.tools.camera_calibration.simulated import (
    HELD_SQUARE_M,
    calibrate_in_simulator,
    ground_errors,
    sim_options,
    simulated_lens,
)
from cart2d.tools.camera_calibration.views import SIM_VIEWS

HELD = Board(9, 6, HELD_SQUARE_M)
# The real procedure's floor board (docs/perception.md), and a larger one laid further out: the
# homography is extrapolated beyond the board, so its error grows with the square of the range.
FLOOR_BOARDS = {
    "9x6 of 30 mm at 0.45 m": GroundBoard(Board(9, 6, 0.03), 0.45),
    "9x6 of 40 mm at 0.5 m": GroundBoard(Board(9, 6, 0.04), 0.5),
}


def lens_errors(result: CameraCalibration, truth: Intrinsics, took_s: float) -> dict[str, Any]:
    """A calibration's lens against the true one, and its own errors: one run's figures."""
    lens = result.intrinsics
    return {
        "views": result.views,
        "rms_px": result.rms_px,
        "seconds": took_s,
        "fx_error_pct": 100 * (lens.fx / truth.fx - 1),
        "fy_error_pct": 100 * (lens.fy / truth.fy - 1),
        "cx_error_px": lens.cx - truth.cx,
        "cy_error_px": lens.cy - truth.cy,
        "k1": lens.dist[0],
        "k2": lens.dist[1],
        "k1_true": truth.dist[0],
        "k2_true": truth.dist[1],
        "board_rms_m": result.ground_rms_m,
    }


def lens_cells(r: dict[str, Any]) -> list[Any]:
    """lens_errors' figures as table cells (views to seconds)."""
    return [
        r["views"],
        f"{r['rms_px']:.3f}",
        f"{r['fx_error_pct']:+.2f} / {r['fy_error_pct']:+.2f}",
        f"{r['cx_error_px']:+.2f} / {r['cy_error_px']:+.2f}",
        f"{r['k1']:.3f} / {r['k2']:.3f} ({r['k1_true']:.2f} / {r['k2_true']:.2f})",
        f"{1000 * r['board_rms_m']:.2f}",
        f"{r['seconds']:.2f}",
    ]


def sim_calibration_runs(
    mount: Mount,
    seeds: Sequence[int],
    distances_m: Sequence[float],
    central_errors: Callable[[CameraCalibration], list[float]],
) -> list[dict[str, Any]]:
    """One calibration per simulator seed (its pixel noise) and floor board. `central_errors` is
    the synthetic runs' ground-error measure (the same floor points), for the two side by side;
    "full_width_error_m" is the worst over the whole width of the picture."""
    truth = simulated_lens(mount)
    runs = []
    for floor_name, on_floor in FLOOR_BOARDS.items():
        for seed in seeds:
            start = time.perf_counter()
            result = calibrate_in_simulator(
                HELD, on_floor, SIM_VIEWS, mount, sim_options(seed=seed), say=lambda _: None
            )
            took_s = time.perf_counter() - start
            runs.append(
                {
                    "seed": seed,
                    "floor_board": floor_name,
                    **lens_errors(result, truth, took_s),
                    "ground_error_m": central_errors(result),
                    "full_width_error_m": [float(ground_errors(result, mount, d).max()) for d in distances_m],
                }
            )
    return runs

"""## Odometry (UMBmark): systematic odometry errors before and after `cart2d calibrate`.

Borenstein and Feng's UMBmark in the simulator: a 2 m square, n runs clockwise and n
counter-clockwise, each side a one-point path that stops on its corner and each corner a turn on
the spot; the return error of a run is the true end position (ground truth) minus the one the
odometry computed, and E_max,syst is the larger distance of the CW and CCW centroids from zero.
For each setting of the systematic simulator faults (measuring-wheel radii, their track) the
section runs `cart2d calibrate`'s procedure: a UMBmark with the firmware's default geometry (the
"before"), Borenstein's corrections of the radii and the track (PARAM_SET), a second, shorter
pass that corrects what the first-order formulas left, and a last UMBmark with the final values
(the "after"). The same UMBmark without faults is the floor. A separate square, recorded at
250 Hz of ground truth, checks that the corners really are stops with turns on the spot.

Target: E_max,syst at least 10x smaller after calibration, for every fault setting.
`python -m bench.umbmark [--quick]`: the quick form (CI) runs one fault setting, one run each way.
"""

from __future__ import annotations

import math
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt

from bench.common import Section, section_main, spread, table
from cart2d.link import Link
from cart2d.planning import point_polyline_distance
from cart2d.simulation.simulator import SimOptions, Simulator
from cart2d.tools.umbmark.arithmetic import (
    Calibration,
    Geometry,
    Measurement,
    sim_layout,
    square_corners,
    true_geometry,
)
from cart2d.tools.umbmark.procedure import Schedule, SimSetup, calibrate_in_sim
from cart2d.tools.umbmark.runners import drive_square

NAME = "umbmark"
SIDE_M = 2.0
TARGET_FACTOR = 10.0


@dataclass(frozen=True)
class Setting:
    slug: str
    title: str
    faults: dict[str, float]


SETTINGS = [
    Setting(
        "radii",
        "wheel radii (left +1 %, right -0.5 %)",
        {"enc_radius_scale_l": 1.01, "enc_radius_scale_r": 0.995},
    ),
    Setting("track", "track +6 mm (+2 %)", {"enc_track_error_m": 0.006}),
    Setting(
        "both",
        "radii and track",
        {"enc_radius_scale_l": 1.01, "enc_radius_scale_r": 0.995, "enc_track_error_m": 0.006},
    ),
]


def _mm(value: float) -> str:
    return f"{value * 1e3:.3g} mm"


def _return_errors(m: Measurement) -> list[float]:
    return [math.hypot(*p) for p in (*m.cw, *m.ccw)]


def _ideal(truth: Geometry) -> tuple[float, float]:
    """What UMBmark can find for the simulator's true geometry, relative to the default one (the
    geometry without faults): E_d = D_R/D_L and the track factor that makes the turns right with
    the mean radius kept (b_true / (k_mean b))."""
    default = true_geometry({})
    e_d = (truth.radius_right_m / truth.radius_left_m) / (default.radius_right_m / default.radius_left_m)
    k_mean = (truth.radius_left_m + truth.radius_right_m) / (default.radius_left_m + default.radius_right_m)
    return e_d, truth.track_m / (k_mean * default.track_m)


# -- the corners, from the truth stream -------------------------------------------------------------
def corner_check() -> dict[str, float]:
    """One CCW square without faults, ground truth at 250 Hz: how fast the cart moves while it
    turns, and how far its true path strays from the square."""
    grid, (sx, sy), _ = sim_layout(SIDE_M)
    with tempfile.TemporaryDirectory() as tmp:
        options = SimOptions(
            speed="max",
            eeprom=Path(tmp) / "eeprom.bin",
            grid=grid,
            start=(sx, sy, 0.0),
            truth_hz=250,
            quiet=True,
        )
        with Simulator(options) as sim, Link(sim.pty) as link:
            samples: list[dict[str, Any]] = []
            assert sim.side is not None
            sim.side.subscribe(samples.append)
            t_end = time.monotonic() + 120.0
            drive_square(link, SIDE_M, False, lambda: time.monotonic() > t_end, 0.01)
            sim.run_for(0.5)  # the last samples in
    corners = [(sx, sy)] + [(sx + x, sy + y) for x, y in square_corners(SIDE_M, False)]
    turning = [s for s in samples if abs(s["omega"]) > 0.2]
    deviation = max(point_polyline_distance((s["x"], s["y"]), corners) for s in samples)
    return {
        "max_speed_turning_mps": max(abs(s["v"]) for s in turning),
        "max_deviation_m": deviation,
        "samples": len(samples),
    }


# -- plots -----------------------------------------------------------------------------------------
def _scatter(ax: Any, m: Measurement, title: str, unit: float, unit_name: str) -> None:
    for points, colour, label in ((m.cw, "tab:blue", "CW"), (m.ccw, "tab:red", "CCW")):
        xs, ys = [p[0] / unit for p in points], [p[1] / unit for p in points]
        ax.scatter(xs, ys, s=28, facecolors="none", edgecolors=colour, label=f"{label} runs")
        cx, cy = sum(xs) / len(xs), sum(ys) / len(ys)
        ax.scatter([cx], [cy], marker="x", s=90, color=colour, label=f"{label} centroid")
        ax.plot([0, cx], [0, cy], color=colour, linewidth=0.8, linestyle=":")
    ax.scatter([0], [0], marker="+", s=120, color="black", label="start")
    ax.set_title(f"{title}\nE_max,syst {m.e_max_syst_m() / unit:.3g} {unit_name}", fontsize=9)
    ax.set_xlabel(f"return error x ({unit_name})")
    ax.set_ylabel(f"return error y ({unit_name})")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, linewidth=0.3)


def plot_setting(out: Path, setting: Setting, result: Calibration) -> str:
    name = f"{NAME}_{setting.slug}.png"
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4.8))
    _scatter(left, result.first(), "before calibration", 1e-3, "mm")
    assert result.verification is not None
    _scatter(right, result.verification, "after calibration", 1e-6, "µm")
    left.legend(fontsize=7, loc="best")
    fig.suptitle(f"UMBmark, {SIDE_M:g} m square: {setting.title}", fontsize=10)
    fig.tight_layout()
    fig.savefig(out / name, dpi=110)
    plt.close(fig)
    return name


def plot_floor(out: Path, m: Measurement) -> str:
    name = f"{NAME}_floor.png"
    fig, ax = plt.subplots(figsize=(5, 4.8))
    _scatter(ax, m, "no faults, default geometry (the floor)", 1e-6, "µm")
    ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    fig.savefig(out / name, dpi=110)
    plt.close(fig)
    return name


# -- the section -------------------------------------------------------------------------------------
def run(out: Path, quick: bool) -> Section:
    t0 = time.monotonic()
    runs, refine_runs = (1, 1) if quick else (5, 2)
    settings = [s for s in SETTINGS if s.slug == "both"] if quick else SETTINGS
    quiet = lambda _line: None  # noqa: E731
    results: list[tuple[Setting, Calibration, float]] = []
    for setting in settings:
        start = time.monotonic()
        schedule = Schedule(SIDE_M, runs, passes=2, refine_runs=refine_runs)
        result = calibrate_in_sim(schedule, SimSetup(setting.faults, save=False), quiet)
        results.append((setting, result, time.monotonic() - start))
    floor = calibrate_in_sim(Schedule(SIDE_M, runs, passes=0), SimSetup(save=False), quiet)
    floor_m = floor.first()
    corners = corner_check()

    rows, identified, plots, data_settings = [], [], [], []
    targets_met = True
    for setting, result, wall_s in results:
        before, after = result.e_max_before_m(), result.e_max_after_m()
        assert after is not None and result.verification is not None
        factor = before / max(after, 1e-12)
        targets_met &= factor >= TARGET_FACTOR
        one_pass = result.passes[1][0].e_max_syst_m()  # measured with the first pass's geometry
        rows.append(
            [
                setting.title,
                _mm(before),
                _mm(one_pass),
                _mm(after),
                f"{factor:,.0f}x",
                spread([e * 1e3 for e in _return_errors(result.first())]).text(".3g", "mm"),
                spread([e * 1e3 for e in _return_errors(result.verification)]).text(".2g", "mm"),
            ]
        )
        assert result.truth is not None  # calibrate_in_sim sets it
        ideal_d, ideal_b = _ideal(result.truth)
        found_d = (result.after.radius_right_m / result.after.radius_left_m) / (
            result.before.radius_right_m / result.before.radius_left_m
        )
        found_b = result.after.track_m / result.before.track_m
        first = result.passes[0][1]
        ratio_err, track_err = result.identified_errors() or (math.nan, math.nan)
        identified.append(
            [
                setting.title,
                f"{ideal_d:.5f}",
                f"{first.e_d:.5f} → {found_d:.5f}",
                f"{ideal_b:.5f}",
                f"{first.e_b:.5f} → {found_b:.5f}",
                f"{ratio_err * 1e6:+.1f} / {track_err * 1e6:+.1f}",
            ]
        )
        plots.append(plot_setting(out, setting, result))
        data_settings.append(
            {
                "slug": setting.slug,
                "title": setting.title,
                "wall_s": wall_s,
                "factor": factor,
                "e_max_syst_one_pass_m": one_pass,
                "ideal_e_d": ideal_d,
                "ideal_e_b": ideal_b,
                "found_e_d": found_d,
                "found_e_b": found_b,
                "return_error_before_m": spread(_return_errors(result.first())).as_dict(),
                "return_error_after_m": spread(_return_errors(result.verification)).as_dict(),
                **result.as_dict(),
            }
        )
    plots.append(plot_floor(out, floor_m))
    wall_s = time.monotonic() - t0

    floor_errors = spread([e * 1e3 for e in _return_errors(floor_m)]).text(".2g", "mm")
    markdown = "\n".join(
        [
            "## Odometry (UMBmark)",
            "",
            f"Borenstein and Feng's UMBmark in the simulator: a {SIDE_M:g} m square, {runs} run(s) "
            f"clockwise and {runs} counter-clockwise, stopping at every corner and turning on the spot; a "
            "run's return error is the true end position (ground truth) minus the odometry's, E_max,syst "
            "the larger of the CW and CCW centroid distances. `cart2d calibrate --sim` "
            "(cart2d/tools/umbmark/) measured with the default geometry, applied Borenstein's corrections "
            "(E_d to the radii with their mean kept, E_b to the track), refined them in a second pass "
            f"({refine_runs} run(s) each way) and measured again.",
            "",
            table(
                [
                    "systematic fault",
                    "E_max,syst before",
                    "after one pass",
                    "after two",
                    "improvement",
                    "return error per run, before",
                    "after",
                ],
                rows,
            ),
            f"Floor, no faults and the default geometry: E_max,syst {_mm(floor_m.e_max_syst_m())}, "
            f"return error per run {floor_errors}.",
            "",
            "What UMBmark identified, against the simulator's truth (E_d = D_R/D_L, E_b = the track factor "
            "with the mean radius kept; first pass → after both passes; the last column: error of the "
            "final r_R/r_L and of track/mean radius, ppm). UMBmark cannot see a common scale error of both "
            "radii (a larger square still closes): with the left wheel +1 % and the right -0.5 % the "
            "odometry still measures distances 0.25 % short after calibration; the track absorbs it in "
            "the turns.",
            "",
            table(["systematic fault", "E_d true", "E_d found", "E_b true", "E_b found", "ppm"], identified),
            f"Corners (one square without faults, ground truth at 250 Hz): the cart moves at most "
            f"{corners['max_speed_turning_mps'] * 1e3:.1f} mm/s while it turns (|ω| > 0.2 rad/s), and its "
            f"true path stays within {_mm(corners['max_deviation_m'])} of the square.",
            "",
            "Target: E_max,syst at least 10x smaller after calibration: "
            + ("**met**." if targets_met else "**missed**."),
            "Borenstein and Feng report about 10x on real robots, whose floor is set by non-systematic "
            "errors (slip, uneven floors) that the simulator does not add here: its floor is the "
            "odometry's own resolution, so the calibrated cart comes back to within a fraction of a "
            "millimetre. One pass of the first-order formulas leaves a few percent of the error (after "
            "one pass), which the second pass removes.",
            "",
            *[f"![UMBmark {name}]({name})" for name in plots],
            "",
            f"_{len(results)} fault setting(s), {wall_s:.0f} s of wall time._",
            "",
        ]
    )
    data = {
        "side_m": SIDE_M,
        "runs": runs,
        "refine_runs": refine_runs,
        "settings": data_settings,
        "floor": floor_m.as_dict(),
        "corners": corners,
        "wall_s": wall_s,
    }
    return Section(NAME, markdown, data, targets_met)


if __name__ == "__main__":
    sys.exit(section_main(run))

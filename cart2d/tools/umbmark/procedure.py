"""The UMBmark calibration (`cart2d calibrate`): passes of runs each way, each followed by the
corrected geometry written with PARAM_SET, a check with the final values, and SAVE at the end. A
restart of the MCU anywhere in between (STATUS: a new boot count, or the uptime going backwards)
stops the calibration: it loses the run's path and the values set in RAM.
"""

from __future__ import annotations

import math
import tempfile
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

from cart2d.link import Link, LinkError, firmware
from cart2d.link.firmware import ControllerRestarted, ResetWatch
from cart2d.params import setting_id
from cart2d.simulation.simulator import SimOptions, Simulator
from cart2d.tools.umbmark.arithmetic import (
    Axes,
    Calibration,
    Corrections,
    Geometry,
    Measurement,
    sim_layout,
    true_geometry,
    umbmark_corrections,
)
from cart2d.tools.umbmark.runners import RunError, Runner, SimRunner

SETTING_NAMES = ("enc_radius_left_m", "enc_radius_right_m", "enc_track_m")


def setting_ids() -> tuple[int, int, int]:
    left, right, track = (setting_id(name) for name in SETTING_NAMES)
    return left, right, track


def read_geometry(link: Link) -> Geometry:
    left, right, track = (firmware.read_setting(link, i) for i in setting_ids())
    return Geometry(left, right, track)


def write_geometry(link: Link, geometry: Geometry) -> Geometry:
    """PARAM_SET of the three values (RAM only); returns what the firmware keeps (float32)."""
    values = (geometry.radius_left_m, geometry.radius_right_m, geometry.track_m)
    kept = [firmware.write_setting(link, i, v) for i, v in zip(setting_ids(), values, strict=True)]
    return Geometry(*kept)


def save_settings(link: Link, timeout_s: float = 10.0) -> None:
    """SAVE, then wait until the firmware has written the EEPROM."""
    link.call("SAVE")
    deadline = time.monotonic() + timeout_s
    while firmware.read_status(link).eeprom_busy:
        if time.monotonic() > deadline:
            raise LinkError("the EEPROM write did not finish")
        time.sleep(0.02)


def measure(
    runner: Runner,
    geometry: Geometry,
    runs: int,
    say: Callable[[str], None],
    title: str,
    watch: ResetWatch | None = None,
) -> Measurement:
    """n runs each way, alternating CW and CCW."""
    m = Measurement(geometry)
    for i in range(runs):
        for clockwise, points in ((True, m.cw), (False, m.ccw)):
            label = f"{title}, {'CW' if clockwise else 'CCW'} run {i + 1}/{runs}"
            error = runner.drive(clockwise, label, watch)
            points.append(error)
            say(f"{label}: return error x {error[0] * 1e3:+7.1f} mm, y {error[1] * 1e3:+7.1f} mm")
    return m


@dataclass(frozen=True)
class Schedule:
    """What a calibration drives: a square of `side_m`, `passes` passes of `runs` runs each way
    (`refine_runs` in the passes after the first, if given), each correcting the last; then, with
    `verify`, a check of `runs` runs each way with the final values. `axes`: which centroid
    coordinates give alpha and beta (umbmark_corrections)."""

    side_m: float = 2.0
    runs: int = 5
    passes: int = 2
    verify: bool = True
    axes: Axes = "xy"
    refine_runs: int | None = None

    def runs_in_pass(self, k: int) -> int:
        """The runs each way of pass k (0: the first)."""
        return self.runs if k == 0 or self.refine_runs is None else self.refine_runs


@dataclass(frozen=True)
class SimSetup:
    """The simulator of calibrate_in_sim: its faults, its EEPROM file (None: a temporary one), its
    speed and seed; `save`: SAVE the new values (unless the check found them worse)."""

    faults: Mapping[str, float] = field(default_factory=dict)
    eeprom: Path | None = None
    speed: str = "max"
    seed: int = 1
    save: bool = True


def calibrate(
    runner: Runner,
    link: Link,
    schedule: Schedule,
    say: Callable[[str], None] = print,
    watch: ResetWatch | None = None,
) -> Calibration:
    """UMBmark passes, each followed by PARAM_SET of the corrected geometry; then, if asked, a
    last pass with the final values (with passes = 0: only that, a measurement). Passes after
    the first may use fewer runs (`refine_runs`). Nothing is saved here. A restart of the MCU
    at any point (the watch's baseline, else the first STATUS here, onwards) stops it with
    RunError: it ruins the run it happens in and loses the geometry set in RAM."""
    watch = watch or ResetWatch(firmware.read_status(link))
    try:
        return _calibrate(runner, link, schedule, say, watch)
    except ControllerRestarted as exc:
        raise RunError(ruined(exc)) from exc


def ruined(exc: ControllerRestarted) -> str:
    return (
        f"{exc}. That ruins the calibration: the run it happened in lost its path and maybe its pose, "
        "and the wheel geometry set since the last SAVE is gone; calibration stopped, nothing saved"
    )


def check_not_restarted(watch: ResetWatch, link: Link) -> None:
    """RunError if the MCU restarted since the watch last looked (before a SAVE)."""
    try:
        watch.read(link)
    except ControllerRestarted as exc:
        raise RunError(ruined(exc)) from exc


def _calibrate(
    runner: Runner, link: Link, schedule: Schedule, say: Callable[[str], None], watch: ResetWatch
) -> Calibration:
    before = geometry = read_geometry(link)
    done: list[tuple[Measurement, Corrections]] = []
    passes = schedule.passes
    for k in range(passes):
        m = measure(runner, geometry, schedule.runs_in_pass(k), say, f"pass {k + 1}/{passes}", watch)
        c = umbmark_corrections(m.cw, m.ccw, schedule.side_m, geometry, schedule.axes)
        say(
            f"pass {k + 1}: E_max,syst {m.e_max_syst_m() * 1e3:.1f} mm; "
            f"alpha {math.degrees(c.alpha_rad):+.3f} deg, beta {math.degrees(c.beta_rad):+.3f} deg "
            f"-> E_d {c.e_d:.5f}, E_b {c.e_b:.5f}"
        )
        geometry = write_geometry(link, c.geometry)
        say(f"  odometry now: {geometry.text()}")
        done.append((m, c))
    result = Calibration(schedule.side_m, before, geometry, done)
    if schedule.verify:
        title = "check" if passes else "UMBmark"
        result.verification = measure(runner, geometry, schedule.runs, say, title, watch)
    watch.read(link)
    return result


def calibrate_in_sim(schedule: Schedule, setup: SimSetup, say: Callable[[str], None] = print) -> Calibration:
    """UMBmark calibration in a simulator of its own, with the setup's faults, judged by ground
    truth. The new values are saved (SAVE) unless the check found them worse than the old ones,
    which are then restored."""
    side_m, faults = schedule.side_m, dict(setup.faults)
    grid, start_ccw, start_cw = sim_layout(side_m)
    with tempfile.TemporaryDirectory() as tmp:
        options = SimOptions(
            speed=setup.speed,
            seed=setup.seed,
            eeprom=setup.eeprom or Path(tmp) / "eeprom.bin",
            grid=grid,
            start=(*start_ccw, 0.0),
            quiet=True,
        )
        with Simulator(options) as sim, Link(sim.pty) as link:
            firmware.check_compatible(firmware.wait_for_version(link))
            if faults:
                sim.control("faults", **faults)
            runner = SimRunner(sim, link, side_m, start_ccw, start_cw)
            watch = ResetWatch(firmware.read_status(link))
            result = calibrate(runner, link, schedule, say, watch)
            result.truth, result.faults = true_geometry(faults), dict(faults)
            after = result.e_max_after_m()
            if after is not None and after > result.e_max_before_m():
                say("the check found the new values worse than the old: not saved, the old ones restored")
                write_geometry(link, result.before)
            elif setup.save and schedule.passes:
                check_not_restarted(watch, link)
                save_settings(link)
                result.saved = True
    return result

"""The `cart2d calibrate` command: odometry calibration with UMBmark (arithmetic.py), in the
simulator or on a cart (runners.py, procedure.py); exit status 2 for bad option values, 1 if it
failed or made things worse.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from pathlib import Path

from cart2d.link import CommandRefused, Link, LinkError, firmware
from cart2d.link.firmware import ResetWatch
from cart2d.simulation import faults as fault_table
from cart2d.simulation.side_channel import SimulatorError
from cart2d.tools import cli_args
from cart2d.tools.umbmark.arithmetic import Calibration
from cart2d.tools.umbmark.procedure import (
    Schedule,
    SimSetup,
    calibrate,
    calibrate_in_sim,
    check_not_restarted,
    save_settings,
)
from cart2d.tools.umbmark.runners import Aborted, RunError, SerialRunner

SYSTEMATIC_FAULTS = ("enc_radius_scale_l", "enc_radius_scale_r", "enc_track_error_m")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    where = parser.add_mutually_exclusive_group(required=True)
    where.add_argument("--sim", action="store_true", help="in the simulator, judged by ground truth")
    where.add_argument("--serial", metavar="PORT", help="a real cart; you measure where each run ends")
    parser.add_argument("--baud", type=int, default=115200)
    parser.add_argument("--side", type=float, default=2.0, help="side of the square, m (default 2)")
    parser.add_argument("--runs", type=int, default=5, help="runs each way per pass (default 5)")
    parser.add_argument(
        "--passes", type=int, help="passes, each correcting the last (default: 2 sim, 1 cart)"
    )
    parser.add_argument(
        "--no-check", action="store_true", help="sim: skip the last UMBmark with the new values"
    )
    parser.add_argument("--no-save", action="store_true", help="leave the new values in RAM (no SAVE)")
    parser.add_argument("--report", type=Path, help="write the numbers to this JSON file")
    sim = parser.add_argument_group("simulation")
    sim.add_argument("--eeprom", type=Path, help="the simulator's EEPROM file (default: a temporary one)")
    sim.add_argument("--faults", default="{}", help="simulator faults, JSON: sim/README.md")
    for key in SYSTEMATIC_FAULTS:
        sim.add_argument(f"--{key.replace('_', '-')}", type=float, dest=key, help=f"fault {key}")
    sim.add_argument(
        "--speed", type=cli_args.speed, default="max", help="simulated seconds per second, or 'max' (default)"
    )
    sim.add_argument("--seed", type=cli_args.seed, default=1)


def sim_faults(args: argparse.Namespace) -> dict[str, float]:
    """The faults of --faults and the fault options, checked (ValueError: every problem)."""
    try:
        faults = json.loads(args.faults)
    except json.JSONDecodeError as exc:
        raise ValueError(f"--faults is not JSON: {exc}") from None
    if not isinstance(faults, dict):
        raise ValueError('--faults takes a JSON object, such as {"enc_slip_l": 0.02}')
    for key in SYSTEMATIC_FAULTS:
        if getattr(args, key, None) is not None:
            faults[key] = getattr(args, key)
    problems = fault_table.problems(faults)
    if problems:
        raise ValueError("; ".join(problems))
    return faults


def saved_words(args: argparse.Namespace, saved: bool) -> str:
    """Where the new values went, in words."""
    if not saved:
        return "not saved: the values last set stay in RAM until a reset"
    if not args.sim:
        return "saved to EEPROM"
    if args.eeprom is None:
        return (
            "saved to the simulated EEPROM, a temporary file deleted with the simulator: nothing is kept "
            "(--eeprom FILE keeps it)"
        )
    return f"saved to the simulated EEPROM, kept in {args.eeprom}"


def _print_summary(result: Calibration, say: Callable[[str], None]) -> None:
    say(f"before: {result.before.text()}")
    say(f"after:  {result.after.text()}")
    if result.truth is not None:
        identified = result.identified_errors()
        assert identified is not None
        say(
            f"simulator truth: {result.truth.text()}; found r_R/r_L within {identified[0] * 1e6:+.0f} ppm, "
            f"track/mean radius within {identified[1] * 1e6:+.0f} ppm"
        )
    before = result.e_max_before_m()
    after = result.e_max_after_m()
    line = f"E_max,syst before {before * 1e3:.1f} mm"
    if after is not None:
        line += f", after {after * 1e3:.2f} mm ({before / max(after, 1e-12):.0f}x smaller)"
    say(line)


def _run_serial(args: argparse.Namespace, passes: int, say: Callable[[str], None]) -> Calibration:
    with Link(args.serial, args.baud) as link:
        firmware.check_compatible(firmware.wait_for_version(link))
        runner = SerialRunner(link, args.side, say=say)
        say(
            f"UMBmark: a {args.side:g} m square; per pass, {args.runs} run(s) clockwise and "
            f"{args.runs} counter-clockwise; {passes} pass(es). Mark the start: the wheel-axis centre "
            "and the heading. Run this again afterwards to see the new values' errors."
        )
        watch = ResetWatch(firmware.read_status(link))
        schedule = Schedule(args.side, args.runs, passes, verify=False)
        result = calibrate(runner, link, schedule, say, watch)
        if not args.no_save:
            check_not_restarted(watch, link)
            save_settings(link)
            result.saved = True
    return result


def option_problems(args: argparse.Namespace) -> tuple[dict[str, float], list[str]]:
    """The simulator's faults, and one line per bad option value (checked before anything runs)."""
    problems, faults = [], {}
    if not 0.2 <= args.side <= 20.0 or args.runs < 1 or (args.passes is not None and args.passes < 1):
        problems.append("--side from 0.2 to 20 m, --runs and --passes at least 1")
    if args.sim:
        try:
            faults = sim_faults(args)
        except ValueError as exc:
            problems.append(str(exc))
    if args.report is not None and not args.report.parent.is_dir():
        problems.append(f"--report {args.report}: its folder does not exist")
    return faults, problems


def main_calibrate(args: argparse.Namespace, say: Callable[[str], None] = print) -> int:
    """The `cart2d calibrate` command; exit status 2 for bad option values (nothing run), 1 if it
    failed or made things worse."""
    faults, problems = option_problems(args)
    for problem in problems:
        print(f"cart2d calibrate: {problem}", file=sys.stderr)
    if problems:
        return 2
    passes = args.passes if args.passes is not None else (2 if args.sim else 1)
    try:
        if args.sim:
            schedule = Schedule(args.side, args.runs, passes, verify=not args.no_check)
            setup = SimSetup(faults, args.eeprom, args.speed, args.seed, save=not args.no_save)
            result = calibrate_in_sim(schedule, setup, say)
        else:
            result = _run_serial(args, passes, say)
    except (LinkError, CommandRefused, SimulatorError, RunError, Aborted, ValueError, OSError) as exc:
        print(f"cart2d calibrate: {exc}", file=sys.stderr)
        return 1
    _print_summary(result, say)
    say(saved_words(args, result.saved))
    if args.report is not None:
        args.report.write_text(json.dumps(result.as_dict(), indent=2) + "\n")
    after = result.e_max_after_m()
    return 0 if after is None or after <= result.e_max_before_m() else 1

"""The `cart2d` command line: `sim` (simulator + gateway), `serve` (a real robot on a serial
port), `mission` (a headless mission run with a report), `calibrate` (odometry, UMBmark),
`camera calibrate` (the camera's lens and ground homography), `camera detect` (the obstacle
detector on pictures)."""

from __future__ import annotations

import argparse
import logging
import signal
import sys
import threading
from collections.abc import Sequence
from pathlib import Path
from types import FrameType

from cart2d.server import serving
from cart2d.simulation import faults as fault_table
from cart2d.tools import cli_args, explore_command, fleet_args, live, map_command
from cart2d.tools import fleet as fleet_cli
from cart2d.tools import localisation as localisation_cli
from cart2d.tools import recording_args as recording_cli
from cart2d.tools.camera_calibration.command import add_arguments as add_camera_calibrate_arguments
from cart2d.tools.camera_calibration.command import main_camera_calibrate
from cart2d.tools.camera_detect import add_arguments as add_camera_detect_arguments
from cart2d.tools.camera_detect import main_camera_detect
from cart2d.tools.ros2_args import add_ros2_arguments
from cart2d.tools.umbmark.command import add_arguments as add_calibrate_arguments
from cart2d.tools.umbmark.command import main_calibrate


def cmd_mission(args: argparse.Namespace) -> int:
    from cart2d.tools.missions import spec as mission_file
    from cart2d.tools.missions.run import main_mission  # tqdm and friends only for this command

    report = args.report or mission_file.default_report_path(args.mission)
    mcap = recording_cli.mission_mcap_path(args, args.mission, report)
    return main_mission(args.mission, report, args.speed, args.seed, mcap, args.record_camera_fps)


def cmd_replay(args: argparse.Namespace) -> int:
    from cart2d.tools.replay import main_replay

    return main_replay(args)


def build_parser() -> argparse.ArgumentParser:
    parser = cli_args.Parser(prog="cart2d", description=__doc__)
    parser.add_argument("-v", "--verbose", action="store_true")
    parser.add_argument("--version", action="version", version=cli_args.version_text())
    sub = parser.add_subparsers(dest="command", required=True)

    sim = sub.add_parser("sim", help="the simulator running the built firmware, with the gateway and panel")
    live.network_args(sim)
    sim.add_argument(
        "--speed", type=cli_args.speed, default="1", help="simulated seconds per second, or 'max' (default 1)"
    )
    sim.add_argument("--seed", type=cli_args.seed, default=1, help="seed of the simulator's random faults")
    sim.add_argument(
        "--no-bootloader",
        action="store_true",
        help="a bare chip: no Optiboot in the simulated Nano's boot section (by default it runs there, as on "
        "every Nano: resets start it, and firmware updates go through avrdude as on the real cart); the "
        "firmware then starts right after a reset, and cannot be updated from the panel",
    )
    sim.add_argument(
        "--fault",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a simulator fault for this run (repeatable; PUT /api/sim/faults changes them later): "
        + ", ".join(f"{f.name} ({f.range_text()})" for f in fault_table.FAULTS),
    )
    recording_cli.add_live_arguments(sim)
    add_ros2_arguments(sim)
    sim.add_argument(
        "--camera-port",
        type=cli_args.camera_port_number,
        default=8180,
        help="the simulated ESP32-CAM's port (/capture, /status, /control); its stream on the next one "
        "(default 8180)",
    )
    sim.add_argument("--no-camera", action="store_true", help="run without the simulated camera")
    sim.add_argument(
        "--world",
        type=Path,
        metavar="FILE.json",
        help='boxes standing in the simulated world, as a mission\'s "world": {"boxes": [{"x", "y", "sx", '
        '"sy", "height", "colour", "id"}, ...]} (m); the panel\'s Box mode and /api/sim/boxes change them',
    )
    live.camera_args(sim)
    localisation_cli.add_markers_argument(sim)
    map_command.add_map_argument(sim)
    fleet_args.add_arguments(sim)
    sim.set_defaults(run=live.cmd_sim)

    serve = sub.add_parser("serve", help="the gateway and panel for a real cart on a serial port")
    serve.add_argument(
        "--serial",
        required=True,
        help="the Nano's serial port, e.g. /dev/ttyUSB0, or a network bridge: socket://HOST:PORT, "
        "rfc2217://HOST:PORT (docs/network-link.md)",
    )
    serve.add_argument("--baud", type=int, default=115200)
    live.network_args(serve)
    recording_cli.add_live_arguments(serve)
    add_ros2_arguments(serve)
    live.camera_args(serve)
    localisation_cli.add_markers_argument(serve)
    map_command.add_map_argument(serve)
    fleet_args.add_arguments(serve)
    serve.set_defaults(run=live.cmd_serve)

    mission = sub.add_parser("mission", help="run a mission in the simulator and write a report")
    mission.add_argument("mission", type=Path, help="MISSION.json: grid, obstacles, start, goals, ...")
    mission.add_argument(
        "--report", type=Path, help="where to write the report (default: MISSION.report.json beside it)"
    )
    mission.add_argument(
        "--speed", type=cli_args.speed, default="max", help="simulated seconds per second, or 'max' (default)"
    )
    mission.add_argument("--seed", type=cli_args.seed, default=1)
    recording_cli.add_mission_arguments(mission)
    mission.set_defaults(run=cmd_mission)

    fleet_cli.add_parser(sub)

    replay = sub.add_parser("replay", help="play an MCAP recording back into the panel (read-only)")
    replay.add_argument(
        "file", type=Path, help="a recording of cart2d mission, sim --record or serve --record"
    )
    replay.add_argument(
        "--speed", type=cli_args.replay_speed, default=1.0, help="recorded seconds per second (default 1)"
    )
    replay.add_argument("--loop", action="store_true", help="start again at the end")
    replay.add_argument("--host", type=cli_args.host, help="bind address (default 127.0.0.1)")
    replay.add_argument("--port", type=cli_args.port_number, help="HTTP port (default 8080)")
    replay.add_argument(
        "--allow-host", action="append", default=[], metavar="NAME", help="also answer to this Host name"
    )
    replay.set_defaults(run=cmd_replay)

    calibrate = sub.add_parser("calibrate", help="odometry calibration (UMBmark): wheel radii and track")
    add_calibrate_arguments(calibrate)
    calibrate.set_defaults(run=main_calibrate)

    camera = sub.add_parser("camera", help="the cart's camera: calibrate, detect")
    camera_sub = camera.add_subparsers(dest="camera_command", required=True)
    camera_calibrate = camera_sub.add_parser(
        "calibrate", help="the camera's lens and ground homography from checkerboard views"
    )
    add_camera_calibrate_arguments(camera_calibrate)
    camera_calibrate.set_defaults(run=main_camera_calibrate)
    camera_detect = camera_sub.add_parser("detect", help="the obstacle detector on pictures, with no cart")
    add_camera_detect_arguments(camera_detect)
    camera_detect.set_defaults(run=main_camera_detect)

    tags = sub.add_parser("tags", help="AprilTag markers for localisation: print")
    tags_sub = tags.add_subparsers(dest="tags_command", required=True)
    tags_print = tags_sub.add_parser("print", help="printable sheets of markers at true size (PDF or PNG)")
    localisation_cli.add_print_arguments(tags_print)
    tags_print.set_defaults(run=localisation_cli.cmd_tags_print)

    maps = sub.add_parser("map", help="maps built from what the camera saw: save")
    maps_sub = maps.add_subparsers(dest="map_command", required=True)
    map_save = maps_sub.add_parser("save", help="the running gateway's seen map as a ROS map_server map")
    map_command.add_save_arguments(map_save)
    map_save.set_defaults(run=map_command.cmd_map_save)

    explore = sub.add_parser("explore", help="the running gateway's cart explores the room and saves the map")
    explore_command.add_explore_arguments(explore)
    explore.set_defaults(run=explore_command.cmd_explore)
    return parser


def _stop_like_ctrl_c(signum: int, frame: FrameType | None) -> None:
    # uvicorn re-raises a SIGTERM it caught once it has shut down; with the default action the
    # process would die there, before the finally blocks that stop the simulator and the link.
    raise KeyboardInterrupt


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, _stop_like_ctrl_c)
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING, format="%(name)s: %(message)s"
    )
    serving.install_log_filter()  # a flood of one message (a refused connection each) stays a few lines
    try:
        code: int = args.run(args)
    except KeyboardInterrupt:
        code = 0
    return code


if __name__ == "__main__":
    sys.exit(main())

"""`cart2d camera calibrate`: the camera's lens and its ground homography from checkerboard
views (views.py; --sim: simulated.py), saved next to the gateway's settings."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path

from cart2d.perception.calibration import (
    MIN_VIEWS,
    Board,
    GroundBoard,
    calibration_path,
    load_calibration,
    save_calibration,
)
from cart2d.perception.camera_model import Mount
from cart2d.tools.camera_calibration.views import SIM_VIEWS, calibrate, camera_views, synthetic_views


def _board(text: str) -> tuple[int, int, float | None]:
    """COLSxROWS or COLSxROWS@SQUARE_M: inner corners, and the square's side in metres."""
    corners, _, square = text.lower().partition("@")
    try:
        cols, rows = (int(n) for n in corners.split("x"))
        square_m = float(square) if square else None
    except ValueError:
        cols = rows = 0
        square_m = None
    if not (3 <= cols <= 30 and 3 <= rows <= 30 and cols != rows):
        raise argparse.ArgumentTypeError(
            f"{text!r}: give the inner corners as COLSxROWS, such as 9x6 (not square), "
            "and the square's side after an @ if you like: 9x6@0.025"
        )
    return cols, rows, square_m


def add_arguments(parser: argparse.ArgumentParser) -> None:
    where = parser.add_mutually_exclusive_group(required=True)
    where.add_argument("--camera", metavar="URL", help="the ESP32-CAM's base URL, e.g. http://192.168.4.2")
    where.add_argument(
        "--sim", action="store_true", help="the simulated camera (a simulator of its own places the board)"
    )
    where.add_argument("--synthetic", action="store_true", help="a dry run on rendered views of a known lens")
    where.add_argument(
        "--images",
        type=Path,
        metavar="DIR",
        help="no cart: the lens from a folder of pictures of the board (saved only with --out)",
    )
    parser.add_argument(
        "--sim-address",
        metavar="HOST:PORT",
        help="with --sim: a running `cart2d sim`'s side channel (it prints it), not a simulator of its own",
    )
    parser.add_argument(
        "--board",
        type=_board,
        default=(9, 6, None),
        help="inner corners, COLSxROWS, and the square's side: COLSxROWS@SQUARE_M (default 9x6@0.03)",
    )
    parser.add_argument(
        "--square-m",
        type=float,
        help="square side, m (default 0.03; --sim: 0.015 held up, 0.03 on the floor)",
    )
    parser.add_argument(
        "--views", type=int, help=f"views of the held board (default 12, --sim 20; at least {MIN_VIEWS})"
    )
    parser.add_argument(
        "--floor-x-m",
        type=float,
        default=0.45,
        help="the floor board's middle, ahead of the wheel axis, m (default 0.45)",
    )
    parser.add_argument(
        "--floor-y-m", type=float, default=0.0, help="... and left of the centre line, m (default 0)"
    )
    parser.add_argument("--out", type=Path, help=f"where to save (default: {calibration_path()})")


def main_camera_calibrate(args: argparse.Namespace, say: Callable[[str], None] = print) -> int:
    sim = bool(args.sim)
    views_wanted = args.views if args.views is not None else (SIM_VIEWS if sim else 12)
    given_square_m = args.square_m if args.square_m is not None else args.board[2]
    square_m = given_square_m if given_square_m is not None else 0.03
    if args.square_m is not None and args.board[2] is not None and args.square_m != args.board[2]:
        print(
            "cart2d camera calibrate: the square's side given twice (--board ...@, --square-m)",
            file=sys.stderr,
        )
        return 2
    if args.sim_address and not sim:
        print("cart2d camera calibrate: --sim-address goes with --sim", file=sys.stderr)
        return 2
    if views_wanted < MIN_VIEWS or not 0.01 <= square_m <= 0.2:
        print(
            f"cart2d camera calibrate: --views at least {MIN_VIEWS}, --square-m from 0.01 to 0.2",
            file=sys.stderr,
        )
        return 2
    mount = Mount.from_robot()
    board = Board(args.board[0], args.board[1], square_m)
    ground = GroundBoard(board, args.floor_x_m, args.floor_y_m)
    if args.images is not None:
        return _calibrate_folder(args.images, board, mount, args.out, say)
    try:
        if sim:
            from cart2d.simulation.controls import CameraTimeout
            from cart2d.simulation.side_channel import SimulatorError
            from cart2d.tools.camera_calibration.simulated import (
                HELD_SQUARE_M,
                calibrate_in_simulator,
                calibrate_running_simulator,
                describe_truth,
            )

            held = board if given_square_m is not None else Board(board.cols, board.rows, HELD_SQUARE_M)
            try:
                if args.sim_address:
                    result = calibrate_running_simulator(
                        args.sim_address, held, ground, views_wanted, mount, say
                    )
                else:
                    result = calibrate_in_simulator(held, ground, views_wanted, mount, say=say)
            except (SimulatorError, CameraTimeout) as exc:
                raise ValueError(f"the simulator: {exc}") from exc
            say(describe_truth(mount))
        elif args.synthetic:
            truth, views, floor = synthetic_views(board, ground, views_wanted, mount)
            result = calibrate(views, floor, board, ground, mount, say)
            say(
                f"the synthetic lens was fx {truth.fx:.1f} fy {truth.fy:.1f} cx {truth.cx:.1f} "
                f"cy {truth.cy:.1f} px, k1 {truth.dist[0]:.3f} k2 {truth.dist[1]:.3f}"
            )
        else:
            views, floor_view = camera_views(args.camera, board, ground, views_wanted, mount, input)
            result = calibrate(views, floor_view, board, ground, mount, say)
    except (ValueError, OSError) as exc:
        print(f"cart2d camera calibrate: {exc}", file=sys.stderr)
        return 1
    path = save_calibration(result, args.out)
    reloaded = load_calibration(path, mount)
    if not reloaded.calibrated:
        print(f"cart2d camera calibrate: {path} could not be read back", file=sys.stderr)
        return 1
    say(f"saved to {path}; the gateway loads it at start")
    return 0


def _calibrate_folder(
    directory: Path, board: Board, mount: Mount, out: Path | None, say: Callable[[str], None]
) -> int:
    from cart2d.tools.camera_calibration.folder import calibrate_folder, pictures, with_nominal_ground

    try:
        pictures(directory)
    except ValueError as exc:
        print(f"cart2d camera calibrate: {exc}", file=sys.stderr)
        return 2
    try:
        checked = calibrate_folder(directory, board, say)
    except (ValueError, OSError) as exc:
        print(f"cart2d camera calibrate: {exc}", file=sys.stderr)
        return 1
    if out is None:
        say("nothing saved (no --out): pictures from another camera are not the cart's calibration")
        return 0
    path = save_calibration(with_nominal_ground(checked, mount), out)
    say(f"saved to {path}: the lens, and the floor where config/robot.toml [camera] mounts it")
    return 0

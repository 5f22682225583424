"""The command line's Foxglove and recording options: `--foxglove [PORT]` and `--record DIR` on
`cart2d sim` and `serve`, `--mcap FILE` / `--no-mcap` on `cart2d mission`."""

from __future__ import annotations

import argparse
import contextlib
import socket
from collections.abc import Iterator
from pathlib import Path

from cart2d.recording.publisher import GatewayLike
from cart2d.recording.session import (
    DEFAULT_CAMERA_FPS,
    DEFAULT_FOXGLOVE_PORT,
    Recording,
    open_recording,
    session_file_name,
)
from cart2d.tools import cli_args


def add_camera_fps_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--record-camera-fps",
        type=cli_args.camera_fps,
        default=DEFAULT_CAMERA_FPS,
        metavar="FPS",
        help=f"camera frames a second kept in the recording (default {DEFAULT_CAMERA_FPS:g}; 0: none)",
    )


def add_live_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--foxglove",
        type=cli_args.port_number,
        nargs="?",
        const=DEFAULT_FOXGLOVE_PORT,
        metavar="PORT",
        help=f"also serve the live data to the Foxglove app or Lichtblick (Foxglove WebSocket, port "
        f"{DEFAULT_FOXGLOVE_PORT} unless given)",
    )
    parser.add_argument(
        "--foxglove-host",
        type=cli_args.host,
        default="127.0.0.1",
        help="bind address of the Foxglove server (default 127.0.0.1: this machine only)",
    )
    parser.add_argument(
        "--record",
        type=Path,
        metavar="DIR",
        help="record the session to an MCAP file in DIR (cart2d-DATE-TIME.mcap; `cart2d replay` plays it)",
    )
    add_camera_fps_argument(parser)


def add_mission_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--mcap",
        type=Path,
        metavar="FILE",
        help="where to record the run (default: MISSION.mcap beside the report)",
    )
    parser.add_argument("--no-mcap", action="store_true", help="do not record the run")
    add_camera_fps_argument(parser)


def mission_mcap_path(args: argparse.Namespace, mission: Path, report: Path) -> Path | None:
    if args.no_mcap:
        return None
    if args.mcap is not None:
        path: Path = args.mcap
        return path
    return report.parent / f"{mission.stem if mission.suffix == '.json' else mission.name}.mcap"


def record_problem(args: argparse.Namespace) -> str | None:
    """Why --record DIR or --foxglove PORT cannot be used, in a sentence; None if they can.
    Checked before anything starts (the port could still be taken in between: then the
    SDK's error stops the command)."""
    folder: Path | None = args.record
    if folder is not None and folder.exists() and not folder.is_dir():
        return f"--record {folder}: not a folder"
    if args.foxglove is not None:
        try:
            family = socket.AF_INET6 if ":" in args.foxglove_host else socket.AF_INET
            with socket.socket(family, socket.SOCK_STREAM) as probe:
                probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
                probe.bind((args.foxglove_host, args.foxglove))
        except OSError as exc:
            return (
                f"--foxglove {args.foxglove}: cannot listen on {args.foxglove_host} ({exc.strerror or exc})"
            )
    return None


@contextlib.contextmanager
def live_session(gateway: GatewayLike, args: argparse.Namespace) -> Iterator[Recording | None]:
    """The Foxglove server and the recording asked for on the command line, with a line each."""
    path = args.record / session_file_name() if args.record is not None else None
    with open_recording(
        gateway, path, args.foxglove, args.foxglove_host, camera_fps=args.record_camera_fps
    ) as recording:
        if recording is not None and recording.server is not None:
            host = args.foxglove_host
            shown = f"[{host}]" if ":" in host else host
            print(
                f"Foxglove live view: ws://{shown}:{recording.server.port} (Foxglove app or Lichtblick: "
                "Open connection, Foxglove WebSocket)",
                flush=True,
            )
        if recording is not None and recording.mcap_path is not None:
            print(f"recording to {recording.mcap_path} (cart2d replay plays it back)", flush=True)
        yield recording

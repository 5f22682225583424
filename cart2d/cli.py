"""The `cart2d` command line: `sim` (simulator + gateway), `serve` (a real robot on a serial
port), `mission` (a headless mission run with a report), `calibrate` (odometry, UMBmark),
`camera calibrate` (the camera's lens and ground homography)."""

from __future__ import annotations

import argparse
import contextlib
import logging
import signal
import socket
import sys
import threading
from collections.abc import Sequence
from pathlib import Path
from types import FrameType

from cart2d import cli_args
from cart2d import faults as fault_table
from cart2d.calibrate import add_arguments as add_calibrate_arguments
from cart2d.calibrate import main_calibrate
from cart2d.gateway import Gateway
from cart2d.gateway.camera import CameraFeed
from cart2d.gateway.live_map import world_for
from cart2d.gateway.sim_world import with_boxes, world_file_boxes
from cart2d.link import Link, LinkError, ports
from cart2d.perception.calibrate_command import add_arguments as add_camera_calibrate_arguments
from cart2d.perception.calibrate_command import main_camera_calibrate
from cart2d.recording import cli as recording_cli
from cart2d.server import addresses, create_app, is_loopback, serving
from cart2d.simulation.camera import HOST as SIM_CAMERA_HOST
from cart2d.simulation.camera import SimCameraServer
from cart2d.simulator import SimOptions, Simulator, SimulatorError, World, default_bootloader
from cart2d.store import Store

log = logging.getLogger("cart2d")


def _network_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--host",
        type=cli_args.host,
        help="bind address for this run (default: the saved one, 127.0.0.1 at first; the panel changes it)",
    )
    parser.add_argument(
        "--port",
        type=cli_args.port_number,
        help="HTTP port for this run (default: the saved one, 8080 at first)",
    )
    parser.add_argument(
        "--allow-host",
        action="append",
        default=[],
        metavar="NAME",
        help="also answer to this Host name (a reverse proxy's, a DNS name of this machine); repeatable",
    )


def _camera_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--camera",
        type=cli_args.camera_url,
        metavar="URL",
        help="the ESP32-CAM's base URL, http://HOST[:PORT] (stock CameraWebServer: stream on PORT + 1)",
    )
    parser.add_argument(
        "--camera-stream",
        type=cli_args.camera_stream_url,
        metavar="URL",
        help="the camera's MJPEG stream URL outright (ESPHome's esp32_camera_web_server, other cameras)",
    )


def _attach_camera(gateway: Gateway, args: argparse.Namespace) -> None:
    """The camera of --camera / --camera-stream (this run only), else the saved one (PUT
    /api/settings/camera), read from now on (closed with the gateway)."""
    saved = gateway.settings.camera
    try:
        if args.camera or args.camera_stream:
            feed = CameraFeed.of(args.camera, args.camera_stream)
        else:
            feed = CameraFeed.of(saved.url, saved.stream_url)
    except ValueError as exc:
        log.warning("the saved camera is not used: %s", exc)
        return
    if feed is not None:
        gateway.use_camera(feed.start())
        log.info("camera stream %s", feed.reader.url)


def _detach_camera(gateway: Gateway) -> None:
    gateway.use_camera(None)  # lets the camera go: it streams to one client at a time


class Listening:
    """Where this run listens: --host and --port, else the saved ones. The command line's apply
    to this run only: they are never saved (the panel's network form saves an address)."""

    def __init__(self, store: Store, args: argparse.Namespace) -> None:
        self.saved = store.load()
        network = self.saved.network
        self.host: str = args.host or network.host
        self.port: int = args.port or network.port
        self.connections, backlog = serving.descriptor_budget()
        self.sock = addresses.open_listener(self.host, self.port, backlog)  # CannotListen
        self.settings = self.saved if is_loopback(self.host) else store.ensure_token(self.saved)

    def banner(self) -> list[str]:
        first, *others = addresses.panel_urls(self.host, self.port)
        lines = [f"cart2d panel: {first}   (Ctrl-C stops)"]
        if others:
            lines.append(f"  from other machines: {', '.join(others)}")
        if self.settings.token and not is_loopback(self.host):
            lines.append(
                f"access token: {self.settings.token} (listening on {self.host}, the gateway takes changes "
                "only with it, from this machine too; the panel asks for it once)"
            )
        return lines


def _listen(store: Store, args: argparse.Namespace) -> Listening | None:
    """The listening socket, opened before anything starts; None once the reason is printed."""
    try:
        return Listening(store, args)
    except addresses.CannotListen as exc:
        hint = ""
        if args.host is None and args.port is None:
            hint = f" (the address saved in {store.path}; --host and --port choose others for this run)"
        print(f"cart2d {args.command}: {exc}{hint}", file=sys.stderr)
        return None


def _connect(gateway: Gateway, wait_s: float) -> None:
    """Checks the firmware once it answers (a Nano resets when its port opens: give it time)."""
    try:
        version = gateway.wait_for_firmware(wait_s, 0.5)
    except LinkError as exc:
        log.warning("%s; the gateway starts anyway and keeps trying", exc)
        return
    log.info("firmware %s on %s", version.firmware, gateway.link.port)


def _serve(gateway: Gateway, where: Listening, allowed_hosts: list[str]) -> None:
    app = create_app(gateway, where.host, where.settings.token, allowed_hosts)
    for line in where.banner():
        print(line, flush=True)
    serving.serve(app, where.sock, where.connections)


def _fault_options(options: list[str]) -> tuple[dict[str, float], list[str]]:
    """The faults of --fault KEY=VALUE options, and one sentence per bad one."""
    chosen: dict[str, float] = {}
    problems = []
    for option in options:
        try:
            name, value = fault_table.parse_option(option)
        except ValueError as exc:
            problems.append(f"--fault {option}: {exc}")
            continue
        chosen[name] = value
    return chosen, problems


def cmd_sim(args: argparse.Namespace) -> int:
    faults, problems = _fault_options(args.fault)
    problems += [p for p in [recording_cli.record_problem(args)] if p]
    boxes, world_problems = world_file_boxes(args.world) if args.world else ([], [])
    problems += world_problems
    for problem in problems:
        print(f"cart2d sim: {problem}", file=sys.stderr)
    if problems:
        return 2
    store = Store()
    where = _listen(store, args)
    if where is None:
        return 1
    with contextlib.closing(where.sock), contextlib.ExitStack() as listeners:
        camera_socks = _camera_listeners(args)
        if camera_socks is None:
            return 1
        for sock in camera_socks:
            listeners.enter_context(contextlib.closing(sock))
        store.directory.mkdir(parents=True, exist_ok=True)
        options = SimOptions(
            speed=args.speed,
            seed=args.seed,
            eeprom=store.directory / "sim-eeprom.bin",
            pty_link=store.directory / "sim-tty",
            faults=faults,
            bootloader=None if args.no_bootloader else default_bootloader(),
            # the map's walls and the --world boxes, placed again at every restart (sim_world.py)
            world=with_boxes(world_for(where.settings.map), World(tuple(boxes))) if boxes else None,
        )
        try:
            sim = Simulator(options).start()
        except SimulatorError as exc:
            print(f"cart2d sim: {exc}", file=sys.stderr)
            return 2
        camera = _start_camera(sim, args, camera_socks)
        link = Link(sim.pty).open()
        gateway = Gateway(link, store, where.settings, sim)
        try:
            with recording_cli.live_session(gateway, args):
                _connect(gateway, 5.0)
                gateway.start()
                if camera and not (args.camera or args.camera_stream):
                    args.camera = camera.url  # the simulated ESP32-CAM, read as a real one is
                _attach_camera(gateway, args)
                on = f"; faults: {', '.join(f'{k}={v:g}' for k, v in faults.items())}" if faults else ""
                on += f"; {len(boxes)} boxes from {args.world}" if args.world else ""
                print(
                    f"simulator running ({args.speed}x real time{on}), robot serial port {sim.pty}, "
                    f"side channel {sim.control_address}",
                    flush=True,
                )
                if camera:
                    # Without the scheme: the panel's is the one address to open in a browser.
                    where_cam = camera.url.removeprefix("http://")
                    print(
                        f"simulated ESP32-CAM on {where_cam} (/capture; stream on port {camera.port + 1})",
                        flush=True,
                    )
                _serve(gateway, where, args.allow_host)
        finally:
            _detach_camera(gateway)
            gateway.close()
            link.close()
            if camera:
                camera.stop()
            sim.stop()
    return 0


def _camera_listeners(args: argparse.Namespace) -> list[socket.socket] | None:
    """The simulated ESP32-CAM's listening sockets, its port and its stream's (the next one),
    opened before anything starts as the panel's is; [] with --no-camera; None once why not is
    printed (a port in use: one sentence, not uvicorn's errno)."""
    if args.no_camera:
        return []
    opened: list[socket.socket] = []
    try:
        for port in (args.camera_port, args.camera_port + 1):
            opened.append(addresses.open_listener(SIM_CAMERA_HOST, port))
    except addresses.CannotListen as exc:
        for sock in opened:
            sock.close()
        print(
            f"cart2d sim: the simulated camera cannot listen: {exc} (--camera-port P takes P and P + 1, "
            "--no-camera runs without it)",
            file=sys.stderr,
        )
        return None
    return opened


def _start_camera(
    sim: Simulator, args: argparse.Namespace, socks: list[socket.socket]
) -> SimCameraServer | None:
    """The simulated ESP32-CAM's server on its listening sockets (None with --no-camera, or once
    why not is printed: the cart drives without it); its base URL is kept as sim.camera_url, what
    `serve --camera` takes for a real camera."""
    if args.no_camera:
        return None
    try:
        camera = SimCameraServer(
            lambda: sim.control_address, args.camera_port, SIM_CAMERA_HOST, socks
        ).start()
    except SimulatorError as exc:
        print(f"cart2d sim: {exc}; running without it (--camera-port chooses another port)", file=sys.stderr)
        return None
    sim.camera_url = camera.url
    return camera


def _open_serial(args: argparse.Namespace) -> Link | None:
    """The cart's serial port, open; None once the reason and the ports there are are printed.
    Only the first opening is checked: a port that goes away later is reopened when it is back."""
    problem = ports.port_problem(args.serial)
    link = Link(args.serial, args.baud)
    if problem is None:
        try:
            return link.open(wait_s=6.0 if ports.is_url(args.serial) else 3.0)  # a connect may take 5 s
        except LinkError as exc:
            link.close()
            if ports.is_url(args.serial):
                print(
                    f"cart2d serve: {ports.url_problem(args.serial, link.open_error or str(exc))}",
                    file=sys.stderr,
                )
                return None
            problem = str(exc)
    print(f"cart2d serve: {problem}; {ports.ports_sentence()}", file=sys.stderr)
    return None


def cmd_serve(args: argparse.Namespace) -> int:
    problem = recording_cli.record_problem(args)
    if problem:
        print(f"cart2d serve: {problem}", file=sys.stderr)
        return 2
    store = Store()
    where = _listen(store, args)
    if where is None:
        return 1
    with contextlib.closing(where.sock):
        link = _open_serial(args)
        if link is None:
            return 1
        gateway = Gateway(link, store, where.settings)
        try:
            with recording_cli.live_session(gateway, args):
                _connect(gateway, 5.0)
                gateway.start()
                _attach_camera(gateway, args)
                _serve(gateway, where, args.allow_host)
        finally:
            _detach_camera(gateway)
            gateway.close()
            link.close()
    return 0


def cmd_mission(args: argparse.Namespace) -> int:
    from cart2d import mission_file
    from cart2d.mission import main_mission  # tqdm and friends only for this command

    report = args.report or mission_file.default_report_path(args.mission)
    mcap = recording_cli.mission_mcap_path(args, args.mission, report)
    return main_mission(args.mission, report, args.speed, args.seed, mcap, args.record_camera_fps)


def cmd_replay(args: argparse.Namespace) -> int:
    from cart2d.recording.replay_cli import main_replay

    return main_replay(args)


def build_parser() -> argparse.ArgumentParser:
    parser = cli_args.Parser(prog="cart2d", description=__doc__)
    parser.add_argument("-v", "--verbose", action="store_true")
    parser.add_argument("--version", action="version", version=cli_args.version_text())
    sub = parser.add_subparsers(dest="command", required=True)

    sim = sub.add_parser("sim", help="the simulator running the built firmware, with the gateway and panel")
    _network_args(sim)
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
    _camera_args(sim)
    sim.set_defaults(run=cmd_sim)

    serve = sub.add_parser("serve", help="the gateway and panel for a real cart on a serial port")
    serve.add_argument(
        "--serial",
        required=True,
        help="the Nano's serial port, e.g. /dev/ttyUSB0, or a network bridge: socket://HOST:PORT, "
        "rfc2217://HOST:PORT (docs/network-link.md)",
    )
    serve.add_argument("--baud", type=int, default=115200)
    _network_args(serve)
    recording_cli.add_live_arguments(serve)
    _camera_args(serve)
    serve.set_defaults(run=cmd_serve)

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

    camera = sub.add_parser("camera", help="the cart's camera: calibrate")
    camera_sub = camera.add_subparsers(dest="camera_command", required=True)
    camera_calibrate = camera_sub.add_parser(
        "calibrate", help="the camera's lens and ground homography from checkerboard views"
    )
    add_camera_calibrate_arguments(camera_calibrate)
    camera_calibrate.set_defaults(run=main_camera_calibrate)
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

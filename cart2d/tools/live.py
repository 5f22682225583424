"""`cart2d sim` (the simulator, the gateway and the panel) and `cart2d serve` (the gateway and
the panel for a real cart on a serial port): the gateway runs live until Ctrl-C."""

from __future__ import annotations

import argparse
import contextlib
import logging
import socket
import sys

from cart2d.gateway import Gateway
from cart2d.gateway.camera import CameraFeed
from cart2d.gateway.live_map import world_for
from cart2d.link import Link, LinkError, ports
from cart2d.link.built import default_bootloader
from cart2d.maps.world import World
from cart2d.server import addresses, create_app, is_loopback, serving
from cart2d.server.app import AddRoutes
from cart2d.simulation import faults as fault_table
from cart2d.simulation.camera import HOST as SIM_CAMERA_HOST
from cart2d.simulation.camera import SimCameraServer
from cart2d.simulation.side_channel import SimulatorError
from cart2d.simulation.simulator import SimOptions, Simulator
from cart2d.simulation.wiring import simulated_gateway
from cart2d.simulation.world import with_boxes, world_file
from cart2d.store import Store
from cart2d.tools import cli_args, fleet_args, map_command
from cart2d.tools import localisation as localisation_cli
from cart2d.tools import recording_args as recording_cli
from cart2d.tools.ros2_args import ros2_problem, ros2_session

log = logging.getLogger("cart2d")


def network_args(parser: argparse.ArgumentParser) -> None:
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


def camera_args(parser: argparse.ArgumentParser) -> None:
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


def _serve(
    gateway: Gateway, where: Listening, allowed_hosts: list[str], simulation: AddRoutes | None = None
) -> None:
    app = create_app(gateway, where.host, where.settings.token, allowed_hosts, simulation)
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
    problems += [
        p for p in [recording_cli.record_problem(args), ros2_problem(args), fleet_args.problem(args)] if p
    ]
    boxes, look, world_problems = world_file(args.world) if args.world else ([], None, [])
    problems += world_problems
    markers, markers_problem = localisation_cli.markers_of(args)
    floor_plan, map_problem = map_command.floor_plan_of(args)
    problems += [p for p in (markers_problem, map_problem) if p]
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
            # the map's walls and the --world boxes, placed again at every restart (simulation/world.py)
            world=with_boxes(world_for(where.settings.map), World(tuple(boxes))) if boxes else None,
            look=look,  # the world file's materials and lights (sim/README.md, "The look")
        )
        try:
            sim = Simulator(options).start()
        except SimulatorError as exc:
            print(f"cart2d sim: {exc}", file=sys.stderr)
            return 2
        camera = _start_camera(sim, args, camera_socks)
        link = Link(sim.pty).open()
        simulation = simulated_gateway(link, store, where.settings, sim)
        gateway = simulation.gateway
        try:
            with recording_cli.live_session(gateway, args), ros2_session(gateway, args):
                _connect(gateway, 5.0)
                gateway.start()
                if camera and not (args.camera or args.camera_stream):
                    args.camera = camera.url  # the simulated ESP32-CAM, read as a real one is
                map_command.load_floor_plan(gateway, floor_plan, args.map)
                _attach_camera(gateway, args)
                if markers is not None:
                    localisation_cli.start_localisation(gateway, markers, store.directory, sim)
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
                with fleet_args.fleet_vehicle(gateway, args):
                    _serve(gateway, where, args.allow_host, simulation.add_routes)
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
    markers, markers_problem = localisation_cli.markers_of(args)
    floor_plan, map_problem = map_command.floor_plan_of(args)
    problem = (
        recording_cli.record_problem(args)
        or ros2_problem(args)
        or fleet_args.problem(args)
        or markers_problem
        or map_problem
    )
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
            with recording_cli.live_session(gateway, args), ros2_session(gateway, args):
                _connect(gateway, 5.0)
                gateway.start()
                map_command.load_floor_plan(gateway, floor_plan, args.map)
                _attach_camera(gateway, args)
                if markers is not None:
                    localisation_cli.start_localisation(gateway, markers, store.directory)
                with fleet_args.fleet_vehicle(gateway, args):
                    _serve(gateway, where, args.allow_host)
        finally:
            _detach_camera(gateway)
            gateway.close()
            link.close()
    return 0

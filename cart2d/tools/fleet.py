"""`cart2d fleet` (the fleet manager and its page, on a broker) and `cart2d fleet sim --carts N`
(N simulated carts in one arena, each the real firmware in its own simulator with its own
gateway joined to the fleet as a VDA 5050 vehicle, a mosquitto on loopback unless --mqtt names
a broker, and the fleet manager)."""

from __future__ import annotations

import argparse
import contextlib
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from cart2d.fleet.api import fleet_app
from cart2d.fleet.arena import FLEET_MAP, map_lattice
from cart2d.fleet.broker import BrokerError, Mosquitto
from cart2d.fleet.gateway_vehicle import join_fleet
from cart2d.fleet.lattice import Lattice
from cart2d.fleet.manager import FleetManager
from cart2d.fleet.mqtt import Broker
from cart2d.gateway import Gateway
from cart2d.gateway.camera import CameraFeed
from cart2d.gateway.live_map import world_for
from cart2d.link import Link
from cart2d.maps.occupancy import OccupancyMap
from cart2d.maps.world import Box, World
from cart2d.server import addresses, is_loopback, serving
from cart2d.simulation.camera import SimCameraServer
from cart2d.simulation.shared_arena import CartStart, SharedArena, read_fleet_world
from cart2d.simulation.side_channel import SimulatorError
from cart2d.simulation.simulator import SimOptions, Simulator
from cart2d.simulation.wiring import simulated_gateway
from cart2d.simulation.world import with_boxes
from cart2d.store import FloorPlan, GatewaySettings, MapSettings, Store
from cart2d.tools import cli_args, map_command

MAX_CARTS = 8


def add_parser(sub: argparse._SubParsersAction[cli_args.Parser]) -> None:
    fleet = sub.add_parser("fleet", help="the fleet manager (VDA 5050 master control) and its page")
    _common(fleet)
    fleet.set_defaults(run=cmd_fleet)
    fleet_sub = fleet.add_subparsers(dest="fleet_command")
    sim = fleet_sub.add_parser(
        "sim", help="N simulated carts in one arena, each with its gateway, and the manager"
    )
    _common(sim)
    sim.add_argument("--carts", type=_carts, default=3, help=f"how many carts (1 to {MAX_CARTS}, default 3)")
    sim.add_argument(
        "--world",
        type=Path,
        metavar="FILE.json",
        help='{"boxes": [...] as cart2d sim --world, "carts": [{"id", "x", "y", "theta"}, ...]}: start poses',
    )
    map_command.add_map_argument(sim)
    sim.add_argument(
        "--speed", type=cli_args.speed, default="1", help="simulated seconds per second (default 1)"
    )
    sim.add_argument(
        "--cameras",
        type=cli_args.camera_port_number,
        metavar="PORT",
        help="each cart's simulated ESP32-CAM, with perception on, on PORT, PORT + 2, ... (its stream on the "
        "next port); each sees the others (default: no cameras)",
    )
    sim.add_argument(
        "--broker-port",
        type=cli_args.port_number,
        help="without --mqtt: the started mosquitto's port (default: a free one)",
    )
    sim.set_defaults(run=cmd_fleet_sim)


def _common(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--mqtt", metavar="URL", help="the broker, mqtt://HOST[:PORT] or mqtts://...")
    parser.add_argument("--mqtt-ca", type=Path, metavar="FILE", help="mqtts://: the broker's CA certificate")
    parser.add_argument(
        "--host",
        type=cli_args.host,
        default="127.0.0.1",
        help="the page's address (loopback only: it has no token)",
    )
    parser.add_argument(
        "--port", type=cli_args.port_number, default=8090, help="the page's port (default 8090)"
    )


def _carts(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of carts") from None
    if not 1 <= n <= MAX_CARTS:
        raise argparse.ArgumentTypeError(f"{n} carts: 1 to {MAX_CARTS}")
    return n


def _broker(args: argparse.Namespace, command: str) -> Broker | None:
    try:
        return Broker.of(args.mqtt, str(args.mqtt_ca) if args.mqtt_ca else None)
    except ValueError as exc:
        print(f"cart2d {command}: --mqtt: {exc}", file=sys.stderr)
        return None


def cmd_fleet(args: argparse.Namespace) -> int:
    if args.mqtt is None:
        print("cart2d fleet: --mqtt URL names the broker the carts are on", file=sys.stderr)
        return 2
    broker = _broker(args, "fleet")
    if broker is None:
        return 2
    lattice = map_lattice(Store().load().map)
    return _run_manager(FleetManager(lattice, broker), args, None)


def _run_manager(manager: FleetManager, args: argparse.Namespace, arena: SharedArena | None) -> int:
    if not is_loopback(args.host):
        print(
            "cart2d fleet: the fleet page has no access token: it listens on loopback only", file=sys.stderr
        )
        return 2
    try:
        sock = addresses.open_listener(args.host, args.port)
    except addresses.CannotListen as exc:
        print(f"cart2d fleet: {exc} (--port chooses another)", file=sys.stderr)
        return 1
    with contextlib.closing(sock):
        manager.start()
        try:
            app = fleet_app(manager, args.host, arena.view if arena else None)
            print(f"cart2d fleet: http://{args.host}:{args.port}/   (Ctrl-C stops)", flush=True)
            serving.serve(app, sock)
        finally:
            manager.close()
    return 0


@dataclass
class SimCart:
    name: str
    sim: Simulator
    link: Link
    gateway: Gateway


def default_starts(lattice: Lattice, n: int) -> list[CartStart]:
    """n carts spread over the lattice's nodes (every other column of the lowest rows)."""
    cells = sorted(lattice.free, key=lambda c: (c[1], c[0]))
    spread = [c for c in cells if c[0] % 2 == 0 and c[1] % 2 == 0] + cells
    chosen = list(dict.fromkeys(spread))[:n]
    return [
        CartStart(id=f"cart{k + 1}", x=lattice.position(c)[0], y=lattice.position(c)[1])
        for k, c in enumerate(chosen)
    ]


def cmd_fleet_sim(args: argparse.Namespace) -> int:
    spec, problems = read_fleet_world(args.world) if args.world else (None, [])
    for problem in problems:
        print(f"cart2d fleet sim: {problem}", file=sys.stderr)
    if problems:
        return 2
    floor_plan, map_problem = map_command.floor_plan_of(args)
    if map_problem:
        print(f"cart2d fleet sim: {map_problem}", file=sys.stderr)
        return 2
    arena_map = FLEET_MAP if floor_plan is None else fleet_map(floor_plan, args.map.stem)
    boxes = [b.box() for b in spec.boxes] if spec else []
    lattice = map_lattice(arena_map, boxes)
    if not lattice.free:
        print(f"cart2d fleet sim: --map {args.map}: no free floor for a cart on it", file=sys.stderr)
        return 2
    starts = (spec.carts if spec and spec.carts else default_starts(lattice, args.carts))[: args.carts]
    if len(starts) < args.carts:
        print(f"cart2d fleet sim: {args.world} places {len(starts)} carts, not {args.carts}", file=sys.stderr)
        return 2
    with contextlib.ExitStack() as stack:
        broker = _start_broker(args, stack)
        if broker is None:
            return 2
        try:
            fleet = SimFleet.start(starts, args.speed, boxes, broker, stack, arena_map=arena_map)
            if args.cameras is not None:
                fleet.attach_cameras(args.cameras, stack)
        except SimulatorError as exc:
            print(f"cart2d fleet sim: {exc}", file=sys.stderr)
            return 2
        manager = FleetManager(lattice, broker)
        manager.stoppers = [_stopper(c.gateway) for c in fleet.carts]
        print(
            f"fleet: {len(fleet.carts)} carts on {broker}: {', '.join(c.name for c in fleet.carts)}",
            flush=True,
        )
        return _run_manager(manager, args, fleet.arena)
    return 0


@dataclass
class SimFleet:
    """Simulated carts in one arena, each with its gateway joined to the fleet (closed with the
    ExitStack it was started on)."""

    carts: list[SimCart]
    arena: SharedArena

    @classmethod
    def start(
        cls,
        starts: list[CartStart],
        speed: str,
        boxes: list[Box],
        broker: Broker,
        stack: contextlib.ExitStack,
        home: Path | None = None,
        arena_map: MapSettings = FLEET_MAP,
    ) -> SimFleet:
        """`home`: where each cart's settings and EEPROM go (HOME/NAME; default the settings'
        folder's fleet/); `arena_map`: every cart's map, and its walls every simulator's."""
        home = home or Store().directory / "fleet"
        carts = [_start_cart(s, speed, boxes, broker, stack, home / s.id, arena_map) for s in starts]
        arena = SharedArena({c.name: c.sim for c in carts}).start()
        stack.callback(arena.close)
        return cls(carts, arena)

    def attach_cameras(self, first_port: int, stack: contextlib.ExitStack) -> None:
        """Each cart's simulated ESP32-CAM on first_port + 2k (its stream on the next port), its
        frames the gateway's perception (no lockstep: the simulators keep to the wall clock)."""
        for k, cart in enumerate(self.carts):
            server = SimCameraServer(_address(cart.sim), first_port + 2 * k).start()
            stack.callback(server.stop)
            feed = CameraFeed.of(server.url, None)
            assert feed is not None  # a base URL always gives a feed
            cart.gateway.use_camera(feed.start())
            stack.callback(cart.gateway.use_camera, None)
            print(f"fleet: {cart.name}'s camera on {server.url.removeprefix('http://')}", flush=True)


def _address(sim: Simulator) -> Callable[[], str]:
    return lambda: sim.control_address


def _stopper(gateway: Gateway) -> Callable[[], None]:
    def stop() -> None:
        gateway.stop("STOP ALL from the fleet")

    return stop


def _start_broker(args: argparse.Namespace, stack: contextlib.ExitStack) -> Broker | None:
    if args.mqtt is not None:
        return _broker(args, "fleet sim")
    try:
        mosquitto = Mosquitto(args.broker_port).start()
    except BrokerError as exc:
        print(f"cart2d fleet sim: {exc}", file=sys.stderr)
        return None
    stack.callback(mosquitto.close)
    print(f"fleet: mosquitto on {mosquitto.broker} (loopback only)", flush=True)
    return mosquitto.broker


def fleet_map(occupancy: OccupancyMap, name: str) -> MapSettings:
    """A floor plan (--map) as the fleet's map: the carts plan on it, the simulators stand its
    walls, and the lattice's nodes lie on its free floor."""
    return MapSettings(floor_plan=FloorPlan.of(occupancy, name))


def _start_cart(
    start: CartStart,
    speed: str,
    boxes: list[Box],
    broker: Broker,
    stack: contextlib.ExitStack,
    home: Path,
    arena_map: MapSettings,
) -> SimCart:
    store = Store(home)
    store.directory.mkdir(parents=True, exist_ok=True)
    settings = GatewaySettings(map=arena_map)
    pose = (start.x, start.y, start.theta)
    options = SimOptions(
        speed=speed,
        eeprom=store.directory / "sim-eeprom.bin",
        start=pose,
        world=with_boxes(world_for(arena_map), World(tuple(boxes))),
        quiet=True,
    )
    sim = Simulator(options).start()
    stack.callback(sim.stop)
    link = Link(sim.pty).open()
    stack.callback(link.close)
    gateway = simulated_gateway(link, store, settings, sim).gateway
    stack.callback(gateway.close)
    gateway.wait_for_firmware(10.0, 0.5)
    gateway.start()
    gateway.set_pose(*pose)  # the firmware's odometry starts where the simulated cart stands
    vehicle = join_fleet(gateway, broker, start.id)
    stack.callback(vehicle.close)
    return SimCart(start.id, sim, link, gateway)
